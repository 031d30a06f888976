"""Corrupt and lying image files made at test time for the hostile-input tests and ``benchmarks/fuzz.py``:
TIFFs whose header declares far more pixels than the file holds (80000^2, 200000^2, tiled or in one strip),
JPEG/PNG headers declaring 30000^2, truncated TIFF/JPEG/PNG, deep JSON/YAML/XML. Nothing here reads the
machine's own files."""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import tifffile

_SHORT, _LONG = 3, 4


def lying_tiff(width: int, height: int, tile: int | None = 256, payload: bytes = b"\x80" * 16) -> bytes:
    """A little-endian TIFF of one 8-bit grey page declaring ``width`` x ``height`` with ONE tile (``tile`` px) or
    ONE strip of every row (``tile=None``) holding ``payload``: a few hundred bytes that claim gigabytes."""
    tags: list[tuple[int, int, int]] = [(256, _LONG, width), (257, _LONG, height), (258, _SHORT, 8),
                                        (259, _SHORT, 1), (262, _SHORT, 1), (277, _SHORT, 1)]
    data_offset = 8
    ifd_offset = data_offset + len(payload)
    if tile is None:
        tags += [(273, _LONG, data_offset), (278, _LONG, height), (279, _LONG, len(payload))]
    else:
        tags += [(322, _SHORT, tile), (323, _SHORT, tile), (324, _LONG, data_offset), (325, _LONG, len(payload))]
    out = b"II*\x00" + struct.pack("<I", ifd_offset) + payload + struct.pack("<H", len(tags))
    for tag, kind, value in sorted(tags):
        packed = struct.pack("<HH", value, 0) if kind == _SHORT else struct.pack("<I", value)
        out += struct.pack("<HHI", tag, kind, 1) + packed
    return out + struct.pack("<I", 0)


def lying_jpeg(width: int, height: int) -> bytes:
    """The header of a small JPEG with its frame's size changed to ``width`` x ``height`` (and no scan data)."""
    data = cv2.imencode(".jpg", np.full((16, 16), 128, np.uint8))[1].tobytes()
    sof = data.index(b"\xff\xc0")
    head = bytearray(data[: sof + 19])
    head[sof + 5 : sof + 7] = height.to_bytes(2, "big")
    head[sof + 7 : sof + 9] = width.to_bytes(2, "big")
    return bytes(head)


def lying_png(width: int, height: int) -> bytes:
    """A PNG signature and IHDR declaring ``width`` x ``height`` 8-bit grey, and one tiny IDAT."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")


def scan_image(rng: np.random.Generator, size: int = 160) -> np.ndarray:
    """A small 8-bit scan: noise with one bright '+' at the centre."""
    image = rng.normal(40, 4, (size, size)).clip(0, 255)
    c = size // 2
    image[c - 12 : c + 13, c - 1 : c + 2] = 220
    image[c - 1 : c + 2, c - 12 : c + 13] = 220
    return image.astype(np.uint8)


def encoded(image: np.ndarray, kind: str) -> bytes:
    """``image`` as TIFF (tiled, deflate), JPEG or PNG bytes."""
    if kind == "tif":
        import io

        buffer = io.BytesIO()
        tifffile.imwrite(buffer, image, tile=(64, 64), compression="deflate")
        return buffer.getvalue()
    return cv2.imencode(f".{kind}", image)[1].tobytes()


def deep_json(depth: int) -> str:
    return "[" * depth + "]" * depth


def deep_yaml(depth: int) -> str:
    return "name: " + "[" * depth + "]" * depth + "\n"


def deep_xml(depth: int) -> str:
    return "<a>" * depth + "</a>" * depth


def corpus(rng: np.random.Generator) -> dict[str, Callable[[], bytes]]:
    """Name -> maker of every corrupt or lying file (images by their extension; text files too)."""
    image = scan_image(rng)
    tif, jpg, png = (encoded(image, k) for k in ("tif", "jpg", "png"))
    return {
        "lie80k_tile.tif": lambda: lying_tiff(80000, 80000),
        "lie200k_tile.tif": lambda: lying_tiff(200000, 200000),
        "lie80k_strip.tif": lambda: lying_tiff(80000, 80000, tile=None),
        "lie30k.jpg": lambda: lying_jpeg(30000, 30000),
        "lie60k.jpg": lambda: lying_jpeg(60000, 60000),
        "lie30k.png": lambda: lying_png(30000, 30000),
        "lie1e9.png": lambda: lying_png(10**9, 10**9),
        "trunc.tif": lambda: tif[: len(tif) // 3],
        "trunc_head.tif": lambda: tif[:60],
        "trunc.jpg": lambda: jpg[: len(jpg) // 2],
        "trunc.png": lambda: png[: len(png) // 2],
        "flipped.jpg": lambda: bytes(b ^ 0x55 if i % 97 == 50 else b for i, b in enumerate(jpg)),
        "flipped.png": lambda: bytes(b ^ 0x55 if i % 97 == 50 else b for i, b in enumerate(png)),
        "empty.tif": lambda: b"",
        "magic_only.tif": lambda: b"II*\x00",
        "text.tif": lambda: b"hello, not an image\n",
        "deep.json": lambda: deep_json(100000).encode(),
        "deep.yaml": lambda: deep_yaml(5000).encode(),
        "deep.xml": lambda: deep_xml(100000).encode(),
    }


def write_corpus(folder: Path, rng: np.random.Generator) -> dict[str, Path]:
    """Write :func:`corpus` into ``folder``; name -> path."""
    paths = {}
    for name, make in corpus(rng).items():
        paths[name] = folder / name
        paths[name].write_bytes(make())
    return paths
