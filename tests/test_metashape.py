"""The Metashape export: a script that, run in Metashape Pro on the open project, places the measured fiducials on
the scans. Metashape is not here: the script runs against a small stand-in module with the classes it uses, and
the projections it places are checked against the synthetic frames' true mark centres."""

from __future__ import annotations

import json
import subprocess
import sys
import types
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from aerofid.formats.camera_file import write_camera
from aerofid.formats.metashape import PIXEL_OFFSET, LeftOut, metashape_data, metashape_script
from aerofid.formats.orientation import from_result
from aerofid.orientation.interior import orient
from aerofid.orientation.measurements import Measurements
from aerofid.synth_frame import frame_spec, wild_rc10_camera, write_frame

CAMERA = wild_rc10_camera()
PIXEL_MM = 0.2
"""1250 x 1250 px frames (as tests/test_batch.py)."""
TRUTH_PX = 0.1
"""How far a found mark may lie from its true centre (the frame tests' bound, test_frame.py)."""
BLUNDER_PX = 8.0
"""A measurement this far off is rejected by the adjustment's data snooping."""


# --- a stand-in for the Metashape module: only what the script uses --------------------------------------------

class _Vector(list):
    pass


class _Projection:
    def __init__(self, coord, pinned=False):
        self.coord, self.pinned = list(coord), pinned


class _Marker:
    class Type:
        Regular, Fiducial = "Regular", "Fiducial"

    Projection = _Projection

    def __init__(self):
        self.type, self.sensor, self.label = _Marker.Type.Regular, None, ""
        self.reference = types.SimpleNamespace(location=None)
        self.projections = {}


class _Sensor:
    def __init__(self, key):
        self.key, self.film_camera, self.focal_length, self.pixel_size = key, False, None, None


class _Camera:
    def __init__(self, label, sensor):
        self.label, self.sensor = label, sensor

    def __hash__(self):
        return id(self)


class _Chunk:
    def __init__(self, cameras):
        self.cameras, self.markers = cameras, []

    def addMarker(self):  # noqa: N802 (Metashape's name)
        m = _Marker()
        self.markers.append(m)
        return m


def run_script(text: str, chunk: _Chunk | None, monkeypatch, capsys) -> str:
    """Execute the script with the stand-in module as ``Metashape``; what it printed."""
    module = types.ModuleType("Metashape")
    module.Vector, module.Marker = _Vector, _Marker
    module.app = types.SimpleNamespace(document=types.SimpleNamespace(chunk=chunk))
    monkeypatch.setitem(sys.modules, "Metashape", module)
    capsys.readouterr()
    exec(compile(text, "metashape_fiducials.py", "exec"), {"__name__": "__main__"})
    return capsys.readouterr().out


def fiducial_markers(chunk: _Chunk) -> dict[str, _Marker]:
    assert all(m.type == _Marker.Type.Fiducial for m in chunk.markers)
    out = {m.label: m for m in chunk.markers}
    assert len(out) == len(chunk.markers)                    # one marker per fiducial name (and sensor)
    return out


# --- tests ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def measured():
    """Two scans' orientations from true mark centres (+ noise); scan1's first fiducial is a blunder."""
    out = {}
    for i, name in enumerate(("roll/scan1.tif", "roll/scan2.tif")):
        spec = frame_spec(CAMERA, PIXEL_MM, np.random.default_rng(5 + i), rotation_deg=90 * i, mirrored=bool(i))
        truth = spec.mm_to_px(CAMERA.xy_mm)
        marks = truth + np.random.default_rng(i).normal(0, 0.03, truth.shape)
        if i == 0:
            marks[0] += BLUNDER_PX
        res = orient(CAMERA, Measurements(marks, CAMERA.names, name), image=name)
        out[name] = (res, dict(zip(CAMERA.names, truth, strict=True)))
    return out


def test_the_script_pins_the_used_fiducials_at_metashape_pixels_and_reports_missing_scans(measured, monkeypatch,
                                                                                          capsys):
    (res1, truth1), (res2, _) = measured["roll/scan1.tif"], measured["roll/scan2.tif"]
    assert [f.name for f in res1.rejected] == [CAMERA.names[0]]          # the blunder is rejected
    text = metashape_script([from_result(res1), from_result(res2)], CAMERA, [LeftOut("scan3.tif", "failed: x")])
    sensor = _Sensor("s0")
    scan1, other = _Camera("scan1", sensor), _Camera("unrelated", sensor)
    chunk = _Chunk([scan1, other])
    printed = run_script(text, chunk, monkeypatch, capsys)
    markers = fiducial_markers(chunk)
    used = {f.name: f for f in res1.used}
    assert set(markers) == set(used)                                      # the rejected fiducial gets no marker
    for name, m in markers.items():
        p = m.projections[scan1]
        assert p.pinned and p.coord == [used[name].x_px + PIXEL_OFFSET, used[name].y_px + PIXEL_OFFSET]
        assert np.hypot(*(np.array(p.coord) - PIXEL_OFFSET - truth1[name])) < TRUTH_PX
        x, y = CAMERA.fiducial(name).x_mm, CAMERA.fiducial(name).y_mm
        assert m.reference.location == [x, -y, 0.0] and CAMERA.y_axis == "up"   # given to Metashape y down
        assert m.sensor is sensor and other not in m.projections
    assert sensor.film_camera and sensor.focal_length == CAMERA.focal_length_mm
    assert sensor.pixel_size[0] == sensor.pixel_size[1] == pytest.approx(PIXEL_MM, rel=1e-3)
    assert "scan1: 7 fiducials placed" in printed
    assert "scan2: no camera with this label in the chunk: not placed" in printed
    assert "scan3.tif: left out: failed: x" in printed and "1 of 2 scans placed" in printed
    again = run_script(text, chunk, monkeypatch, capsys)                  # a second run reuses the markers
    assert set(fiducial_markers(chunk)) == set(used) and "1 of 2 scans placed" in again


def test_cameras_of_the_chunk_that_share_a_label_get_no_fiducials(measured, monkeypatch, capsys):
    """Two cameras of the project labelled as one scan: the script cannot tell which is the scan; it placed the
    fiducials on the first."""
    text = metashape_script([from_result(measured["roll/scan1.tif"][0])], CAMERA, [])
    chunk = _Chunk([_Camera("scan1", _Sensor("s0")), _Camera("scan1", _Sensor("s1"))])
    printed = run_script(text, chunk, monkeypatch, capsys)
    assert chunk.markers == [] and not any(c.sensor.film_camera for c in chunk.cameras)
    assert "scan1: 2 cameras in the chunk have this label: not placed" in printed
    assert "0 of 1 scans placed" in printed and "no camera with this label" not in printed
    unique = _Camera("scan1.tif", _Sensor("s2"))                          # the scan's file name: one camera
    chunk = _Chunk([_Camera("scan1", _Sensor("s0")), _Camera("scan1", _Sensor("s1")), unique])
    printed = run_script(text, chunk, monkeypatch, capsys)
    assert "1 of 1 scans placed" in printed and all(unique in m.projections for m in chunk.markers)


def test_a_camera_file_with_y_down_keeps_y_and_no_project_is_one_message(measured, monkeypatch, capsys):
    res, _ = measured["roll/scan2.tif"]
    down = replace(CAMERA, y_axis="down")
    chunk = _Chunk([_Camera("scan2.tif", _Sensor(1))])                    # a label with the extension matches too
    run_script(metashape_script([from_result(res)], down), chunk, monkeypatch, capsys)
    for m in fiducial_markers(chunk).values():
        f = down.fiducial(m.label)
        assert m.reference.location == [f.x_mm, f.y_mm, 0.0]
    printed = run_script(metashape_script([from_result(res)], down), None, monkeypatch, capsys)
    assert printed.startswith("aerofid: open the project")


def test_the_data_are_one_json_literal_that_survives_any_name(measured, monkeypatch, capsys):
    res, _ = measured["roll/scan2.tif"]
    odd = "a '''b\\\" \n\u00e9.tif"
    stored = replace(from_result(res), image=odd)
    left = [LeftOut("x'''\ny.tif", "failed: ''' \\")]
    text = metashape_script([stored, from_result(measured["roll/scan1.tif"][0])], CAMERA, left)
    namespace: dict = {}
    monkeypatch.setitem(sys.modules, "Metashape", types.ModuleType("Metashape"))
    head = text[:text.index("\ndef place_fiducials")]                     # the constants and the data only
    exec(compile(head, "metashape_fiducials.py", "exec"), namespace)
    assert namespace["DATA"] == json.loads(json.dumps(metashape_data([stored, from_result(
        measured["roll/scan1.tif"][0])], CAMERA, left)))
    assert namespace["DATA"]["frames"][0]["image"] == odd
    assert text.count("def ") == 1                                        # no code generated per frame or fiducial


def test_frames_with_the_same_label_are_left_out_after_the_first(measured):
    res, _ = measured["roll/scan1.tif"]
    twin = replace(from_result(res), image="other/scan1.tif")
    d = metashape_data([from_result(res), twin], CAMERA)
    assert [f["image"] for f in d["frames"]] == ["roll/scan1.tif"]
    assert d["left_out"] == [{"image": "other/scan1.tif", "reason": "another frame has the camera label 'scan1'"}]


def orient_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "aerofid", "orient", *map(str, args)], capture_output=True,
                          text=True)


def test_orient_metashape_round_trip_from_a_synthetic_scan(tmp_path, monkeypatch, capsys):
    """``aerofid orient SCAN --camera C --metashape S.py`` on a rendered frame; the script places every fiducial
    within the frame tests' bound of its true centre; measurements mode writes the same."""
    spec = frame_spec(CAMERA, PIXEL_MM, np.random.default_rng(3), rotation_deg=180)
    scan = tmp_path / "DZB-0042.tif"
    truth = write_frame(spec, scan, "tiled").marks
    cam = tmp_path / "camera.json"
    write_camera(cam, CAMERA)
    script, report = tmp_path / "fid.py", tmp_path / "io.json"
    r = orient_cli(scan, "--camera", cam, "--metashape", script, "-o", report)
    assert r.returncode == 0, r.stderr
    sensor = _Sensor(0)
    chunk = _Chunk([_Camera("DZB-0042", sensor)])
    run_script(script.read_text(), chunk, monkeypatch, capsys)
    markers = fiducial_markers(chunk)
    assert len(markers) >= 6
    for name, m in markers.items():
        u, v = m.projections[chunk.cameras[0]].coord
        assert np.hypot(u - PIXEL_OFFSET - truth[name][0], v - PIXEL_OFFSET - truth[name][1]) < TRUTH_PX
    found = json.loads(report.read_text())["orientation"]["fiducials"]
    meas = tmp_path / "m.csv"
    meas.write_text("name,x,y\n" + "".join(f"{f['name']},{f['x_px']!r},{f['y_px']!r}\n" for f in found))
    r = orient_cli(scan, "--camera", cam, "-m", meas, "--metashape", tmp_path / "m.py")
    assert r.returncode == 0, r.stderr
    assert json.loads(_data(tmp_path / "m.py"))["frames"] == json.loads(_data(script))["frames"]


def _data(script: Path) -> str:
    text = script.read_text()
    return text[text.index("r'''") + 4:text.index("''')")]


@pytest.mark.parametrize("args, match", [(["--metashape", "fid.txt"], "ending in .py"),
                                         (["--metashape", "fid.py", "--camera", "23cm"], "--metashape")])
def test_bad_metashape_options_are_one_line_and_exit_2(tmp_path, args, match):
    cam = tmp_path / "camera.json"
    write_camera(cam, CAMERA)
    scan = tmp_path / "s.tif"
    scan.write_bytes(b"")
    argv = [scan, *(["--camera", cam] if "--camera" not in args else []), *args]
    r = subprocess.run([sys.executable, "-m", "aerofid", "orient", *map(str, argv)], capture_output=True, text=True,
                       cwd=tmp_path)
    assert r.returncode == 2 and match in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not list(tmp_path.glob("fid*"))
