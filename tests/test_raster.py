"""Tests of aerofid.io.raster (opening scans, windowed reads, boxes) and aerofid.io.colour (grey levels and
colour policy)."""

from __future__ import annotations

import math
import os

import cv2
import numpy as np
import pytest
import tifffile
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid.errors import AerofidInputError
from aerofid.io import raster as raster_module
from aerofid.io.array import ArrayRaster
from aerofid.io.colour import MIX_WEIGHTS, choose_channel_mix, luminance_first, mark_contrast, normalise, to_grey
from aerofid.io.jpeg import subsampled_components
from aerofid.io.raster import Raster, check_window_size, clip_box, open_raster, segment_indices
from aerofid.io.reduce import ReducedView
from conftest import realdata_path
from raster_checks import HEIGHT, WIDTH, random_image, record_decoded_segments, write_tiff

COLORMAP = np.zeros((3, 256), np.uint16)
BANDS_CONTIG = {"photometric": "minisblack", "planarconfig": "contig"}
VOLUME = {"photometric": "minisblack", "volumetric": True, "tile": (2, 16, 16)}
RC20 = "unbc_bc_wild_rc20/15BCC02013_114.jpg"
WINDOWS = [(0, 0, WIDTH, HEIGHT), (10, 20, 50, 60), (31, 47, 97, 150), (WIDTH - 1, HEIGHT - 1, WIDTH, HEIGHT)]
GEOTIFF_TAGS = [
    (33550, "d", 3, (0.5, 0.5, 0.0), False),  # ModelPixelScale
    (33922, "d", 6, (0.0, 0.0, 0.0, 500000.0, 6000000.0, 0.0), False),  # ModelTiepoint
    (34735, "H", 8, (1, 1, 0, 1, 1024, 0, 1, 1), False),  # GeoKeyDirectory: projected
]


def smooth_image(bands, shape=(HEIGHT, WIDTH)):
    """A smooth uint8 image, which JPEG keeps close to the original."""
    y, x = np.mgrid[: shape[0], : shape[1]]
    planes = [(127 + 100 * np.sin(x / 17 + k) * np.cos(y / 23 - k)) for k in range(bands)]
    image = np.stack(planes, axis=-1).round().astype(np.uint8)
    return image[:, :, 0] if bands == 1 else image


# Lossless TIFF layouts: (id, dtype, bands, tifffile.imwrite keyword arguments).
LOSSLESS_TIFFS = [
    ("striped-raw", np.uint8, 1, {}),
    ("striped-raw-multistrip-rgb", np.uint8, 3, {"rowsperstrip": 16}),
    ("striped-deflate", np.uint8, 1, {"rowsperstrip": 16, "compression": "zlib"}),
    ("striped-lzw-rgb", np.uint8, 3, {"rowsperstrip": 7, "compression": "lzw"}),
    ("striped-packbits", np.uint8, 1, {"rowsperstrip": 10, "compression": "packbits"}),
    ("tiled-raw", np.uint8, 1, {"tile": (32, 48)}),
    ("tiled-deflate", np.uint8, 1, {"tile": (32, 48), "compression": "zlib"}),
    ("tiled-lzw-rgb", np.uint8, 3, {"tile": (64, 32), "compression": "lzw"}),
    ("tiled-predictor-16bit", np.uint16, 1, {"tile": (32, 32), "compression": "zlib", "predictor": 2}),
    ("tiled-16bit-rgb", np.uint16, 3, {"tile": (48, 64), "compression": "zlib"}),
    ("tiled-float32", np.float32, 1, {"tile": (32, 32), "compression": "zlib"}),
    ("bigtiff-tiled", np.uint16, 1, {"tile": (32, 32), "bigtiff": True, "compression": "zlib"}),
    ("bigtiff-striped-rgb", np.uint8, 3, {"bigtiff": True, "rowsperstrip": 8}),
    ("bigendian-16bit", np.uint16, 1, {"byteorder": ">", "tile": (32, 32)}),
    ("bigendian-raw-16bit", np.uint16, 1, {"byteorder": ">"}),
    ("geotiff", np.uint8, 1, {"tile": (32, 32), "extratags": GEOTIFF_TAGS}),
]


def write_cv2(path, rgb_or_grey):
    """Write an RGB(A) or grey image with OpenCV (which wants BGR(A)) and return ``path``."""
    image = rgb_or_grey
    if image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR if image.shape[2] == 3 else cv2.COLOR_RGBA2BGRA)
    assert cv2.imwrite(str(path), image)
    return path


# ------------------------------------------------------------------------------------------------
# Reading TIFF
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("dtype", "bands", "kwargs"), [c[1:] for c in LOSSLESS_TIFFS], ids=[c[0] for c in LOSSLESS_TIFFS]
)
def test_lossless_tiff_windows_equal_slices_of_the_image(tmp_path, dtype, bands, kwargs):
    image = random_image(dtype, bands)
    path = write_tiff(tmp_path / "scan.tif", image, **kwargs)
    with open_raster(path) as raster:
        assert (raster.width, raster.height, raster.bands) == (WIDTH, HEIGHT, bands)
        assert raster.dtype == np.dtype(dtype)
        assert raster.tiled == ("tile" in kwargs)
        assert raster.format == "tiff"
        for x0, y0, x1, y1 in WINDOWS:
            window = raster.read_window((x0, y0, x1, y1))
            assert window.dtype == np.dtype(dtype) and window.dtype.isnative
            np.testing.assert_array_equal(window, image[y0:y1, x0:x1])


@pytest.mark.parametrize("kwargs", [{"tile": (32, 32), "compression": "zlib"},
                                    {"rowsperstrip": 8, "compression": "zlib"}], ids=["tiled", "striped"])
def test_segments_read_at_their_offsets_or_under_the_lock_are_the_same(tmp_path, kwargs, monkeypatch):
    """A TIFF's tiles or strips are read with ``os.pread`` at their offsets (the threads of a reduced read need no
    lock), or, where the platform or the file handle has no descriptor, by a seek and a read under a lock: the same
    windows and reduced windows either way."""
    image = random_image(np.uint16, 1)
    path = write_tiff(tmp_path / "scan.tif", image, **kwargs)
    with open_raster(path) as raster:
        assert raster._reader._positional is not None
        by_offset = [raster.read_window(w) for w in WINDOWS], raster.read_reduced((0, 0, WIDTH, HEIGHT), 4)
    monkeypatch.setattr(raster_module, "_positional_reads", lambda filehandle: None)
    with open_raster(path) as raster:
        assert raster._reader._positional is None
        locked = [raster.read_window(w) for w in WINDOWS], raster.read_reduced((0, 0, WIDTH, HEIGHT), 4)
    for a, b in zip(by_offset[0], locked[0], strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(by_offset[1], locked[1])
    np.testing.assert_array_equal(by_offset[0][0], image[WINDOWS[0][1]:WINDOWS[0][3], WINDOWS[0][0]:WINDOWS[0][2]])


def test_a_positional_read_gathers_short_reads_and_stops_at_the_end(tmp_path, monkeypatch):
    """``_pread`` gives ``count`` bytes from the offset as a file's ``read`` does: gathered where the system returns
    fewer at a time, fewer only where the file ends."""
    path = tmp_path / "bytes.bin"
    path.write_bytes(bytes(range(256)) * 4)
    real = os.pread
    monkeypatch.setattr(os, "pread", lambda fd, n, offset: real(fd, min(n, 100), offset))    # 100 bytes at a time
    fd = os.open(path, os.O_RDONLY)
    try:
        assert raster_module._pread(fd, 300, 10) == (bytes(range(256)) * 4)[10:310]
        assert raster_module._pread(fd, 300, 900) == (bytes(range(256)) * 4)[900:]          # the file ends
        assert raster_module._pread(fd, 10, 2000) == b""
    finally:
        os.close(fd)


@pytest.mark.parametrize("tile", [None, (32, 32)])
def test_planar_separate_rgb_is_read_as_rgb(tmp_path, tile):
    image = random_image(np.uint8, 3)
    path = tmp_path / "planar.tif"
    planes = image.transpose(2, 0, 1)
    tifffile.imwrite(path, planes, photometric="rgb", planarconfig="separate", tile=tile, compression="zlib")
    with open_raster(path) as raster:
        assert raster.bands == 3
        np.testing.assert_array_equal(raster.read_window((5, 7, 100, 190)), image[7:190, 5:100])


@pytest.mark.parametrize("kwargs", [{"tile": (32, 32)}, {"rowsperstrip": 16}], ids=["tiled", "striped"])
@pytest.mark.parametrize("bands", [1, 3])
def test_jpeg_compressed_tiff_matches_tifffile_and_the_original(tmp_path, kwargs, bands):
    image = smooth_image(bands)
    path = write_tiff(tmp_path / "jpeg.tif", image, compression="jpeg", **kwargs)
    whole = tifffile.imread(path)
    with open_raster(path) as raster:
        window = raster.read_window((10, 20, 150, 200))
    np.testing.assert_array_equal(window, whole[20:200, 10:150])
    assert np.abs(window.astype(int) - image[20:200, 10:150]).mean() < 3


def test_rgba_tiff_drops_alpha(tmp_path):
    image = random_image(np.uint8, 4)
    path = tmp_path / "rgba.tif"
    tifffile.imwrite(path, image, photometric="rgb", extrasamples=["unassalpha"], tile=(32, 32))
    with open_raster(path) as raster:
        assert raster.bands == 3
        np.testing.assert_array_equal(raster.read_window((3, 4, 60, 70)), image[4:70, 3:60, :3])


def test_miniswhite_tiff_is_inverted_to_minisblack(tmp_path):
    image = random_image(np.uint8, 1)
    path = tmp_path / "white.tif"
    tifffile.imwrite(path, image, photometric="miniswhite")
    with open_raster(path) as raster:
        np.testing.assert_array_equal(raster.read_window((0, 0, 40, 30)), 255 - image[:30, :40])


def test_tiled_read_decodes_only_the_intersecting_tiles(tmp_path, monkeypatch):
    image = random_image(np.uint8, 1, shape=(256, 256))
    path = write_tiff(tmp_path / "tiled.tif", image, tile=(64, 64), compression="zlib")  # 4 x 4 tiles
    decoded = record_decoded_segments(monkeypatch)
    with open_raster(path) as raster:
        np.testing.assert_array_equal(raster.read_window((70, 70, 120, 100)), image[70:100, 70:120])
        assert decoded == [5]  # row 1, column 1
        decoded.clear()
        np.testing.assert_array_equal(raster.read_window((60, 0, 130, 10)), image[0:10, 60:130])
        assert decoded == [0, 1, 2]
        decoded.clear()
        np.testing.assert_array_equal(raster.read_window((0, 0, 256, 256)), image)
        assert decoded == list(range(16))


def test_striped_read_decodes_only_the_intersecting_strips(tmp_path, monkeypatch):
    image = random_image(np.uint8, 3, shape=(100, 40))
    path = write_tiff(tmp_path / "striped.tif", image, rowsperstrip=10, compression="zlib")
    decoded = record_decoded_segments(monkeypatch)
    with open_raster(path) as raster:
        np.testing.assert_array_equal(raster.read_window((5, 25, 30, 41)), image[25:41, 5:30])
    assert decoded == [2, 3, 4]


def test_layouts_that_cannot_be_windowed_are_decoded_whole_once(tmp_path, monkeypatch):
    image = random_image(np.uint8, 3, shape=(100, 40))
    path = write_tiff(tmp_path / "striped.tif", image, rowsperstrip=10, compression="zlib")
    # tifffile repairs wrong segment counts itself, so force the "cannot window" verdict
    monkeypatch.setattr(raster_module._TiffSegmentReader, "expected_segments", lambda self: -1)
    decoded = record_decoded_segments(monkeypatch)
    with open_raster(path) as raster:
        assert decoded == []  # lazily: nothing decoded before the first read
        np.testing.assert_array_equal(raster.read_window((5, 25, 30, 41)), image[25:41, 5:30])
        np.testing.assert_array_equal(raster.read_window((0, 90, 40, 100)), image[90:100])
    assert sorted(decoded) == list(range(10))  # every strip, once


def test_a_corrupt_tile_outside_the_window_is_never_decoded(tmp_path):
    image = random_image(np.uint8, 1, shape=(128, 128))
    path = write_tiff(tmp_path / "tiled.tif", image, tile=(64, 64), compression="zlib")
    with tifffile.TiffFile(path) as tif:
        offset, count = tif.pages[0].dataoffsets[3], tif.pages[0].databytecounts[3]  # bottom-right tile
    with path.open("r+b") as file:
        file.seek(offset)
        file.write(b"\xff" * count)
    with open_raster(path) as raster:
        np.testing.assert_array_equal(raster.read_window((0, 0, 64, 128)), image[:, :64])
        with pytest.raises(AerofidInputError, match="cannot decode window"):
            raster.read_window((60, 60, 70, 70))


def test_empty_tiles_read_as_nodata_and_a_huge_window_is_refused(tmp_path):
    path = tmp_path / "sparse.tif"

    def tiles():  # one real tile, then empty ones: a 40000 x 40000 image in a small file
        yield np.full((256, 256), 7, np.uint8)
        yield from (None for _ in range(157 * 157 - 1))

    tifffile.imwrite(path, tiles(), shape=(40000, 40000), dtype=np.uint8, tile=(256, 256), compression="zlib")
    with open_raster(path) as raster:
        window = raster.read_window((250, 0, 260, 3))
        np.testing.assert_array_equal(window, [[7] * 6 + [0] * 4] * 3)
        with pytest.raises(AerofidInputError, match=r"1\.6 GB.*smaller box"):
            raster.read_window((0, 0, 40000, 40000))


# ------------------------------------------------------------------------------------------------
# Reading PNG and JPEG
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("dtype", "bands"), [(np.uint8, 1), (np.uint8, 3), (np.uint16, 1), (np.uint16, 3)])
def test_png_windows_equal_slices_of_the_image(tmp_path, dtype, bands):
    image = random_image(dtype, bands)
    path = write_cv2(tmp_path / "scan.png", image)
    with open_raster(path) as raster:
        assert (raster.width, raster.height, raster.bands) == (WIDTH, HEIGHT, bands)
        assert raster.dtype == np.dtype(dtype)
        assert raster.format == "png" and not raster.tiled
        for x0, y0, x1, y1 in WINDOWS:
            np.testing.assert_array_equal(raster.read_window((x0, y0, x1, y1)), image[y0:y1, x0:x1])


def test_png_rgba_drops_alpha(tmp_path):
    image = random_image(np.uint8, 4)
    with open_raster(write_cv2(tmp_path / "rgba.png", image)) as raster:
        assert raster.bands == 3
        np.testing.assert_array_equal(raster.read_window((0, 0, WIDTH, HEIGHT)), image[:, :, :3])


def test_png_window_is_a_copy_not_a_view_of_the_cache(tmp_path):
    image = random_image(np.uint8, 1)
    with open_raster(write_cv2(tmp_path / "grey.png", image)) as raster:
        raster.read_window((0, 0, 10, 10))[:] = 0
        np.testing.assert_array_equal(raster.read_window((0, 0, 10, 10)), image[:10, :10])


@pytest.mark.parametrize("bands", [1, 3])
def test_jpeg_windows_match_the_decoded_file_in_rgb_order(tmp_path, bands):
    image = smooth_image(bands)
    path = write_cv2(tmp_path / "scan.jpg", image)
    decoded = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if bands == 3:
        decoded = cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)
    with open_raster(path) as raster:
        assert (raster.format, raster.bands, raster.dtype) == ("jpeg", bands, np.uint8)
        window = raster.read_window((31, 47, 97, 150))
    np.testing.assert_array_equal(window, decoded[47:150, 31:97])
    assert np.abs(window.astype(int) - image[47:150, 31:97]).mean() < 3


@pytest.mark.parametrize(("bands", "sampling", "subsampled"), [
    (3, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420, True), (3, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_422, True),
    (3, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444, False), (1, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420, False)])
def test_a_jpeg_says_whether_its_chroma_is_subsampled(tmp_path, bands, sampling, subsampled):
    """Its start of frame's sampling factors: chroma on a coarser grid than luma (4:2:0, 4:2:2) or not (4:4:4, grey);
    a view reduced by 2 or more has the chroma at its own resolution."""
    image = smooth_image(bands)
    path = tmp_path / "scan.jpg"
    pixels = image[:, :, ::-1] if bands == 3 else image
    assert cv2.imwrite(str(path), pixels, [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, sampling])
    with open_raster(path) as raster:
        assert raster.chroma_subsampled is subsampled
        assert ReducedView(raster, 1).chroma_subsampled is subsampled
        assert ReducedView(raster, 2).chroma_subsampled is False


@pytest.mark.parametrize("quality", [95, 75, 40, 33, 20, 15])
def test_a_jpeg_says_how_coarsely_its_luminance_is_quantised(tmp_path, quality):
    """The mean step of the luma table's 10 lowest frequencies, from the file's header, is libjpeg's (IJG) scaling of
    the standard table (ITU-T T.81 K.1) at the quality written; luminance goes first up to 20 grey levels."""
    path = tmp_path / "scan.jpg"
    assert cv2.imwrite(str(path), smooth_image(3)[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, quality])
    scale = 5000 // quality if quality < 50 else 200 - 2 * quality
    lowest = [16, 11, 12, 14, 12, 10, 16, 14, 13, 14]                # K.1 in zigzag order
    steps = [min(max((q * scale + 50) // 100, 1), 255) for q in lowest]
    with open_raster(path) as raster:
        assert raster.luma_step == pytest.approx(sum(steps) / 10 / 255)
        assert luminance_first(raster.chroma_subsampled, raster.luma_step) is (sum(steps) / 10 <= 20)
    assert luminance_first(True, None) and not luminance_first(False, 0.0)


@pytest.mark.parametrize(("compression", "subsampled"), [("jpeg", True), ("zlib", False)])
def test_a_tiff_says_whether_its_chroma_is_subsampled(tmp_path, compression, subsampled):
    """tifffile stores an RGB JPEG-compressed TIFF as YCbCr with its chroma on a grid of 2 x 2 px."""
    path = write_tiff(tmp_path / "scan.tif", smooth_image(3), compression=compression, tile=(32, 32))
    with open_raster(path) as raster:
        assert raster.chroma_subsampled is subsampled
    with open_raster(write_tiff(tmp_path / "grey.tif", smooth_image(1), compression=compression)) as raster:
        assert raster.chroma_subsampled is False


@given(st.binary(max_size=40))
def test_any_start_of_frame_reads_as_subsampled_or_not(body):
    assert subsampled_components(body) in (True, False)


def test_an_array_is_subsampled_only_as_declared():
    rgb = smooth_image(3)
    assert ArrayRaster(rgb).chroma_subsampled is False
    assert ArrayRaster(rgb, chroma_subsampled=True).chroma_subsampled is True
    assert ArrayRaster(rgb[:, :, 0], chroma_subsampled=True).chroma_subsampled is False


def test_format_comes_from_content_not_name(tmp_path):
    image = random_image(np.uint8, 1)
    png = write_cv2(tmp_path / "scan.png", image)
    renamed = png.rename(tmp_path / "scan.tif")
    with Raster(renamed) as raster:
        assert raster.format == "png"
        np.testing.assert_array_equal(raster.read_window((0, 0, 5, 5)), image[:5, :5])


# ------------------------------------------------------------------------------------------------
# Window reads, property-based
# ------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def property_files(tmp_path_factory):
    """One RGB 16-bit image written tiled, striped and raw, with the image itself."""
    directory = tmp_path_factory.mktemp("property")
    image = random_image(np.uint16, 3, seed=1)
    paths = [
        write_tiff(directory / "tiled.tif", image, tile=(32, 48), compression="zlib"),
        write_tiff(directory / "striped.tif", image, rowsperstrip=9, compression="lzw"),
        write_tiff(directory / "raw.tif", image),
    ]
    return image, paths


@st.composite
def windows_inside(draw, width=WIDTH, height=HEIGHT):
    """Non-empty integer windows inside a width x height image."""
    x0 = draw(st.integers(0, width - 1))
    y0 = draw(st.integers(0, height - 1))
    return x0, y0, draw(st.integers(x0 + 1, width)), draw(st.integers(y0 + 1, height))


@settings(max_examples=60, deadline=None)
@given(box=windows_inside(), which=st.integers(0, 2))
def test_any_window_equals_the_slice(property_files, box, which):
    image, paths = property_files
    x0, y0, x1, y1 = box
    with open_raster(paths[which]) as raster:
        np.testing.assert_array_equal(raster.read_window(box), image[y0:y1, x0:x1])


@settings(deadline=None)  # a pure index computation: under a loaded machine it missed hypothesis' 200 ms deadline
@given(
    box=windows_inside(width=500, height=400),
    segment=st.tuples(st.integers(1, 130), st.integers(1, 130)),
    planes=st.integers(1, 3),
)
def test_segment_indices_are_exactly_the_intersecting_segments(box, segment, planes):
    x0, y0, x1, y1 = box
    rows, cols = segment
    across, down = math.ceil(500 / cols), math.ceil(400 / rows)
    expected = [
        plane * across * down + r * across + c
        for plane in range(planes)
        for r in range(down)
        for c in range(across)
        if r * rows < y1 and (r + 1) * rows > y0 and c * cols < x1 and (c + 1) * cols > x0
    ]
    assert segment_indices(box, segment, (400, 500), planes).tolist() == expected


# ------------------------------------------------------------------------------------------------
# Errors
# ------------------------------------------------------------------------------------------------


def assert_one_line_error(excinfo, *words):
    message = str(excinfo.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_missing_file(tmp_path):
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(tmp_path / "nope.tif")
    assert_one_line_error(excinfo, "does not exist", "check the path")


def test_directory(tmp_path):
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(tmp_path)
    assert_one_line_error(excinfo, "is a folder")


@pytest.mark.parametrize(
    ("name", "content", "words"),
    [
        ("empty.tif", b"", ("empty file", "TIFF", "JPEG", "PNG")),
        ("text.tif", b"hello, world\n", ("not a supported image format", "TIFF", "JPEG", "PNG")),
        ("corrupt.tif", b"II*\x00" + b"\xfe" * 64, ("cannot read", "corrupt")),
        ("corrupt.jpg", b"\xff\xd8\xff" + b"\x00" * 64, ("cannot decode", "re-export")),
        ("corrupt.png", b"\x89PNG\r\n\x1a\n" + b"\x00" * 64, ("cannot decode",)),
    ],
)
def test_unreadable_files(tmp_path, name, content, words):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(path)
    assert_one_line_error(excinfo, *words)


def test_unsupported_format_names_the_supported_ones(tmp_path):
    path = tmp_path / "scan.bmp"
    assert cv2.imwrite(str(path), np.zeros((8, 8), np.uint8))
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(path)
    assert_one_line_error(excinfo, "TIFF", "JPEG", "PNG", "convert")


@pytest.mark.parametrize(
    ("data", "kwargs", "words"),
    [
        (np.zeros((16, 16, 2), np.uint8), BANDS_CONTIG, ["2 samples"]),
        (np.zeros((16, 16, 5), np.uint8), BANDS_CONTIG, ["5 samples"]),
        (np.zeros((16, 16), np.int16), {}, ["int16", "unsigned"]),
        (np.zeros((16, 16), np.uint8), {"photometric": "palette", "colormap": COLORMAP}, ["PALETTE"]),
        (np.zeros((16, 16), np.float32), {"photometric": "miniswhite"}, ["MINISWHITE"]),
        (np.zeros((4, 16, 16), np.uint8), VOLUME, ["2-D"]),
    ],
    ids=["2-bands", "5-bands", "signed", "palette", "float-miniswhite", "volumetric"],
)
def test_unsupported_sample_layouts(tmp_path, data, kwargs, words):
    path = tmp_path / "odd.tif"
    tifffile.imwrite(path, data, **kwargs)
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(path)
    assert_one_line_error(excinfo, *words)


@pytest.mark.parametrize(
    ("box", "words"),
    [
        ((-1, 0, 10, 10), ("outside", "clip_box")),
        ((0, 0, WIDTH + 1, 10), ("outside", "clip_box")),
        ((10, 10, 10, 20), ("empty",)),
        ((10, 20, 15, 5), ("empty",)),
        ((0.0, 0.0, 10.0, 10.0), ("integers", "clip_box")),
        ((0, 0, 10), ("integers",)),
        ("abcd", ("integers",)),
    ],
)
def test_bad_windows(tmp_path, box, words):
    path = write_tiff(tmp_path / "scan.tif", random_image(np.uint8, 1), tile=(32, 32))
    with open_raster(path) as raster, pytest.raises(AerofidInputError) as excinfo:
        raster.read_window(box)
    assert_one_line_error(excinfo, *words)


def test_reading_a_closed_raster(tmp_path):
    path = write_tiff(tmp_path / "scan.tif", random_image(np.uint8, 1))
    with open_raster(path) as raster:
        pass
    raster.close()  # closing twice is harmless
    with pytest.raises(AerofidInputError, match="closed"):
        raster.read_window((0, 0, 1, 1))


def test_check_window_size():
    check_window_size((0, 0, 1000, 1000), 3, 2)
    check_window_size((0, 0, 100, 100), 1, 1, limit_bytes=10_000)
    with pytest.raises(AerofidInputError, match="smaller box"):
        check_window_size((0, 0, 100, 101), 1, 1, limit_bytes=10_000)
    with pytest.raises(AerofidInputError, match="GB"):
        check_window_size((0, 0, 20000, 20000), 3, 1)


# ------------------------------------------------------------------------------------------------
# clip_box
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("box", "expected"),
    [
        ((10, 20, 30, 40), ((10, 20, 30, 40), False)),
        ((10.2, 20.7, 29.1, 39.9), ((10, 20, 30, 40), False)),
        ((-5.5, 20, 30, 40), ((0, 20, 30, 40), True)),
        ((90, 40, 130.5, 80.2), ((90, 40, 100, 50), True)),
        ((-10, -10, 1000, 1000), ((0, 0, 100, 50), True)),
        ((99.5, 49.5, 100, 50), ((99, 49, 100, 50), False)),
        (np.array([1.0, 2.0, 3.0, 4.0]), ((1, 2, 3, 4), False)),
    ],
)
def test_clip_box_examples(box, expected):
    assert clip_box(box, 100, 50) == expected


@pytest.mark.parametrize(
    ("box", "words"),
    [
        ((100, 0, 120, 10), ("outside",)),
        ((-20, 0, 0, 10), ("outside",)),
        ((0, 50, 10, 60), ("outside",)),
        ((10, 10, 10, 20), ("empty",)),
        ((10, 30, 20, 20), ("empty",)),
        ((0, 0, math.nan, 10), ("non-finite",)),
        ((0, 0, math.inf, 10), ("non-finite",)),
        ((0, 0, 10), ("3 numbers",)),
        ((0, 0, "x", 10), ("not four numbers",)),
        (None, ("not four numbers",)),
    ],
)
def test_clip_box_errors(box, words):
    with pytest.raises(AerofidInputError) as excinfo:
        clip_box(box, 100, 50)
    assert_one_line_error(excinfo, *words)


finite = st.floats(-300, 300, allow_nan=False)


@given(
    x0=finite,
    y0=finite,
    dx=st.floats(0.01, 300),
    dy=st.floats(0.01, 300),
    width=st.integers(1, 200),
    height=st.integers(1, 200),
)
def test_clip_box_properties(x0, y0, dx, dy, width, height):
    box = (x0, y0, x0 + dx, y0 + dy)
    rounded = (math.floor(box[0]), math.floor(box[1]), math.ceil(box[2]), math.ceil(box[3]))
    overlaps = rounded[0] < width and rounded[2] > 0 and rounded[1] < height and rounded[3] > 0
    if not overlaps:
        with pytest.raises(AerofidInputError):
            clip_box(box, width, height)
        return
    (cx0, cy0, cx1, cy1), was_clipped = clip_box(box, width, height)
    assert all(isinstance(v, int) for v in (cx0, cy0, cx1, cy1))
    assert 0 <= cx0 < cx1 <= width and 0 <= cy0 < cy1 <= height
    intersection = (max(rounded[0], 0), max(rounded[1], 0), min(rounded[2], width), min(rounded[3], height))
    assert (cx0, cy0, cx1, cy1) == intersection
    inside = rounded[0] >= 0 and rounded[1] >= 0 and rounded[2] <= width and rounded[3] <= height
    assert was_clipped == (not inside)


# ------------------------------------------------------------------------------------------------
# normalise, to_grey and the colour policy
# ------------------------------------------------------------------------------------------------


def test_normalise():
    np.testing.assert_array_equal(normalise(np.array([0, 51, 255], np.uint8)), np.float32([0, 0.2, 1]))
    twelve_bit = normalise(np.array([0, 4095], np.uint16))  # not rescaled as if 12-bit
    np.testing.assert_allclose(twelve_bit, [0, 4095 / 65535])
    floats = np.array([0.25, 0.5, 2.0])
    assert normalise(floats).dtype == np.float32
    np.testing.assert_array_equal(normalise(floats), np.float32(floats))
    with pytest.raises(AerofidInputError, match="integer or float"):
        normalise(np.array([True, False]))


def red_mark_on_black(seed=0):
    """A noisy black uint8 RGB window with a red disc: a mark printed in red on the film border."""
    rng = np.random.default_rng(seed)
    window = np.clip(rng.normal(20, 3, (64, 64, 3)), 0, 255)
    y, x = np.mgrid[:64, :64]
    window[(x - 32) ** 2 + (y - 32) ** 2 < 36, 0] = 200
    return window.round().astype(np.uint8)


def test_auto_picks_the_channel_of_a_red_mark():
    window = red_mark_on_black()
    assert choose_channel_mix(window, "bright") == "red"
    grey = to_grey(window)
    np.testing.assert_allclose(grey, window[:, :, 0] / np.float32(255), rtol=1e-6)
    assert grey.dtype == np.float32


def test_auto_with_dark_polarity_picks_the_channel_of_a_dark_mark():
    rng = np.random.default_rng(1)
    window = np.clip(rng.normal(180, 4, (64, 64, 3)), 0, 65535).astype(np.uint16) * 257
    window[20:40, 20:40, 2] = 20 * 257  # dark in blue only
    assert choose_channel_mix(window, "dark") == "blue"
    np.testing.assert_allclose(to_grey(window, polarity="dark"), window[:, :, 2] / 65535, rtol=1e-6)


def test_fixed_policies():
    window = red_mark_on_black()
    rgb = window / np.float32(255)
    for mix, weights in MIX_WEIGHTS.items():
        np.testing.assert_allclose(to_grey(window, mix), rgb @ np.float32(weights), rtol=1e-5)
    np.testing.assert_allclose(to_grey(window, "max"), rgb.max(axis=-1))
    red, green, blue = window[32, 32].astype(float)
    assert red == 200
    luma = (0.299 * red + 0.587 * green + 0.114 * blue) / 255
    assert to_grey(window, "luminance")[32, 32] == pytest.approx(luma)


def test_grey_windows_are_only_normalised():
    grey = random_image(np.uint16, 1)
    for policy in ("auto", "red", "max"):
        np.testing.assert_array_equal(to_grey(grey, policy, "dark"), normalise(grey))


def test_mark_contrast_floors_the_noise():
    flat = np.zeros((10, 10), np.float32)
    flat[5, 5] = flat[5, 6] = 1.0  # two bright pixels: 99th percentile is 1, MAD is 0
    assert mark_contrast(flat, "bright", noise_floor=0.01) == pytest.approx(100)
    assert mark_contrast(1 - flat, "dark", noise_floor=0.01) == pytest.approx(100)


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: to_grey(red_mark_on_black(), "purple"), ("colour policy", "luminance")),
        (lambda: to_grey(red_mark_on_black(), "auto", "grey"), ("polarity", "bright, dark")),
        (lambda: to_grey(np.zeros((4, 4, 4), np.uint8)), ("(h, w, 3)",)),
        (lambda: to_grey(np.zeros((0, 4), np.uint8)), ("non-empty",)),
        (lambda: choose_channel_mix(np.zeros((4, 4), np.uint8)), ("grey",)),
    ],
)
def test_colour_policy_errors(call, words):
    with pytest.raises(AerofidInputError) as excinfo:
        call()
    assert_one_line_error(excinfo, *words)


@pytest.fixture(scope="module")
def rc20():
    """The real Wild RC20 colour frame, opened once (skipped where ../shared/realdata is absent)."""
    with open_raster(realdata_path(RC20)) as raster:
        yield raster


# Corner mark centres found by eye. The top-right mark is left out: its 160-pixel box holds a bright
# piece of landscape, whose 99th percentile then outweighs the mark in every mix.
@pytest.mark.parametrize(
    ("centre_x", "centre_y"), [(653, 190), (648, 5201), (5667, 5213)], ids=["tl", "bl", "br"]
)
def test_real_wild_rc20_red_corner_marks_keep_their_contrast_with_auto(rc20, centre_x, centre_y):
    """The Wild RC20 colour scan prints its marks in red on a black border; luminance loses contrast."""
    assert (rc20.width, rc20.height, rc20.bands) == (5908, 5408, 3)
    half = 80
    window = rc20.read_window((centre_x - half, centre_y - half, centre_x + half, centre_y + half))
    floor = 1 / 255
    auto = mark_contrast(to_grey(window, "auto"), "bright", noise_floor=floor)
    luminance = mark_contrast(to_grey(window, "luminance"), "bright", noise_floor=floor)
    assert choose_channel_mix(window) == "red"
    assert auto > 1.5 * luminance


def test_a_file_with_subsampled_chroma_has_its_marks_measured_in_luminance_where_it_shows_them():
    """Where the chroma is subsampled, luminance is the one mix at full resolution: taken where it shows the mark with
    :data:`LUMA_SHARE` of the best mix's contrast (a red ring through libjpeg's 4:2:0: 0.53-0.59 of red's), not for a
    blue one (0.31-0.33 of blue's)."""
    y, x = np.mgrid[:91, :91]
    ring = np.abs(np.hypot(x - 45, y - 45) - 18) < 4
    for seed in range(3):
        for channel, mix in [(0, "luminance"), (2, "blue")]:
            window = np.full((91, 91, 3), 30.0) + np.random.default_rng(seed).normal(0, 3, (91, 91, 1))
            window[ring, channel] = 200
            ok, jpeg = cv2.imencode(".jpg", window.round().astype(np.uint8)[:, :, ::-1],
                                    [cv2.IMWRITE_JPEG_QUALITY, 90, cv2.IMWRITE_JPEG_SAMPLING_FACTOR,
                                     cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420])
            decoded = cv2.imdecode(jpeg, cv2.IMREAD_COLOR)[:, :, ::-1]
            assert choose_channel_mix(decoded) == ("red", "blue")[channel // 2]
            assert choose_channel_mix(decoded, luma_first=True) == mix
            np.testing.assert_array_equal(to_grey(decoded, luma_first=True), to_grey(decoded, mix))


def test_real_wild_rc20_jpeg_is_4_2_0_and_its_red_marks_are_measured_in_luminance(rc20):
    """Its luminance shows the red corner marks with more than half red's contrast: taken, the JPEG's one plane at full
    resolution (:data:`aerofid.io.colour.LUMA_SHARE`)."""
    assert rc20.chroma_subsampled
    for x, y in [(653, 190), (648, 5201), (5667, 5213)]:
        window = rc20.read_window((x - 34, y - 34, x + 35, y + 35))
        assert choose_channel_mix(window, luma_first=True) == "luminance"
        assert choose_channel_mix(window) == "red"


def test_auto_judges_the_channels_on_the_middle_of_the_box():
    """A red mark in the middle, a bright cyan image area in a corner of the box (a Wild RC20 midside notch
    beside water): the cyan area is brightest in green and blue, the mark only in red."""
    rng = np.random.default_rng(3)
    window = np.clip(rng.normal(25, 2, (120, 120, 3)), 0, 255)
    y, x = np.mgrid[:120, :120]
    ring = np.abs(np.hypot(x - 60, y - 60) - 20) < 3
    window[ring, 0] = 160
    window[(x - 120) ** 2 + (y - 120) ** 2 < 45 ** 2] = (60, 150, 165)
    window = window.round().astype(np.uint8)
    assert choose_channel_mix(window) == "red"


def test_auto_picks_the_channel_of_a_red_ring_that_fills_the_middle_of_a_noisy_window():
    """A red ring 46 px across and 10 px wide in a 91 px window, noise of 10 grey levels in every channel: the ring
    covers half the window's middle and spreads the red channel's levels, so their MAD is no noise measure (it chose
    blue or green in 4 of these 5 windows); the noise of the first differences is."""
    y, x = np.mgrid[:91, :91]
    window = np.empty((91, 91, 3))
    window[:] = (30, 28, 26)
    window[np.abs(np.hypot(x - 45, y - 45) - 18) < 5, 0] = 110
    for seed in range(5):
        noisy = np.clip(window + np.random.default_rng(seed).normal(0, 10, window.shape), 0, 255)
        assert choose_channel_mix(noisy.round().astype(np.uint8)) == "red"
