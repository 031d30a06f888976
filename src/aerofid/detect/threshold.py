"""Thresholds that separate a mark's pixels from its ground.

- :func:`optimum_threshold`: the optimum threshold of Reddi, Rudin & Keshavan (1984) used by Hunt, Ryan &
  Gifford (seed 001, eq. 4; thesis 000, section 4.2.8.1 and Appendix B): the threshold k that maximises the
  interclass variance sigma^2(k) = p_D (m_D - m_O)^2 + p_B (m_B - m_O)^2, found by iterating the condition
  of Appendix B eq. 5, k = (m_D(k) + m_B(k)) / 2, exactly as the thesis' C function ``cthval`` does.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, overload

import cv2
import numpy as np

from aerofid.robust import difference_noise_sigma

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
    c0, c1 = _cumulative_sums(v[None], np.array([lo]), np.array([width]), n_bins)
    found = _reddi_iteration(functools.partial(_row_class_means, c0[0], c1[0]), n_bins, max_iterations)
    if found is None:
        return None
    k, iterations = found
    value, mean_dark, mean_bright, bright_fraction = _fields(lo, width, k, c0[0, k], c1[0, k], c0[0, -1], c1[0, -1])
    return Threshold(value=value, mean_dark=float(mean_dark), mean_bright=float(mean_bright),
                     bright_fraction=float(bright_fraction), iterations=iterations)


def _cumulative_sums(v: np.ndarray, lo: np.ndarray, width: np.ndarray, n_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Each row of ``v`` binned into ``n_bins`` of ``width`` from ``lo`` (per row), and the histogram's cumulative
    sums: ``c0[:, k]`` the pixels in bins below k, ``c1[:, k]`` the sum of their bin indices (``n_bins + 1``
    columns; thesis C ``cthval``)."""
    m = len(v)
    idx = np.minimum(((v - lo[:, None]) / width[:, None]).astype(np.int64), n_bins - 1)
    hist = np.bincount((idx + n_bins * np.arange(m)[:, None]).ravel(), minlength=m * n_bins)
    hist = hist.reshape(m, n_bins).astype(np.float64)
    c0, c1 = np.zeros((m, n_bins + 1)), np.zeros((m, n_bins + 1))
    np.cumsum(hist, axis=1, out=c0[:, 1:])
    np.cumsum(hist * np.arange(n_bins, dtype=np.float64), axis=1, out=c1[:, 1:])
    return c0, c1


def _class_means(below0: Any, below1: Any, total0: Any, total1: Any) -> tuple[Any, Any]:
    """The mean bins of the dark and bright classes from the cumulative sums at k (``below0``, ``below1``:
    :func:`_cumulative_sums`' ``c0[k]``, ``c1[k]``) and their totals; numbers or arrays alike (bins 0 and
    n_bins - 1 hold the minimum and maximum, so both classes are populated for 1 <= k < n_bins)."""
    return below1 / below0, (total1 - below1) / (total0 - below0)


def _row_class_means(c0: np.ndarray, c1: np.ndarray, k: int) -> tuple[float, float]:
    """:func:`_class_means` at ``k`` of one window's cumulative sums."""
    return _class_means(c0[k], c1[k], c0[-1], c1[-1])


def _fields(lo: Any, width: Any, k: Any, below0: Any, below1: Any, total0: Any, total1: Any) -> tuple[Any, ...]:
    """A :class:`Threshold`'s value, class means and bright fraction (grey levels of the window from ``lo`` in bins
    of ``width``) at the bin ``k`` the iteration settled on, from the cumulative sums there (:func:`_class_means`);
    numbers or arrays alike."""
    m_dark, m_bright = _class_means(below0, below1, total0, total1)
    return lo + k * width, lo + (m_dark + 0.5) * width, lo + (m_bright + 0.5) * width, (total0 - below0) / total0


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


@dataclass(frozen=True, eq=False)
class Thresholds:
    """:func:`optimum_thresholds` of several windows: per window, whether it has one (``found``) and the fields of
    :class:`Threshold` (NaN, and 0 iterations, where it has none)."""

    found: np.ndarray
    value: np.ndarray
    mean_dark: np.ndarray
    mean_bright: np.ndarray
    bright_fraction: np.ndarray
    iterations: np.ndarray

    def set(self, i: int, t: Threshold) -> None:
        """Window ``i``'s fields from its own :class:`Threshold`."""
        self.found[i], self.iterations[i] = True, t.iterations
        self.value[i], self.mean_dark[i], self.mean_bright[i] = t.value, t.mean_dark, t.mean_bright
        self.bright_fraction[i] = t.bright_fraction

    def threshold(self, i: int) -> Threshold | None:
        """Window ``i``'s :class:`Threshold` (None where it has none), as :func:`optimum_threshold` returns it."""
        if not self.found[i]:
            return None
        return Threshold(value=float(self.value[i]), mean_dark=float(self.mean_dark[i]),
                         mean_bright=float(self.mean_bright[i]), bright_fraction=float(self.bright_fraction[i]),
                         iterations=int(self.iterations[i]))


def optimum_thresholds(windows: np.ndarray, n_bins: int = N_BINS, max_iterations: int = MAX_ITERATIONS,
                       min_contrast: float = MIN_CONTRAST) -> Thresholds:
    """:func:`optimum_threshold` of each row of ``windows`` (``(n, pixels)``) at once: each row's histogram,
    cumulative sums and Reddi iteration (:func:`_reddi_iteration`'s steps, its cycle rule included) are the same
    operations on the same numbers, so the same thresholds, to the bit (tests compare them on some 12 000
    windows). Several times faster than one call per window for a few dozen windows; a row with a value that is
    not finite (:func:`optimum_threshold` leaves it out), and every row of a call with :data:`STRAGGLERS` rows or
    fewer, is thresholded alone; rows are taken :data:`BLOCK_ROWS` at a time (the tables of a block are a few
    tens of MB).

    Examples
    --------
    >>> t = optimum_thresholds(np.array([[0.1, 0.1, 0.9, 0.9], [0.5, 0.5, 0.5, 0.5]]))
    >>> t.found.tolist(), round(float(t.value[0]), 3)
    ([True, False], 0.5)
    """
    v = np.asarray(windows, dtype=np.float64)
    n = len(v)
    out = Thresholds(np.zeros(n, bool), np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan),
                     np.full(n, np.nan), np.zeros(n, np.int64))
    finite = np.isfinite(v).all(axis=1)
    alone = np.flatnonzero(~finite) if finite.sum() > STRAGGLERS else np.arange(n)
    for i in alone.tolist():
        got = optimum_threshold(v[i], n_bins, max_iterations, min_contrast)
        if got is not None:
            out.set(i, got)
    if len(alone) < n:
        rows = np.flatnonzero(finite)
        for b in range(0, rows.size, BLOCK_ROWS):
            _block_thresholds(v, rows[b:b + BLOCK_ROWS], n_bins, max_iterations, min_contrast, out)
    return out


BLOCK_ROWS = 4096
"""Rows of :func:`optimum_thresholds` iterated together (five tables of ``n_bins + 1`` values per row)."""


def _block_thresholds(v: np.ndarray, rows: np.ndarray, n_bins: int, max_iterations: int, min_contrast: float,
                      out: Thresholds) -> None:
    """:func:`optimum_thresholds` of the ``rows`` of ``v`` (every value finite), written into ``out``."""
    size = v.shape[1]
    lo, hi = v[rows].min(axis=1, initial=np.inf), v[rows].max(axis=1, initial=-np.inf)
    keep = (hi - lo >= min_contrast) & (size >= 2)
    rows, lo, width = rows[keep], lo[keep], (hi[keep] - lo[keep]) / n_bins
    c0, c1 = _cumulative_sums(v[rows], lo, width, n_bins)
    k, iterations = _reddi_iterations(c0, c1, n_bins, max_iterations)
    done = iterations > 0
    rows, k, iterations, c0, c1, lo, width = (a[done] for a in (rows, k, iterations, c0, c1, lo, width))
    at = np.arange(rows.size)
    out.found[rows], out.iterations[rows] = True, iterations
    out.value[rows], out.mean_dark[rows], out.mean_bright[rows], out.bright_fraction[rows] = _fields(
        lo, width, k, c0[at, k], c1[at, k], c0[:, -1], c1[:, -1])


STRAGGLERS = 4
"""When this few windows of :func:`optimum_thresholds` are still iterating, each is finished alone
(:func:`_reddi_iteration` from its start: the same steps), not by whole-array steps for a handful of rows."""


def _reddi_iterations(c0: np.ndarray, c1: np.ndarray, n_bins: int, max_iterations: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_reddi_iteration` for every row of the cumulative sums ``c0``, ``c1`` (:func:`optimum_threshold`'s,
    one window per row) at once: (k, iterations), 0 iterations where it gave None. Every k's step
    e = (m_dark(k) + m_bright(k)) / 2 + 0.5 - k is computed first, for the whole table (the same operations as
    one k's), so that an iteration gathers one value per row."""
    m, width = c0.shape
    with np.errstate(divide="ignore", invalid="ignore"):       # k = 0 and n_bins leave a class empty: never visited
        m_dark, m_bright = _class_means(c0, c1, c0[:, -1:], c1[:, -1:])
        error = ((m_dark + m_bright) / 2.0 + 0.5 - np.arange(width)).ravel()
    base = width * np.arange(m)
    k = np.full(m, n_bins // 2, np.int64)
    found_k, found_it = np.zeros(m, np.int64), np.zeros(m, np.int64)
    visited = np.full(m * width, np.inf)      # |e| at each k visited, and the iteration it was visited in
    when = np.zeros(m * width, np.int64)
    live = np.arange(m)
    for it in range(1, max_iterations + 1):
        if live.size <= STRAGGLERS:
            break
        at = base[live] + k[live]
        e = error.take(at)
        settled = np.abs(e) < 0.5
        found_k[live[settled]], found_it[live[settled]] = k[live[settled]], it
        go = ~settled
        live, at, e = live[go], at[go], e[go]
        visited[at], when[at] = np.abs(e), it
        k_next = np.clip(np.rint(k[live] + e), 1, n_bins - 1).astype(np.int64)
        cycle = np.isfinite(visited.take(base[live] + k_next))
        for r in live[cycle].tolist():
            found_k[r], found_it[r] = _closest(visited[base[r]:base[r] + width], when[base[r]:base[r] + width]), it
        live = live[~cycle]
        k[live] = k_next[~cycle]
    else:
        live = live[:0]                     # max_iterations done: the rest have none
    for r in live.tolist():
        got = _reddi_iteration(functools.partial(_row_class_means, c0[r], c1[r]), n_bins, max_iterations)
        if got is not None:
            found_k[r], found_it[r] = got
    return found_k, found_it


def _closest(visited: np.ndarray, when: np.ndarray) -> int:
    """The cycle rule of :func:`_reddi_iteration` for one window: the k visited whose |e| came closest to the
    condition (``visited``, inf where not visited), of equals the first visited (``when``: the iteration), as the
    minimum of a dict in insertion order gives it."""
    closest = np.flatnonzero(visited == visited.min())
    return int(closest[np.argmin(when[closest])])


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
    at least ``min_class`` pixels, means at least ``min_sep`` apart); NaN for the other tiles.

    The tiles of one shape (the whole ones; those of the last row, of the last column, the corner) are thresholded
    together (:func:`optimum_thresholds`: the thresholds :func:`optimum_threshold` gives each). A tile's classes are
    its pixels at and above the threshold (compared in ``w``'s type) and below it; their means are compared in
    float64, and in ``w``'s own arithmetic, as one tile's ``mean()`` gives them, where the two could disagree
    (within :data:`MEAN_GUARD` of ``min_sep``)."""
    h, wd = w.shape
    ny, nx = -(-h // region), -(-wd // region)
    t = np.full((ny, nx), np.nan)
    for (i0, ni, th), (j0, nj, tw) in itertools.product(_tile_bands(h, region), _tile_bands(wd, region)):
        block = w[i0 * region:i0 * region + ni * th, j0 * region:j0 * region + nj * tw]
        tiles = block.reshape(ni, th, nj, tw).transpose(0, 2, 1, 3).reshape(ni * nj, th * tw)
        t[i0:i0 + ni, j0:j0 + nj] = _bimodal(tiles, min_sep, min_contrast, min_class).reshape(ni, nj)
    return t


MEAN_GUARD = 1e-4
"""Where the difference of a tile's class means in float64 lies within this fraction of its largest grey level of
``min_sep``, :func:`tile_thresholds` takes it as ``mean()`` gives it in the tile's own type (float32 rounding of
sums of at most a few hundred terms lies far within it)."""


def _tile_bands(n: int, region: int) -> list[tuple[int, int, int]]:
    """The tiles along an axis of ``n`` px by size: (first tile, number of tiles, their size)."""
    bands = [(0, n // region, region)] if n >= region else []
    return bands + ([(n // region, 1, n % region)] if n % region else [])


def _bimodal(tiles: np.ndarray, min_sep: float, min_contrast: float, min_class: int) -> np.ndarray:
    """:func:`tile_thresholds` on tiles of one shape, one per row of ``tiles``: the threshold, or NaN."""
    out = np.full(len(tiles), np.nan)
    # one tile at a time: where a pixel has no finite value (an infinite one makes the float64 sums below nan, the
    # tile's own mean infinite), where the tiles' type is narrower than float32 (its means round beyond
    # MEAN_GUARD), and a shape of STRAGGLERS tiles or fewer (the edge tiles of a small window: faster alone)
    plain = np.isfinite(tiles).all(axis=1) & (tiles.dtype.kind != "f" or tiles.dtype.itemsize >= 4)
    plain &= len(tiles) > STRAGGLERS
    for i in np.flatnonzero(~plain).tolist():
        out[i] = _bimodal_tile(tiles[i], min_sep, min_contrast, min_class)
    rows = np.flatnonzero(plain)
    if not rows.size:
        return out
    found = optimum_thresholds(tiles[rows], min_contrast=min_contrast)
    rows, value = rows[found.found], found.value[found.found]
    sub = tiles[rows]
    cut = value.astype(sub.dtype) if sub.dtype.kind == "f" else value   # as ``tile >= threshold`` compares
    bright = sub >= cut[:, None]
    nb = bright.sum(axis=1)
    enough = (nb >= min_class) & (sub.shape[1] - nb >= min_class)
    rows, value, sub, bright, nb = rows[enough], value[enough], sub[enough], bright[enough], nb[enough]
    g = sub.astype(np.float64)
    sum_bright = np.where(bright, g, 0.0).sum(axis=1)
    diff = sum_bright / nb - (g.sum(axis=1) - sum_bright) / (sub.shape[1] - nb)
    keep = diff >= min_sep
    close = np.abs(diff - min_sep) <= MEAN_GUARD * np.maximum(np.abs(g).max(axis=1), 1.0)
    for i in np.flatnonzero(close).tolist():      # the tile decides alone, its means in its own arithmetic
        keep[i] = np.isfinite(_bimodal_tile(sub[i], min_sep, min_contrast, min_class))
    out[rows[keep]] = value[keep]
    return out


def _bimodal_tile(tile: np.ndarray, min_sep: float, min_contrast: float, min_class: int) -> float:
    """:func:`tile_thresholds` on one tile (its pixels in any order): the threshold, or NaN."""
    th = optimum_threshold(tile, min_contrast=min_contrast)
    if th is None:
        return float("nan")
    bright = tile >= th.value
    nb = int(bright.sum())
    if nb < min_class or tile.size - nb < min_class:
        return float("nan")
    return th.value if float(tile[bright].mean() - tile[~bright].mean()) >= min_sep else float("nan")


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
