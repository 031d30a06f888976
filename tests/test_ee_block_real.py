"""A real EarthExplorer "block" midside mark (../shared/realdata/hipp_nagap_ee/fiducial_templates/ee/block/T.jpg):
a small bright dot with a thin line through it, in a dark block beside two larger dots. No centre is published,
so the test asserts what must hold regardless: ``auto`` finds the dot from boxes of several sizes with answers
that agree, and the answer does not depend on how the crop is mirrored or transposed."""

import cv2
import numpy as np
import pytest

import aerofid
from conftest import realdata_path

DOT = (390, 273)  # read off the crop by eye, to the pixel


@pytest.fixture(scope="module")
def img():
    crop = cv2.imread(str(realdata_path("hipp_nagap_ee/fiducial_templates/ee/block/T.jpg")), cv2.IMREAD_GRAYSCALE)
    assert crop is not None, "the real EarthExplorer block crop cannot be decoded"
    return crop


def test_the_dot_on_a_line_is_found_from_boxes_of_several_sizes(img):
    """The line through the dot runs out of every box: the mark's extent must not be taken from it (it was:
    'cut by the box edge' for every box)."""
    x, y = DOT
    got = []
    for half in (20, 30, 45):
        r = aerofid.locate(img, (x - half, y - half, x + half, y + half))
        assert r.found, (half, r.reason)
        got.append((r.x, r.y))
    p = np.array(got)
    assert np.hypot(*(p.max(axis=0) - p.min(axis=0))) < 0.2  # measured 0.14 px
    assert np.hypot(p[0, 0] - x, p[0, 1] - y) < 1.0


def test_the_dot_is_mirror_consistent(img):
    x, y, half = DOT[0], DOT[1], 30
    crop = img[y - half:y + half, x - half:x + half]
    h, w = crop.shape
    pts = []
    for im, back in ((crop, lambda a, b: (a, b)), (crop[:, ::-1], lambda a, b: (w - 1 - a, b)),
                     (crop[::-1], lambda a, b: (a, h - 1 - b)), (crop.T, lambda a, b: (b, a))):
        r = aerofid.locate(np.ascontiguousarray(im), (0, 0, im.shape[1], im.shape[0]))
        assert r.found, r.reason
        pts.append(back(r.x, r.y))
    p = np.array(pts)
    assert max(np.hypot(*(a - b)) for a in p for b in p) <= 0.1
