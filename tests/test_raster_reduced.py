"""Tests of bounded-memory reduced reads (``read_reduced``: :mod:`aerofid.io.reduce`), JPEGs too large to
decode whole (:mod:`aerofid.io.jpeg`) and arrays read like scans (:mod:`aerofid.io.array`)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
import tracemalloc
import types
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from unittest import mock

import cv2
import numpy as np
import pytest
import tifffile
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid.errors import AerofidInputError
from aerofid.io import jpeg, reduce
from aerofid.io import raster as raster_module
from aerofid.io.array import ArrayRaster, as_image_array, open_image
from aerofid.io.raster import Raster, open_raster
from conftest import realdata_path
from raster_checks import HEIGHT, WIDTH, random_image, record_decoded_segments, write_tiff

BOXES = [(0, 0, WIDTH, HEIGHT), (3, 5, 100, 77), (31, 47, 97, 150), (WIDTH - 1, HEIGHT - 1, WIDTH, HEIGHT)]
FACTORS = [1, 2, 3, 8, 64, 500]
RC20 = "unbc_bc_wild_rc20/15BCC02013_114.jpg"


def block_mean(window, factor):
    """Reference: means of ``factor`` x ``factor`` blocks (edge blocks: of the pixels they have), by NaN padding."""
    a = np.asarray(window, np.float64)
    h, w = a.shape[:2]
    rows, cols = -(-h // factor), -(-w // factor)
    padded = np.full((rows * factor, cols * factor, *a.shape[2:]), np.nan)
    padded[:h, :w] = a
    return np.nanmean(padded.reshape(rows, factor, cols, factor, *a.shape[2:]), axis=(1, 3))


def smooth_image(bands, shape=(HEIGHT, WIDTH)):
    """A smooth uint8 image whose bands differ, which JPEG keeps close to the original."""
    y, x = np.mgrid[: shape[0], : shape[1]]
    planes = [(127 + 100 * np.sin(x / 37 + 2 * k) * np.cos(y / 43 - k)) for k in range(bands)]
    image = np.stack(planes, axis=-1).round().astype(np.uint8)
    return image[:, :, 0] if bands == 1 else image


def write_cv2(path, rgb_or_grey, *params):
    """Write an RGB or grey image with OpenCV (which wants BGR) and return ``path``."""
    image = cv2.cvtColor(rgb_or_grey, cv2.COLOR_RGB2BGR) if rgb_or_grey.ndim == 3 else rgb_or_grey
    assert cv2.imwrite(str(path), image, list(params))
    return path


def assert_one_line_error(excinfo, *words):
    message = str(excinfo.value)
    assert "\n" not in message
    for word in words:
        assert word in message, message


# ------------------------------------------------------------------------------------------------
# read_reduced equals the block mean of read_window
# ------------------------------------------------------------------------------------------------

LAYOUTS = [
    ("tiled-zlib-rgb16", np.uint16, 3, "tif", {"tile": (32, 48), "compression": "zlib"}),
    ("tiled-grey8", np.uint8, 1, "tif", {"tile": (64, 32), "compression": "lzw"}),
    ("striped-lzw-grey16", np.uint16, 1, "tif", {"rowsperstrip": 7, "compression": "lzw"}),
    ("striped-rgb8", np.uint8, 3, "tif", {"rowsperstrip": 16, "compression": "zlib"}),
    ("memmapped-rgb8", np.uint8, 3, "tif", {}),
    ("memmapped-bigendian-grey16", np.uint16, 1, "tif", {"byteorder": ">"}),
    ("tiled-float32", np.float32, 1, "tif", {"tile": (32, 32), "compression": "zlib"}),
    ("png-rgb16", np.uint16, 3, "png", {}),
    ("png-grey8", np.uint8, 1, "png", {}),
]


@pytest.fixture(scope="module")
def layout_files(tmp_path_factory):
    """Each layout written once: ``{id: (path, image)}``."""
    directory = tmp_path_factory.mktemp("layouts")
    files = {}
    for k, (name, dtype, bands, kind, kwargs) in enumerate(LAYOUTS):
        image = random_image(dtype, bands, seed=k)
        path = directory / f"{name}.{kind}"
        files[name] = (write_tiff(path, image, **kwargs) if kind == "tif" else write_cv2(path, image), image)
    return files


@pytest.mark.parametrize("name", [layout[0] for layout in LAYOUTS])
def test_read_reduced_is_the_block_mean_of_the_window(layout_files, name):
    path, image = layout_files[name]
    with open_raster(path) as raster:
        for x0, y0, x1, y1 in BOXES:
            window = raster.read_window((x0, y0, x1, y1))
            np.testing.assert_array_equal(window, image[y0:y1, x0:x1])
            for factor in FACTORS:
                reduced = raster.read_reduced((x0, y0, x1, y1), factor)
                assert reduced.dtype == np.float32
                expected = block_mean(window, factor)
                assert reduced.shape == expected.shape
                np.testing.assert_allclose(reduced, expected, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("name", ["tiled-zlib-rgb16", "memmapped-rgb8", "png-grey8"])
def test_factor_one_is_read_window_as_float32(layout_files, name):
    path, _ = layout_files[name]
    with open_raster(path) as raster:
        box = (3, 5, 100, 77)
        reduced = raster.read_reduced(box, 1)
        assert reduced.dtype == np.float32
        np.testing.assert_array_equal(reduced, raster.read_window(box).astype(np.float32))


def test_partial_edge_blocks_by_hand():
    image = np.array([[0, 1, 2, 3, 4], [5, 6, 7, 8, 9], [10, 11, 12, 13, 14]], np.uint8)
    with ArrayRaster(image) as raster:
        np.testing.assert_allclose(raster.read_reduced((0, 0, 5, 3), 2), [[3, 5, 6.5], [10.5, 12.5, 14]])
        np.testing.assert_allclose(raster.read_reduced((1, 1, 5, 3), 3), [[9.5, 11.5]])
        np.testing.assert_allclose(raster.read_reduced((0, 0, 5, 3), 9), [[7]])


def test_miniswhite_and_planar_tiffs_are_reduced_as_read(tmp_path):
    grey = random_image(np.uint8, 1)
    rgb = random_image(np.uint8, 3, seed=3)
    white = tmp_path / "white.tif"
    tifffile.imwrite(white, grey, photometric="miniswhite", tile=(32, 32))
    planar = tmp_path / "planar.tif"
    tifffile.imwrite(planar, np.moveaxis(rgb, -1, 0), photometric="rgb", planarconfig="separate", tile=(32, 32))
    with open_raster(white) as raster:
        np.testing.assert_allclose(raster.read_reduced((2, 3, 90, 60), 4), block_mean(255 - grey[3:60, 2:90], 4))
    with open_raster(planar) as raster:
        np.testing.assert_allclose(raster.read_reduced((2, 3, 90, 60), 4), block_mean(rgb[3:60, 2:90], 4),
                                   rtol=1e-6)


@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_any_box_and_factor_equals_the_block_mean(layout_files, data):
    name = data.draw(st.sampled_from(["tiled-zlib-rgb16", "striped-lzw-grey16", "memmapped-rgb8"]))
    path, image = layout_files[name]
    x0 = data.draw(st.integers(0, WIDTH - 1))
    y0 = data.draw(st.integers(0, HEIGHT - 1))
    x1 = data.draw(st.integers(x0 + 1, WIDTH))
    y1 = data.draw(st.integers(y0 + 1, HEIGHT))
    factor = data.draw(st.integers(1, 40))
    with open_raster(path) as raster:
        reduced = raster.read_reduced((x0, y0, x1, y1), factor)
    np.testing.assert_allclose(reduced, block_mean(image[y0:y1, x0:x1], factor), rtol=1e-6)


# ------------------------------------------------------------------------------------------------
# Strips: whole tile rows, each tile decoded once, memory bounded
# ------------------------------------------------------------------------------------------------


def test_strips_are_whole_tile_rows_and_each_tile_is_decoded_once(tmp_path, monkeypatch):
    image = random_image(np.uint8, 1, shape=(256, 256))
    path = write_tiff(tmp_path / "tiled.tif", image, tile=(64, 64), compression="zlib")  # 4 x 4 tiles
    monkeypatch.setattr(reduce, "STRIP_BYTES", 1)  # one tile row per strip
    monkeypatch.setattr(reduce, "CHUNK_SAMPLES", 100)  # several chunks per strip
    decoded = record_decoded_segments(monkeypatch)
    reads = []
    read = Raster._samples

    def recording_read(self, box, copy=True):
        reads.append(box)
        return read(self, box, copy)

    monkeypatch.setattr(Raster, "_samples", recording_read)
    with open_raster(path) as raster:
        reduced = raster.read_reduced((10, 30, 200, 250), 3)  # block rows straddle the tile rows
    np.testing.assert_allclose(reduced, block_mean(image[30:250, 10:200], 3), rtol=1e-6)
    assert reads == [(10, 30, 200, 64), (10, 64, 200, 128), (10, 128, 200, 192), (10, 192, 200, 250)]
    assert sorted(decoded) == [r * 4 + c for r in range(4) for c in range(4)]  # each tile once


def test_peak_memory_is_bounded_by_the_strip_not_the_box(tmp_path, monkeypatch):
    n, tile = 4096, 256
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 16, (tile, tile, 3), dtype=np.uint8)
    tiles = (noise + np.uint8(k % 200) for k in range((n // tile) ** 2))
    path = tmp_path / "big.tif"
    tifffile.imwrite(path, tiles, shape=(n, n, 3), dtype=np.uint8, tile=(tile, tile), photometric="rgb",
                     compression="zlib", compressionargs={"level": 1})
    whole = n * n * 3  # 50 MB of samples; the reduced output is 0.8 MB
    monkeypatch.setattr(reduce, "STRIP_BYTES", 2 * 2**20)
    monkeypatch.setattr(reduce, "CHUNK_SAMPLES", 2**17)
    with open_raster(path) as raster:
        tracemalloc.start()
        try:
            reduced = raster.read_reduced((0, 0, n, n), 8)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        corner = raster.read_window((0, 0, 512, 512))
    assert reduced.shape == (512, 512, 3)
    np.testing.assert_allclose(reduced[:64, :64], block_mean(corner, 8), rtol=1e-6)
    assert peak < whole / 5, f"peak {peak / 1e6:.1f} MB for a {whole / 1e6:.0f} MB image"


def test_strips_read_by_threads_give_the_same_numbers_and_each_tile_is_decoded_once(tmp_path, monkeypatch):
    """A whole-frame reduced read of a compressed tiled TIFF, its strips read by several threads at once
    (:data:`aerofid.parallel.THREADS`): each tile decoded once, by more than one thread, and every number
    that of the read one strip after another."""
    image = random_image(np.uint8, 3, shape=(1024, 700))
    path = write_tiff(tmp_path / "tiled.tif", image, tile=(32, 64), compression="zlib")  # 32 x 11 tiles
    monkeypatch.setattr(reduce, "STRIP_BYTES", 2**20)
    monkeypatch.setattr(raster_module, "THREADS", 3)
    threads = []
    strip_rows = Raster._strip_rows

    def recording_rows(self, r0, r1, columns):
        threads.append(threading.get_ident())
        return strip_rows(self, r0, r1, columns)

    monkeypatch.setattr(Raster, "_strip_rows", recording_rows)
    with open_raster(path) as raster:
        alone = raster.read_reduced((0, 0, 700, 1024), 16)    # 2 MB: fewer bytes than THREADED_BYTES
    assert set(threads) == {threading.get_ident()}
    threads.clear()
    monkeypatch.setattr(reduce, "THREADED_BYTES", 2**20)
    decoded = record_decoded_segments(monkeypatch)
    with open_raster(path) as raster:
        together = raster.read_reduced((0, 0, 700, 1024), 16)
    assert np.array_equal(together, alone)
    np.testing.assert_allclose(together, block_mean(image, 16), rtol=1e-6)
    assert sorted(decoded) == list(range(32 * 11))
    assert len(threads) == 7 and len(set(threads)) > 1     # strips of 160 rows: 5 tile rows, 1 MB for 3 threads


@settings(max_examples=80, deadline=None)
@given(st.data())
def test_strips_read_by_threads_are_the_strips_read_in_turn(data):
    """:func:`aerofid.io.reduce.reduce_in_strips` with several threads gives exactly the numbers of one strip after
    another, for any window (from row 0, where the threads are used, or not), factor, row step and strip budget,
    and reads each source row once."""
    dtype = data.draw(st.sampled_from([np.uint8, np.uint16, np.float32]))
    bands = data.draw(st.sampled_from([1, 3]))
    h, w = data.draw(st.integers(1, 300)), data.draw(st.integers(1, 40))
    rng = np.random.default_rng(data.draw(st.integers(0, 2**16)))
    image = (rng.normal(0, 1000, (h, w, bands)) if dtype == np.float32 else rng.integers(0, 255, (h, w, bands))
             ).astype(dtype)
    x0, x1 = 0, w
    y0 = data.draw(st.sampled_from([0, data.draw(st.integers(0, h - 1))]))
    y1 = data.draw(st.integers(y0 + 1, h))
    factor, row_step = data.draw(st.integers(1, 12)), data.draw(st.integers(1, 16))
    strip_bytes = data.draw(st.integers(1, 60)) * row_step * w * bands * image.itemsize
    rows = []

    def read_rows(r0, r1):
        rows.extend(range(r0, r1))
        return image[r0:r1, x0:x1]

    original = reduce.STRIP_BYTES, reduce.THREADED_BYTES
    reduce.STRIP_BYTES, reduce.THREADED_BYTES = strip_bytes, 0
    try:
        outs = [reduce.reduce_in_strips(read_rows, (x0, y0, x1, y1), factor, bands, itemsize=image.itemsize,
                                        row_step=row_step, threads=threads) for threads in (1, 2, 4)]
    finally:
        reduce.STRIP_BYTES, reduce.THREADED_BYTES = original
    assert np.array_equal(outs[1], outs[0]) and np.array_equal(outs[2], outs[0])
    assert sorted(rows) == sorted(list(range(y0, y1)) * 3)


def mapped_file_bytes():
    """Bytes of files mapped into this process and resident (Linux ``RssFile``)."""
    with open("/proc/self/status") as status:
        line = next(line for line in status if line.startswith("RssFile:"))
    return int(line.split()[1]) * 1024


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs Linux /proc")
def test_a_memory_mapped_tiff_is_unmapped_strip_by_strip(tmp_path, monkeypatch):
    n = 4096
    image = np.broadcast_to(np.arange(n, dtype=np.uint8)[:, None, None], (n, n, 3))
    path = write_tiff(tmp_path / "raw.tif", np.ascontiguousarray(image))  # 50 MB, uncompressed: memory-mapped
    monkeypatch.setattr(reduce, "STRIP_BYTES", 2 * 2**20)
    with open_raster(path) as raster:
        before = mapped_file_bytes()
        reduced = raster.read_reduced((0, 0, n, n), 16)
        grown = mapped_file_bytes() - before
    np.testing.assert_allclose(reduced[:, 0, 0], np.arange(256) * 16 % 256 + 7.5)
    assert grown < 10 * 2**20, f"{grown / 2**20:.0f} MB of the file stay mapped"


# ------------------------------------------------------------------------------------------------
# Errors
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("factor", [0, -2, 2.5, "2", None, True])
def test_bad_factors(layout_files, factor):
    path, _ = layout_files["tiled-grey8"]
    with open_raster(path) as raster, pytest.raises(AerofidInputError) as excinfo:
        raster.read_reduced((0, 0, 10, 10), factor)
    assert_one_line_error(excinfo, "factor", "integer >= 1")


@pytest.mark.parametrize(("box", "words"), [((-1, 0, 10, 10), ("outside",)), ((5, 5, 5, 9), ("empty",)),
                                            ((0.0, 0, 3, 3), ("integers",))])
def test_bad_boxes(layout_files, box, words):
    path, _ = layout_files["tiled-grey8"]
    with open_raster(path) as raster, pytest.raises(AerofidInputError) as excinfo:
        raster.read_reduced(box, 2)
    assert_one_line_error(excinfo, *words)


def test_a_reduced_output_over_the_limit_is_refused_before_reading(tmp_path, monkeypatch):
    path = tmp_path / "sparse.tif"

    def tiles():  # one real tile, then empty ones: a 40000 x 40000 image in a small file
        yield np.full((256, 256), 7, np.uint8)
        yield from (None for _ in range(157 * 157 - 1))

    tifffile.imwrite(path, tiles(), shape=(40000, 40000), dtype=np.uint8, tile=(256, 256), compression="zlib")
    decoded = record_decoded_segments(monkeypatch)
    with open_raster(path) as raster:
        with pytest.raises(AerofidInputError) as excinfo:
            raster.read_reduced((0, 0, 40000, 40000), 1)
        assert_one_line_error(excinfo, "6.4 GB", "larger factor")
        with pytest.raises(AerofidInputError, match=r"1\.6 GB.*larger factor"):
            raster.read_reduced((0, 0, 40000, 40000), 2)
        assert decoded == []
        reduced = raster.read_reduced((0, 0, 1000, 10), 10)
    np.testing.assert_allclose(reduced, [[7] * 25 + [4.2] + [0] * 74], rtol=1e-6)
    assert decoded == [0, 1, 2, 3]


def test_reduced_read_of_a_closed_raster(layout_files):
    path, _ = layout_files["png-grey8"]
    raster = open_raster(path)
    raster.close()
    with pytest.raises(AerofidInputError, match="closed"):
        raster.read_reduced((0, 0, 4, 4), 2)


# ------------------------------------------------------------------------------------------------
# JPEG: whole decode when modest, libjpeg's reduced decode when too large
# ------------------------------------------------------------------------------------------------


def jpeg_with_header(width, height, components=3):
    """The bytes of a JPEG that declares ``width`` x ``height`` (an APP0 segment, a frame, no scan)."""
    app0 = b"\xff\xe0\x00\x10JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00"
    specs = b"".join(bytes([k + 1, 0x11, 0]) for k in range(components))
    sof = (b"\xff\xc0" + (8 + 3 * components).to_bytes(2, "big") + b"\x08" + height.to_bytes(2, "big")
           + width.to_bytes(2, "big") + bytes([components]) + specs)
    return b"\xff\xd8" + app0 + sof + b"\xff\xd9"


def png_with_header(width, height, colour_type=2):
    """The bytes of a PNG whose IHDR declares ``width`` x ``height`` 8-bit samples (no image data)."""
    ihdr = b"IHDR" + width.to_bytes(4, "big") + height.to_bytes(4, "big") + bytes([8, colour_type, 0, 0, 0])
    return b"\x89PNG\r\n\x1a\n" + (13).to_bytes(4, "big") + ihdr + zlib.crc32(ihdr).to_bytes(4, "big")


def test_a_huge_jpeg_is_opened_from_its_header_and_windows_are_refused(tmp_path, monkeypatch):
    path = tmp_path / "huge.jpg"
    path.write_bytes(jpeg_with_header(60000, 50000))
    monkeypatch.setattr(jpeg, "_decode_with_cv2", lambda path: pytest.fail("decoded whole"))
    with open_raster(path) as raster:
        assert (raster.width, raster.height, raster.bands, raster.dtype) == (60000, 50000, 3, np.uint8)
        with pytest.raises(AerofidInputError) as excinfo:
            raster.read_window((0, 0, 10, 10))
        assert_one_line_error(excinfo, "60000 x 50000 JPEG", "too large to decode whole", "9.0 GB", "tiled TIFF")
        with pytest.raises(AerofidInputError) as excinfo:
            raster.read_reduced((0, 0, 60000, 50000), 8)  # the header is all there is
        assert_one_line_error(excinfo, "cannot decode", "re-export")
        with pytest.raises(AerofidInputError) as excinfo:
            raster.read_reduced((0, 0, 600, 500), 3)
        assert_one_line_error(excinfo, "reducing by 3", "even factor", "tiled TIFF")


def test_a_huge_grey_jpeg_header_gives_one_band(tmp_path):
    path = tmp_path / "grey.jpg"
    path.write_bytes(jpeg_with_header(40000, 30000, components=1))
    with open_raster(path) as raster:
        assert (raster.width, raster.height, raster.bands) == (40000, 30000, 1)


def test_a_huge_png_is_refused_from_its_header(tmp_path):
    path = tmp_path / "huge.png"
    path.write_bytes(png_with_header(60000, 60000))
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(path)
    assert_one_line_error(excinfo, "60000 x 60000 PNG", "10.8 GB", "tiled TIFF")


def test_a_jpeg_without_a_frame_cannot_be_decoded(tmp_path):
    path = tmp_path / "frameless.jpg"
    path.write_bytes(b"\xff\xd8\xff\xe0\x00\x04ab\xff\xda\x00\x02")
    with pytest.raises(AerofidInputError) as excinfo:
        open_raster(path)
    assert_one_line_error(excinfo, "cannot decode", "header", "re-export")


def test_headers_declare_the_size_of_real_files(tmp_path):
    rgb = write_cv2(tmp_path / "rgb.jpg", smooth_image(3))
    grey = write_cv2(tmp_path / "grey.png", random_image(np.uint16, 1))
    header = jpeg.read_header(rgb, "jpeg")                                                      # 4:2:0, quality 95
    assert header._replace(luma_step=None) == jpeg.ImageHeader(WIDTH, HEIGHT, 3, 1, chroma_subsampled=True)
    assert header.luma_step == pytest.approx(1.2 / 255)
    assert jpeg.read_header(grey, "png") == jpeg.ImageHeader(WIDTH, HEIGHT, 1, 2, scalable=False)


@pytest.fixture(params=[1, 3], ids=["grey", "rgb"])
def jpeg_pair(request, tmp_path, monkeypatch):
    """A JPEG opened twice: decoded whole, and (with the budget made tiny) through libjpeg's reduced decode."""
    shape = (600, 808)  # a multiple of 8 by 8: no encoder padding in any 8 x 8 block
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(request.param, shape), cv2.IMWRITE_JPEG_QUALITY, 95)
    whole = open_raster(path)
    monkeypatch.setattr(jpeg, "DECODE_BUDGET_BYTES", 400_000)  # less than a whole decode, more than 1/2
    reduced = open_raster(path)
    yield whole, reduced
    whole.close()
    reduced.close()


def test_the_jpeg_decode_follows_the_memory_budget(tmp_path, monkeypatch):
    """AEROFID_MEMORY_BUDGET_GB bounds a JPEG's whole decode too (it had its own fixed 1 GB)."""
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(3, (600, 808)))
    header = jpeg.read_header(path, "jpeg")
    assert jpeg.decodes_whole(header)                                   # 1.5 MB within the default 1 GB
    monkeypatch.setenv("AEROFID_MEMORY_BUDGET_GB", "0.001")            # 1 MB
    assert not jpeg.decodes_whole(header)
    with open_raster(path) as r:                                        # read reduced through libjpeg, not whole
        assert r.read_reduced((0, 0, 808, 600), 8).shape[:2] == (75, 101)


def test_modest_jpeg_is_decoded_whole_and_reduced_exactly(jpeg_pair):
    whole, _ = jpeg_pair
    box = (13, 7, 701, 533)
    np.testing.assert_allclose(whole.read_reduced(box, 8), block_mean(whole.read_window(box), 8), rtol=1e-6)


@pytest.mark.parametrize("factor", [2, 4, 8, 16, 24])
def test_libjpeg_reduced_decode_is_close_to_the_block_mean(jpeg_pair, factor):
    whole, huge = jpeg_pair
    assert huge.bands == whole.bands and (huge.width, huge.height) == (whole.width, whole.height)
    with pytest.raises(AerofidInputError, match="too large to decode whole"):
        huge.read_window((0, 0, 8, 8))
    for box, mean_tolerance in [((0, 0, 808, 600), 0.5), ((16, 64, 808, 520), 0.5), ((13, 7, 701, 533), 1.0)]:
        expected = block_mean(whole.read_window(box), factor)
        got = huge.read_reduced(box, factor)
        assert got.shape == expected.shape and got.dtype == np.float32
        error = np.abs(got - expected)
        assert error.mean() < mean_tolerance and error.max() < 6, (box, error.mean(), error.max())


def test_odd_factors_are_refused_and_the_reduced_decode_is_kept(jpeg_pair, monkeypatch):
    _, huge = jpeg_pair
    calls = []
    imread = cv2.imread
    # the reduced decodes (name, flags); a whole decode into an array (name, array, flags) may run beside them
    monkeypatch.setattr(jpeg.cv2, "imread", lambda *args: (len(args) == 2 and calls.append(args[1])) or imread(*args))
    for factor in (1, 3, 5):
        with pytest.raises(AerofidInputError, match=f"reducing by {factor}"):
            huge.read_reduced((0, 0, 100, 100), factor)
    huge.read_reduced((0, 0, 800, 600), 8)
    huge.read_reduced((8, 8, 100, 100), 16)  # 8 divides 16: the same reduced decode
    huge.read_reduced((8, 8, 100, 100), 4)
    assert len(calls) == 2 and calls[0] != calls[1]


def test_the_reduced_decode_respects_the_budget(tmp_path, monkeypatch):
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(3, (400, 400)))
    monkeypatch.setattr(jpeg, "DECODE_BUDGET_BYTES", 400 * 400 * 3 // 16 - 1)  # 1/4 decode is just too big
    with open_raster(path) as raster:
        assert raster.read_reduced((0, 0, 400, 400), 8).shape == (50, 50, 3)
        with pytest.raises(AerofidInputError, match="reducing by 4"):
            raster.read_reduced((0, 0, 400, 400), 4)


@pytest.fixture
def held_decode(monkeypatch):
    """The background decode held until the test lets it go (``release``); the paths it decoded (``calls``)."""
    jpeg.forget_decodes()
    go, entered, calls = threading.Event(), threading.Event(), []
    decode = jpeg._read_only

    def held(path, header=None):
        calls.append(path)
        entered.set()
        assert go.wait(30), "the decode was never let go"
        return decode(path, header)

    monkeypatch.setattr(jpeg, "_read_only", held)
    yield types.SimpleNamespace(release=go.set, calls=calls, entered=entered)
    go.set()
    jpeg.forget_decodes()


@pytest.mark.parametrize("bands", [1, 3])
@pytest.mark.parametrize("factor", [2, 8, 16])
def test_a_jpeg_opens_and_gives_its_overview_before_its_decode_ends(tmp_path, held_decode, bands, factor):
    """An 8-bit JPEG opens from its header and its overview is libjpeg's reduced decode (what a JPEG too large to
    decode whole reads), both while the whole decode is still held; its windows then wait for that decode."""
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(bands, (600, 808)), cv2.IMWRITE_JPEG_QUALITY, 95)
    header = jpeg.read_header(path, "jpeg")
    box = (16, 64, 808, 520)
    expected = jpeg.HugeJpegReader(path, header, bands).read_reduced(box, factor)
    with open_raster(path) as raster:
        assert (raster.width, raster.height, raster.bands, raster.dtype) == (808, 600, bands, np.uint8)
        got = raster.read_overview(box, factor)
        assert held_decode.entered.wait(10) and len(held_decode.calls) == 1   # the decode began, and is still held
        held_decode.release()
        window = raster.read_window((0, 0, 808, 600))
    np.testing.assert_array_equal(got, expected[:, :, 0] if bands == 1 else expected)
    decoded = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(window, decoded if bands == 1 else decoded[:, :, ::-1])


def test_an_overview_is_the_exact_reduced_read_elsewhere(jpeg_pair, layout_files):
    """An odd factor of a JPEG, and every TIFF, is read exactly (``read_reduced``)."""
    whole, _ = jpeg_pair
    np.testing.assert_array_equal(whole.read_overview((0, 0, 808, 600), 3), whole.read_reduced((0, 0, 808, 600), 3))
    for path, _ in layout_files.values():
        with open_raster(path) as raster:
            box = (0, 0, raster.width, raster.height)
            factors = (3,) if raster.format == "jpeg" else (3, 4)
            for factor in factors:
                np.testing.assert_array_equal(raster.read_overview(box, factor), raster.read_reduced(box, factor))


def test_an_overview_checks_its_request_as_a_reduced_read(tmp_path, monkeypatch):
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(1, (600, 808)))
    with open_raster(path) as raster:
        for box, factor, words in [((0, 0, 808, 600), "2", "factor"), ((0, 0, 900, 600), 2, "outside")]:
            with pytest.raises(AerofidInputError) as excinfo:
                raster.read_overview(box, factor)
            assert_one_line_error(excinfo, words)
        monkeypatch.setattr(raster_module, "WINDOW_LIMIT_BYTES", 1000)
        with pytest.raises(AerofidInputError) as excinfo:
            raster.read_overview((0, 0, 808, 600), 2)
        assert_one_line_error(excinfo, "GB")


def test_two_opens_share_one_decode_and_a_failure_is_not_kept(tmp_path, monkeypatch):
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(3, (600, 808)))
    jpeg.forget_decodes()
    calls = []
    decode = jpeg._read_only
    monkeypatch.setattr(jpeg, "_read_only", lambda p, h=None: calls.append(p) or decode(p, h))
    with open_raster(path) as first, open_raster(path) as second:
        np.testing.assert_array_equal(second.read_window((5, 6, 70, 80)), first.read_window((5, 6, 70, 80)))
    assert calls == [path.resolve()]
    monkeypatch.setattr(jpeg, "_read_only", lambda p, h=None: calls.append(p) or (_ for _ in ()).throw(MemoryError()))
    jpeg.forget_decodes()
    for _ in range(2):                                      # the memory it lacked, as such, and tried again
        with open_raster(path) as raster, pytest.raises(MemoryError):
            raster.read_window((0, 0, 8, 8))
    assert len(calls) == 3
    jpeg.forget_decodes()


def test_opens_from_two_threads_at_once_share_one_decode(tmp_path, held_decode):
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(1, (64, 80)))
    start = threading.Barrier(8)

    def opened(_):
        start.wait()
        return open_raster(path)

    with ThreadPoolExecutor(8) as pool:
        rasters = list(pool.map(opened, range(8)))
    held_decode.release()
    for raster in rasters:
        assert raster.read_window((0, 0, 80, 64)).shape == (64, 80)
        raster.close()
    assert len(held_decode.calls) == 1


def test_a_failed_decode_is_forgotten_without_being_read(tmp_path, monkeypatch):
    """A decode that failed (memory, a file being written) is not kept even when no window asked for it, and only its
    own file's is dropped."""
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(1, (64, 80)))
    other = write_cv2(tmp_path / "other.jpg", smooth_image(1, (48, 40)))
    jpeg.forget_decodes()
    with open_raster(other) as kept:
        kept.read_window((0, 0, 8, 8))
    decode = jpeg._read_only
    monkeypatch.setattr(jpeg, "_read_only", lambda p, h=None: (_ for _ in ()).throw(MemoryError())
                        if p.name == "scan.jpg" else decode(p, h))
    with open_raster(path):
        pass                                                # closed without a read: the failure is not kept
    monkeypatch.setattr(jpeg, "_read_only", lambda p, h=None: pytest.fail(f"{p.name} was decoded again"))
    with open_raster(other) as again:                       # another file's decode is still kept
        assert again.read_window((0, 0, 40, 48)).shape == (48, 40)
    monkeypatch.setattr(jpeg, "_read_only", decode)
    with open_raster(path) as raster:
        assert raster.read_window((0, 0, 80, 64)).shape == (64, 80)
    jpeg.forget_decodes()


def test_a_jpeg_whose_name_is_not_utf8_is_read(tmp_path):
    """OpenCV's imread crashes on a name that is not valid UTF-8 (a lone surrogate once decoded): the reduced decode
    reads such a file's bytes instead (in a child process, so that a crash fails the test, not the run)."""
    folder = os.fsencode(tmp_path)
    path = os.fsdecode(folder + b"/scan\xff.jpg")
    Path(path).write_bytes(cv2.imencode(".jpg", smooth_image(1, (1200, 1600)))[1].tobytes())
    code = ("import sys; from aerofid.io.raster import open_raster\n"
            "with open_raster(sys.argv[1]) as r: print(r.read_overview((0, 0, 1600, 1200), 8).shape)")
    out = subprocess.run([sys.executable, "-c", code, path], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "(150, 200)", (out.returncode, out.stderr[-500:])


def test_a_jpeg_that_decodes_to_another_size_than_its_header_is_one_line(tmp_path, monkeypatch):
    """The header gave the raster its size; a decode of another size is refused when a window is read."""
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(1, (64, 80)))
    jpeg.forget_decodes()
    monkeypatch.setattr(jpeg, "IMREAD_INTO", False)     # OpenCV's own decode (the one into the header's array
    monkeypatch.setattr(jpeg, "_decode_with_cv2", lambda p: np.zeros((56, 80, 1), np.uint8))   # is of its size)
    with open_raster(path) as raster, pytest.raises(AerofidInputError) as excinfo:
        raster.read_window((0, 0, 8, 8))
    assert_one_line_error(excinfo, "declares 80 x 64", "decodes to 80 x 56", "re-export")
    jpeg.forget_decodes()


def test_a_truncated_jpeg_is_an_error_when_a_window_is_read_or_checked(tmp_path):
    """libjpeg's reduced decode gives a truncated JPEG's overview (grey where data is missing); its whole decode
    fails, which a window and ``check_decoded`` (what a frame's search calls when it read no window) tell."""
    data = cv2.imencode(".jpg", np.full((640, 800), 90, np.uint8))[1].tobytes()
    path = tmp_path / "trunc.jpg"
    path.write_bytes(data[: len(data) // 2])
    jpeg.forget_decodes()
    for read in (lambda r: r.read_window((0, 0, 8, 8)), lambda r: r.check_decoded()):
        with open_raster(path) as raster:
            assert raster.read_overview((0, 0, 800, 640), 8).shape == (80, 100)
            with pytest.raises(AerofidInputError) as excinfo:
                read(raster)
        assert_one_line_error(excinfo, "corrupt or truncated")


def test_a_lossless_jpeg_is_decoded_whole_not_reduced(tmp_path):
    """libjpeg cannot scale a lossless JPEG (SOF3): its overview is the exact reduced read of its whole decode."""
    imagecodecs = pytest.importorskip("imagecodecs")
    image = smooth_image(1, (96, 128))
    path = tmp_path / "lossless.jpg"
    path.write_bytes(imagecodecs.jpeg8_encode(image, lossless=True))
    header = jpeg.read_header(path, "jpeg")
    assert not header.scalable and not jpeg.decodes_in_background(header, "jpeg")
    with open_raster(path) as raster:
        np.testing.assert_array_equal(raster.read_overview((0, 0, 128, 96), 8), raster.read_reduced((0, 0, 128, 96), 8))
        np.testing.assert_array_equal(raster.read_window((0, 0, 128, 96)), image)
    with pytest.raises(AerofidInputError) as excinfo:
        jpeg.HugeJpegReader(path, header, 1).read_reduced((0, 0, 128, 96), 8)
    assert_one_line_error(excinfo, "lossless", "tiled TIFF")


def _in_child(work) -> int:
    """``work()`` in a forked child: its exit status (0: done; -1: still running after 60 s, killed)."""
    pid = os.fork()
    if pid == 0:                                            # pragma: no cover (the child)
        try:
            os._exit(0 if work() else 1)
        finally:
            os._exit(2)
    deadline = time.monotonic() + 60
    while (done := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    if done[0] == 0:
        os.kill(pid, 9)
        os.waitpid(pid, 0)
        return -1
    return os.waitstatus_to_exitcode(done[1])


def test_a_forked_child_decodes_on_its_own(tmp_path, held_decode):
    """A child forked while its parent's decode runs (a test runner, a process pool started by fork) has no
    decoding thread: a raster it inherited decodes there, and a file it opens gets a decode of its own."""
    path = write_cv2(tmp_path / "scan.jpg", smooth_image(1, (64, 80)))
    other = write_cv2(tmp_path / "other.jpg", smooth_image(1, (48, 40)))
    with open_raster(path) as raster:
        # the child lets its own copy of the hold go: its parent's decode stays held, and no thread of the child
        # would ever finish it
        child_work = lambda: held_decode.release() or raster.read_window((0, 0, 80, 64)).shape == (64, 80)  # noqa: E731
        assert _in_child(child_work) == 0
        held_decode.release()
    assert _in_child(lambda: open_raster(other).read_window((0, 0, 40, 48)).shape == (48, 40)) == 0
    with open_raster(path) as raster:
        raster.read_window((0, 0, 8, 8))
        assert _in_child(lambda: open_raster(path).read_window((0, 0, 80, 64)).shape == (64, 80)) == 0


def test_real_rc20_jpeg_reduced_decode_is_close_to_the_block_mean(monkeypatch):
    path = realdata_path(RC20)
    with open_raster(path) as whole:
        expected = whole.read_reduced((0, 0, whole.width, whole.height), 8)
    monkeypatch.setattr(jpeg, "DECODE_BUDGET_BYTES", 50_000_000)
    with open_raster(path) as huge:
        assert isinstance(huge._reader, jpeg.HugeJpegReader)
        got = huge.read_reduced((0, 0, huge.width, huge.height), 8)
    error = np.abs(got - expected)[:, :-1]  # the last column (4 pixels wide) includes the encoder's padding
    assert error.mean() < 0.5 and error.max() < 6


# ------------------------------------------------------------------------------------------------
# Arrays read like scans, and open_image
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32, np.float64])
@pytest.mark.parametrize("bands", [1, 3])
def test_array_raster_reads_like_a_raster(dtype, bands):
    image = (random_image(np.uint16, bands) // 2).astype(dtype)  # int16 holds it; floats beyond 1: 0-65535
    samples = as_image_array(image)  # signed -> unsigned, floats beyond 1 divided by 65535
    expected_dtype = {np.int16: np.uint16, np.float64: np.float32}.get(dtype, dtype)
    np.testing.assert_allclose(samples, image / 65535 if np.dtype(dtype).kind == "f" else image, rtol=1e-6)
    with ArrayRaster(image) as raster:
        assert (raster.path, raster.format, raster.tiled) == (None, "array", False)
        assert (raster.width, raster.height, raster.bands, raster.dtype) == (WIDTH, HEIGHT, bands,
                                                                             np.dtype(expected_dtype))
        for x0, y0, x1, y1 in BOXES:
            window = raster.read_window((x0, y0, x1, y1))
            np.testing.assert_array_equal(window, samples[y0:y1, x0:x1])
            assert not np.shares_memory(window, image)
            for factor in (1, 3, 8):
                np.testing.assert_allclose(raster.read_reduced((x0, y0, x1, y1), factor),
                                           block_mean(samples[y0:y1, x0:x1], factor), rtol=1e-6)
    with pytest.raises(AerofidInputError, match="closed"):
        raster.read_window((0, 0, 1, 1))


def test_array_raster_drops_alpha_and_checks_windows():
    image = random_image(np.uint8, 4)
    with ArrayRaster(image) as raster:
        assert raster.bands == 3
        np.testing.assert_array_equal(raster.read_window((0, 0, 5, 5)), image[:5, :5, :3])
        with pytest.raises(AerofidInputError, match="outside"):
            raster.read_window((0, 0, WIDTH + 1, 5))
        with pytest.raises(AerofidInputError, match="factor"):
            raster.read_reduced((0, 0, 5, 5), 0)


@pytest.mark.parametrize(
    ("array", "words"),
    [
        (np.zeros((4, 4, 2)), ("shape (4, 4, 2)", "RGB")),
        (np.zeros(5), ("shape (5,)",)),
        (np.zeros((0, 4)), ("empty", "at least one pixel")),
        (np.zeros((4, 4), bool), ("dtype bool", "unsigned integers or floats")),
        (np.array([["a"]]), ("dtype <U1",)),
        (np.zeros((3, 3), complex), ("dtype complex128",)),
    ],
)
def test_as_image_array_refuses_what_is_not_an_image(array, words):
    with pytest.raises(AerofidInputError) as excinfo:
        as_image_array(array)
    assert_one_line_error(excinfo, *words)


def test_as_image_array_accepts_lists_and_keeps_views():
    assert as_image_array([[1, 2], [3, 4]]).shape == (2, 2)
    image = np.zeros((4, 4, 4), np.uint8)
    assert np.shares_memory(as_image_array(image), image)


def test_open_image_closes_only_what_it_opened(layout_files):
    path, image = layout_files["png-grey8"]
    with open_image(path) as opened:
        assert isinstance(opened, Raster)
        np.testing.assert_array_equal(opened.read_window((0, 0, 3, 3)), image[:3, :3])
    with pytest.raises(AerofidInputError, match="closed"):
        opened.read_window((0, 0, 1, 1))
    with open_image(image) as from_array:
        assert isinstance(from_array, ArrayRaster)
        np.testing.assert_array_equal(from_array.read_window((0, 0, 3, 3)), image[:3, :3])
    for mine in (open_raster(path), ArrayRaster(image)):
        with open_image(mine) as same:
            assert same is mine
        np.testing.assert_array_equal(mine.read_window((0, 0, 3, 3)), image[:3, :3])  # still open
        mine.close()


@pytest.mark.parametrize(("image", "words"), [(None, ("NoneType", "path")), (3.5, ("float", "numpy array"))])
def test_open_image_refuses_other_things(image, words):
    with pytest.raises(AerofidInputError) as excinfo:
        open_image(image)
    assert_one_line_error(excinfo, *words)


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_strips_of_any_height_fold_into_the_block_mean(data):
    """Strips cut anywhere (a block begun in one strip and ended in the next, several blocks, a short last block):
    the block sums of :func:`reduce._fold_blocks` give the block mean, in integers for integer samples."""
    dtype = data.draw(st.sampled_from([np.uint8, np.uint16, np.int16, np.float32]))
    bands = data.draw(st.sampled_from([1, 3]))
    h, w = data.draw(st.integers(1, 60)), data.draw(st.integers(1, 60))
    rng = np.random.default_rng(data.draw(st.integers(0, 2**16)))
    info = np.iinfo(dtype) if np.dtype(dtype).kind in "ui" else None
    image = (rng.integers(info.min, info.max, (h, w, bands), endpoint=True).astype(dtype) if info is not None
             else rng.normal(0, 1000, (h, w, bands)).astype(dtype))
    x0, y0 = data.draw(st.integers(0, w - 1)), data.draw(st.integers(0, h - 1))
    x1, y1 = data.draw(st.integers(x0 + 1, w)), data.draw(st.integers(y0 + 1, h))
    factor = data.draw(st.integers(2, 20))
    row_step = data.draw(st.integers(1, 9))
    strip_rows = data.draw(st.integers(1, 12))
    strip_bytes = strip_rows * row_step * (x1 - x0) * bands * image.itemsize
    original = reduce.STRIP_BYTES
    reduce.STRIP_BYTES = strip_bytes
    try:
        out = reduce.reduce_in_strips(lambda r0, r1: image[r0:r1, x0:x1], (x0, y0, x1, y1), factor, bands,
                                      itemsize=image.itemsize, row_step=row_step)
    finally:
        reduce.STRIP_BYTES = original
    scale = float(np.abs(image).max()) + 1.0  # partial means of a block in several strips add up in float32
    np.testing.assert_allclose(out, block_mean(image[y0:y1, x0:x1], factor), rtol=2e-7, atol=1e-6 * scale)


def _sparse_fold(out, strip, first, wy, wx, bands):
    """The fold of a reduced source's strip as it was written with scipy.sparse (CSR products, summed in the
    order of their indices): the reference of :func:`aerofid.io.reduce._fold`'s banded products."""
    from scipy import sparse

    def csr(w):
        rows, cols, values = [], [], []
        for m in range(w.weight.shape[1]):                  # the order the sparse matrices were built in
            keep = w.weight[:, m] > 0
            rows.append(np.flatnonzero(keep))
            cols.append(w.first[keep] + m)
            values.append(w.weight[keep, m])
        return sparse.csr_array((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                                shape=(len(w.first), w.sources))

    wy_rows = csr(wy)
    wy_columns = sparse.csc_array(wy_rows)
    wxs = sparse.csr_array(sparse.kron(csr(wx), sparse.identity(bands)))
    chunk = max(1, reduce.CHUNK_SAMPLES // max(strip[0].size, 1))
    for c0 in range(0, strip.shape[0], chunk):
        c1 = min(c0 + chunk, strip.shape[0])
        touched = wy_columns.indices[wy_columns.indptr[first + c0]:wy_columns.indptr[first + c1]]
        if touched.size == 0:
            continue
        k0, k1 = int(touched.min()), int(touched.max()) + 1
        samples = strip[c0:c1].astype(np.float64).reshape(c1 - c0, -1)
        rows = wy_rows[k0:k1, first + c0:first + c1] @ samples
        out[k0:k1] += (wxs @ rows.T).T


@given(data=st.data())
@settings(max_examples=150, deadline=None)
def test_a_reduced_sources_fold_gives_the_numbers_of_the_sparse_products(data):
    """:func:`aerofid.io.reduce._fold` (a reduced JPEG's source pixels weighted by the area they share with each
    block) adds, bit for bit, what the sparse matrix products it replaced added: windows that begin inside a source
    pixel, strips anywhere in the window, chunks of a few rows, 8- and 16-bit and float samples, grey and RGB."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**16)))
    scale = data.draw(st.sampled_from([2, 4, 8]))
    factor = scale * data.draw(st.integers(1, 6))
    bands = data.draw(st.sampled_from([1, 3]))
    x0, y0 = data.draw(st.integers(0, 40)), data.draw(st.integers(0, 40))
    x1, y1 = x0 + data.draw(st.integers(1, 90)), y0 + data.draw(st.integers(1, 90))
    wy, wx = reduce.block_weights(y0, y1, factor, scale), reduce.block_weights(x0, x1, factor, scale)
    dtype = data.draw(st.sampled_from([np.uint8, np.uint16, np.float32]))
    r0 = data.draw(st.integers(0, wy.sources - 1))
    r1 = data.draw(st.integers(r0 + 1, wy.sources))
    shape = (r1 - r0, wx.sources, bands)
    strip = (rng.normal(0, 300, shape).astype(dtype) if dtype == np.float32
             else rng.integers(0, np.iinfo(dtype).max, shape, endpoint=True).astype(dtype))
    start = rng.normal(0, 10, (len(wy.first), len(wx.first) * bands)).astype(np.float32)
    got, want = start.copy(), start.copy()
    with mock.patch.object(reduce, "CHUNK_SAMPLES", data.draw(st.sampled_from([1, 7, 2**21]))):
        reduce._fold(got, strip, r0, wy, wx, bands)
        _sparse_fold(want, strip, r0, wy, wx, bands)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(wy.dense().sum(axis=1), 1.0)


@given(start=st.integers(0, 60), length=st.integers(1, 200), factor=st.integers(1, 40),
       scale=st.sampled_from([1, 2, 4, 8]))
@settings(max_examples=200, deadline=None)
def test_the_block_weights_are_those_the_sparse_matrix_held(start, length, factor, scale):
    """:func:`aerofid.io.reduce.block_weights` as banded arrays holds the weights of the sparse matrix it replaced
    (that matrix's construction written out here), each block's first and last source pixel of a weight."""
    stop = start + length
    n = -(-(stop - start) // factor)
    block = np.arange(n)
    b0 = start + block * factor
    b1 = np.minimum(b0 + factor, stop)
    want = np.zeros((n, -(-stop // scale) - start // scale))
    for m in range(-(-factor // scale) + 1):
        source = b0 // scale + m
        overlap = np.minimum((source + 1) * scale, b1) - np.maximum(source * scale, b0)
        keep = overlap > 0
        want[block[keep], source[keep] - start // scale] = overlap[keep] / (b1 - b0)[keep]
    w = reduce.block_weights(start, stop, factor, scale)
    np.testing.assert_array_equal(w.dense(), want)
    on = want > 0
    np.testing.assert_array_equal(w.first, np.argmax(on, axis=1))
    np.testing.assert_array_equal(w.last, want.shape[1] - 1 - np.argmax(on[:, ::-1], axis=1))


@pytest.mark.parametrize("bands", [1, 3])
def test_a_jpeg_decoded_into_an_array_from_its_header_is_opencvs_own_decode(tmp_path, bands):
    """The whole decode into an array made from the header (OpenCV 5's ``imread`` into a destination: no second
    copy of a large image at the decode's peak) gives the samples of OpenCV's own decode, RGB, EXIF orientation
    ignored (a JPEG that says it is turned is read as stored, as ``IMREAD_UNCHANGED`` reads it)."""
    img = smooth_image(bands, (120, 160))
    img[10:30, 20:60] = 255                                   # not symmetric: a turn would show
    path = write_cv2(tmp_path / "scan.jpg", img, cv2.IMWRITE_JPEG_QUALITY, 90)
    data = path.read_bytes()
    # an APP1 Exif segment with orientation 6 (turned 90 degrees) right after SOI
    entry = b"\x01\x12\x00\x03\x00\x00\x00\x01\x00\x06\x00\x00"      # tag 0x0112, SHORT, 1 value: 6
    tiff = b"MM\x00\x2a\x00\x00\x00\x08" + b"\x00\x01" + entry + b"\x00" * 4
    app1 = b"Exif\x00\x00" + tiff
    path.write_bytes(data[:2] + b"\xff\xe1" + (len(app1) + 2).to_bytes(2, "big") + app1 + data[2:])
    header = jpeg.read_header(path, "jpeg")
    own = jpeg._decode_with_cv2(path)
    assert own.shape == (120, 160, bands)
    into = jpeg._decode_in_place(path, header)
    if not jpeg.IMREAD_INTO:
        assert into is None
        pytest.skip("this OpenCV cannot decode into a given array")
    assert into is not None and into.shape == own.shape and into.dtype == np.uint8
    np.testing.assert_array_equal(into, own)
    jpeg.forget_decodes()
    with open_raster(path) as raster:
        np.testing.assert_array_equal(raster.read_window((0, 0, 160, 120)), own if bands == 3 else own[:, :, 0])
    jpeg.forget_decodes()


def _exif_thumbnail_first(data: bytes) -> bytes:
    """``data`` (a JPEG) with an APP1 segment holding a whole small JPEG (an EXIF thumbnail: its own start of scan
    and end of image) right after its start of image."""
    thumb = cv2.imencode(".jpg", np.full((16, 16), 120, np.uint8))[1].tobytes()
    app1 = b"Exif\x00\x00" + thumb
    return data[:2] + b"\xff\xe1" + (len(app1) + 2).to_bytes(2, "big") + app1 + data[2:]


def _window_refused(path, *fragments):
    """A window of the JPEG at ``path``, decoded anew, is a one-line error naming ``fragments``."""
    jpeg.forget_decodes()
    with open_raster(path) as raster, pytest.raises(AerofidInputError) as excinfo:
        raster.read_window((0, 0, 8, 8))
    assert_one_line_error(excinfo, *fragments)
    jpeg.forget_decodes()


@pytest.mark.parametrize("cut", [0.5, 0.95, "end marker"])
def test_a_truncated_jpeg_with_a_thumbnail_is_still_refused(tmp_path, cut):
    """The thumbnail's markers do not make a truncated scan whole: the marker walk skips segments by their length."""
    data = _exif_thumbnail_first(cv2.imencode(".jpg", smooth_image(3, (240, 320)))[1].tobytes())
    path = tmp_path / "trunc.jpg"
    path.write_bytes(data[:-2] if cut == "end marker" else data[: int(len(data) * cut)])
    assert not jpeg._ends_its_scans(path)
    _window_refused(path, "corrupt or truncated")


def test_a_jpeg_whose_header_libjpeg_refuses_is_refused_not_an_empty_image(tmp_path):
    """``cv2.imread`` into an array leaves the array as it was when libjpeg refuses the header (here a Huffman
    table whose counts make no code): OpenCV's own decode then decides, and refuses the file."""
    data = bytearray(cv2.imencode(".jpg", smooth_image(3, (240, 320)))[1].tobytes())
    k = data.find(b"\xff\xc4")
    data[k + 5:k + 21] = bytes([255] * 16)
    path = tmp_path / "bad_table.jpg"
    path.write_bytes(bytes(data))
    assert jpeg._ends_its_scans(path)
    assert jpeg._decode_in_place(path, jpeg.read_header(path, "jpeg")) is None
    _window_refused(path, "cannot decode")


def test_a_whole_jpeg_with_a_thumbnail_and_bytes_after_its_end_is_decoded_into_its_array(tmp_path):
    img = smooth_image(3, (240, 320))
    path = tmp_path / "thumb.jpg"
    path.write_bytes(_exif_thumbnail_first(cv2.imencode(".jpg", img)[1].tobytes()) + b"trailing bytes")
    assert jpeg._ends_its_scans(path)
    into = jpeg._decode_in_place(path, jpeg.read_header(path, "jpeg"))
    if not jpeg.IMREAD_INTO:
        pytest.skip("this OpenCV cannot decode into a given array")
    assert into is not None
    np.testing.assert_array_equal(into, jpeg._decode_with_cv2(path))


@pytest.mark.parametrize("chunk", [1, 2, 3, 7, 1 << 22])
def test_the_marker_walk_reads_in_chunks_as_a_whole(tmp_path, monkeypatch, chunk):
    """The end of a scan's data is found wherever the chunks cut it (an FF and its fill bytes carried over):
    baseline, progressive, with restart markers, with a thumbnail, cut anywhere."""
    monkeypatch.setattr(jpeg, "_CHUNK", chunk)
    img = smooth_image(3, (48, 64))
    kinds = [cv2.imencode(".jpg", img)[1].tobytes(),
             cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1])[1].tobytes(),
             cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_RST_INTERVAL, 2])[1].tobytes()]
    kinds.append(_exif_thumbnail_first(kinds[0]))
    for k, data in enumerate(kinds):
        path = tmp_path / f"{k}.jpg"
        path.write_bytes(data + b"\xff\xff")                   # bytes after the end marker
        assert jpeg.jpeg_structure(path) == "complete"
        for cut in (len(data) - 2, len(data) - 1, len(data) // 2, 700):
            path.write_bytes(data[:cut])
            assert jpeg.jpeg_structure(path) == "truncated", (k, cut)
    path.write_bytes(b"\xff\xd8\xff\xd9")
    assert jpeg.jpeg_structure(path) == "unexpected"            # an end before any scan


def test_a_truncated_jpeg_too_large_to_decode_whole_is_refused_not_read_grey(tmp_path, monkeypatch):
    """libjpeg's reduced decode makes up a truncated file's missing rows (grey): a JPEG read only reduced is refused
    when its marker walk runs out of data."""
    data = cv2.imencode(".jpg", np.full((640, 800), 90, np.uint8))[1].tobytes()
    path = tmp_path / "trunc.jpg"
    path.write_bytes(data[: len(data) // 2])
    monkeypatch.setattr(jpeg, "DECODE_BUDGET_BYTES", 640 * 800 - 1)
    with open_raster(path) as raster, pytest.raises(AerofidInputError) as excinfo:
        raster.read_reduced((0, 0, 800, 640), 8)
    assert_one_line_error(excinfo, "truncated", "re-export")
    path.write_bytes(data)
    with open_raster(path) as raster:
        assert raster.read_reduced((0, 0, 800, 640), 8).shape == (80, 100)
