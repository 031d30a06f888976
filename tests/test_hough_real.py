"""The Hough detector on real fiducial marks: the NAGAP 'arc' marks (a thin bright '+' in a dark notch,
with data-strip text and forest beside it) cut from real scans (../shared/realdata/hipp_nagap_ee).

No centre coordinates are published for these crops, so the test asserts what must hold regardless:
the mark is found from a loose box, and the answer does not depend on how the crop is mirrored or
transposed (mapped back, the centres agree to 0.1 px)."""

import cv2
import numpy as np
import pytest

from aerofid.detect.hough import HoughParams, detect

ARC = "hipp_nagap_ee/fiducial_templates/nagap/arc"
EXTERNAL = HoughParams(mark="external")


def _loose_box(img):
    """A 300 px wide strip across the middle of the crop: notch, text and forest included."""
    h, w = img.shape
    return (w // 2 - 150, 0, w // 2 + 150, h) if w > h else (0, h // 2 - 150, w, h // 2 + 150)


def _locate(img, box):
    """The hough answer in the box, in the crop's pixels (grey levels on [0, 1], the mark bright)."""
    x0, y0, x1, y1 = box
    d = detect(img[y0:y1, x0:x1].astype(np.float32) / 255.0, EXTERNAL)
    return d.shifted(x0, y0)


@pytest.mark.parametrize("name", ["T", "B", "L", "R"])
def test_real_arc_mark_found_and_mirror_consistent(name, realdata):
    img = cv2.imread(str(realdata(f"{ARC}/{name}.jpg")), cv2.IMREAD_GRAYSCALE)
    assert img is not None, name
    h, w = img.shape
    box = _loose_box(img)
    r = _locate(img, box)
    assert r.found and r.score > 0.8 and r.sigma < 0.05, (name, r.reason, r.score, r.sigma)

    def mirrored(fn_img, fn_box, back):
        ri = _locate(np.ascontiguousarray(fn_img(img)), fn_box(box))
        assert ri.found, (name, ri.reason)
        return back(ri.x, ri.y)

    x0, y0, x1, y1 = box
    answers = [
        mirrored(lambda a: a[:, ::-1], lambda b: (w - x1, y0, w - x0, y1), lambda x, y: (w - 1 - x, y)),
        mirrored(lambda a: a[::-1, :], lambda b: (x0, h - y1, x1, h - y0), lambda x, y: (x, h - 1 - y)),
        mirrored(lambda a: a.T, lambda b: (y0, x0, y1, x1), lambda x, y: (y, x)),
    ]
    for ax, ay in answers:
        assert np.hypot(ax - r.x, ay - r.y) < 0.1, (name, (r.x, r.y), (ax, ay))
