"""Camera files: JSON/YAML certificate, minimal JSON, MicMac MeasuresCamera.xml, validation."""

from __future__ import annotations

import csv
import json

import pytest

from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera, write_camera
from aerofid.orientation.camera import Camera

MIN = {"name": "cam", "fiducials": {"P1": [-106, -106], "P2": [106, 106], "P3": [-106, 106], "P4": [106, -106]}}


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_minimal_json_is_accepted(tmp_path):
    cam = read_camera(write(tmp_path, "c.json", json.dumps(MIN)))
    assert cam.names == ("P1", "P2", "P3", "P4")
    assert cam.xy_mm.shape == (4, 2)
    assert cam.y_axis == "up" and cam.focal_length_mm is None
    assert cam.principal_point_mm == ((0.0, 0.0), "origin")


def test_full_yaml_certificate(tmp_path):
    text = """
name: Wild RC20 s/n 5046
focal_length_mm: 153.664
principal_point:
  ppa: [0.001, 0.002]
  pbs: [0.000, -0.003]
pixel_size_um: 21
fiducials:
  P1: [106.004, -106.002]
  P2: {x: -105.998, y: -105.998, style: wild_corner}
  P3: [-106.007, 106.006]
  P4: [106.000, 105.999]
"""
    cam = read_camera(write(tmp_path, "c.yaml", text))
    assert cam.focal_length_mm == 153.664
    assert cam.ppa_mm == (0.001, 0.002) and cam.pbs_mm == (0.0, -0.003)
    assert cam.principal_point_mm == ((0.001, 0.002), "ppa")
    assert cam.fiducial("P2").style == "wild_corner"
    assert cam.pixel_size_um == 21
    # round trip through JSON and YAML
    for ext in ("json", "yaml"):
        out = tmp_path / f"out.{ext}"
        write_camera(out, cam)
        assert read_camera(out) == cam


def test_fiducial_list_form():
    cam = Camera.from_dict({"name": "c", "fiducials": [{"name": n, "x": x, "y": y} for n, (x, y) in
                                                          MIN["fiducials"].items()]})
    assert cam.names == ("P1", "P2", "P3", "P4")


@pytest.mark.parametrize("text,match", [
    ('{"name": "c", "fiducials": {"P1": [0, 0], "P1": [1, 1], "P2": [0, 5], "P3": [5, 0]}}', "duplicate"),
    ('{"name": "c", "fiducials": {"P1": [0, 0], "P2": [10, 0]}}', "at least 3"),
    ('{"name": "c", "fiducials": {"P1": [0, "a"], "P2": [10, 0], "P3": [0, 10]}}', "number"),
    ('{"name": "c", "fiducials": {"P1": [0, 2000], "P2": [10, 0], "P3": [0, 10]}}', "implausible"),
    ('{"name": "c", "fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [20, 0]}}', "collinear"),
    ('{"name": "c", "fiducials": {"P1": [0, 0], "P2": [0, 0], "P3": [0, 10]}}', "same coordinates"),
    ('{"name": "c", "focal_length_mm": -5, "fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [0, 10]}}',
     "focal length"),
    ('{"name": "c", "pixel_size_um": 0, "fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [0, 10]}}', "pixel size"),
    # the bounds of a pixel size given on the command line (checked_pixel_size): 0.5 um was accepted here
    ('{"name": "c", "pixel_size_um": 0.5, "fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [0, 10]}}',
     "at least 1.27 um, 20000 dpi, and less than 1000 um"),
    ('{"fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [0, 10]}}', "name"),
    ('{"name": "c", "fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [0, 10]}, "focal": 3}', "unknown"),
    ('{"name": "c", "fiducials": {"P1": [0, 0], "P2": [10, 0], "P3": [0, 10]}, "y_axis": "left"}', "y_axis"),
    ("{not json", "not valid JSON"),
])
def test_invalid_camera_files_are_clear_errors(tmp_path, text, match):
    with pytest.raises(AerofidInputError, match=match):
        read_camera(write(tmp_path, "c.json", text))


@pytest.mark.parametrize("suffix", ["json", "yaml"])
@pytest.mark.parametrize(("digits", "match"), [(400, "finite number, not 100000000000000000000[.][.][.][(]401"),
                                               (5000, "thousands of digits")])
def test_integers_too_large_for_a_float_or_for_python_are_clear_errors(tmp_path, suffix, digits, match):
    """An integer beyond a float's range (400 digits) and one beyond what Python converts (5000 digits, its limit
    4300) were an OverflowError and a ValueError; the first is shown by its first digits."""
    big = "1" + "0" * digits
    text = (f'{{"name": "c", "fiducials": {{"P1": [{big}, 0], "P2": [10, 0], "P3": [0, 10]}}}}' if suffix == "json"
            else f"name: c\nfiducials:\n  P1: [{big}, 0]\n  P2: [10, 0]\n  P3: [0, 10]\n")
    with pytest.raises(AerofidInputError, match=match):
        read_camera(write(tmp_path, f"c.{suffix}", text))


@pytest.mark.parametrize(("text", "match"), [
    ("name: c\nfiducials:\n  P1: [0x" + "f" * 4000 + ", 0]\n  P2: [10, 0]\n  P3: [0, 10]\n",
     "an integer of 16000 bits"),
    ("name: c\nmade: 2001-13-45\nfiducials:\n  P1: [0, 0]\n  P2: [10, 0]\n  P3: [0, 10]\n",
     "is not valid YAML: month must be in 1..12")])
def test_a_yaml_integer_python_will_not_write_and_a_bad_date_are_clear_errors(tmp_path, text, match):
    """YAML reads a hexadecimal integer of any length, which Python will not write in decimal (repr raised), and a
    date's own ValueError was taken for a number of thousands of digits (a helper's review)."""
    with pytest.raises(AerofidInputError, match=match):
        read_camera(write(tmp_path, "c.yaml", text))


def test_duplicate_names_in_yaml(tmp_path):
    with pytest.raises(AerofidInputError, match="duplicate"):
        read_camera(write(tmp_path, "c.yml", "name: c\nfiducials:\n  P1: [0, 0]\n  P1: [1, 1]\n  P2: [0, 9]\n"))


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(AerofidInputError, match="does not exist"):
        read_camera(tmp_path / "nope.json")


def test_fiducial_centre_is_intersection_of_opposite_lines():
    cam = Camera.from_dict({"name": "c", "fiducials": {"1": [-100, -100.2], "2": [100, 100.2], "3": [-100, 100],
                                                       "4": [100, -100], "5": [-112, 0.5]}})
    cx, cy = cam.fiducial_centre_mm()
    # the diagonals 1-2 and 3-4 cross at the origin (5 has no opposite partner)
    assert cx == pytest.approx(0.0, abs=1e-9) and cy == pytest.approx(0.0, abs=1e-9)


def test_micmac_measures_camera_real_rc20(realdata):
    cam = read_camera(realdata("unbc_bc_wild_rc20/MeasuresCamera.xml"))
    # SOURCES.md: P1 lower-right, P2 lower-left, P3 upper-left, P4 upper-right; x right, y up
    assert cam.names == ("P1", "P2", "P3", "P4")
    assert cam.fiducial("P1").x_mm == 106.004 and cam.fiducial("P1").y_mm == -106.002
    assert cam.fiducial("P3").x_mm < 0 < cam.fiducial("P3").y_mm
    assert cam.y_axis == "up"


def test_micmac_measures_camera_corner_origin_is_y_down(realdata):
    cam = read_camera(realdata("spymicmac_docs/MeasuresCamera_example.xml"))
    assert len(cam.fiducials) == 8
    assert cam.y_axis == "down"
    assert cam.fiducial("P7").x_mm == 110.002 and cam.fiducial("P7").y_mm == 0.0


def test_usgs_calibration_reports_load_as_cameras(realdata):
    """Every 8-mark row of the transcribed USGS reports makes a valid camera (GPL data: read only)."""
    path = realdata("usgs_calib_reports_transcribed/combined_reports.csv")
    marks = ["ll", "lr", "ul", "ur", "ml", "mr", "mt", "mb"]
    n, bad = 0, []
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            try:
                fids = {m: [float(row[f"{m}x"]), float(row[f"{m}y"])] for m in marks}
            except (KeyError, ValueError):
                continue
            n += 1
            try:
                cam = Camera.from_dict({"name": row["camera_model"] or "usgs", "fiducials": fids})
            except AerofidInputError as e:
                bad.append((row["cal_file"], str(e)))
                continue
            assert len(cam.fiducials) == 8
    assert n == 705  # SOURCES.md: 705 rows have all 8 marks
    # one transcription slip (lly = -1006.005 for -106.005) is caught by the plausibility check
    assert bad == [("Report_RT-R_581.pdf", bad[0][1])] and "implausible" in bad[0][1]
