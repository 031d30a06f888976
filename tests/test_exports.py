"""Exports of an orientation and its resampled grid: CSV and JSON fiducials and matrices, OpenCV matrices that
OpenCV's own warp applies as documented, ASP pinhole intrinsics; and reading orientations back."""

from __future__ import annotations

import csv
import io
import json

import cv2
import numpy as np
import pytest

from aerofid.errors import AerofidInputError
from aerofid.formats.exports import asp_tsai, check_format, fiducials_csv, matrices, opencv_yaml, orientation_json
from aerofid.formats.micmac import affine_plane_xml
from aerofid.formats.orientation import from_result, read_orientation
from aerofid.frame.result import OK, FrameOrientation
from aerofid.io.array import ArrayRaster
from aerofid.orientation.grid import ResampleGrid
from aerofid.orientation.interior import orient
from aerofid.orientation.measurements import Measurements
from aerofid.resample.frame import resampled_bands
from aerofid.synth_frame import frame_spec, render_frame, wild_rc10_camera

PIXEL_MM = 0.25
"""A 1000 px frame: enough for the geometry, quick to render."""


@pytest.fixture(scope="module")
def oriented(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exports")
    cam = wild_rc10_camera()
    spec = frame_spec(cam, PIXEL_MM, np.random.default_rng(11), rotation_deg=270, mirrored=True)
    marks = spec.mm_to_px(cam.xy_mm) + np.random.default_rng(1).normal(0, 0.05, (len(cam.names), 2))
    res = orient(cam, Measurements(marks, cam.names, "scan.tif"), image="scan.tif")
    (folder / "io.json").write_text(json.dumps(res.to_dict()))
    fo = FrameOrientation("scan.tif", cam.name, *spec.size_px, OK, (), (), res, 270, True, PIXEL_MM, "given")
    (folder / "frame.json").write_text(json.dumps(fo.to_dict()))
    (folder / "px2mm.xml").write_text(affine_plane_xml(res.pixel_to_mm))
    return folder, cam, spec, res


def test_every_stored_form_reads_back_to_the_same_transformation(oriented):
    folder, cam, _, res = oriented
    forms = [read_orientation(folder / n) for n in ("io.json", "frame.json", "px2mm.xml")] + [from_result(res)]
    for stored in forms:
        assert np.allclose(stored.transform.matrix, res.pixel_to_mm, rtol=1e-12, atol=1e-12)
    assert forms[0].y_axis == forms[1].y_axis == forms[3].y_axis == cam.y_axis   # handedness and 'mirrored'
    assert forms[2].y_axis is None and forms[2].fiducials == ()      # an AffinePlane tells neither
    assert [f.name for f in forms[0].fiducials] == [f.name for f in res.fiducials]


@pytest.mark.parametrize("text, match", [("{}", "no interior orientation"), ("[1, 2]", "no interior orientation"),
                                         ('{"pixel_to_mm": [[1, 2], [3, 4]]}', "2x3 or 3x3"),
                                         ('{"pixel_to_mm": [[0, 0, 1], [0, 0, 2]]}', "invertible"),
                                         ("<AffinitePlane><I00>1</I00></AffinitePlane>", "two numbers"),
                                         ("not json", "not valid JSON")])
def test_bad_orientation_files_are_one_line(tmp_path, text, match):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(AerofidInputError, match=match):
        read_orientation(p)


def test_csv_and_json_give_the_fiducials_and_their_place_in_the_output(oriented):
    folder, cam, _, res = oriented
    stored = read_orientation(folder / "io.json")
    grid = ResampleGrid(0.05, (-115, -115, 115, 115), cam.y_axis)
    rows = list(csv.DictReader(io.StringIO(fiducials_csv(stored, grid))))
    d = json.loads(orientation_json(stored, grid))
    assert [r["name"] for r in rows] == [f["name"] for f in d["fiducials"]] == [f.name for f in res.fiducials]
    for r, f in zip(rows, res.fiducials):
        assert float(r["x_px"]) == f.x_px and float(r["residual_y_mm"]) == f.residual_y_mm
        out = grid.to_pixel([(f.x_mm, f.y_mm)])[0]
        assert np.allclose([float(r["x_out_px"]), float(r["y_out_px"])], out)
    assert np.allclose(np.array(d["pixel_to_mm"]) @ np.array(d["mm_to_pixel"]), np.eye(3))
    assert np.allclose(np.array(d["output_pixel_to_mm"]) @ np.array(d["scan_to_output"]), d["pixel_to_mm"])


def test_opencv_matrices_warp_as_aerofid_resamples(oriented, tmp_path):
    """cv2.warpAffine with the exported M (dst = M src, pixel centres at integers) gives aerofid's resampled frame:
    the convention the export states is the one OpenCV applies."""
    folder, cam, spec, _ = oriented
    stored = read_orientation(folder / "io.json")
    grid = ResampleGrid(0.4, (-110, -110, 110, 110), cam.y_axis)
    path = tmp_path / "m.yml"
    path.write_text(opencv_yaml(stored, grid))
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    M = fs.getNode("scan_to_output").mat()
    size = (int(fs.getNode("width").real()), int(fs.getNode("height").real()))
    fs.release()
    assert np.allclose(M, matrices(stored, grid)["scan_to_output"]) and size == (grid.width, grid.height)
    scan = render_frame(spec)
    warped = cv2.warpAffine(scan, M[:2], size, flags=cv2.INTER_LINEAR)
    with ArrayRaster(scan) as r:
        ours = np.concatenate(list(resampled_bands(r, np.linalg.inv(M), grid, "bilinear", (128, 128))))
    inner = (slice(2, -2), slice(2, -2))
    assert np.abs(warped[inner].astype(int) - ours[inner].astype(int)).max() <= 1


def test_asp_intrinsics_put_the_principal_point_where_the_grid_does(oriented):
    _, cam, _, _ = oriented
    grid = ResampleGrid(0.021, (-115, -115, 115, 115), cam.y_axis)
    text = asp_tsai(grid, cam.focal_length_mm, cam.principal_point_mm[0])
    kv = dict(line.split(" = ") for line in text.splitlines() if " = " in line)
    assert text.splitlines()[:2] == ["VERSION_4", "PINHOLE"] and text.splitlines()[-1] == "NULL"
    assert float(kv["fu"]) == float(kv["fv"]) == cam.focal_length_mm and float(kv["pitch"]) == 0.021
    col, row = float(kv["cu"]) / 0.021, float(kv["cv"]) / 0.021
    assert np.allclose(grid.to_mm([(col, row)])[0], cam.ppa_mm)
    with pytest.raises(AerofidInputError, match="focal length"):
        asp_tsai(grid, None, (0.0, 0.0))


def test_unknown_formats_are_named():
    with pytest.raises(AerofidInputError, match="csv, json, opencv, asp"):
        check_format("pix4d", resampled=True)
    with pytest.raises(AerofidInputError, match="--metashape SCRIPT.py"):     # the original scan's, not here
        check_format("metashape", resampled=True)
    with pytest.raises(AerofidInputError, match="resampled frame"):
        check_format("asp", resampled=False)
