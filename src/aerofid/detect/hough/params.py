"""Every parameter of the ``hough`` method in one validated class, :class:`HoughParams`.

The defaults are the values of Hunt, Ryan & Gifford (seed 001) and of the thesis' C code (seed 000, section
4.2.8 and Appendix C); the verification knobs are aerofid's (beyond the seed, see
:mod:`aerofid.detect.hough.detector`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from aerofid.conventions import MARKS
from aerofid.detect.params import MAX_PX, MethodParams, check, is_int, number_in

MAX_WINDOW = 4096
"""Largest first-stage window (px)."""


@dataclass(frozen=True)
class HoughParams(MethodParams):
    """Parameters of the ``hough`` method (seed 001; thesis 000): one window's analysis, the box search, the
    similarity model and the verification.

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> from aerofid.detect.hough import HoughParams, detect
    >>> scene = synth.mark_scene("cross", 30, width=2.0, window=60, rng=np.random.default_rng(1))
    >>> found = detect(scene.image, HoughParams(mark="external"))
    >>> bool(abs(found.x - scene.marks[0].x) < 0.1 and abs(found.y - scene.marks[0].y) < 0.1)
    True
    >>> HoughParams(theta_step=7)
    Traceback (most recent call last):
    ...
    ValueError: theta_step must divide 180 degrees and lie in [0.5, 45] (e.g. 1, 2, 3, 5, 10, 20, 30), not 7
    """

    # --- one window (seed 001, Hough Transform / Detection / Decoding; thesis Appendix C) -------------------
    rho_step: float = 0.5
    """Quantisation of rho in px (seed 001, Hough Transform: "rho has a resolution of 0.5 pixels"; C ``RES``)."""
    theta_step: float = 5.0
    """Quantisation of theta in degrees over 0..175 (seed 001: "the angle theta has 5 deg of resolution")."""
    hough_threshold: float = 0.30
    """Accumulator cells not above this fraction of the peak are zeroed (seed 001, Detection/Decoding: 30 %)."""
    max_bright_fraction: float = 0.30
    """A window with more than this fraction of pixels above threshold is rejected (seed 001, Optimum
    Thresholding: "if the number of pixels identified as fiducial ... exceeds 30 percent")."""
    threshold_gain: float = 1.1
    """The optimum threshold is multiplied by this before use (thesis Appendix C, ``optth *= 1.1``)."""
    min_pixels: int = 3
    """Fewest above-threshold pixels for a Hough transform (the C code rejects an accumulator peak below one
    vote, ``Hthresh <= 10`` with votes of 80); a line needs at least a few pixels."""
    taper: float = 0.8
    """Weight of the matched filter ``taper_half_width`` from each of its two peaks (Appendix C ``coordinate``:
    .8, 1, .8)."""
    taper_half_width: float = 5.0
    """Angular half-width in degrees over which the matched filter tapers from 1 to ``taper``."""
    pair_separation: float = 90.0
    """Angle between the two lines of the mark in degrees (90 for a '+'; eq. 2 decodes any separation)."""
    rho_deviation: float = 5.0
    """Rho values further than this (px) from the median of their theta column are outliers (Appendix C
    ``DEV`` = 10 cells of 0.5 px)."""
    min_rho_extent: float = 2.0
    """Smallest rho extent (px) in the projection's denominator (eq. 5): the 2 px stroke of the seed's external
    fiducial. Not in the seed, whose marks were axis-aligned (see :func:`.analysis.theta_projection`)."""
    mark: str = "auto"
    """Similarity model (seed 001, Similarity Measure, eq. 6; C ``correlate``): ``"external"`` (two sharp
    peaks), ``"panel"`` (raised cosine) or ``"auto"`` (the better of both). Also picks the first-stage window."""

    # --- the box search (seed 001, Partitioning / Recursion / Similarity; C ``estcoor``, ``fid``, ``fiducial``)
    window_size: int | None = None
    """First-stage window (px); None: 40 for external fiducials (C ``WNDSZ1``), 16 for panels (seed 001
    Table 1), both for ``mark="auto"``."""
    overlap: float = 0.30
    """Overlap of neighbouring first-stage windows (seed 001: "overlap, e.g., 30 percent"; C: step 0.7 W)."""
    stage1_accept: float = 0.6
    """A first-stage metric above this is accepted at once (Appendix C ``pthl``)."""
    stage2_enter: float = 0.3
    """A first-stage metric below this moves on to the next window (Appendix C ``pm``)."""
    stage2_accept: float = 0.4
    """A second-stage metric above this is accepted at once (Appendix C ``pth``)."""
    min_metric: float = 0.2
    """The best metric must exceed this, else "no mark identified" (Appendix C ``pmin``)."""
    max_recursion: int = 5
    """Re-centrings of one window before its answer is taken as it is (Appendix C: ``loop > 5``)."""
    convergence: float = 1.0
    """The recursion has converged when the centre moves by less than this (L1 distance, px). The C code's
    integer test ``error < 3`` allows up to 2 px; sub-pixel answers allow a tighter test."""
    exhaustive: bool = False
    """Analyse every spiral position even after a mark is accepted (to list every candidate, table 5.1)."""
    max_rejections: int | None = 8
    """Beyond the seed: once this many candidates have failed verification, no further candidate is verified
    and the search ends (None: no limit). Measured (15 marks per style and condition of
    benchmarks/bench_marks.py): a true '+' or panel was always the first candidate verified, while windows
    without a '+' (JPEG bull's-eyes and dots) had 13-37 refused candidates and took 1.0-1.2 s."""
    stage2_fallback: bool = True
    """When the second-stage window cannot be analysed at all (more than 30 % bright, or no pair of lines),
    let the first-stage candidate compete with its first-stage metric. The seed drops such a candidate; with
    marks wider than the seed's 1 px strokes the half-size window is often more than 30 % bright. ``False``
    reproduces the seed."""

    # --- verification (beyond the seed) ------------------------------------------------------------------
    verify: bool = True
    """Refine every candidate to sub-pixel and verify it is a '+' (False: the seed's one-pixel answer)."""
    min_arm_balance: float = 0.35
    """The weakest of the four half-arms must carry at least this fraction of the strongest's contrast, else the
    candidate is an L, a T, a bar or a corner of a roof, not a '+'."""
    min_arm_snr: float = 3.0
    """The weakest half-arm's contrast must be at least this many times the grey-level noise."""
    max_crossing_gap: float | None = None
    """Before the cross fit, refuse a candidate whose Hough centre has no bright pixel of the thresholded window
    within this many px (:func:`~aerofid.detect.hough.detector.crossing_gap`); None: fit every candidate. A '+'
    whose crossing a dust speck hides, or that is open at its centre, has no stroke there and is still fitted and
    found, so the search of a box fits every candidate; ``auto`` sets it where it only asks whether a '+' crosses
    at a centre that two other methods agree on (``AutoParams.cross_check_crossing_gap``)."""

    def validate(self) -> None:
        """Refuse, in one line, any value that would fail or exhaust memory later."""
        _validate_window_analysis(self)
        _validate_search(self)
        _validate_verification(self)


def _validate_window_analysis(p: HoughParams) -> None:
    check(number_in(p.rho_step, 0.1, 20.0), f"rho_step must be in [0.1, 20] px, not {p.rho_step!r}")
    check(number_in(p.theta_step, 0.5, 45.0) and abs(180.0 / p.theta_step - round(180.0 / p.theta_step)) < 1e-9,
          f"theta_step must divide 180 degrees and lie in [0.5, 45] (e.g. 1, 2, 3, 5, 10, 20, 30), "
          f"not {p.theta_step!r}")
    check(number_in(p.hough_threshold, 0.0, 1.0, hi_open=True),
          f"hough_threshold must be a fraction in [0, 1), not {p.hough_threshold!r}")
    check(number_in(p.max_bright_fraction, 0.0, 1.0, lo_open=True),
          f"max_bright_fraction must be a fraction in (0, 1], not {p.max_bright_fraction!r}")
    check(number_in(p.threshold_gain, 0.0, 10.0, lo_open=True),
          f"threshold_gain must be in (0, 10], not {p.threshold_gain!r}")
    check(is_int(p.min_pixels) and p.min_pixels >= 1, f"min_pixels must be an integer >= 1, not {p.min_pixels!r}")
    check(number_in(p.taper, 0.0, 1.0), f"taper must be in [0, 1], not {p.taper!r}")
    check(number_in(p.taper_half_width, 0.0, 90.0, lo_open=True),
          f"taper_half_width must be in (0, 90] degrees, not {p.taper_half_width!r}")
    check(number_in(p.pair_separation, 0.0, 180.0, lo_open=True, hi_open=True),
          f"pair_separation must be between 0 and 180 degrees (exclusive), not {p.pair_separation!r}")
    check(number_in(p.rho_deviation, 0.0, math.inf), f"rho_deviation must be >= 0 px, not {p.rho_deviation!r}")
    check(number_in(p.min_rho_extent, 0.0, math.inf), f"min_rho_extent must be >= 0 px, not {p.min_rho_extent!r}")
    check(p.mark in MARKS, f"mark must be one of {', '.join(MARKS)}, not {p.mark!r}")


def _validate_search(p: HoughParams) -> None:
    check(p.window_size is None or (is_int(p.window_size) and 4 <= p.window_size <= MAX_WINDOW),
          f"window_size must be None or an integer in [4, {MAX_WINDOW}] px, not {p.window_size!r}")
    check(number_in(p.overlap, 0.0, 1.0, hi_open=True), f"overlap must be a fraction in [0, 1), not {p.overlap!r}")
    for name in ("stage1_accept", "stage2_enter", "stage2_accept", "min_metric"):
        value = getattr(p, name)
        check(number_in(value, -1.0, 1.0), f"{name} must be a correlation in [-1, 1], not {value!r}")
    check(is_int(p.max_recursion) and 0 <= p.max_recursion <= 100,
          f"max_recursion must be an integer in [0, 100], not {p.max_recursion!r}")
    check(number_in(p.convergence, 0.0, math.inf), f"convergence must be >= 0 px, not {p.convergence!r}")
    check(p.max_rejections is None or (is_int(p.max_rejections) and p.max_rejections >= 1),
          f"max_rejections must be None or an integer >= 1, not {p.max_rejections!r}")
    for name in ("exhaustive", "stage2_fallback"):
        check(isinstance(getattr(p, name), bool), f"{name} must be True or False, not {getattr(p, name)!r}")


def _validate_verification(p: HoughParams) -> None:
    check(isinstance(p.verify, bool), f"verify must be True or False, not {p.verify!r}")
    check(number_in(p.min_arm_balance, 0.0, 1.0), f"min_arm_balance must be in [0, 1], not {p.min_arm_balance!r}")
    check(number_in(p.min_arm_snr, 0.0, math.inf), f"min_arm_snr must be >= 0, not {p.min_arm_snr!r}")
    check(p.max_crossing_gap is None or number_in(p.max_crossing_gap, 0.0, MAX_PX),
          f"max_crossing_gap must be None or in [0, {MAX_PX}] px, not {p.max_crossing_gap!r}")


DEFAULT = HoughParams()
"""The seed's parameters (the default of every function that takes a :class:`HoughParams`)."""

__all__ = ["DEFAULT", "HoughParams"]
