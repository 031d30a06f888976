"""Hough-transform cross detector of Hunt, Ryan & Gifford (seed 001, PE&RS 1993; thesis 000, chapter 4).

A fiducial mark or a cloth ground panel is modelled as two line segments crossing at their midpoints ('+').
In one window the algorithm (thesis section 4.2.8, C function ``fid``):

1. thresholds the window at Reddi's optimum threshold (:func:`aerofid.detect.threshold.optimum_threshold`, raised
   by the C code's factor 1.1) and rejects windows that are homogeneous or more than 30 % bright;
2. maps every bright pixel into (rho, theta) by rho = x cos(theta) + y sin(theta) (eq. 1), theta in
   0..175 deg by 5 deg, rho by 0.5 px;
3. zeroes accumulator cells below 30 % of the peak and projects onto theta, dividing each column's sum by
   the square of its rho extent (eq. 5), which favours sharp peaks over the broad "bow-tie";
4. correlates the projection with a matched filter of two tapered peaks 90 deg apart to find the pair
   (theta1, theta2);
5. rejects rho values far from the median of each column and averages the rest;
6. decodes the centre with the inverse transform (eq. 2, valid for non-orthogonal pairs too).

Beyond the seed (which stops at one pixel): :func:`verify_candidate` fits a blurred-cross model to the
grey values (:mod:`aerofid.detect.hough.cross_fit`) for a sub-pixel centre with its standard deviation, and
checks that the candidate is a '+' (four balanced, visible arms) before it may be accepted. The search over a box (spiral of windows, two tiers, recursion, similarity metric) is in
:mod:`aerofid.detect.hough.search`; :func:`detect` runs it on a whole window.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aerofid.detect.threshold import optimum_threshold

METHOD = "hough"

# --- parameters: the seed's values (thesis 4.2.8 and Appendix C) ----------------------------------------
RHO_STEP = 0.5
"""Quantisation of rho in px (seed 001, Hough Transform: "rho has a resolution of 0.5 pixels"; C ``RES``)."""
THETA_STEP = 5.0
"""Quantisation of theta in degrees over 0..175 (seed 001: "the angle theta has 5 deg of resolution")."""
HOUGH_THRESHOLD = 0.30
"""Accumulator cells below this fraction of the peak are zeroed (seed 001, Detection/Decoding: 30 %)."""
MAX_BRIGHT_FRACTION = 0.30
"""A window with more than this fraction of pixels above threshold is rejected (seed 001, Optimum
Thresholding: "if the number of pixels identified as fiducial ... exceeds 30 percent")."""
THRESHOLD_GAIN = 1.1
"""The optimum threshold is multiplied by this before use (thesis Appendix C, ``optth *= 1.1``)."""
MIN_PIXELS = 3
"""Fewest above-threshold pixels for a Hough transform (the C code rejects an accumulator peak below one
vote, ``Hthresh <= 10`` with votes of 80); a line needs at least a few pixels."""
TAPER = 0.8
"""Weight of the matched filter 5 deg from each of its two peaks (Appendix C ``coordinate``: .8, 1, .8)."""
TAPER_HALF_WIDTH = 5.0
"""Angular half-width in degrees over which the matched filter tapers from 1 to ``TAPER``."""
PAIR_SEPARATION = 90.0
"""Angle between the two lines of the mark in degrees (90 for a '+'; eq. 2 decodes any separation)."""
RHO_DEVIATION = 5.0
"""Rho values further than this (px) from the median of their theta column are outliers (Appendix C
``DEV`` = 10 cells of 0.5 px)."""
MIN_RHO_EXTENT = 2.0
"""Smallest rho extent (px) used in the projection's denominator (eq. 5): the 2 px stroke of the seed's
external fiducial. Not in the seed, whose marks were axis-aligned (see :func:`theta_projection`)."""
EXTERNAL_NEIGHBOUR = 0.75
"""The ideal external-fiducial profile: 1 at the two peaks, this value one theta step either side
(Appendix C ``correlate``)."""

MARK_MODELS = ("external", "panel", "auto")


@dataclass(frozen=True)
class HoughParams:
    """Every parameter of one window's Hough analysis, with the seed's values as defaults."""

    rho_step: float = RHO_STEP
    theta_step: float = THETA_STEP
    hough_threshold: float = HOUGH_THRESHOLD
    max_bright_fraction: float = MAX_BRIGHT_FRACTION
    threshold_gain: float = THRESHOLD_GAIN
    min_pixels: int = MIN_PIXELS
    taper: float = TAPER
    taper_half_width: float = TAPER_HALF_WIDTH
    pair_separation: float = PAIR_SEPARATION
    rho_deviation: float = RHO_DEVIATION
    min_rho_extent: float = MIN_RHO_EXTENT

    def __post_init__(self):
        if not (0 < self.rho_step <= 20):
            raise ValueError("rho_step must be in (0, 20] px")
        if not (0 < self.theta_step <= 45) or abs(180.0 / self.theta_step - round(180.0 / self.theta_step)) > 1e-9:
            raise ValueError("theta_step must divide 180 degrees (e.g. 1, 2, 3, 5, 10, 20, 30)")
        if not (0 <= self.hough_threshold < 1):
            raise ValueError("hough_threshold must be a fraction in [0, 1)")
        if not (0 < self.max_bright_fraction <= 1):
            raise ValueError("max_bright_fraction must be a fraction in (0, 1]")
        if not (0 < self.pair_separation < 180):
            raise ValueError("pair_separation must be between 0 and 180 degrees")


@dataclass(frozen=True)
class WindowAnalysis:
    """The Hough analysis of one window (thesis ``fid``), in the window's own pixel coordinates."""

    x: float
    y: float
    theta1: float   # degrees
    theta2: float
    rho1: float     # px, relative to the window origin
    rho2: float
    threshold: float
    background: float
    projection: np.ndarray = field(repr=False)
    thetas: np.ndarray = field(repr=False)
    binary: np.ndarray = field(repr=False)
    accumulator: np.ndarray = field(repr=False)
    accumulator_thresholded: np.ndarray = field(repr=False)
    rho_min: float = 0.0
    rho_step: float = RHO_STEP


def theta_grid(theta_step: float) -> np.ndarray:
    """theta in degrees: 0, step, ..., 180 - step (seed: 0..175 by 5)."""
    return np.arange(0.0, 180.0 - 1e-9, theta_step)


def hough_accumulate(xs: np.ndarray, ys: np.ndarray, thetas_deg: np.ndarray, rho_step: float,
                     rho_max: float) -> tuple[np.ndarray, float]:
    """Accumulator A[theta, rho] of the points (xs, ys) by rho = x cos(theta) + y sin(theta) (eq. 1).

    Cell ``j`` of a column holds rho in [rho_min + j*rho_step, rho_min + (j+1)*rho_step) with
    rho_min = -rho_max. Returns (accumulator, rho_min).
    """
    t = np.deg2rad(thetas_deg)
    rho = np.outer(np.cos(t), xs) + np.outer(np.sin(t), ys)          # (n_theta, n_points)
    n_rho = int(np.ceil(2 * rho_max / rho_step)) + 1
    rho_min = -rho_max
    j = np.floor((rho - rho_min) / rho_step).astype(np.int64)
    np.clip(j, 0, n_rho - 1, out=j)
    flat = (np.arange(len(thetas_deg))[:, None] * n_rho + j).ravel()
    acc = np.bincount(flat, minlength=len(thetas_deg) * n_rho).reshape(len(thetas_deg), n_rho)
    return acc.astype(np.float64), rho_min


def threshold_accumulator(acc: np.ndarray, fraction: float) -> np.ndarray:
    """Zero every cell not above ``fraction`` of the peak (seed 001, Detection/Decoding; C ``coordinate``)."""
    out = acc.copy()
    out[out <= fraction * acc.max()] = 0.0
    return out


def theta_projection(acc_t: np.ndarray, rho_step: float = RHO_STEP, min_extent: float = MIN_RHO_EXTENT) -> np.ndarray:
    """projection(theta) = sum_rho AM / (rho_max - rho_min)^2 (seed 001, eq. 5).

    The extent is measured in px over the non-zero cells, inclusive of the cells' width
    ((last - first + 1) * rho_step, as the C code's ``div`` counts cells), and never less than
    ``min_extent``: a line is as wide as the mark's stroke, so a column whose only surviving cell is an
    isolated one (votes of the crossing piling up at an unrelated angle) must not outweigh the true peak.
    An empty column projects to 0.
    """
    nz = acc_t > 0
    total = acc_t.sum(axis=1)
    any_nz = nz.any(axis=1)
    first = np.argmax(nz, axis=1)
    last = acc_t.shape[1] - 1 - np.argmax(nz[:, ::-1], axis=1)
    extent = np.maximum((last - first + 1) * rho_step, min_extent)
    return np.where(any_nz, total / extent ** 2, 0.0)


def matched_filter(thetas_deg: np.ndarray, taper: float = TAPER, half_width: float = TAPER_HALF_WIDTH,
                   separation: float = PAIR_SEPARATION) -> np.ndarray:
    """Weights w[k, i]: the matched filter of two tapered peaks ``separation`` apart, the first at theta_k.

    Each peak weighs 1 at its centre and falls linearly to ``taper`` at ``half_width`` degrees (Appendix C:
    .8, 1, .8 at 5 deg steps); theta is periodic with period 180 deg.
    """
    d1 = _angle_diff(thetas_deg[None, :], thetas_deg[:, None])
    d2 = _angle_diff(thetas_deg[None, :], thetas_deg[:, None] + separation)

    def peak(d):
        w = 1.0 - (1.0 - taper) * np.abs(d) / half_width
        return np.where(np.abs(d) <= half_width + 1e-9, w, 0.0)

    return peak(d1) + peak(d2)


def _angle_diff(a, b):
    """Signed difference a - b of line angles, folded into [-90, 90) degrees."""
    return (np.asarray(a) - np.asarray(b) + 90.0) % 180.0 - 90.0


def best_pair(projection: np.ndarray, thetas_deg: np.ndarray, params: HoughParams) -> tuple[int, int]:
    """Indices (k1, k2) of the strongest pair of projection peaks ``pair_separation`` apart (C ``coordinate``)."""
    response = matched_filter(thetas_deg, params.taper, params.taper_half_width, params.pair_separation) @ projection
    # the pair (k, k + 90) is the same as (k + 90, k): search theta1 over half the circle for a '+'
    n = len(thetas_deg)
    span = n if params.pair_separation != 90.0 else n // 2
    k1 = int(np.argmax(response[:span]))
    target = (thetas_deg[k1] + params.pair_separation) % 180.0
    k2 = int(np.argmin(np.abs(_angle_diff(thetas_deg, target))))
    return k1, k2


def column_rho(acc_t: np.ndarray, k: int, rho_min: float, rho_step: float, deviation: float) -> float | None:
    """Average rho of the non-zero cells of column k after dropping those further than ``deviation`` px from
    their median (seed 001: "eliminates as extraneous peaks those having rho values significantly different
    from the majority, and computes an average rho"; C ``rho``). Cell centres are used."""
    cells = np.flatnonzero(acc_t[k] > 0)
    if cells.size == 0:
        return None
    rho = rho_min + (cells + 0.5) * rho_step
    med = np.median(rho)
    keep = np.abs(rho - med) <= deviation
    return float(rho[keep].mean()) if keep.any() else float(med)


def decode(theta1_deg: float, rho1: float, theta2_deg: float, rho2: float) -> tuple[float, float]:
    """Intersection of two lines given in normal form: the inverse transform, eq. 2 of seed 001."""
    t1, t2 = np.deg2rad(theta1_deg), np.deg2rad(theta2_deg)
    det = np.cos(t1) * np.sin(t2) - np.cos(t2) * np.sin(t1)
    x = (rho1 * np.sin(t2) - rho2 * np.sin(t1)) / det
    y = (-rho1 * np.cos(t2) + rho2 * np.cos(t1)) / det
    return float(x), float(y)


def analyse_window(window: np.ndarray, params: HoughParams = HoughParams()) -> WindowAnalysis | str:
    """One window's Hough analysis (thesis ``fid`` without the recursion), or a string saying why not."""
    thr = optimum_threshold(window)
    if thr is None:
        return "homogeneous window"
    threshold = thr.value * params.threshold_gain
    binary = window > threshold
    count = int(binary.sum())
    if count > params.max_bright_fraction * window.size:
        return f"more than {params.max_bright_fraction:.0%} of the window is bright"
    if count < params.min_pixels:
        return "too few bright pixels"
    ys, xs = np.nonzero(binary)
    thetas = theta_grid(params.theta_step)
    h, w = window.shape
    acc, rho_min = hough_accumulate(xs.astype(np.float64), ys.astype(np.float64), thetas, params.rho_step,
                                    float(np.hypot(h, w)))
    acc_t = threshold_accumulator(acc, params.hough_threshold)
    projection = theta_projection(acc_t, params.rho_step, params.min_rho_extent)
    k1, k2 = best_pair(projection, thetas, params)
    rho1 = column_rho(acc_t, k1, rho_min, params.rho_step, params.rho_deviation)
    rho2 = column_rho(acc_t, k2, rho_min, params.rho_step, params.rho_deviation)
    if rho1 is None or rho2 is None:
        return "no pair of orthogonal peaks"
    x, y = decode(thetas[k1], rho1, thetas[k2], rho2)
    return WindowAnalysis(x=x, y=y, theta1=float(thetas[k1]), theta2=float(thetas[k2]), rho1=rho1, rho2=rho2,
                          threshold=threshold, background=thr.mean_dark, projection=projection,
                          thetas=thetas, binary=binary, accumulator=acc, accumulator_thresholded=acc_t,
                          rho_min=rho_min, rho_step=params.rho_step)


# --- similarity metric (seed 001, Similarity Measure; C ``correlate``) ------------------------------------

def external_model(thetas_deg: np.ndarray, theta0: float, separation: float = PAIR_SEPARATION,
                   neighbour: float = EXTERNAL_NEIGHBOUR) -> np.ndarray:
    """The ideal external-fiducial projection: two sharp peaks ``separation`` apart at theta0 (1 at the
    peaks, ``neighbour`` one theta step either side, 0 elsewhere)."""
    step = thetas_deg[1] - thetas_deg[0] if len(thetas_deg) > 1 else 180.0
    model = np.zeros_like(thetas_deg, dtype=np.float64)
    for centre in (theta0, theta0 + separation):
        d = np.abs(_angle_diff(thetas_deg, centre))
        model = np.maximum(model, np.where(d < step / 2, 1.0, np.where(d < 1.5 * step, neighbour, 0.0)))
    return model


def panel_model(thetas_deg: np.ndarray, theta0: float) -> np.ndarray:
    """The marked-ground-point projection: the raised cosine f(theta) = 1 + cos(4 (theta - theta0)) (eq. 6)."""
    return 1.0 + np.cos(4.0 * np.deg2rad(thetas_deg - theta0))


def correlation(a: np.ndarray, b: np.ndarray) -> float | None:
    """Normalised correlation coefficient of two profiles; None if either has no variance."""
    a = a - a.mean()
    b = b - b.mean()
    den = np.sqrt((a * a).sum() * (b * b).sum())
    if den <= 0:
        return None
    return float((a * b).sum() / den)


def similarity(projection: np.ndarray, thetas_deg: np.ndarray, theta0: float, mark: str = "auto",
               separation: float = PAIR_SEPARATION) -> tuple[float | None, str, np.ndarray]:
    """The similarity metric: correlation of the projection with the model of ``mark`` ("external",
    "panel", or "auto" = the better of both, as the C ``correlate`` returns). Returns (metric, model name,
    model profile); the metric is None for a projection with no variance."""
    models = {"external": external_model(thetas_deg, theta0, separation), "panel": panel_model(thetas_deg, theta0)}
    names = ("external", "panel") if mark == "auto" else (mark,)
    best: tuple[float | None, str, np.ndarray] = (None, names[0], models[names[0]])
    for name in names:
        r = correlation(projection, models[name])
        if r is not None and (best[0] is None or r > best[0]):
            best = (r, name, models[name])
    return best


__all__ = ["HoughParams", "WindowAnalysis", "analyse_window", "decode", "hough_accumulate",
           "matched_filter", "similarity", "theta_projection", "threshold_accumulator"]
