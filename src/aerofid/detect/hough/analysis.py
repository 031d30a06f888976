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

Steps 2 and 6 are the package's one Hough line transform (:mod:`aerofid.detect.hough_lines`). The search
over a box (spiral of windows, two tiers, recursion, similarity metric) is in :mod:`aerofid.detect.hough.search`;
the sub-pixel fit and verification (beyond the seed) in :mod:`aerofid.detect.hough.cross_fit` and
:mod:`aerofid.detect.hough.detector`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerofid.detect.hough.params import DEFAULT, HoughParams
from aerofid.detect.hough_lines import accumulate_window, intersection, theta_grid
from aerofid.detect.threshold import Threshold, optimum_threshold
from aerofid.kept import Kept, digest

METHOD = "hough"

EXTERNAL_NEIGHBOUR = 0.75
"""The ideal external-fiducial profile: 1 at the two peaks, this value one theta step either side
(Appendix C ``correlate``)."""


class Unknown:
    """The type of :data:`UNKNOWN`."""


UNKNOWN = Unknown()
"""A window's optimum threshold not yet computed (:func:`analyse_window` computes it)."""


@dataclass(frozen=True, eq=False)
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
    rho_step: float = 0.5


def threshold_accumulator(acc: np.ndarray, fraction: float) -> np.ndarray:
    """Zero every cell not above ``fraction`` of the peak (seed 001, Detection/Decoding; C ``coordinate``)."""
    return np.where(acc > fraction * acc.max(), acc, 0.0)


def theta_projection(acc_t: np.ndarray, rho_step: float, min_extent: float) -> np.ndarray:
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


def matched_filter(thetas_deg: np.ndarray, taper: float, half_width: float, separation: float) -> np.ndarray:
    """Weights w[k, i]: the matched filter of two tapered peaks ``separation`` apart, the first at theta_k.

    Each peak weighs 1 at its centre and falls linearly to ``taper`` at ``half_width`` degrees (Appendix C:
    .8, 1, .8 at 5 deg steps); theta is periodic with period 180 deg.
    """
    d1 = _angle_diff(thetas_deg[None, :], thetas_deg[:, None])
    d2 = _angle_diff(thetas_deg[None, :], thetas_deg[:, None] + separation)

    def peak(d: np.ndarray) -> np.ndarray:
        w = 1.0 - (1.0 - taper) * np.abs(d) / half_width
        return np.where(np.abs(d) <= half_width + 1e-9, w, 0.0)

    return peak(d1) + peak(d2)


@functools.lru_cache(maxsize=16)
def _matched_filter(thetas: bytes, taper: float, half_width: float, separation: float) -> np.ndarray:
    """:func:`matched_filter` of the theta grid ``thetas`` (its float64 bytes), made once per grid and setting (a
    box's search analyses thousands of windows with the same one); read-only."""
    w = matched_filter(np.frombuffer(thetas, np.float64), taper, half_width, separation)
    w.setflags(write=False)
    return w


def _angle_diff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray:
    """Signed difference a - b of line angles, folded into [-90, 90) degrees."""
    return (np.asarray(a) - np.asarray(b) + 90.0) % 180.0 - 90.0


def best_pair(projection: np.ndarray, thetas_deg: np.ndarray, params: HoughParams) -> tuple[int, int]:
    """Indices (k1, k2) of the strongest pair of projection peaks ``pair_separation`` apart (C ``coordinate``)."""
    weights = _matched_filter(np.asarray(thetas_deg, np.float64).tobytes(), params.taper, params.taper_half_width,
                              params.pair_separation)
    response = weights @ projection
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
    rho = rho_min + (cells + 0.5) * rho_step  # ascending: the median is the middle, as np.median gives it
    med = 0.5 * (rho[(rho.size - 1) // 2] + rho[rho.size // 2])
    keep = np.abs(rho - med) <= deviation
    return float(rho[keep].mean()) if keep.any() else float(med)


def window_accumulator(binary: np.ndarray, thetas_deg: np.ndarray, rho_step: float) -> tuple[np.ndarray, float]:
    """The Hough accumulator of the bright pixels of ``binary`` (seed 001, eq. 1;
    :func:`aerofid.detect.hough_lines.accumulate_window`), rho cells from -hypot(h, w); returns (accumulator,
    rho_min)."""
    h, w = binary.shape
    rho_max = float(np.hypot(h, w))
    n_rho = int(np.ceil(2 * rho_max / rho_step)) + 1
    return accumulate_window(binary, np.deg2rad(thetas_deg), -rho_max, rho_step, n_rho), -rho_max


@functools.lru_cache(maxsize=8)
def _theta_grid(theta_step: float) -> np.ndarray:
    """:func:`aerofid.detect.hough_lines.theta_grid`, made once per step (for every window of a search); read-only."""
    grid = theta_grid(theta_step)
    grid.setflags(write=False)
    return grid


KEPT_SIDE = 24
"""Analyses of windows up to this side (px: a panel's 16 px windows and their 8 px second stage) are kept
(:data:`ANALYSES_KEPT`), about 60 kB each: the overlapping windows of one box's searches meet the same pixels
again (in ``aerofid.locate`` on a panel in clutter, 900 of 3200 analyses of a box repeated within the last 256)."""
ANALYSES_KEPT = 256
"""The analyses :func:`analyse_window` keeps, the latest."""


_ANALYSES: Kept[WindowAnalysis | str] = Kept(ANALYSES_KEPT)


def analyse_window(window: np.ndarray, params: HoughParams = DEFAULT,
                   known: Threshold | None | Unknown = UNKNOWN) -> WindowAnalysis | str:
    """One window's Hough analysis (thesis ``fid`` without the recursion), or a string saying why not.
    ``known``: the window's :func:`~aerofid.detect.threshold.optimum_threshold` where it is known (None: it
    has none; the search computes those of its spiral's windows together). A small window's analysis
    (:data:`KEPT_SIDE`) is kept by its pixels, the parameters and ``known``, and given again (read-only arrays)."""
    if max(window.shape) > KEPT_SIDE:
        return _analysed(window, params, known)
    pixels = np.ascontiguousarray(window)
    key = (digest(pixels.tobytes()), pixels.shape, pixels.dtype.str, params,
           None if known is None else "unknown" if isinstance(known, Unknown) else known)
    got = _ANALYSES.get(key)
    if got is None:
        got = _analysed(window, params, known)
        if not isinstance(got, str):
            for a in (got.projection, got.binary, got.accumulator, got.accumulator_thresholded):
                a.setflags(write=False)
        _ANALYSES.put(key, got)
    return got


def bright_refusal(count: int, pixels: int, params: HoughParams = DEFAULT) -> str | None:
    """Why a window of ``pixels`` pixels, ``count`` of them above its threshold (the optimum threshold times
    ``threshold_gain``), is not analysed further (:func:`analyse_window`): more than ``max_bright_fraction`` of it
    bright (no thin mark on its ground), or fewer than ``min_pixels``; None where it is analysed."""
    if count > params.max_bright_fraction * pixels:
        return f"more than {params.max_bright_fraction:.0%} of the window is bright"
    if count < params.min_pixels:
        return "too few bright pixels"
    return None


def bright_value(optimum: float, params: HoughParams = DEFAULT) -> Any:
    """A window's threshold: its ``optimum`` threshold (a Python float) times ``threshold_gain`` (a number of whatever
    type that product has: a Python float, or a numpy scalar where the parameter is one)."""
    return optimum * params.threshold_gain


def bright_pixels(window: np.ndarray, thr: Threshold, params: HoughParams = DEFAULT) -> tuple[float, np.ndarray]:
    """The window's threshold (:func:`bright_value`) and its pixels above it: the one comparison of
    :func:`analyse_window`, which the spiral's first windows repeat in the same number type
    (:func:`aerofid.detect.hough.search.spiral_thresholds`)."""
    threshold = bright_value(thr.value, params)
    return threshold, window > threshold


def _analysed(window: np.ndarray, params: HoughParams, known: Threshold | None | Unknown) -> WindowAnalysis | str:
    """:func:`analyse_window`, computed."""
    thr = optimum_threshold(window) if isinstance(known, Unknown) else known
    if thr is None:
        return "homogeneous window"
    threshold, binary = bright_pixels(window, thr, params)
    refused = bright_refusal(int(binary.sum()), window.size, params)
    if refused is not None:
        return refused
    thetas = _theta_grid(params.theta_step)
    acc, rho_min = window_accumulator(binary, thetas, params.rho_step)
    acc_t = threshold_accumulator(acc, params.hough_threshold)
    projection = theta_projection(acc_t, params.rho_step, params.min_rho_extent)
    k1, k2 = best_pair(projection, thetas, params)
    rho1 = column_rho(acc_t, k1, rho_min, params.rho_step, params.rho_deviation)
    rho2 = column_rho(acc_t, k2, rho_min, params.rho_step, params.rho_deviation)
    if rho1 is None or rho2 is None:
        return "no pair of orthogonal peaks"
    centre = intersection(np.deg2rad(thetas[k1]), rho1, np.deg2rad(thetas[k2]), rho2)
    if centre is None:
        return "the two Hough lines are parallel"
    return WindowAnalysis(x=centre[0], y=centre[1], theta1=float(thetas[k1]), theta2=float(thetas[k2]),
                          rho1=rho1, rho2=rho2, threshold=threshold, background=thr.mean_dark,
                          projection=projection, thetas=thetas, binary=binary, accumulator=acc,
                          accumulator_thresholded=acc_t, rho_min=rho_min, rho_step=params.rho_step)


# --- similarity metric (seed 001, Similarity Measure; C ``correlate``) ------------------------------------

def external_model(thetas_deg: np.ndarray, theta0: float, separation: float = 90.0,
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


def _correlation(a: np.ndarray, b_centred: np.ndarray, b_squares: float) -> float | None:
    """Normalised correlation coefficient of the profile ``a`` and a profile given centred, with its sum of squares;
    None if either has no variance."""
    a = a - a.mean()
    den = np.sqrt((a * a).sum() * b_squares)
    if den <= 0:
        return None
    return float((a * b_centred).sum() / den)


@functools.lru_cache(maxsize=512)
def _model(name: str, thetas: bytes, theta0: float, separation: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The model profile ``name`` of :func:`similarity` on the theta grid ``thetas`` (its float64 bytes), centred, and
    the centred profile's sum of squares: made once per grid, peak and separation (a box's search correlates thousands
    of projections with the same few dozen); read-only."""
    grid = np.frombuffer(thetas, np.float64)
    model = external_model(grid, theta0, separation) if name == "external" else panel_model(grid, theta0)
    centred = model - model.mean()
    for a in (model, centred):
        a.setflags(write=False)
    return model, centred, (centred * centred).sum()


def similarity(projection: np.ndarray, thetas_deg: np.ndarray, theta0: float, mark: str = "auto",
               separation: float = 90.0) -> tuple[float | None, str, np.ndarray]:
    """The similarity metric: correlation of the projection with the model of ``mark`` ("external",
    "panel", or "auto" = the better of both, as the C ``correlate`` returns). Returns (metric, model name,
    model profile, read-only); the metric is None for a projection with no variance."""
    names = ("external", "panel") if mark == "auto" else (mark,)
    grid = np.asarray(thetas_deg, np.float64).tobytes()
    best: tuple[float | None, str, np.ndarray] | None = None
    for name in names:
        model, centred, squares = _model(name, grid, float(theta0), float(separation))
        r = _correlation(projection, centred, squares)
        if best is None or (r is not None and (best[0] is None or r > best[0])):
            best = (r, name, model)
    assert best is not None
    return best


__all__ = ["UNKNOWN", "HoughParams", "Unknown", "WindowAnalysis", "analyse_window", "best_pair", "bright_pixels",
           "bright_refusal", "bright_value", "column_rho",
           "matched_filter", "similarity", "theta_projection", "threshold_accumulator", "window_accumulator"]
