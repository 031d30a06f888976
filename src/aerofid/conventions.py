"""The package's vocabulary, in one place (lowest layer: imports nothing of aerofid).

Pixel coordinates: x = column, y = row, the centre of the top-left pixel is (0, 0); boxes are
(x0, y0, x1, y1) with x1, y1 exclusive.
"""

from __future__ import annotations

import math
from typing import Literal

Polarity = Literal["bright", "dark"]
"""A mark brighter than its ground (most fiducials) or darker (negatives, some panels)."""
POLARITIES: tuple[Polarity, ...] = ("bright", "dark")
POLARITY_CHOICES = (*POLARITIES, "auto")
"""What a user may ask for: one polarity, or ``"auto"`` (both are tried; the more confident answer wins)."""


def opposite(polarity: Polarity) -> Polarity:
    """The other polarity."""
    return "dark" if polarity == "bright" else "bright"


MarkKind = Literal["auto", "external", "panel"]
MARKS: tuple[str, ...] = ("auto", "external", "panel")
"""Kinds of mark: let the detector decide, an external (film) fiducial, or a cloth ground panel."""

SEED_METHODS: tuple[str, ...] = ("hough", "symmetry", "circles", "lines")
"""The seeds' methods, by the name a user gives (``locate(method=...)``, ``--method``): each is an entry of
:data:`aerofid.detect.registry.METHODS`, in its order."""
METHOD_NAMES: tuple[str, ...] = ("auto", *SEED_METHODS)
"""What ``method`` may be: ``auto`` or one of the seeds' methods."""

FOUND = "found"
NOT_FOUND = "not_found"
"""Every answer's status: a mark was located, or explicitly not (never an exception, never a made-up centre)."""

Box = tuple[int, int, int, int]
"""(x0, y0, x1, y1) in full-image pixels, x1 and y1 exclusive."""

LEAST_GREY_STEP = 1e-4
"""The least grey-level step (grey levels on [0, 1]) the screening believes: its noise floor
(:func:`aerofid.detect.screen.local_noise`; flat JPEG black has almost no noise, and its specks would outrank the
mark), and the least quantisation step a reduced read reports (:func:`aerofid.io.reduce.read_reduced_levels`). A
16-bit scan's 1/65535 let the few specks in its black clipped to 0 outrank every mark of ``synth.demo_frame``,
which its float samples (floor 1e-4) keep below them (a helper's audit)."""


def finite_or_none(v: float | None) -> float | None:
    """A number as JSON may carry it: a float, or None for a missing, NaN or infinite value.

    Examples
    --------
    >>> finite_or_none(1), finite_or_none(float("nan")), finite_or_none(None)
    (1.0, None, None)
    """
    return None if v is None or not math.isfinite(v) else float(v)


MM_PER_INCH = 25.4
MIN_DPI, MAX_DPI = 50.0, 20000.0
"""Resolutions believed: below 50 dpi a tag is a default (72, 96 dpi are screen defaults and refused separately),
above 20000 dpi no film scanner goes."""

MIN_PIXEL_MM = MM_PER_INCH / MAX_DPI
"""The least pixel size of a scan (mm): that of :data:`MAX_DPI`, 0.00127 mm."""

MAX_GIVEN_MM = 1.0
"""A pixel size given for a scan is less than this (mm): a 23 cm frame of fewer than 230 px is no scan to measure
(a browse image's 0.3 mm is the coarsest one seen)."""


def plausible_pixel_size(pixel_size_mm: float) -> bool:
    """Whether a scan's pixel size (mm) is one a film scan has: at least :data:`MIN_PIXEL_MM` and less than
    :data:`MAX_GIVEN_MM` (what a user gives, and a camera file's scan pixel size)."""
    return MIN_PIXEL_MM <= pixel_size_mm < MAX_GIVEN_MM


__all__ = ["FOUND", "LEAST_GREY_STEP", "MARKS", "MAX_DPI", "MAX_GIVEN_MM", "METHOD_NAMES", "MIN_DPI", "MIN_PIXEL_MM",
           "MM_PER_INCH", "NOT_FOUND", "POLARITIES", "POLARITY_CHOICES", "SEED_METHODS", "Box", "MarkKind", "Polarity",
           "opposite", "finite_or_none", "plausible_pixel_size"]
