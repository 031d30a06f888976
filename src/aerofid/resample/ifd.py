"""TIFF and BigTIFF file headers and image file directories (IFDs) as bytes, little-endian.

TIFF 6.0 (Adobe, 1992), section 2 "TIFF Structure": an 8-byte header (``II``, 42, the first IFD's offset); an
IFD is a 2-byte entry count, 12-byte entries sorted by tag code (tag, type, count, the value itself when it fits
4 bytes, left-justified, else the offset of the value), then the next IFD's offset (0: the last). Every value
and IFD starts on a word (even) boundary. BigTIFF (Aware Systems' BigTIFF proposal, as libtiff implements it):
a 16-byte header (``II``, 43, 8, 0, the first IFD's 8-byte offset), an 8-byte entry count, 20-byte entries whose
count and value fields have 8 bytes, an 8-byte next-IFD offset, and the LONG8 type for offsets past 4 GB.

An IFD is written with its values that do not fit an entry right after it, so :func:`ifd_size` is known from
the tags alone (not their values' offsets): a writer can lay out every IFD before it knows where the image
data will go.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from fractions import Fraction

ASCII, SHORT, LONG, RATIONAL, DOUBLE, LONG8 = 2, 3, 4, 5, 12, 16
"""The TIFF field types used here (TIFF 6.0 section 2; LONG8 from BigTIFF)."""
NEW_SUBFILE_TYPE, IMAGE_WIDTH, IMAGE_LENGTH, BITS_PER_SAMPLE, COMPRESSION, PHOTOMETRIC = 254, 256, 257, 258, 259, 262
IMAGE_DESCRIPTION, SAMPLES_PER_PIXEL, X_RESOLUTION, Y_RESOLUTION, PLANAR_CONFIGURATION = 270, 277, 282, 283, 284
RESOLUTION_UNIT, SOFTWARE, PREDICTOR, TILE_WIDTH, TILE_LENGTH, TILE_OFFSETS = 296, 305, 317, 322, 323, 324
TILE_BYTE_COUNTS, SAMPLE_FORMAT = 325, 339
"""The tag codes used here (TIFF 6.0 appendix A)."""
_FORMAT = {ASCII: "s", SHORT: "H", LONG: "I", RATIONAL: "I", DOUBLE: "d", LONG8: "Q"}
"""Each type's struct code (a RATIONAL is two LONGs: numerator, denominator)."""
_ITEM = {ASCII: 1, SHORT: 2, LONG: 4, RATIONAL: 8, DOUBLE: 8, LONG8: 8}
"""Bytes of one value of each type."""
_LONG_MAX = 2 ** 32 - 1
WORD = 2
"""TIFF 6.0: an IFD and every value an entry points to start at an even offset."""


@dataclass(frozen=True)
class Tag:
    """One IFD entry: ``code``, field ``type`` and its values (a RATIONAL's as numerator, denominator pairs;
    an ASCII's as the text, written with its terminating NUL)."""

    code: int
    type: int
    values: tuple[int | float, ...] | str

    @property
    def count(self) -> int:
        """The entry's count: values (RATIONAL pairs; ASCII bytes with the NUL)."""
        if isinstance(self.values, str):
            return len(self.values.encode("ascii")) + 1
        return len(self.values) // 2 if self.type == RATIONAL else len(self.values)

    def data(self) -> bytes:
        """The values as little-endian bytes."""
        if isinstance(self.values, str):
            return self.values.encode("ascii") + b"\0"
        return struct.pack(f"<{len(self.values)}{_FORMAT[self.type]}", *self.values)


def rational(code: int, value: float) -> Tag:
    """A RATIONAL tag holding ``value`` (>= 0) as the nearest fraction whose terms fit a LONG.

    Examples
    --------
    >>> rational(282, 10 / 0.015).values
    (2000, 3)
    """
    fraction = Fraction(value).limit_denominator(max(1, min(_LONG_MAX, int(_LONG_MAX / max(value, 1.0)))))
    return Tag(code, RATIONAL, (fraction.numerator, fraction.denominator))


def header(bigtiff: bool, first_ifd: int) -> bytes:
    """The file header pointing at the first IFD.

    Examples
    --------
    >>> header(False, 8).hex(), header(True, 16).hex()
    ('49492a0008000000', '49492b00080000001000000000000000')
    """
    if bigtiff:
        return b"II" + struct.pack("<HHHQ", 43, 8, 0, first_ifd)
    return b"II" + struct.pack("<HI", 42, first_ifd)


def header_size(bigtiff: bool) -> int:
    """Bytes of :func:`header`."""
    return 16 if bigtiff else 8


def _sizes(bigtiff: bool) -> tuple[int, int, int]:
    """(entry count field, one entry, the value field in an entry / the next-IFD offset) in bytes."""
    return (8, 20, 8) if bigtiff else (2, 12, 4)


def _even(n: int) -> int:
    return n + (-n) % WORD


def ifd_size(tags: list[Tag], bigtiff: bool) -> int:
    """Bytes of :func:`ifd_bytes` for these tags (the IFD and its out-of-line values), whatever their values."""
    count, entry, field = _sizes(bigtiff)
    size = count + entry * len(tags) + field
    for t in tags:
        n = t.count * _ITEM[t.type]
        size += _even(n) if n > field else 0
    return size


def ifd_bytes(tags: list[Tag], offset: int, next_ifd: int, bigtiff: bool) -> bytes:
    """The IFD at file ``offset`` (even) with ``tags`` (sorted here by code, each code once), followed by the
    values that do not fit their entry (each at an even offset); ``next_ifd`` the next IFD's offset or 0.

    Examples
    --------
    >>> b = ifd_bytes([Tag(257, LONG, (300,)), Tag(256, SHORT, (400,))], 8, 0, False)
    >>> b.hex(" ", 2)
    '0200 0001 0300 0100 0000 9001 0000 0101 0400 0100 0000 2c01 0000 0000 0000'
    """
    if offset % WORD:
        raise ValueError(f"an IFD must start at an even offset, not {offset}")
    tags = sorted(tags, key=lambda t: t.code)
    if len({t.code for t in tags}) != len(tags):
        raise ValueError("each tag may appear once in an IFD")
    count, entry, field = _sizes(bigtiff)
    unit = "Q" if bigtiff else "I"
    entries, values = [struct.pack(f"<{'Q' if bigtiff else 'H'}", len(tags))], []
    at = offset + count + entry * len(tags) + field
    for t in tags:
        data = t.data()
        if len(data) <= field:
            inline = data.ljust(field, b"\0")
        else:
            inline = struct.pack(f"<{unit}", at)
            values.append(data.ljust(_even(len(data)), b"\0"))
            at += _even(len(data))
        entries.append(struct.pack(f"<HH{unit}", t.code, t.type, t.count) + inline)
    out = b"".join(entries) + struct.pack(f"<{unit}", next_ifd) + b"".join(values)
    assert len(out) == ifd_size(tags, bigtiff)
    return out


__all__ = ["ASCII", "BITS_PER_SAMPLE", "COMPRESSION", "DOUBLE", "IMAGE_DESCRIPTION", "IMAGE_LENGTH", "IMAGE_WIDTH",
           "LONG", "LONG8", "NEW_SUBFILE_TYPE", "PHOTOMETRIC", "PLANAR_CONFIGURATION", "PREDICTOR", "RATIONAL",
           "RESOLUTION_UNIT", "SAMPLES_PER_PIXEL", "SAMPLE_FORMAT", "SHORT", "SOFTWARE", "TILE_BYTE_COUNTS",
           "TILE_LENGTH", "TILE_OFFSETS", "TILE_WIDTH", "X_RESOLUTION", "Y_RESOLUTION", "Tag", "header", "header_size",
           "ifd_bytes", "ifd_size", "rational"]
