"""The scan's pixel size from the file's resolution tags (TIFF XResolution/ResolutionUnit, JPEG JFIF density,
PNG pHYs), read from the header alone."""

from __future__ import annotations

import numbers
import os
import struct
from pathlib import Path
from typing import BinaryIO

import tifffile

from aerofid.conventions import MAX_DPI, MAX_GIVEN_MM, MIN_DPI, MIN_PIXEL_MM, MM_PER_INCH, plausible_pixel_size
from aerofid.errors import AerofidInputError
from aerofid.io.jpeg import header_segments

SCREEN_DEFAULTS = (72.0, 96.0)
"""dpi values that image software writes when it knows nothing of the scan: not a scan resolution."""
SCREEN_ROUNDING = 1.3
"""How far (dpi) a tag may lie from a screen default and still be one: PNG stores whole dots per metre (96 dpi is
3779 or 3780, 95.99 or 96.01 dpi; the USGS browse frame of ``tma_browse`` declares 3779), JFIF and TIFF may store
whole dots per centimetre (96 dpi as 38, 96.52 dpi; 72 as 28, 71.12 dpi). No film scanner scans near 72 or 96 dpi."""


def checked_pixel_size(pixel_size_mm: object) -> float:
    """A pixel size given for a scan (mm per px) as a float, refused in one line unless it is a number from that of
    :data:`~aerofid.conventions.MAX_DPI` (0.00127 mm) to less than :data:`~aerofid.conventions.MAX_GIVEN_MM`.

    >>> import numpy as np
    >>> checked_pixel_size(0.021), checked_pixel_size(np.float32(0.5))
    (0.021, 0.5)
    >>> checked_pixel_size(21)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: pixel size 21 mm: give the scan's pixel size in mm, e.g. 0.021 (...)
    """
    if isinstance(pixel_size_mm, numbers.Real) and not isinstance(pixel_size_mm, bool):
        size = float(pixel_size_mm)
        if plausible_pixel_size(size):
            return size
    raise AerofidInputError(f"pixel size {pixel_size_mm!r} mm: give the scan's pixel size in mm, e.g. 0.021 "
                            f"(at least {MIN_PIXEL_MM:g} mm, {MAX_DPI:g} dpi, and less than {MAX_GIVEN_MM:g} mm)")


def pixel_size_from_tags(path: str | os.PathLike[str]) -> float | None:
    """The pixel size (mm per px) the file's resolution tags declare, or None when it declares none, declares
    different x and y resolutions, or a value no scan has (:data:`~aerofid.conventions.MIN_DPI`,
    :data:`~aerofid.conventions.MAX_DPI`,
    :data:`SCREEN_DEFAULTS` to within :data:`SCREEN_ROUNDING`).

    Examples
    --------
    >>> import numpy as np, tifffile, tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "scan.tif")
    >>> tifffile.imwrite(p, np.zeros((8, 8), np.uint8), resolution=(1200, 1200), resolutionunit="INCH")
    >>> round(pixel_size_from_tags(p), 6)
    0.021167
    """
    p = Path(path)
    try:
        with p.open("rb") as f:
            head = f.read(8)
            if head[:2] == b"\xff\xd8":
                dpi = _jfif_dpi(f)
            elif head[:8] == b"\x89PNG\r\n\x1a\n":
                dpi = _png_dpi(f)
            elif head[:2] in (b"II", b"MM"):
                dpi = _tiff_dpi(p)
            else:
                dpi = None
    except (OSError, ValueError, struct.error, tifffile.TiffFileError):
        return None
    if dpi is None or not (MIN_DPI <= dpi <= MAX_DPI) or any(abs(dpi - d) <= SCREEN_ROUNDING
                                                             for d in SCREEN_DEFAULTS):
        return None
    return MM_PER_INCH / dpi


def _same(x: float, y: float, unit_per_inch: float) -> float | None:
    """x and y resolutions in units per ``1 / unit_per_inch`` inch as dpi, None unless they agree."""
    if x <= 0 or y <= 0 or abs(x - y) > 1e-6 * max(x, y):
        return None
    return float(x) * unit_per_inch


def _jfif_dpi(f: BinaryIO) -> float | None:
    """The JFIF APP0 density (units 1 = dpi, 2 = dots per cm) among the header's segments."""
    for marker, body in header_segments(f):
        if marker == 0xE0 and body[:5] == b"JFIF\x00" and len(body) >= 12:
            units, xd, yd = body[7], *struct.unpack(">HH", body[8:12])
            return None if units not in (1, 2) else _same(xd, yd, 1.0 if units == 1 else 2.54)
    return None


def _png_dpi(f: BinaryIO) -> float | None:
    """The PNG pHYs chunk (pixels per metre when its unit is 1)."""
    while True:
        head = f.read(8)
        if len(head) < 8:
            return None
        length, kind = struct.unpack(">I4s", head)
        if kind == b"pHYs":
            xd, yd, unit = struct.unpack(">IIB", f.read(9))
            return _same(xd, yd, 0.0254) if unit == 1 else None
        if kind in (b"IDAT", b"IEND"):
            return None
        f.seek(length + 4, os.SEEK_CUR)


def _tiff_dpi(path: Path) -> float | None:
    """The first page's XResolution and YResolution (ResolutionUnit 2 = inch, 3 = centimetre)."""
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages.first.tags
        unit, xr, yr = tags.get("ResolutionUnit"), tags.get("XResolution"), tags.get("YResolution")
        if unit is None or xr is None or yr is None or int(unit.value) not in (2, 3):
            return None
        x, y = (v.value[0] / v.value[1] if v.value[1] else 0.0 for v in (xr, yr))
        return _same(x, y, 1.0 if int(unit.value) == 2 else 2.54)


__all__ = ["pixel_size_from_tags"]
