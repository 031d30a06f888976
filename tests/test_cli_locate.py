"""`aerofid locate` with several named boxes: one opening, JSON that `aerofid orient` reads, exit statuses,
one-line errors with nothing written, --param routing, `python -m aerofid`."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import tifffile

from aerofid import synth

SIZE = 640
MM_TO_PX = np.array([[2.381 * np.cos(0.004), 2.381 * np.sin(0.004), 320.37],
                     [2.381 * np.sin(0.004), -2.383 * np.cos(0.004), 319.62]])
"""The scan's true film mm -> pixel affine (0.42 mm pixels, rotated 0.23 deg, y down, a small shear)."""
FIDUCIALS_MM = {"UL": (-100.0, 100.0), "UR": (100.0, 100.0), "LR": (100.0, -100.0), "LL": (-100.0, -100.0),
                "T": (0.0, 100.0), "B": (0.0, -100.0)}
"""The camera's fiducials; all but ``B`` are drawn in the scan (``B`` is a fiducial the scan lost)."""
DRAWN = ("UL", "UR", "LR", "LL", "T")
HALF = 45


def to_px(xy_mm):
    return MM_TO_PX @ np.array([xy_mm[0], xy_mm[1], 1.0])


def box_text(name):
    x, y = to_px(FIDUCIALS_MM[name])
    return f"{name}={int(x) - HALF},{int(y) - HALF},{int(x) + HALF},{int(y) + HALF}"


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    """A 640 x 640 tiled TIFF with five '+' fiducials at the camera's positions, and the camera file."""
    rng = np.random.default_rng(7)
    hw = (SIZE, SIZE)
    img = synth.film_border(hw, rng)
    for name in DRAWN:
        cov = synth.coverage(hw, tuple(to_px(FIDUCIALS_MM[name])), synth.cross_shape(40, 2.0, 0.23), 16, extent=24)
        img = synth.paint(img, cov, 0.85)
    img = np.clip(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.015, rng), 0, 1)
    folder = tmp_path_factory.mktemp("frame")
    scan = folder / "scan.tif"
    tifffile.imwrite(scan, synth.to_uint8(img), tile=(128, 128))
    camera = folder / "camera.json"
    camera.write_text(json.dumps({"name": "synthetic", "focal_length_mm": 152.0,
                                  "fiducials": {k: list(v) for k, v in FIDUCIALS_MM.items()}}))
    return scan, camera


def run(*args, module="aerofid.cli", cwd=None):
    return subprocess.run([sys.executable, "-m", module, *map(str, args)], capture_output=True, text=True, cwd=cwd)


def assert_one_line_error(r, status=2):
    assert r.returncode == status, (r.stdout, r.stderr)
    assert r.stderr.startswith("error: ") and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


def check_orientation(d):
    """``orient``'s JSON: the pixel -> mm affine maps each drawn fiducial's true pixel centre to its mm."""
    pixel_to_mm = np.vstack([d["pixel_to_mm"], [0, 0, 1]])
    for name in DRAWN:
        x, y = to_px(FIDUCIALS_MM[name])
        mm = pixel_to_mm @ [x, y, 1.0]
        assert np.hypot(*(mm[:2] - FIDUCIALS_MM[name])) < 0.03, name  # 0.07 px
    np.testing.assert_allclose(np.linalg.inv(pixel_to_mm)[:2], MM_TO_PX, atol=0.05)


def test_named_boxes_to_json_then_orient_gives_the_true_transformation(frame, tmp_path):
    scan, camera = frame
    out = tmp_path / "located.json"
    boxes = [a for name in ("UL", "UR", "LR", "LL", "T") for a in ("--box", box_text(name))]
    r = run("locate", scan, *boxes, "--mark", "external", "--json", "-o", out)
    assert r.returncode == 0, r.stderr
    printed = json.loads(r.stdout)
    written = json.loads(out.read_text())
    assert printed == written
    assert written["image"] == "scan.tif" and written["status"] == "found" and written["not_found"] == []
    assert [p["name"] for p in written["points"]] == ["UL", "UR", "LR", "LL", "T"]
    for p in written["points"]:
        assert p["status"] == "found" and np.hypot(p["x"] - to_px(FIDUCIALS_MM[p["name"]])[0],
                                                   p["y"] - to_px(FIDUCIALS_MM[p["name"]])[1]) < 0.1
    o = run("orient", "--camera", camera, "--measurements", out, "--json")
    assert o.returncode == 0, o.stderr
    d = json.loads(o.stdout)
    assert d["rms_px"] < 0.1 and d["missing"] == ["B"]
    assert sorted(f["name"] for f in d["fiducials"]) == sorted(DRAWN)
    check_orientation(d)


def test_a_mark_not_found_is_status_1_and_orient_uses_the_others_and_names_it(frame, tmp_path):
    scan, camera = frame
    boxes = tmp_path / "boxes.csv"
    boxes.write_text("# fiducials of scan.tif\nname,x0,y0,x1,y1\n"
                     + "".join(box_text(n).replace("=", ",") + "\n" for n in (*DRAWN, "B")))
    out, sheet = tmp_path / "located.json", tmp_path / "sheet.png"
    r = run("locate", scan, "--boxes", boxes, "-o", out, "--overlay", sheet)
    assert r.returncode == 1, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 7 and lines[5].startswith("B ") and "not found" in lines[5]
    assert lines[-1] == "found 5 of 6; not found: B"
    d = json.loads(out.read_text())
    assert d["status"] == "not_found" and d["not_found"] == ["B"] and d["found"] == list(DRAWN)
    assert d["points"][5]["x"] is None and d["points"][5]["reason"]
    assert cv2.imread(str(sheet)) is not None
    o = run("orient", "--camera", camera, "--measurements", out, "--json")
    assert o.returncode == 0, o.stderr
    assert "B" in o.stderr and "not found" in o.stderr
    res = json.loads(o.stdout)
    assert res["missing"] == ["B"]
    check_orientation(res)
    t = run("orient", "--camera", camera, "--measurements", out)
    assert "not measured: B" in t.stdout


def test_orient_names_the_marks_not_found_when_too_few_are_left(frame, tmp_path):
    _, camera = frame
    m = tmp_path / "m.json"
    m.write_text(json.dumps({"image": "scan.tif", "points": [
        {"name": "UL", "status": "found", "x": 10.0, "y": 10.0}, {"name": "UR", "status": "found", "x": 500, "y": 9},
        {"name": "LR", "status": "not_found", "x": None, "y": None}]}))
    r = run("orient", "--camera", camera, "--measurements", m)
    assert_one_line_error(r)
    assert "at least 3" in r.stderr and "LR" in r.stderr


def test_one_unnamed_box_keeps_the_single_mark_output(frame):
    scan, _ = frame
    x0, y0, x1, y1 = box_text("UL").split("=")[1].split(",")
    r = run("locate", scan, "--box", f"{x0},{y0},{x1},{y1}", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["status"] == "found" and d["x"] == d["points"][0]["x"] and d["sigma"] > 0
    assert d["points"][0]["name"] == "1"
    t = run("locate", scan, "--box", f"{x0},{y0},{x1},{y1}")
    assert t.stdout.startswith("found  x=")


def test_overlay_per_mark_with_name_in_the_path_and_plots(frame, tmp_path):
    scan, _ = frame
    r = run("locate", scan, "--box", box_text("UL"), "--box", box_text("T"), "--overlay", tmp_path / "ov_{name}.png",
            "--plot", tmp_path / "diag_{name}.png")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["diag_T.png", "diag_UL.png", "ov_T.png", "ov_UL.png"]


@pytest.mark.parametrize("param", ["window_size=24", "max_asymmetry=0.2", "theta_step=1.0"])
def test_param_with_the_default_method_auto_is_routed(frame, param):
    scan, _ = frame
    r = run("locate", scan, "--box", box_text("UR"), "--param", param, "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["status"] == "found"


@pytest.mark.parametrize("param,match", [
    ("no_such=1", "valid: "),
    ("window_size=2", "window_size"),
    ("window_size=abc", "window_size"),
    ("window_size", "NAME=VALUE"),
])
def test_bad_param_is_one_line_naming_the_valid_ones(frame, tmp_path, param, match):
    scan, _ = frame
    r = run("locate", scan, "--box", box_text("UR"), "--box", box_text("UL"), "--param", param,
            "-o", tmp_path / "x.json")
    assert_one_line_error(r)
    assert match in r.stderr
    if param.startswith("no_such"):
        assert "'no_such'" in r.stderr and "window_size" in r.stderr and "max_asymmetry" in r.stderr
    assert list(tmp_path.iterdir()) == []


BAD = [
    (["--box", "P1=10,10,90,90", "--box", "P1=100,100,190,190"], "'P1' is given twice"),
    (["--box", "UL=10,10,90,90", "--boxes", "{tmp}/boxes.csv"], "'UL' is given twice"),
    (["--boxes", "{tmp}/badrow.csv"], "line 3 of"),
    (["--boxes", "{tmp}/short.csv"], "line 2 of"),
    (["--boxes", "{tmp}/emptybox.csv"], "line 1 of"),
    (["--boxes", "{tmp}/nothing.csv"], "no boxes"),
    (["--boxes", "{tmp}/missing.csv"], "does not exist"),
    (["--box", "a b=10,10,90,90"], "box name"),
    (["--box", "=10,10,90,90"], "box name"),
    (["--box", "P1=10,10,90"], "four numbers"),
    (["--box", "P1=10,10,ninety,90"], "'ninety' is not a number"),
    ([], "give a box"),
    (["--box", "P1=10,10,90,90", "--box", "P2=700,700,800,800"], "P2=700,700,800,800"),
    (["--box", "P1=10,10,90,90", "--box", "P2=100,10,190,90", "--plot", "{tmp}/d.png"], "{name}"),
    (["--box", "P1=10,10,90,90", "-o", "{tmp}/x.csv"], ".json"),
    (["--box", "P1=10,10,90,90", "--overlay", "{tmp}/nodir/o.png"], "does not exist"),
    (["--box", "P1=10,10,90,90", "--overlay", "{tmp}/o.png", "--plot", "{tmp}/o.png"], "two outputs"),
    (["--box", "P1=10,10,90,90", "--colour", "purple"], "purple"),
]


@pytest.mark.parametrize("args,match", BAD)
def test_bad_input_is_one_line_status_2_and_writes_nothing(frame, tmp_path, args, match):
    scan, _ = frame
    (tmp_path / "boxes.csv").write_text("UL,0,0,90,90\n")
    (tmp_path / "badrow.csv").write_text("name,x0,y0,x1,y1\nA,0,0,90,90\nB,0,zero,90,90\n")
    (tmp_path / "short.csv").write_text("A,0,0,90,90\nB,0,0,90\n")
    (tmp_path / "emptybox.csv").write_text("A,90,0,10,90\n")
    (tmp_path / "nothing.csv").write_text("# nothing\n\n")
    before = sorted(tmp_path.iterdir())
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if "-o" not in args and "--overlay" not in args:
        args += ["--overlay", str(tmp_path / "ov.png"), "-o", str(tmp_path / "out.json")]
    r = run("locate", scan, *args)
    assert_one_line_error(r)
    assert match in r.stderr
    assert sorted(tmp_path.iterdir()) == before


def test_python_m_aerofid_is_the_aerofid_command(frame, tmp_path):
    scan, _ = frame
    r = run("--help", module="aerofid")
    assert r.returncode == 0 and "locate" in r.stdout and "orient" in r.stdout
    assert r.stdout.startswith("Usage: aerofid ")
    script = shutil.which("aerofid") or str(Path(sys.executable).with_name("aerofid"))
    if Path(script).exists():
        s = subprocess.run([script, "--help"], capture_output=True, text=True)
        assert s.stdout == r.stdout
    found = run("locate", scan, "--box", box_text("LL"), module="aerofid")
    assert found.returncode == 0 and found.stdout.startswith("LL  found")
    assert_one_line_error(run("locate", scan, module="aerofid"))
