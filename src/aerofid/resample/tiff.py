"""Writing a large frame band by band as a Cloud-Optimized GeoTIFF (GDAL's COG layout), in bounded memory.

Layout, as GDAL's COG driver writes it (GDAL documentation, COG driver, "File format details") and its
``validate_cloud_optimized_geotiff.py`` checks it:

- the header, then GDAL's "ghost" structural metadata (:data:`GHOST`), then every IFD: the full-resolution
  image's first, then one per overview level in decreasing size (``NewSubfileType`` = 1), each followed by its
  values (tile offsets and byte counts included), all before any tile data;
- then the tile data: the smallest overview's tiles first, ..., the full-resolution tiles last, each level's
  tiles in row-major order, each tile preceded by its byte count (4 bytes, little-endian: GDAL's "block
  leader") and followed by a copy of its last 4 bytes (the "block trailer"), so that a reader fetching a tile
  by an HTTP range request knows its size and can check it was read whole;
- :data:`TILE` px tiles (edge tiles padded with zeros), Deflate with horizontal differencing (TIFF predictor 2;
  floating-point samples predictor 3), the samples' dtype and bands (8/16-bit or float, grey or RGB), overviews
  of 2 x 2 block means (:func:`reduce2`), each half the size of the one before until it fits one tile;
  BigTIFF only when the file would pass 4 GB (or when asked).

GDAL reads such a file as ``LAYOUT=COG`` (``gdalinfo``); tests/test_resample.py checks the validator's rules.

Memory: the full-resolution bands come from an iterator (one row of tiles at a time); the overview pyramid
(:mod:`aerofid.resample.pyramid`) compresses each level's tiles as they are made into a temporary file per level
beside the output, at most one band of each level waiting in memory. At the end the directory is written
(every offset now known; IFDs serialised by :mod:`aerofid.resample.ifd`) and the levels' stored tiles copied
after it in the COG order, a chunk at a time.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from itertools import accumulate
from pathlib import Path
from typing import IO

import numpy as np

import aerofid.resample.ifd as ifd
from aerofid.resample.ifd import ASCII, LONG, LONG8, SHORT, Tag, header, header_size, ifd_bytes, ifd_size, rational
from aerofid.resample.pyramid import LEADER, TILE, TRAILER, overview_sizes, predictor, pyramid, reduce2, stored_size

DEFLATE = 8
"""TIFF compression 8 (Adobe Deflate): read by GDAL, libtiff, tifffile, QGIS; ZSTD is smaller but not read
everywhere."""
BIGTIFF_LIMIT = 2 ** 32 - 1
"""The last byte a classic TIFF's 4-byte offsets reach: a larger file is written as BigTIFF."""
COPY_CHUNK = 1 << 24
"""Bytes copied at a time from a level's temporary file into the output (16 MB)."""
GHOST = ("LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\n"
         "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n ")
"""GDAL's COG structural metadata (GDAL COG driver documentation, "Header ghost area"): what this writer does
(no mask, so no ``MASK_INTERLEAVED_WITH_IMAGERY``). The last space is GDAL's: room for an editor to turn ``NO``
into ``YES`` in place."""
SOFTWARE = "aerofid"


@dataclass(frozen=True)
class Image:
    """What the IFDs say about the image: size, samples, the ImageDescription and the pixel size (mm)."""

    width: int
    height: int
    dtype: np.dtype
    samples: int
    description: str = ""
    pixel_size_mm: float | None = None


def level_tags(image: Image, level: int, size: tuple[int, int], offsets: Sequence[int], counts: Sequence[int],
               bigtiff: bool) -> list[Tag]:
    """The tags of one level's IFD: level 0 the full-resolution image (with the description and resolution
    tags, dots per cm), the others reduced-resolution images (``NewSubfileType`` = 1)."""
    bits = (image.dtype.itemsize * 8,) * image.samples
    kind = (2 if image.dtype.kind == "i" else 3 if image.dtype.kind == "f" else 1,) * image.samples
    offset_type = LONG8 if bigtiff else LONG
    tags = [Tag(ifd.IMAGE_WIDTH, LONG, (size[0],)), Tag(ifd.IMAGE_LENGTH, LONG, (size[1],)),
            Tag(ifd.BITS_PER_SAMPLE, SHORT, bits), Tag(ifd.COMPRESSION, SHORT, (DEFLATE,)),
            Tag(ifd.PHOTOMETRIC, SHORT, (2 if image.samples == 3 else 1,)),  # RGB or min-is-black
            Tag(ifd.SAMPLES_PER_PIXEL, SHORT, (image.samples,)), Tag(ifd.PLANAR_CONFIGURATION, SHORT, (1,)),
            Tag(ifd.SOFTWARE, ASCII, SOFTWARE), Tag(ifd.PREDICTOR, SHORT, (predictor(image.dtype),)),
            Tag(ifd.TILE_WIDTH, LONG, (TILE,)), Tag(ifd.TILE_LENGTH, LONG, (TILE,)),
            Tag(ifd.TILE_OFFSETS, offset_type, tuple(offsets)), Tag(ifd.TILE_BYTE_COUNTS, offset_type, tuple(counts)),
            Tag(ifd.SAMPLE_FORMAT, SHORT, kind)]  # unsigned, signed integer or IEEE float
    if level:
        tags.append(Tag(ifd.NEW_SUBFILE_TYPE, LONG, (1,)))  # a reduced-resolution image
    else:
        if image.description:
            tags.append(Tag(ifd.IMAGE_DESCRIPTION, ASCII, image.description))
        if image.pixel_size_mm is not None:
            dots_per_cm = 10.0 / image.pixel_size_mm
            tags += [rational(ifd.X_RESOLUTION, dots_per_cm), rational(ifd.Y_RESOLUTION, dots_per_cm),
                     Tag(ifd.RESOLUTION_UNIT, SHORT, (3,))]  # centimetre
    return tags


def ghost() -> bytes:
    """GDAL's structural metadata block that follows the header (:data:`GHOST` with its size line)."""
    return f"GDAL_STRUCTURAL_METADATA_SIZE={len(GHOST):06d} bytes\n{GHOST}".encode("ascii")


@dataclass(frozen=True)
class Layout:
    """Where everything goes in the file: the first IFD, each level's IFD (and, last, the first byte after
    them), each level's first tile, and the file's size (the data follow the IFDs, smallest level first)."""

    bigtiff: bool
    first_ifd: int
    ifds: tuple[int, ...]
    data: tuple[int, ...]
    end: int


def layout(image: Image, sizes: Sequence[tuple[int, int]], counts: Sequence[Sequence[int]], bigtiff: bool
           ) -> Layout:
    """The :class:`Layout` of the levels of ``sizes`` whose tiles have ``counts`` bytes (level 0 first)."""
    first = header_size(bigtiff) + len(ghost())
    first += first % 2
    blank = [level_tags(image, i, s, [0] * len(c), c, bigtiff) for i, (s, c) in enumerate(zip(sizes, counts))]
    ifds = tuple(accumulate([first] + [ifd_size(t, bigtiff) for t in blank]))
    data = tuple(accumulate([ifds[-1]] + [stored_size(c) for c in counts[::-1]]))
    return Layout(bigtiff, first, ifds, data[-2::-1], data[-1])


def directory(image: Image, sizes: Sequence[tuple[int, int]], counts: Sequence[Sequence[int]], plan: Layout
              ) -> bytes:
    """Everything before the tile data: header, :func:`ghost`, every level's IFD (level 0 first) with its
    values."""
    parts = [header(plan.bigtiff, plan.first_ifd), ghost().ljust(plan.first_ifd - header_size(plan.bigtiff), b"\0")]
    for i, (size, c) in enumerate(zip(sizes, counts)):
        offsets = list(accumulate([plan.data[i] + LEADER] + [n + LEADER + TRAILER for n in c[:-1]]))
        parts.append(ifd_bytes(level_tags(image, i, size, offsets, c, plan.bigtiff), plan.ifds[i],
                               plan.ifds[i + 1] if i + 1 < len(sizes) else 0, plan.bigtiff))
    return b"".join(parts)


def write_tiled(path: str | os.PathLike[str], bands: Iterable[np.ndarray], width: int, height: int,
                dtype: np.dtype, samples: int, description: str = "", pixel_size_mm: float | None = None,
                progress: Callable[[], None] | None = None, *, bigtiff: bool | None = None) -> None:
    """Write ``bands`` (each TILE rows of ``width`` px, the last one shorter; ``(rows, width)`` or
    ``(rows, width, 3)`` of ``dtype``) as a Cloud-Optimized GeoTIFF with overviews (module docstring) at ``path``.

    ``description`` goes to the ImageDescription tag; ``pixel_size_mm`` to the resolution tags (dots per cm);
    ``progress`` is called after each band; ``bigtiff`` forces (True) or forbids (False) BigTIFF, by default
    used only when the file passes 4 GB.
    """
    image = Image(width, height, np.dtype(dtype), 3 if samples == 3 else 1, description, pixel_size_mm)
    sizes = [(width, height)] + overview_sizes(width, height)
    with ExitStack() as stack:
        files = [stack.enter_context(tempfile.TemporaryFile(dir=Path(path).parent)) for _ in sizes]
        levels = pyramid(files, sizes)
        rows = 0
        for band in bands:
            band = _checked(band, image, rows)
            levels[0].push(band)
            rows += band.shape[0]
            if progress is not None:
                progress()
        if rows != height:
            raise ValueError(f"the bands have {rows} rows, not {height}")
        levels[0].close()
        _assemble(path, image, sizes, [lv.counts for lv in levels], files, bigtiff)


def _checked(band: np.ndarray, image: Image, rows: int) -> np.ndarray:
    shape = (band.shape[0], image.width) + ((3,) if image.samples == 3 else ())
    if band.shape != shape or rows + band.shape[0] > image.height:
        raise ValueError(f"a band of shape {band.shape} at row {rows}: expected {shape} within {image.height} rows")
    return band.astype(image.dtype, copy=False)


def file_layout(image: Image, sizes: Sequence[tuple[int, int]], counts: Sequence[Sequence[int]],
                bigtiff: bool | None = None) -> Layout:
    """:func:`layout` as classic TIFF when the file stays within 4 GB (:data:`BIGTIFF_LIMIT`), else BigTIFF;
    ``bigtiff`` True forces BigTIFF, False forbids it (a ValueError when the file would not fit)."""
    plan = layout(image, sizes, counts, bool(bigtiff))
    if plan.end > BIGTIFF_LIMIT and not plan.bigtiff:
        if bigtiff is False:
            raise ValueError(f"{plan.end} bytes do not fit a classic TIFF")
        plan = layout(image, sizes, counts, True)
    return plan


def _assemble(path: str | os.PathLike[str], image: Image, sizes: list[tuple[int, int]], counts: list[list[int]],
              files: Sequence[IO[bytes]], bigtiff: bool | None) -> None:
    """The directory, then each level's stored tiles, smallest level first."""
    plan = file_layout(image, sizes, counts, bigtiff)
    with open(path, "wb") as out:
        out.write(directory(image, sizes, counts, plan))
        for f, c in zip(files[::-1], counts[::-1]):
            f.seek(0)
            shutil.copyfileobj(f, out, COPY_CHUNK)
            assert f.tell() == stored_size(c)
        assert out.tell() == plan.end


__all__ = ["BIGTIFF_LIMIT", "DEFLATE", "GHOST", "TILE", "Image", "Layout", "directory", "file_layout", "layout",
           "level_tags", "overview_sizes", "reduce2", "write_tiled"]
