"""Thresholds that separate a mark's pixels from its ground.

- :func:`optimum_threshold`: the optimum threshold of Reddi, Rudin & Keshavan (1984) used by Hunt, Ryan &
  Gifford (seed 001, eq. 4; thesis 000, section 4.2.8.1 and Appendix B): the threshold k that maximises the
  interclass variance sigma^2(k) = p_D (m_D - m_O)^2 + p_B (m_B - m_O)^2, found by iterating the condition
  of Appendix B eq. 5, k = (m_D(k) + m_B(k)) / 2, exactly as the thesis' C function ``cthval`` does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, overload

import cv2
import numpy as np

from aerofid.detect.noise import difference_noise_sigma

N_BINS = 256
"""Histogram bins (thesis Appendix C, ``NBIN``)."""

MAX_ITERATIONS = 50
"""Iterations after which ``cthval`` declares the window homogeneous (Appendix C: ``count > 50``)."""

MIN_CONTRAST = 0.02
"""Windows whose grey range (max - min, on the [0, 1] scale) is below this are 'substantially homogeneous,
all black or all white' (seed 001, Optimum Thresholding) and are rejected. About 5 grey levels of 8 bits."""


@dataclass(frozen=True)
class Threshold:
    """An optimum threshold and the two classes it separates (grey levels on the window's scale)."""

    value: float
    mean_dark: float
    mean_bright: float
    bright_fraction: float
    iterations: int


def optimum_threshold(window: np.ndarray, n_bins: int = N_BINS, max_iterations: int = MAX_ITERATIONS,
                      min_contrast: float = MIN_CONTRAST) -> Threshold | None:
    """Reddi's optimum threshold of ``window`` (any shape), or None for a homogeneous window.

    The grey levels are binned into ``n_bins`` between the window's minimum and maximum. Starting at the
    middle bin, k is moved by e = (m(0, k) + m(k, N)) / 2 - k (m = mean bin of the dark and bright classes)
    until |e| < 0.5 bin or k repeats; a window that needs more than ``max_iterations`` steps, or whose grey
    range is below ``min_contrast``, returns None (the seed's "flag").
    """
    v = np.asarray(window, dtype=np.float64).ravel()
    v = v[np.isfinite(v)]
    if v.size < 2:
        return None
    lo, hi = float(v.min()), float(v.max())
    if hi - lo < min_contrast:
        return None
    width = (hi - lo) / n_bins
    idx = np.minimum(((v - lo) / width).astype(np.int64), n_bins - 1)
    hist = np.bincount(idx, minlength=n_bins).astype(np.float64)
    bins = np.arange(n_bins, dtype=np.float64)
    c0 = np.concatenate([[0.0], np.cumsum(hist)])          # c0[k] = pixels in bins < k
    c1 = np.concatenate([[0.0], np.cumsum(hist * bins)])   # c1[k] = sum of bin indices below k
    total0, total1 = c0[-1], c1[-1]

    def class_means(k: int) -> tuple[float, float]:
        # bins 0 and n_bins - 1 hold the minimum and maximum, so both classes are populated for 1 <= k < n_bins
        return c1[k] / c0[k], (total1 - c1[k]) / (total0 - c0[k])

    found = _reddi_iteration(class_means, n_bins, max_iterations)
    if found is None:
        return None
    k, iterations = found
    m_dark, m_bright = class_means(k)
    value = lo + k * width
    return Threshold(value=value, mean_dark=lo + (m_dark + 0.5) * width,
                     mean_bright=lo + (m_bright + 0.5) * width,
                     bright_fraction=float((total0 - c0[k]) / total0), iterations=iterations)


def _reddi_iteration(class_means: Callable[[int], tuple[float, float]], n_bins: int,
                     max_iterations: int) -> tuple[int, int] | None:
    """Appendix B eq. 5 by iteration (C ``cthval``): from the middle bin, move k by
    e = (m_dark(k) + m_bright(k)) / 2 - k until |e| < 0.5 bin; on a cycle keep the k that came closest.
    Returns (k, iterations), or None after ``max_iterations``."""
    k = n_bins // 2
    visited: dict[int, float] = {}
    for it in range(1, max_iterations + 1):
        m_dark, m_bright = class_means(k)
        e = (m_dark + m_bright) / 2.0 + 0.5 - k   # +0.5: from bin centres to the edge between the classes
        if abs(e) < 0.5:
            return k, it
        visited[k] = abs(e)
        k_next = min(max(int(round(k + e)), 1), n_bins - 1)
        if k_next in visited:  # a cycle: keep the k that came closest to the condition (cthval's ikbest)
            return min(visited, key=visited.__getitem__), it
        k = k_next
    return None


def interclass_variance(window: np.ndarray, k: float) -> float:
    """sigma^2(k) = p_D (m_D - m_O)^2 + p_B (m_B - m_O)^2 (seed 001, eq. 4) for a threshold ``k``."""
    v = np.asarray(window, dtype=np.float64).ravel()
    dark, bright = v[v < k], v[v >= k]
    if dark.size == 0 or bright.size == 0:
        return 0.0
    m_o = v.mean()
    p_d, p_b = dark.size / v.size, bright.size / v.size
    return float(p_d * (dark.mean() - m_o) ** 2 + p_b * (bright.mean() - m_o) ** 2)


@overload
def local_dynamic_threshold(window: np.ndarray, region: int = 8, noise_k: float = 4.0,
                            min_contrast: float = MIN_CONTRAST, min_class: int = 2, *,
                            return_thresholds: Literal[True]) -> tuple[np.ndarray, np.ndarray]: ...


@overload
def local_dynamic_threshold(window: np.ndarray, region: int = 8, noise_k: float = 4.0,
                            min_contrast: float = MIN_CONTRAST, min_class: int = 2,
                            return_thresholds: Literal[False] = False) -> np.ndarray: ...


def local_dynamic_threshold(window: np.ndarray, region: int = 8, noise_k: float = 4.0,
                            min_contrast: float = MIN_CONTRAST, min_class: int = 2,
                            return_thresholds: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Binary image of ``window`` by local dynamic thresholding (Sohn et al., seed 004, section 4).

    "The local dynamic thresholding method obtains the local threshold values based on the relative local
    intensity distribution ... the size of local region to estimate bimodal approximation was 8x8" (seed 004;
    Sohn 1996, after Chow & Kaneko 1972). The window is cut into ``region`` x ``region`` tiles (the last row
    and column of tiles may be smaller); in each tile the bimodal threshold is :func:`optimum_threshold`
    (Reddi). A tile counts as bimodal when both classes hold at least ``min_class`` pixels and their means
    differ by at least max(``min_contrast``, ``noise_k`` x the window's noise standard deviation, estimated
    from the MAD of its first differences); pure-noise tiles split at about 1.6 noise sigma and fail
    (:func:`tile_thresholds`). The thresholds of the other tiles are interpolated from the bimodal ones
    (:func:`fill_tiles`), and the tile thresholds are bilinearly interpolated to every pixel between the tile
    centres.

    Returns the boolean image ``window > threshold`` (all False when no tile is bimodal) and, with
    ``return_thresholds``, also the per-pixel threshold surface (NaN when no tile is bimodal).
    """
    w = np.asarray(window, dtype=np.float32)
    if w.ndim != 2 or w.size == 0:
        raise ValueError("window must be a non-empty 2-D array")
    h, wd = w.shape
    region = max(2, int(region))
    min_sep = max(min_contrast, noise_k * difference_noise_sigma(w))
    t = tile_thresholds(w, region, min_sep, min_contrast, min_class)
    if not np.isfinite(t).any():
        out = np.zeros((h, wd), bool)
        return (out, np.full((h, wd), np.nan, np.float32)) if return_thresholds else out
    ny, nx = t.shape
    surface = cv2.resize(fill_tiles(t).astype(np.float32), (nx * region, ny * region),
                         interpolation=cv2.INTER_LINEAR)[:h, :wd]
    binary = w > surface
    return (binary, surface) if return_thresholds else binary


def tile_thresholds(w: np.ndarray, region: int, min_sep: float, min_contrast: float = MIN_CONTRAST,
                    min_class: int = 2) -> np.ndarray:
    """The optimum threshold of every ``region`` x ``region`` tile of ``w`` that is bimodal (both classes of
    at least ``min_class`` pixels, means at least ``min_sep`` apart); NaN for the other tiles."""
    h, wd = w.shape
    ny, nx = -(-h // region), -(-wd // region)
    t = np.full((ny, nx), np.nan)
    for i in range(ny):
        for j in range(nx):
            tile = w[i * region:(i + 1) * region, j * region:(j + 1) * region]
            th = optimum_threshold(tile, min_contrast=min_contrast)
            if th is None:
                continue
            bright = tile >= th.value
            nb = int(bright.sum())
            if nb < min_class or tile.size - nb < min_class:
                continue
            if float(tile[bright].mean() - tile[~bright].mean()) >= min_sep:
                t[i, j] = th.value
    return t


def fill_tiles(t: np.ndarray) -> np.ndarray:
    """The tile thresholds ``t`` with their NaN tiles interpolated from the known ones: normalised Gaussian
    convolution on the tile grid, widened until every tile has a value (the median at the very last)."""
    known = np.isfinite(t)
    ny, nx = t.shape
    filled = t.copy()
    s = 1.0
    while not np.isfinite(filled).all():
        num = cv2.GaussianBlur(np.where(known, t, 0).astype(np.float64), (0, 0), s,
                               borderType=cv2.BORDER_CONSTANT)
        den = cv2.GaussianBlur(known.astype(np.float64), (0, 0), s, borderType=cv2.BORDER_CONSTANT)
        with np.errstate(invalid="ignore", divide="ignore"):
            est = num / den
        fill = ~known & np.isfinite(est) & (den > 1e-6)
        filled[fill] = est[fill]
        s *= 2.0
        if s > 4 * max(ny, nx):
            filled[~np.isfinite(filled)] = float(np.nanmedian(t))
    return filled
