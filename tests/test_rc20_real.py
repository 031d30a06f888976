"""The real Wild RC20 frame (../shared/realdata/unbc_bc_wild_rc20): all 8 fiducial marks by ``auto``.

No pixel truth is published for the scan, but its camera file is: the four corner marks' calibrated
coordinates (MeasuresCamera.xml, P1 lower right, P2 lower left, P3 upper left, P4 upper right) and the
midside spans (SzCaptMm 220.033 x 220.005 mm). So the test asserts what must hold regardless of the truth:
every mark is found from a 120 x 120 box around it, the answer does not depend on how the crop is mirrored
or transposed, and the corner centres fit the calibration by an affine transformation to a fraction of a
pixel (the scanner's own deformation is part of that residual).
"""

import numpy as np
import pytest

import aerofid
from aerofid.formats.camera_file import read_camera
from aerofid.io.raster import open_raster
from aerofid.orientation.adjustment import adjust
from conftest import realdata_path

FRAME = "unbc_bc_wild_rc20/15BCC02013_114.jpg"

MARKS = {  # approximate centres (x, y) read off downsampled crops, as in benchmarks/bench_rc20.py
    "corner TL": (665, 179), "corner TR": (5690, 202), "corner BL": (660, 5213), "corner BR": (5678, 5225),
    "midside T": (3183, 98), "midside B": (3146, 5302), "midside L": (554, 2679), "midside R": (5764, 2723),
}
CALIBRATED = {"P1": "corner BR", "P2": "corner BL", "P3": "corner TL", "P4": "corner TR"}
PIXEL_MM = 25.4 / 600


@pytest.fixture(scope="module")
def crops():
    with open_raster(realdata_path(FRAME)) as r:
        return {k: ((x - 60, y - 60), np.ascontiguousarray(r.read_window((x - 60, y - 60, x + 60, y + 60))))
                for k, (x, y) in MARKS.items()}


@pytest.fixture(scope="module")
def centres(crops):
    out = {}
    for name, ((x0, y0), crop) in crops.items():
        r = aerofid.locate(crop, (0, 0, 120, 120), mark="external")
        assert r.found, (name, r.reason)
        out[name] = (r.x + x0, r.y + y0)
    return out


@pytest.mark.parametrize("name", list(MARKS))
def test_every_mark_found_and_mirror_consistent(crops, centres, name):
    _, crop = crops[name]
    x, y = centres[name][0] - crops[name][0][0], centres[name][1] - crops[name][0][1]
    h, w = crop.shape[:2]
    for img, back in ((crop[:, ::-1], lambda a, b: (w - 1 - a, b)), (crop[::-1], lambda a, b: (a, h - 1 - b)),
                      (np.swapaxes(crop, 0, 1), lambda a, b: (b, a))):
        r = aerofid.locate(np.ascontiguousarray(img), (0, 0, img.shape[1], img.shape[0]), mark="external")
        assert r.found, (name, r.reason)
        assert np.hypot(*(np.subtract(back(r.x, r.y), (x, y)))) <= 0.1


def test_corner_marks_fit_the_calibration_and_midsides_the_spans(centres):
    cam = read_camera(realdata_path("unbc_bc_wild_rc20/MeasuresCamera.xml"))
    px = np.array([centres[CALIBRATED[f.name]] for f in cam.fiducials])
    mm = np.array([[f.x_mm, f.y_mm] for f in cam.fiducials])
    fit = adjust(px, mm, "affine")
    rms_px = float(np.sqrt(np.mean(fit.v ** 2))) / PIXEL_MM
    assert rms_px < 0.5  # measured 0.32 px (13.5 um)
    mid = {k: fit.transform(np.array([centres[k]]))[0] for k in MARKS if k.startswith("midside")}
    span_x = np.hypot(*(mid["midside R"] - mid["midside L"]))
    span_y = np.hypot(*(mid["midside T"] - mid["midside B"]))
    # the camera file's spans, to within 2 px (measured: 12 and 32 um, i.e. 0.3 and 0.8 px)
    assert abs(span_x - 220.033) < 2 * PIXEL_MM and abs(span_y - 220.005) < 2 * PIXEL_MM
    # the midsides lie on the axes through the fiducial centre, opposite each other
    assert abs(mid["midside T"][0] - mid["midside B"][0]) < 2 * PIXEL_MM
    assert abs(mid["midside L"][1] - mid["midside R"][1]) < 2 * PIXEL_MM
