"""The measuring windows' sizes (:mod:`aerofid.find`'s search of a region), and the rows of a scan a search of a
region reads. Light (``math`` alone): a command computes them before the detection modules are imported, so that a
JPEG's whole decode, where the rows need it, runs while they import (:mod:`aerofid.cli.locate_cmd`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

MIN_HALF = 12
"""Smallest half-size of a measuring window (px)."""
MAX_HALF = 320
"""Largest half-size of a measuring window (px)."""


def window_half(half: float) -> int:
    """The half-size (px) of the window :meth:`aerofid.find.Measurer.at` reads for ``half``: rounded up, within
    :data:`MIN_HALF` and :data:`MAX_HALF`.

    Examples
    --------
    >>> window_half(3.2), window_half(40.1), window_half(1000)
    (12, 41, 320)
    """
    return int(min(max(math.ceil(half), MIN_HALF), MAX_HALF))


def rows_read(region: Sequence[Any]) -> int | None:
    """The row above which a search of ``region`` reads (for :func:`~aerofid.io.raster.open_raster`'s ``rows``): its
    bottom, then a measuring window of the largest size (:data:`MAX_HALF`) about a point in it (the screen's
    context, :data:`aerofid.find.CONTEXT`, is less); a window about a mark found outside the region may reach further.
    None where the bottom is not a number (:func:`~aerofid.io.raster.clip_box` then tells).

    Examples
    --------
    >>> rows_read((10, 20, 110, 120)), rows_read((0, 0, 5, float("nan")))
    (441, None)
    """
    try:
        bottom = float(region[3])
    except (TypeError, ValueError, IndexError):
        return None
    return math.ceil(bottom) + MAX_HALF + 1 if math.isfinite(bottom) else None


__all__ = ["MAX_HALF", "MIN_HALF", "rows_read", "window_half"]
