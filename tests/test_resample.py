"""`aerofid resample`: the fiducials land at their calibrated positions in the output, bit depth and bands are kept,
the extent and MicMac naming, bad inputs are one line with nothing written, and blocks change nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
import tifffile
from hypothesis import given, settings
from hypothesis import strategies as st

import aerofid
from aerofid.formats.micmac import affine_plane_xml
from aerofid.formats.orientation import read_orientation
from aerofid.frame.result import FAILED, OK, FrameOrientation
from aerofid.io.array import ArrayRaster
from aerofid.io.raster import open_raster
from aerofid.orientation.grid import ResampleGrid, bounding_extent
from aerofid.orientation.interior import orient
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.transform import AffineTransform
from aerofid.resample import KERNELS
from aerofid.resample.frame import resampled_bands
from aerofid.synth_frame import frame_spec, wild_rc10_camera, write_frame

PIXEL_MM = 0.13
"""Scan pixel size of the test frame: 1924 px a side (a 250 mm film), marks of about 30 px."""
OUT_MM = 0.1
EXTENT = (-115.0, -115.0, 115.0, 115.0)
LANDING_PX = 0.1
"""Issue 13's target: a fiducial located in the output lies within 0.1 px of its calibrated position."""


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "aerofid.cli", "resample", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd)


def assert_one_line_error(r):
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("error: ") and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    """A synthetic scan (film turned 90 degrees, shifted and tilted) with its exact marks, and the JSON that
    ``aerofid orient`` writes for it in both modes."""
    folder = tmp_path_factory.mktemp("resample")
    cam = wild_rc10_camera()
    spec = frame_spec(cam, PIXEL_MM, np.random.default_rng(7), rotation_deg=90)
    truth = write_frame(spec, folder / "scan.tif")
    meas = Measurements(np.array([truth.marks[n] for n in cam.names]), cam.names, "scan.tif")
    io = orient(cam, meas, image="scan.tif")
    (folder / "io.json").write_text(json.dumps(io.to_dict()))
    fo = FrameOrientation("scan.tif", cam.name, *spec.size_px, OK, (), (), io, 90, False, PIXEL_MM, "given")
    (folder / "frame.json").write_text(json.dumps(fo.to_dict()))
    return folder, cam, truth


def landing_errors(path, grid, cam):
    """Each fiducial located in the resampled frame minus where the grid puts its calibrated position (px)."""
    half = 4.0 / grid.pixel_size_mm
    errors = {}
    for f in cam.fiducials:
        x, y = grid.to_pixel([(f.x_mm, f.y_mm)])[0]
        loc = aerofid.locate(path, (x - half, y - half, x + half, y + half), mark="external")
        assert loc.found, (f.name, loc.reason)
        errors[f.name] = (loc.x - x, loc.y - y)
    return errors


@pytest.mark.parametrize("kernel", list(KERNELS))
def test_fiducials_land_at_their_calibrated_positions(frame, kernel):
    folder, cam, _ = frame
    out = folder / f"out_{kernel}.tif"
    r = run(folder / "scan.tif", "--orientation", folder / "frame.json", "--pixel-size", OUT_MM, "--extent", *EXTENT,
            "--kernel", kernel, "-o", out)
    assert r.returncode == 0, r.stderr
    grid = ResampleGrid(OUT_MM, EXTENT, cam.y_axis)
    with open_raster(out) as res:
        assert (res.width, res.height, res.bands, res.dtype) == (grid.width, grid.height, 1, np.uint8)
    errors = landing_errors(out, grid, cam)
    assert max(np.hypot(*e) for e in errors.values()) < LANDING_PX, errors


def test_the_output_is_tiled_compressed_with_overviews_and_describes_itself(frame):
    folder, cam, _ = frame
    out = folder / "described.tif"
    assert run(folder / "scan.tif", "--orientation", folder / "io.json", "--pixel-size", OUT_MM, "--extent", *EXTENT,
               "-o", out).returncode == 0
    with tifffile.TiffFile(out) as tif:
        pages = list(tif.pages)
        assert all(p.is_tiled and p.tilewidth == 512 and p.compression == 8 for p in pages)
        assert [p.shape for p in pages] == [(2301, 2301), (1151, 1151), (576, 576), (288, 288)]
        assert [p.subfiletype for p in pages] == [0, 1, 1, 1]
        inside = json.loads(pages[0].description)
    side = json.loads((folder / "described.px2mm.json").read_text())
    assert inside == side
    stored = read_orientation(folder / "described.px2mm.json")        # the sidecar reads back as an orientation
    xy_out = np.array([[f.x_px, f.y_px] for f in stored.fiducials])
    assert np.allclose(stored.transform(xy_out), cam.xy_mm, atol=1e-9)
    assert stored.y_axis == cam.y_axis


def test_default_extent_is_the_fiducials_bounding_box_as_micmac(frame):
    folder, cam, _ = frame
    out = folder / "default.tif"
    assert run(folder / "scan.tif", "--orientation", folder / "io.json", "--pixel-size", 0.5, "-o", out).returncode == 0
    side = json.loads((folder / "default.px2mm.json").read_text())
    xmin, ymin, xmax, ymax = bounding_extent(cam.xy_mm)
    assert side["grid"]["extent_mm"] == [xmin, ymin, xmax, ymax]
    # y up: the top-left pixel centre is (xmin, ymax), one pixel is 0.5 mm, and every pixel centre in the box is kept
    assert np.allclose(np.array(side["pixel_to_mm"]) @ [0, 0, 1], [xmin, ymax])
    assert np.allclose(np.array(side["pixel_to_mm"])[:, :2], [[0.5, 0], [0, -0.5]])
    with open_raster(out) as res:
        assert res.width == int((xmax - xmin) // 0.5) + 1 and res.height == int((ymax - ymin) // 0.5) + 1


def test_the_micmac_name(frame, tmp_path):
    folder, _, _ = frame
    r = run(folder / "scan.tif", "--orientation", folder / "io.json", "--pixel-size", 0.5, "--micmac-name",
            "-o", tmp_path)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["OIS-Reech_scan.px2mm.json", "OIS-Reech_scan.tif"]


@pytest.mark.parametrize("kind", ["uint16", "rgb"])
def test_bit_depth_and_bands_are_kept(frame, tmp_path, kind):
    folder, cam, _ = frame
    grey = tifffile.imread(folder / "scan.tif")
    image = grey.astype(np.uint16) * 257 if kind == "uint16" else np.dstack([grey, grey // 2, 255 - grey])
    tifffile.imwrite(tmp_path / "scan.tif", image, tile=(256, 256), photometric="rgb" if kind == "rgb" else None)
    common = ("--orientation", folder / "io.json", "--pixel-size", OUT_MM, "--extent", *EXTENT, "--kernel", "bilinear")
    assert run(tmp_path / "scan.tif", *common, "-o", tmp_path / "out.tif").returncode == 0
    assert run(folder / "scan.tif", *common, "-o", tmp_path / "grey.tif").returncode == 0
    out, ref = tifffile.imread(tmp_path / "out.tif"), tifffile.imread(tmp_path / "grey.tif").astype(np.int64)
    assert out.dtype == image.dtype and out.shape[2:] == image.shape[2:]
    if kind == "uint16":       # bilinear is linear: 257 x the 8-bit result, up to the 8-bit rounding
        assert np.abs(out.astype(np.int64) - 257 * ref).max() <= 129 + 1
    else:                      # each band resampled alike
        assert np.array_equal(out[..., 0], ref)
        assert np.abs(out[..., 2].astype(np.int64) - (255 - ref)).max() <= 1
    grid = ResampleGrid(OUT_MM, EXTENT, cam.y_axis)
    assert max(np.hypot(*e) for e in landing_errors(tmp_path / "out.tif", grid, cam).values()) < LANDING_PX


def test_an_affine_plane_gives_the_same_frame(frame, tmp_path):
    folder, _, _ = frame
    H = np.array(json.loads((folder / "io.json").read_text())["pixel_to_mm"])
    xml = tmp_path / "scan-AffinePlane-px2mm.xml"
    xml.write_text(affine_plane_xml(H))                                   # as 'aerofid orient --micmac' writes it
    common = ("--pixel-size", 0.5, "--extent", *EXTENT, "--y-axis", "up")
    assert run(folder / "scan.tif", "--orientation", xml, *common, "-o", tmp_path / "a.tif").returncode == 0
    assert run(folder / "scan.tif", "--orientation", folder / "io.json", *common, "-o", tmp_path / "b.tif"
               ).returncode == 0
    assert np.array_equal(tifffile.imread(tmp_path / "a.tif"), tifffile.imread(tmp_path / "b.tif"))


def _listing(folder):
    return sorted((p.name, p.stat().st_mtime_ns) for p in folder.iterdir())


def test_bad_inputs_are_one_line_and_write_nothing(frame, tmp_path):
    folder, cam, _ = frame
    failed = FrameOrientation("scan.tif", cam.name, 1924, 1924, FAILED, ("3 of 8 marks found",), (), None, None,
                              None, None, "estimated")
    (tmp_path / "failed.json").write_text(json.dumps(failed.to_dict()))
    small = tmp_path / "small.tif"
    tifffile.imwrite(small, tifffile.imread(folder / "scan.tif")[::2, ::2], tile=(256, 256))
    readonly = tmp_path / "readonly.tif"
    readonly.write_bytes(b"old")
    readonly.chmod(0o444)
    before = _listing(tmp_path)
    scan, io = folder / "scan.tif", folder / "io.json"
    cases = [
        (scan, "--orientation", tmp_path / "failed.json", "--pixel-size", 0.5, "-o", tmp_path / "a.tif"),
        (tmp_path / "missing.tif", "--orientation", io, "--pixel-size", 0.5, "-o", tmp_path / "b.tif"),
        (scan, "--orientation", io, "--pixel-size", 0.5, "-o", readonly),
        (scan, "--orientation", io, "--pixel-size", 0.5, "-o", tmp_path / "nofolder" / "c.tif"),
        (scan, "--orientation", io, "--pixel-size", -1, "-o", tmp_path / "d.tif"),
        (scan, "--orientation", io, "--pixel-size", 0.5, "--extent", 1, 0, 0, 1, "-o", tmp_path / "e.tif"),
        (scan, "--orientation", io, "--pixel-size", 0.5, "--export", "metashape=x.xml", "-o", tmp_path / "f.tif"),
        (scan, "--orientation", io, "--pixel-size", 0.5, "--export", f"asp={tmp_path / 'x.tsai'}",
         "-o", tmp_path / "g.tif"),
        (scan, "--orientation", io, "--pixel-size", 0.5, "--micmac-name", "-o", tmp_path / "h.tif"),
        (small, "--orientation", io, "--pixel-size", 0.5, "-o", tmp_path / "i.tif"),      # another scan's
    ]
    for args in cases:
        r = run(*args)
        assert_one_line_error(r)
        assert _listing(tmp_path) == before, args
    assert "failed (3 of 8 marks found)" in run(*cases[0]).stderr
    assert "lie outside" in run(*cases[-1]).stderr
    assert readonly.read_bytes() == b"old"


def test_a_read_only_sidecar_in_the_way_leaves_nothing(frame, tmp_path):
    """The sidecar beside OUT.tif is read-only: the command fails before any work and writes no frame either."""
    folder, _, _ = frame
    side = tmp_path / "out.px2mm.json"
    side.write_text("{}")
    os.chmod(side, 0o444)
    before = _listing(tmp_path)
    r = run(folder / "scan.tif", "--orientation", folder / "io.json", "--pixel-size", 0.5, "-o", tmp_path / "out.tif")
    assert_one_line_error(r)
    assert _listing(tmp_path) == before


@settings(max_examples=25, deadline=None, derandomize=True)
@given(rows=st.integers(1, 70), cols=st.integers(1, 90), kernel=st.sampled_from(list(KERNELS)),
       angle=st.floats(-180, 180), scale=st.floats(0.6, 1.6), rgb=st.booleans())
def test_blocks_of_any_size_give_the_same_frame(rows, cols, kernel, angle, scale, rgb):
    """Resampling in blocks of any size equals resampling in one block, sample for sample."""
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, (97, 83) + ((3,) if rgb else ()), dtype=np.uint8)
    t = np.radians(angle)
    A = scale * np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]) * [[1.0], [-1.0]]
    T = AffineTransform(np.c_[A, [-40.0 * scale, 45.0 * scale]])
    grid = ResampleGrid(1.0, (-60.0, -55.0, 60.0, 50.0), "up")
    out_to_src = np.linalg.inv(grid.scan_to_output(T))
    with ArrayRaster(image) as scan:
        whole = np.concatenate(list(resampled_bands(scan, out_to_src, grid, kernel, (grid.height, grid.width))))
        blocks = np.concatenate(list(resampled_bands(scan, out_to_src, grid, kernel, (rows, cols))))
    assert whole.shape[:2] == (grid.height, grid.width)
    assert np.array_equal(whole, blocks)
    assert whole.any()
