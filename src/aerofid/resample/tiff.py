"""Writing a large frame band by band as a tiled, compressed TIFF with internal overviews, in bounded memory.

Layout (the Cloud-Optimized GeoTIFF conventions tifffile can write): :data:`TILE` px tiles, Deflate with
horizontal differencing (TIFF predictor 2; floating-point samples predictor 3), the full-resolution image
first, then one reduced-resolution page per overview level (``NewSubfileType`` = 1, each half the size of the
one before, 2 x 2 block means, until it fits one tile), as GDAL writes internal overviews. Unlike GDAL's COG
driver, tifffile writes each page's IFD just before its data (the first one at the start of the file) rather
than every IFD at the start.

The full-resolution bands come from an iterator (one row of tiles at a time); each band is also reduced into
every overview level at once and the levels are kept in temporary raw files beside the output (not in memory),
then written as their own pages.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import IO, Any

import numpy as np
import tifffile

TILE = 512
"""Tile side (px) and the rows of one band: COG's usual 512."""
COMPRESSION = "zlib"
"""Deflate (TIFF compression 8): read by GDAL, libtiff, tifffile, QGIS; ZSTD is smaller but not read everywhere."""


def overview_sizes(width: int, height: int) -> list[tuple[int, int]]:
    """(width, height) of each overview level: halved (rounded up) until the level fits one tile.

    Examples
    --------
    >>> overview_sizes(2000, 1200)
    [(1000, 600), (500, 300)]
    """
    sizes = []
    while max(width, height) > TILE:
        width, height = -(-width // 2), -(-height // 2)
        sizes.append((width, height))
    return sizes


def reduce2(band: np.ndarray) -> np.ndarray:
    """2 x 2 block means of a band (an odd last row or column averages the pixels it has), rounded back to
    the band's dtype.

    Examples
    --------
    >>> reduce2(np.array([[0, 2, 7], [4, 6, 9]], np.uint8)).tolist()
    [[3, 8]]
    """
    h, w = band.shape[:2]
    pad = [(0, h % 2), (0, w % 2)] + [(0, 0)] * (band.ndim - 2)
    a = np.pad(band, pad, mode="edge").astype(np.float32)
    m = 0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])
    return np.rint(m).astype(band.dtype) if band.dtype.kind in "ui" else m.astype(band.dtype)


def _tiles(bands: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    """Tiles of bands of TILE rows, row-major, edge tiles padded with zeros to TILE x TILE."""
    for band in bands:
        for c0 in range(0, band.shape[1], TILE):
            tile = band[:, c0:c0 + TILE]
            if tile.shape[:2] != (TILE, TILE):
                pad = [(0, TILE - tile.shape[0]), (0, TILE - tile.shape[1])] + [(0, 0)] * (tile.ndim - 2)
                tile = np.pad(tile, pad)
            yield tile


def _spill(bands: Iterable[np.ndarray], files: list[IO[bytes]]) -> Iterator[np.ndarray]:
    """Pass the bands through, writing each one's reduction to every overview level's raw file."""
    for band in bands:
        level = band
        for f in files:
            level = reduce2(level)
            f.write(np.ascontiguousarray(level).tobytes())
        yield band


def _read_bands(f: IO[bytes], width: int, height: int, rows: int, sample: tuple[int, ...], dtype: np.dtype
                ) -> Iterator[np.ndarray]:
    """A level's raw file read back in bands of ``rows`` rows."""
    f.seek(0)
    row_bytes = width * int(np.prod(sample, dtype=np.int64)) * dtype.itemsize
    for r0 in range(0, height, rows):
        n = min(rows, height - r0)
        yield np.frombuffer(f.read(n * row_bytes), dtype=dtype).reshape((n, width) + sample)


def write_tiled(path: str | os.PathLike[str], bands: Iterable[np.ndarray], width: int, height: int,
                dtype: np.dtype, samples: int, description: str = "", pixel_size_mm: float | None = None,
                progress: Callable[[], None] | None = None) -> None:
    """Write ``bands`` (each TILE rows of ``width`` px, the last one shorter; ``(rows, width)`` or
    ``(rows, width, 3)`` of ``dtype``) as a tiled Deflate TIFF with overviews (module docstring) at ``path``.

    ``description`` goes to the ImageDescription tag; ``pixel_size_mm`` to the resolution tags (dots per cm).
    """
    dtype = np.dtype(dtype)
    sample = (3,) if samples == 3 else ()
    levels = overview_sizes(width, height)
    options: dict[str, Any] = {"tile": (TILE, TILE), "dtype": dtype, "compression": COMPRESSION, "metadata": None,
               "predictor": 3 if dtype.kind == "f" else 2,
               "photometric": "rgb" if samples == 3 else "minisblack"}
    big = width * height * max(samples, 1) * dtype.itemsize > 2 ** 31
    with ExitStack() as stack:
        spill: list[IO[bytes]] = [stack.enter_context(tempfile.TemporaryFile(dir=Path(path).parent)) for _ in levels]
        tif = stack.enter_context(tifffile.TiffWriter(path, bigtiff=big))
        resolution = None if pixel_size_mm is None else (10.0 / pixel_size_mm, 10.0 / pixel_size_mm)
        tif.write(_tiles(_counted(_spill(bands, spill), progress)), shape=(height, width) + sample,
                  description=description or None, resolution=resolution,
                  resolutionunit="CENTIMETER" if resolution else None, **options)
        for (w, h), f in zip(levels, spill):
            tif.write(_tiles(_read_bands(f, w, h, TILE, sample, dtype)), shape=(h, w) + sample, subfiletype=1,
                      **options)


def _counted(bands: Iterable[np.ndarray], progress: Callable[[], None] | None) -> Iterator[np.ndarray]:
    for band in bands:
        yield band
        if progress is not None:
            progress()


__all__ = ["COMPRESSION", "TILE", "overview_sizes", "reduce2", "write_tiled"]
