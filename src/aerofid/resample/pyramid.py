"""The overview pyramid of a frame that comes band by band, each level's tiles compressed as they are made
(:mod:`aerofid.resample.tiff` lays them out as a Cloud-Optimized GeoTIFF).

Each level is the :func:`reduce2` of the whole level above it, half its size (rounded up), until a level fits
one :data:`TILE`; rows go down the pyramid in pairs as they come, so that at most one band of each level waits
in memory. A tile is stored as GDAL's COG driver stores it: its byte count (:data:`LEADER`, 4 bytes), the
Deflate-compressed samples after the TIFF predictor, and its last 4 bytes again (:data:`TRAILER`).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import IO

import imagecodecs
import numpy as np

TILE = 512
"""Tile side (px) and the rows of one band: COG's usual 512."""
DEFLATE_LEVEL = 6
"""zlib's default level, also tifffile's and GDAL's: level 9 is much slower for a few % less."""
LEADER = TRAILER = 4
"""Bytes before (the tile's byte count) and after (its last 4 bytes again) each tile's data: GDAL's
``BLOCK_LEADER=SIZE_AS_UINT4`` and ``BLOCK_TRAILER=LAST_4_BYTES_REPEATED``."""


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


def predictor(dtype: np.dtype) -> int:
    """The TIFF predictor for samples of ``dtype``: 3 (floating point, Adobe TIFF Technical Note 3) for floats,
    else 2 (horizontal differencing, TIFF 6.0 section 14)."""
    return 3 if np.dtype(dtype).kind == "f" else 2


def encode_tile(tile: np.ndarray) -> bytes:
    """One tile's stored bytes: the ``(rows, columns[, samples])`` samples padded with zeros to TILE x TILE,
    little-endian, the :func:`predictor` along each row, Deflate (zlib stream, :data:`DEFLATE_LEVEL`)."""
    h, w = tile.shape[:2]
    full = np.zeros((TILE, TILE, tile.shape[2] if tile.ndim == 3 else 1), tile.dtype.newbyteorder("<"))
    full[:h, :w] = tile.reshape(h, w, -1)
    if predictor(tile.dtype) == 3:
        full = imagecodecs.floatpred_encode(full, axis=-2)
    else:
        full = imagecodecs.delta_encode(full, axis=-2)
    return bytes(imagecodecs.deflate_encode(full.tobytes(), level=DEFLATE_LEVEL))


class Level:
    """One level being written: rows in; every :data:`TILE` rows tiled, encoded and appended to ``file``
    (row-major, each tile's byte count kept); every pair of rows reduced (:func:`reduce2`) into ``below``, the
    next smaller level, so that each level is the :func:`reduce2` of the whole level above it."""

    def __init__(self, file: IO[bytes], width: int, below: Level | None):
        self.file, self.width, self.below = file, width, below
        self.counts: list[int] = []
        self._rows: list[np.ndarray] = []
        self._odd: np.ndarray | None = None

    def push(self, rows: np.ndarray) -> None:
        self._rows.append(rows)
        while sum(r.shape[0] for r in self._rows) >= TILE:
            band = np.concatenate(self._rows) if len(self._rows) > 1 else self._rows[0]
            self._write(band[:TILE])
            self._rows = [band[TILE:]] if band.shape[0] > TILE else []
        if self.below is not None:
            if self._odd is not None:
                rows = np.concatenate([self._odd, rows])
            even = rows.shape[0] - rows.shape[0] % 2
            self._odd = rows[even:] if even < rows.shape[0] else None
            if even:
                self.below.push(reduce2(rows[:even]))

    def close(self) -> None:
        """Write the last, shorter band; the last odd row goes alone into the level below."""
        if self._rows:
            self._write(np.concatenate(self._rows))
            self._rows = []
        if self.below is not None:
            if self._odd is not None:
                self.below.push(reduce2(self._odd))
                self._odd = None
            self.below.close()

    def _write(self, band: np.ndarray) -> None:
        for c0 in range(0, self.width, TILE):
            data = encode_tile(band[:, c0:c0 + TILE])
            self.file.write(struct.pack("<I", len(data)) + data + data[-TRAILER:])
            self.counts.append(len(data))


def stored_size(counts: Sequence[int]) -> int:
    """Bytes of a level's stored tiles (with their leaders and trailers) whose data have ``counts`` bytes."""
    return sum(counts) + (LEADER + TRAILER) * len(counts)


def pyramid(files: Sequence[IO[bytes]], sizes: Sequence[tuple[int, int]]) -> list[Level]:
    """One :class:`Level` per size (the full resolution first), each storing its tiles in its own file and
    feeding the next; push the full resolution's rows into the first, then close it."""
    levels: list[Level] = []
    for f, (w, _) in zip(files[::-1], sizes[::-1]):
        levels.insert(0, Level(f, w, levels[0] if levels else None))
    return levels


__all__ = ["DEFLATE_LEVEL", "LEADER", "TILE", "TRAILER", "Level", "encode_tile", "overview_sizes", "predictor",
           "pyramid", "reduce2", "stored_size"]
