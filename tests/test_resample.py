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
from aerofid.formats.micmac import affine_plane_xml, micmac_texts
from aerofid.formats.orientation import read_orientation
from aerofid.frame.result import FAILED, OK, FrameOrientation
from aerofid.io.array import ArrayRaster
from aerofid.io.raster import open_raster
from aerofid.orientation.grid import ResampleGrid, bounding_extent
from aerofid.orientation.interior import orient
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.transform import AffineTransform
from aerofid.resample import KERNELS, ifd, tiff
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


def test_the_output_has_the_permissions_of_a_file_made_in_place(frame, tmp_path):
    """The resampled TIFF is streamed into a temporary file (mkstemp's: the owner's alone) and renamed: it was left
    readable by its owner only, its sidecar not (a helper's audit); both now as the umask gives any new file."""
    folder, _, _ = frame
    umask = os.umask(0o022)
    try:
        assert run(folder / "scan.tif", "--orientation", folder / "io.json", "--pixel-size", 0.5, "-o",
                   tmp_path / "out.tif").returncode == 0
    finally:
        os.umask(umask)
    assert {p.name: p.stat().st_mode & 0o777 for p in tmp_path.iterdir()} == {"out.tif": 0o644,
                                                                                "out.px2mm.json": 0o644}


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


def test_an_affine_plane_aerofid_writes_carries_its_film_y_axis(frame, tmp_path):
    """``aerofid orient --micmac`` writes the AffinePlane in the camera file's mm, whose certificate y points up; read
    as MicMac's (y down) the frame came out upside down (a helper's audit). The plane aerofid writes notes its y axis
    in a comment MicMac ignores: no ``--y-axis`` is needed; a plane without the note is MicMac's, down."""
    folder, cam, _ = frame
    io = read_orientation(folder / "io.json")
    assert io.y_axis == cam.y_axis == "up"
    plain = tmp_path / "plain-AffinePlane-px2mm.xml"
    plain.write_text(affine_plane_xml(io.transform.matrix[:2]))
    assert read_orientation(plain).y_axis is None
    noted = tmp_path / "scan-AffinePlane-px2mm.xml"
    measured = Measurements(np.array([[f.x_px, f.y_px] for f in io.fiducials]), tuple(f.name for f in io.fiducials),
                            "scan.tif")
    noted.write_text(micmac_texts(cam, orient(cam, measured, image="scan.tif"))[-1])    # as orient --micmac does
    assert read_orientation(noted).y_axis == "up"
    common = ("--pixel-size", 0.5, "--extent", *EXTENT)
    assert run(folder / "scan.tif", "--orientation", noted, *common, "-o", tmp_path / "a.tif").returncode == 0
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


# --- the output file: GDAL's Cloud-Optimized GeoTIFF layout (aerofid.resample.tiff, aerofid.resample.ifd) ---

def cog_layout_errors(path):
    """The rules of GDAL's validate_cloud_optimized_geotiff.py (with its full check), read from the file itself:
    the ghost header right after the TIFF header and the first IFD right after it; the IFDs in page order, by
    decreasing size; every IFD and every tile offset / byte count array before the first tile; each level's
    tiles in row-major order, each level's first tile after the last tile of the next smaller level (the
    smallest level's tiles first); each tile's 4-byte leader its byte count and its trailer its last 4 bytes."""
    raw = path.read_bytes()
    errors = []
    with tifffile.TiffFile(path) as tif:
        pages = list(tif.pages)
        start = 16 if tif.is_bigtiff else 8
        line = raw[start:start + 43].decode("latin-1")
        size = int(line[30:36]) if line.startswith("GDAL_STRUCTURAL_METADATA_SIZE=") else 0
        ghost = set(raw[start + 43:start + 43 + size].decode("latin-1").split())
        first = start + 43 + size + (start + 43 + size) % 2 if size else start
        if pages[0].offset != first:
            errors.append(f"the first IFD is at {pages[0].offset}, not {first}")
        if not {"LAYOUT=IFDS_BEFORE_DATA", "BLOCK_ORDER=ROW_MAJOR", "BLOCK_LEADER=SIZE_AS_UINT4",
                "BLOCK_TRAILER=LAST_4_BYTES_REPEATED", "KNOWN_INCOMPATIBLE_EDITION=NO"} <= ghost:
            errors.append(f"ghost metadata {ghost}")
        tiles = [(list(p.dataoffsets), list(p.databytecounts)) for p in pages]
        first_tile = min(o for offsets, _ in tiles for o in offsets)
        arrays = [t.valueoffset + t.count * (8 if tif.is_bigtiff else 4) for p in pages for t in p.tags.values()
                  if t.code in (324, 325)]
        if max([p.offset for p in pages] + arrays) >= first_tile:
            errors.append("an IFD or a tile array after the first tile")
        if [p.offset for p in pages] != sorted(p.offset for p in pages):
            errors.append("IFDs not in page order")
        if any(a.shape[0] < b.shape[0] or a.shape[1] < b.shape[1] for a, b in zip(pages, pages[1:])):
            errors.append("levels not by decreasing size")
        for i, (offsets, counts) in enumerate(tiles):
            if offsets != sorted(offsets):
                errors.append(f"level {i}: tiles not in row-major order")
            if i + 1 < len(tiles) and offsets[0] < tiles[i + 1][0][-1] + tiles[i + 1][1][-1]:
                errors.append(f"level {i}'s tiles start before level {i + 1}'s end")
            for o, n in zip(offsets, counts):
                if int.from_bytes(raw[o - 4:o], "little") != n or raw[o + n - 4:o + n] != raw[o + n:o + n + 4]:
                    errors.append(f"level {i}: the tile at {o} has a wrong leader or trailer")
    return errors


def write_image(path, image, **kwargs):
    """``image`` written by ``write_tiled`` in bands of TILE rows, as resample_scan feeds it."""
    h, w = image.shape[:2]
    tiff.write_tiled(path, (image[r:r + tiff.TILE] for r in range(0, h, tiff.TILE)), w, h, image.dtype,
                image.shape[2] if image.ndim == 3 else 1, **kwargs)


def reduce2_chain(image):
    levels = [image]
    for _ in tiff.overview_sizes(image.shape[1], image.shape[0]):
        levels.append(tiff.reduce2(levels[-1]))
    return levels


IMAGES = {"uint8": ((1300, 1100), np.uint8), "uint16": ((1100, 1030), np.uint16), "rgb": ((700, 1537, 3), np.uint8),
          "rgb16": ((513, 600, 3), np.uint16), "float32": ((1025, 513), np.float32), "tiny": ((100, 37), np.uint8)}
"""Sizes that are not multiples of 512 (an odd overview size included); the tiny one has no overviews."""


def sample_image(kind):
    shape, dtype = IMAGES[kind]
    rng = np.random.default_rng(3)
    ramp = np.add.outer(np.arange(shape[0]), np.arange(shape[1])).reshape(shape[:2] + (1,) * (len(shape) - 2))
    image = ramp * 3.7 + rng.normal(0, 20, shape)             # compressible and not: both decode paths
    return np.clip(image, 0, np.iinfo(dtype).max).astype(dtype) if dtype != np.float32 else image.astype(dtype)


@pytest.mark.parametrize("kind", list(IMAGES))
def test_the_cog_reads_back_bit_exact_with_its_overviews_in_gdals_layout(tmp_path, kind):
    image = sample_image(kind)
    path = tmp_path / f"{kind}.tif"
    write_image(path, image, description='{"a": 1}', pixel_size_mm=0.015)
    with tifffile.TiffFile(path) as tif:
        pages = list(tif.pages)
        levels = reduce2_chain(image)
        assert len(pages) == len(levels) == (1 if kind == "tiny" else len(pages))
        for page, level in zip(pages, levels):
            assert np.array_equal(page.asarray(), level)
            assert page.is_tiled and page.tilewidth == page.tilelength == tiff.TILE and page.compression == 8
            assert page.predictor == (3 if kind == "float32" else 2)
            assert page.photometric == (2 if image.ndim == 3 else 1)
        assert [p.subfiletype for p in pages] == [0] + [1] * (len(pages) - 1)
        assert pages[0].description == '{"a": 1}'
        assert pages[0].tags["XResolution"].value == (2000, 3) and pages[0].tags["ResolutionUnit"].value == 3
        assert not tif.is_bigtiff
    assert cog_layout_errors(path) == []


@settings(max_examples=10, deadline=None, derandomize=True)
@given(cuts=st.lists(st.integers(1, 1299), max_size=8, unique=True))
def test_bands_cut_anywhere_give_the_same_file(tmp_path_factory, cuts):
    """Rows go down the pyramid in pairs whatever the bands that bring them (odd, taller than a tile): the file
    is the same, byte for byte, as from bands of TILE rows."""
    image = sample_image("uint8")
    folder = tmp_path_factory.mktemp("bands")
    write_image(folder / "tiles.tif", image)
    edges = [0, *sorted(cuts), image.shape[0]]
    tiff.write_tiled(folder / "cut.tif", (image[a:b] for a, b in zip(edges, edges[1:])), image.shape[1],
                     image.shape[0], image.dtype, 1)
    assert (folder / "cut.tif").read_bytes() == (folder / "tiles.tif").read_bytes()


def test_bigtiff_on_request_and_past_4_gb(tmp_path):
    image = sample_image("uint16")
    write_image(tmp_path / "big.tif", image, bigtiff=True)
    with tifffile.TiffFile(tmp_path / "big.tif") as tif:
        assert tif.is_bigtiff
        assert all(np.array_equal(p.asarray(), lv) for p, lv in zip(tif.pages, reduce2_chain(image)))
    assert cog_layout_errors(tmp_path / "big.tif") == []
    # the layout of a 5 GB file, without its data: BigTIFF unless forbidden, its offsets past 4 GB in LONG8
    info = tiff.Image(40000, 40000, np.dtype(np.uint16), 1)
    sizes = [(40000, 40000)] + tiff.overview_sizes(40000, 40000)
    counts = [[1 << 20] * (-(-w // tiff.TILE) * -(-h // tiff.TILE)) for w, h in sizes]
    assert tiff.layout(info, sizes, counts, False).end > tiff.BIGTIFF_LIMIT
    plan = tiff.file_layout(info, sizes, counts)
    assert plan.bigtiff and plan.end > 5e9
    with pytest.raises(ValueError, match="do not fit a classic TIFF"):
        tiff.file_layout(info, sizes, counts, bigtiff=False)
    (tmp_path / "head.tif").write_bytes(tiff.directory(info, sizes, counts, plan))
    with tifffile.TiffFile(tmp_path / "head.tif") as tif:
        assert [p.shape for p in tif.pages] == [(h, w) for w, h in sizes]
        assert tif.pages[0].dataoffsets[-1] == plan.end - 4 - (1 << 20) and tif.pages[0].tags[324].dtype == 16


def test_the_resampled_frame_is_a_cog(frame, tmp_path):
    folder, _, _ = frame
    out = tmp_path / "out.tif"
    assert run(folder / "scan.tif", "--orientation", folder / "io.json", "--pixel-size", OUT_MM, "--extent", *EXTENT,
               "-o", out).returncode == 0
    assert cog_layout_errors(out) == []


def test_the_layout_check_catches_tifffiles_layout(tmp_path):
    """tifffile writes each page's IFD before its data, the full resolution first: the check refuses it."""
    image = sample_image("uint8")
    with tifffile.TiffWriter(tmp_path / "plain.tif") as tif:
        for level in reduce2_chain(image):
            tif.write(level, tile=(tiff.TILE, tiff.TILE), compression="zlib", subfiletype=int(level is not image))
    errors = cog_layout_errors(tmp_path / "plain.tif")
    assert "an IFD or a tile array after the first tile" in errors
    assert "level 0's tiles start before level 1's end" in errors
    assert any("ghost" in e for e in errors) and any("leader or trailer" in e for e in errors)


def test_gdals_own_validator_when_gdal_is_installed(tmp_path):
    """GDAL's validate_cloud_optimized_geotiff.py (full check) and GDAL reading the pixels; skipped without GDAL
    (CI has none)."""
    gdal = pytest.importorskip("osgeo.gdal")
    validator = pytest.importorskip("osgeo_utils.samples.validate_cloud_optimized_geotiff")
    for kind, bigtiff in [("uint8", False), ("rgb16", False), ("rgb16", True), ("float32", False), ("tiny", False)]:
        image = sample_image(kind)
        write_image(tmp_path / f"{kind}.tif", image, bigtiff=bigtiff)
        *_, errors, details = validator.validate(str(tmp_path / f"{kind}.tif"), full_check=True)  # [warnings, ]...
        assert errors == [], (kind, errors, details)
        ds = gdal.Open(str(tmp_path / f"{kind}.tif"))
        assert ds.GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE") == "COG"
        band = ds.GetRasterBand(1)
        levels = [level[..., 0] if image.ndim == 3 else level for level in reduce2_chain(image)]
        for i, level in enumerate(levels):          # ReadRaster: GDAL's bytes, no need for its numpy binding
            b = band.GetOverview(i - 1) if i else band
            assert np.array_equal(np.frombuffer(b.ReadRaster(), image.dtype).reshape(b.YSize, b.XSize), level)
        assert band.GetOverviewCount() == len(levels) - 1
        ds = None


VALUES = {ifd.SHORT: st.integers(0, 2 ** 16 - 1), ifd.LONG: st.integers(0, 2 ** 32 - 1),
          ifd.LONG8: st.integers(0, 2 ** 64 - 1), ifd.RATIONAL: st.integers(1, 2 ** 32 - 1),
          ifd.DOUBLE: st.floats(allow_nan=False)}


@st.composite
def extra_tags(draw, bigtiff):
    """Private tags (65000...) of every type the writer knows, 1-9 values each (an ASCII text up to 20 chars)."""
    types = [t for t in (ifd.ASCII, *VALUES) if bigtiff or t != ifd.LONG8]
    tags = []
    for i, t in enumerate(draw(st.lists(st.sampled_from(types), max_size=6))):
        if t == ifd.ASCII:
            values = draw(st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=20))
        else:
            n = draw(st.integers(1, 9)) * (2 if t == ifd.RATIONAL else 1)
            values = tuple(draw(st.lists(VALUES[t], min_size=n, max_size=n)))
        tags.append(ifd.Tag(65000 + i, t, values))
    return tags


@settings(max_examples=60, deadline=None, derandomize=True)
@given(data=st.data(), bigtiff=st.booleans(), gap=st.integers(0, 3))
def test_the_ifd_writer_reads_back_with_tifffile(tmp_path_factory, data, bigtiff, gap):
    """A 3 x 2 image and extra tags of every type, written by aerofid.resample.ifd (at an odd-sized gap after the
    header, rounded to even) and read back by tifffile: pixels, every value, every value at an even offset."""
    extra = data.draw(extra_tags(bigtiff))
    first = ifd.header_size(bigtiff) + gap + gap % 2
    pixels = np.arange(6, dtype=np.uint8).reshape(2, 3)
    image = [ifd.Tag(256, ifd.SHORT, (3,)), ifd.Tag(257, ifd.LONG, (2,)), ifd.Tag(258, ifd.SHORT, (8,)),
             ifd.Tag(259, ifd.SHORT, (1,)), ifd.Tag(262, ifd.SHORT, (1,)), ifd.Tag(278, ifd.LONG, (2,)),
             ifd.Tag(279, ifd.LONG, (6,))]
    strip = first + ifd.ifd_size(image + [ifd.Tag(273, ifd.LONG, (0,))] + extra, bigtiff)
    tags = [ifd.Tag(273, ifd.LONG, (strip,))] + extra + image[::-1]      # in any order: the writer sorts them
    path = tmp_path_factory.mktemp("ifd") / "t.tif"
    path.write_bytes(ifd.header(bigtiff, first) + b"\0" * (first - ifd.header_size(bigtiff))
                     + ifd.ifd_bytes(tags, first, 0, bigtiff) + pixels.tobytes())
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        assert tif.is_bigtiff == bigtiff and page.offset == first
        assert np.array_equal(page.asarray(), pixels)
        assert [t.code for t in page.tags.values()] == sorted(t.code for t in tags)
        for t in extra:
            got = page.tags[t.code]
            assert got.dtype == t.type and got.count == t.count
            assert got.valueoffset % 2 == 0
            value = got.value if isinstance(got.value, tuple | str) else (got.value,)
            assert value == (t.values.rstrip() if isinstance(t.values, str) else t.values)


def test_the_ifd_writer_refuses_what_tiff_forbids():
    with pytest.raises(ValueError, match="even"):
        ifd.ifd_bytes([ifd.Tag(256, ifd.SHORT, (1,))], 9, 0, False)
    with pytest.raises(ValueError, match="once"):
        ifd.ifd_bytes([ifd.Tag(256, ifd.SHORT, (1,)), ifd.Tag(256, ifd.LONG, (1,))], 8, 0, False)
