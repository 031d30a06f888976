"""`aerofid orient` end to end: JSON output, reports, MicMac export, exit status and one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from aerofid import orient, read_camera, read_measurements

SEED_CAM = {"name": "Wild RC30 (seed 004)", "focal_length_mm": 152.85, "pixel_size_um": 42,
            "fiducials": {"UL": [-106.000, 106.000], "UR": [105.996, 105.999], "LL": [-106.001, -106.004],
                          "LR": [105.999, -105.999]}}
SEED_MEAS = {"image": "seed004.tif", "points": {"UL": [167.5, 212.5], "UR": [5215.0, 234.0], "LL": [148.5, 5259.5],
                                                "LR": [5194.5, 5279.5]}}


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "aerofid.cli", "orient", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd)


@pytest.fixture
def files(tmp_path):
    cam = tmp_path / "cam.json"
    cam.write_text(json.dumps(SEED_CAM))
    meas = tmp_path / "meas.json"
    meas.write_text(json.dumps(SEED_MEAS))
    return cam, meas


def assert_one_line_error(r, status=2):
    assert r.returncode == status, r.stderr
    assert r.stderr.startswith("error: ")
    assert "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_json_output_has_the_documented_fields(files):
    cam, meas = files
    r = run("--camera", cam, "--measurements", meas, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    for key in ("model", "pixel_to_mm", "mm_to_pixel", "variance_of_unit_weight", "parameter_std", "rms_mm",
                "rms_px", "fiducials", "pixel_size_um", "principal_point_px"):
        assert key in d
    assert d["model"] == "affine"
    assert np.shape(d["pixel_to_mm"]) == (2, 3) and np.shape(d["parameter_std"]) == (2, 3)
    # seed 004, table 3 and table 4
    assert round(d["pixel_to_mm"][0][2], 5) == -113.08782 and round(d["pixel_to_mm"][1][2], 5) == 114.91251
    assert round(d["variance_of_unit_weight"], 6) == 0.000968
    f0 = d["fiducials"][0]
    assert set(f0) >= {"name", "x_px", "y_px", "x_mm", "y_mm", "residual_x_mm", "residual_y_mm", "status"}
    assert f0["name"] == "UL" and round(f0["residual_x_mm"], 4) == 0.0168 and f0["status"] == "used"
    # mm_to_pixel is the inverse of pixel_to_mm
    H = np.vstack([d["pixel_to_mm"], [0, 0, 1]])
    Hi = np.vstack([d["mm_to_pixel"], [0, 0, 1]])
    np.testing.assert_allclose(H @ Hi, np.eye(3), atol=1e-9)


def test_projective_json_is_3x3(files):
    cam, meas = files
    r = run("--camera", cam, "--measurements", meas, "--json", "--model", "projective")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert np.shape(d["pixel_to_mm"]) == (3, 3) and np.shape(d["parameter_std"]) == (3, 3)
    assert d["redundancy"] == 0 and d["variance_of_unit_weight"] is None


@pytest.mark.parametrize("ext", ["json", "html", "txt"])
def test_reports(files, tmp_path, ext):
    cam, meas = files
    out = tmp_path / f"report.{ext}"
    r = run("--camera", cam, "--measurements", meas, "-o", out)
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    if ext == "json":
        assert json.loads(text)["model"] == "affine"
    elif ext == "html":
        assert "<svg" in text and "<table>" in text and "UL" in text
        assert "src=\"http" not in text  # self-contained
    else:
        assert "variance of unit weight" in text
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_micmac_export_and_reimport(files, tmp_path):
    cam, meas = files
    out = tmp_path / "Ori-InterneScan"
    out.mkdir()
    r = run("--camera", cam, "--measurements", meas, "--micmac", out, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert (out / "MeasuresCamera.xml").is_file()
    r2 = run("--camera", out / "MeasuresCamera.xml", "--measurements", out / "MeasuresIm-seed004.tif.xml", "--json")
    assert r2.returncode == 0, r2.stderr
    d2 = json.loads(r2.stdout)
    np.testing.assert_allclose(d2["pixel_to_mm"], d["pixel_to_mm"], rtol=1e-12)
    from aerofid.formats.micmac import read_affine_plane

    np.testing.assert_allclose(read_affine_plane(out / "seed004.tif-AffinePlane-px2mm.xml"), d["pixel_to_mm"])


def test_csv_measurements_and_text_output(files, tmp_path):
    cam, _ = files
    csv = tmp_path / "m.csv"
    csv.write_text("name,x,y\n" + "".join(f"{k},{x},{y}\n" for k, (x, y) in SEED_MEAS["points"].items()))
    r = run("--camera", cam, "--measurements", csv, "--model", "similarity")
    assert r.returncode == 0, r.stderr
    assert "similarity model" in r.stdout


@pytest.mark.parametrize("args,match", [
    (["--measurements", "{meas}"], "camera"),
    (["--camera", "{cam}"], "--measurements"),
    (["scan.tif", "--camera", "{cam}"], "'scan.tif' does not exist"),
    (["scan.tif", "--camera", "{cam}", "--measurements", "{meas}", "--lie", "90"], "for a whole frame"),
    (["--camera", "{tmp}/nope.json", "--measurements", "{meas}"], "does not exist"),
    (["--camera", "{cam}", "--measurements", "{meas}", "--model", "helmert"], "helmert"),
    (["--camera", "{cam}", "--measurements", "{meas}", "-o", "{tmp}/r.pdf"], ".json, .html or .txt"),
    (["--camera", "{cam}", "--measurements", "{meas}", "-o", "{tmp}/nodir/r.json"], "does not exist"),
    (["--camera", "{cam}", "--measurements", "{tmp}/bad.json"], "P9"),
])
def test_bad_input_is_one_line_error_exit_2_and_nothing_written(files, tmp_path, args, match):
    cam, meas = files
    (tmp_path / "bad.json").write_text(json.dumps({"points": {"P9": [1, 2], "UL": [3, 4], "UR": [5, 9]}}))
    before = sorted(p.name for p in tmp_path.iterdir())
    r = run(*[a.format(cam=cam, meas=meas, tmp=tmp_path) for a in args])
    assert_one_line_error(r)
    assert match in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_too_few_points_is_exit_2(files, tmp_path):
    cam, _ = files
    m = tmp_path / "m.json"
    m.write_text(json.dumps({"points": {"UL": [167.5, 212.5], "UR": [5215.0, 234.0]}}))
    r = run("--camera", cam, "--measurements", m)
    assert_one_line_error(r)
    assert "at least 3" in r.stderr


def test_ambiguous_correspondence_exit_1_with_json(files, tmp_path):
    cam, _ = files
    m = tmp_path / "m.json"
    m.write_text(json.dumps({"points": list(SEED_MEAS["points"].values())}))  # unnamed, symmetric square
    r = run("--camera", cam, "--measurements", m, "--json")
    assert_one_line_error(r, status=1)
    assert "ambiguous" in r.stderr
    d = json.loads(r.stdout)
    assert d["status"] == "ambiguous" and len(d["correspondence"]["candidates"]) >= 2


def test_named_points_that_cannot_tell_the_correspondence_are_told_to_use_their_names(files):
    """Named points with ``--correspondence auto`` on a symmetric square: the ambiguity's advice is the option that
    uses their names, not to name them (a helper's audit)."""
    cam, meas = files
    r = run("--camera", cam, "--measurements", meas, "--correspondence", "auto")
    assert_one_line_error(r, status=1)
    assert r.stderr.rstrip().endswith("the points are named as in the camera file: give --correspondence names")


def test_a_scan_given_with_measurements_of_another_is_refused(files, tmp_path):
    """IMAGE with --measurements names the outputs; measurements of another scan (by the name they give, or points
    outside IMAGE) were oriented under its name (a helper's audit)."""
    cam, meas = files
    scan = tmp_path / "small.png"
    cv2.imwrite(str(scan), np.zeros((600, 800), np.uint8))
    r = run(scan, "--camera", cam, "--measurements", meas)
    assert_one_line_error(r)
    assert "are of 'seed004.tif', not of 'small.png'" in r.stderr
    points = tmp_path / "points.csv"
    points.write_text("".join(f"{n},{x},{y}\n" for n, (x, y) in SEED_MEAS["points"].items()))
    r = run(scan, "--camera", cam, "--measurements", points)
    assert_one_line_error(r)
    assert "point UR of" in r.stderr and "lies outside 'small.png' (800 x 600 px)" in r.stderr
    big = tmp_path / "big.png"
    cv2.imwrite(str(big), np.zeros((5400, 5300), np.uint8))
    assert run(big, "--camera", cam, "--measurements", points).returncode == 0


def test_python_api_mirrors_cli(files):
    cam, meas = files
    res = orient(read_camera(cam), read_measurements(meas))
    r = run("--camera", cam, "--measurements", meas, "--json")
    assert json.loads(r.stdout) == json.loads(json.dumps(res.to_dict()))
