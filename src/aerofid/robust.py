"""Robust statistics shared by every layer (the lowest module of the package: it imports only numpy).

The medians here are numpy's (``np.median``), to the bit. Of a window's 40 000-80 000 grey levels or differences
(every detector takes several) they are selected in linear time by :func:`_kth`: a histogram of the values finds the
bin that holds the wanted order statistic, and only that bin's values are looked at again. Neither ``np.sort`` nor
``np.partition`` is quick on every processor: on one machine numpy's vectorised sort took a third to a half of the
time of its selection, on another 3-5 times as long (1.4 ms against 0.4 ms for 40 000 doubles); the histogram
costs a few passes over the values on both.
"""

from __future__ import annotations

import math
from typing import Any, overload

import numpy as np

MAD_TO_SIGMA = 1.4826
"""Median absolute deviation -> standard deviation of a Gaussian."""


@overload
def median(values: np.ndarray) -> np.floating[Any]: ...


@overload
def median(values: np.ndarray, axis: int) -> np.ndarray: ...


def median(values: np.ndarray, axis: int | None = None) -> np.floating[Any] | np.ndarray:
    """``np.median(values, axis=axis)``: the same values and floating type (float32 values give
    float32 medians, integers float64 ones; nan where a value is nan or there are none; the middle values averaged as
    numpy's mean averages them: from +0.0, float16 in float32). ``axis`` None (or a 1-D ``values``): the median of all
    the values, a scalar, selected by :func:`_kth`; along an axis, from a sort.

    Examples
    --------
    >>> float(median(np.array([3.0, 1.0, 2.0, 10.0])))
    2.5
    >>> median(np.array([[3.0, 1.0, 2.0], [4.0, np.nan, 0.0]]), axis=1).tolist()
    [2.0, nan]
    """
    if axis is None:
        return _median_of(_floating(values))
    s = np.sort(np.asarray(values), axis=axis)
    if not np.issubdtype(s.dtype, np.floating):
        s = s.astype(np.float64)
    s = np.moveaxis(s, axis, -1)
    n, nan = s.shape[-1], s.dtype.type(np.nan)
    if n == 0:
        return np.full(s.shape[:-1], nan)
    k = n // 2
    middle = _mean_of_middle((s[..., k],) if n % 2 else (s[..., k - 1], s[..., k]), s.dtype)
    return np.where(np.isnan(s[..., -1]), nan, middle)[()]


def robust_std(values: np.ndarray) -> float:
    """MAD_TO_SIGMA x the median absolute deviation of ``values`` (0 for no values).

    Equal to ``MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))`` in float64 (both medians selected by
    :func:`_kth`).

    Examples
    --------
    >>> robust_std(np.array([1.0, 2.0, 3.0, 4.0, 100.0]))
    1.4826
    """
    v = np.asarray(values, np.float64).ravel()
    if v.size == 0:
        return 0.0
    m = float(_median_of(v))
    if np.isnan(m):
        return float("nan")
    deviations = v - m
    return float(MAD_TO_SIGMA * _median_of(np.abs(deviations, out=deviations)))


def difference_noise_sigma(window: np.ndarray) -> float:
    """Robust estimate of the window's white-noise standard deviation: the robust std of the horizontal
    and vertical first differences divided by sqrt(2) (edges are a minority of differences, so the MAD
    ignores them). Where it holds and where it reads low (correlated noise): docs/noise.md."""
    w = np.asarray(window, np.float64)
    d = np.concatenate([np.diff(w, axis=0).ravel(), np.diff(w, axis=1).ravel()])
    return robust_std(d) / np.sqrt(2.0)


def percentile(values: np.ndarray, q: float) -> float:
    """``float(np.percentile(values, q))`` (numpy's default, linear interpolation) for a Python number ``q`` in [0,
    100] and values that are not empty, the same value to the bit: for floating values the same selection (numpy's
    ``partition`` of the flattened values at the same indices: it places equal values, e.g. zeros of either sign,
    as numpy's own call does), the neighbours' weight, the interpolation from the nearer one, in the values' type;
    other values go to ``np.percentile`` itself. numpy's own call spends about 0.1 ms on a few hundred values in its
    generality (this one runs in every least-squares fit's start and in every refinement step of ``lines``).

    Examples
    --------
    >>> percentile(np.array([4.0, 1.0, 3.0, 2.0]), 25), percentile(np.array([4.0, 1.0, 3.0, 2.0]), 90)
    (1.75, 3.7)
    """
    got = _neighbours(values, (q,))
    if got is None:
        return float(np.percentile(values, q))
    if got[1] is None:
        return float("nan")
    (gamma, a, b), = got[1]
    return float(_lerp(a, b, b - a, gamma))


def percentiles(values: np.ndarray, qs: tuple[float, ...]) -> tuple[float, ...]:
    """``np.percentile(values, qs)`` for a tuple of Python numbers ``qs``, to the bit, as :func:`percentile` does for
    one: numpy's one ``partition`` at every index the percentiles need, then each interpolated in float64 (numpy's
    weights of an array of percentiles are float64: the neighbours' difference is taken in the values' type, the rest
    in float64, where :func:`percentile` stays in the values' type). Without ``np.percentile``'s ``np.unique``, whose
    first call imports ``numpy.ma`` (10 ms of a command's start-up).

    Examples
    --------
    >>> percentiles(np.array([4.0, 1.0, 3.0, 2.0]), (25, 90))
    (1.75, 3.7)
    """
    got = _neighbours(values, qs)
    if got is None or got[0].itemsize > 8:      # other types; long doubles, which numpy interpolates in their own
        return tuple(float(v) for v in np.percentile(values, qs))       # precision
    if got[1] is None:
        return tuple(float("nan") for _ in qs)
    return tuple(_lerp(float(a), float(b), float(b - a), gamma) for gamma, a, b in got[1])


def _lerp(a: Any, b: Any, diff: Any, gamma: float) -> Any:
    """numpy's interpolation between neighbours ``a`` and ``b`` (``diff``: b - a) with weight ``gamma`` on ``b``: from
    the nearer one, in the operands' types."""
    return b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma


def _neighbours(values: np.ndarray, qs: tuple[float, ...]
                ) -> tuple[np.dtype, list[tuple[float, Any, Any]] | None] | None:
    """For :func:`percentile` and :func:`percentiles`: floating ``values`` partitioned as numpy's percentiles ``qs``
    partition them, and per percentile the weight of its upper neighbour and its two neighbours, in the values' type
    (below the end: the last value twice, its weight counted from index -1, as numpy does); no list where a value is
    nan (every percentile is nan); None for values of another type (numpy's own call answers). The values' type
    comes first."""
    for q in qs:
        if not 0 <= q <= 100:
            raise ValueError(f"percentile {q!r} is not in [0, 100]")
    arr = np.asarray(values)
    if not np.issubdtype(arr.dtype, np.floating):
        return None
    arr = arr.flatten()
    n = arr.size
    if n == 0:
        raise ValueError("percentile of no values")
    picks = []
    for q in qs:
        virtual = (n - 1) * (q / 100)
        picks.append((virtual, -1 if virtual >= n - 1 else math.floor(virtual)))
    # numpy's indices: the first and last values and each percentile's neighbours, as np.unique sorts them
    arr.partition(sorted({0, -1, *(i for _, below in picks for i in (below, below + 1 if below >= 0 else -1))}))
    if np.isnan(arr[-1]):
        return arr.dtype, None
    return arr.dtype, [(float(virtual - below), arr[below], arr[below + 1] if below >= 0 else arr[-1])
                       for virtual, below in picks]


SELECT_FROM = 2048
"""Fewer values than this are sorted by :func:`_kth` (the histogram's fixed cost would exceed a sort's)."""
SELECT_BINS = 1024
"""Bins of :func:`_kth`'s histogram between the least and the greatest value."""
SELECT_DEPTH = 3
"""Histograms :func:`_kth` nests (each within the bin of the one before) before it sorts what is left."""


def _floating(values: np.ndarray) -> np.ndarray:
    """``values`` flattened, floating (other types as float64, as numpy's median takes them)."""
    v = np.asarray(values).ravel()
    return v if np.issubdtype(v.dtype, np.floating) else v.astype(np.float64)


def _median_of(v: np.ndarray) -> np.floating[Any]:
    """The median of 1-D floating values, in their type (nan where a value is nan or there are none), as numpy's
    mean of the middle one or two: from +0.0 (never -0.0), float16 in float32."""
    n = v.size
    if n == 0:
        return v.dtype.type(np.nan)
    k = n // 2
    picked = _kth(v, (k,) if n % 2 else (k - 1, k))
    if picked is None:
        return v.dtype.type(np.nan)
    return _mean_of_middle(tuple(picked), v.dtype)


def _mean_of_middle(middle: tuple[Any, ...], dtype: np.dtype) -> Any:
    """The mean of the middle one or two values (scalars, or arrays of one per median) as ``np.median`` takes it,
    numpy's mean: summed from +0.0 (never -0.0), float16 in float32; in ``dtype``."""
    t = np.float32 if dtype == np.float16 else dtype.type
    total = t(0)
    for m in middle:
        total = total + t(m)
    return dtype.type(total / t(len(middle)))


def _kth(v: np.ndarray, ks: tuple[int, ...], depth: int = 0) -> list[Any] | None:
    """The ``ks``-th smallest (from 0) of the 1-D floating values ``v``, exactly, in their type; None where a value is
    nan.

    The values are binned by ``floor((v - min) / (max - min) x (SELECT_BINS - 1))``, in float64: each of these steps
    keeps the order of the values (a correctly rounded operation is monotonic), so every value of a lower bin is at most
    every value of a higher one, and the k-th smallest is the (k - values before its bin)-th of its bin's values alone,
    found the same way (a bin of equal values answers at once: a clean scan's differences are mostly 0, on which
    ``np.partition`` took 8 ms for 100 000 values; a bin that holds most of its level's values is first tried for one
    value holding the ranks wanted, :func:`_tied`). Below ``SELECT_FROM`` values, ``SELECT_DEPTH`` bins down, or where
    float64 cannot bin them (infinite values, a span that overflows, or underflows its bins' scale, or that float64
    does not resolve: long doubles), the values are sorted (numpy's sort, unlike its partition, is quick on ties).
    """
    if v.size < SELECT_FROM:
        s = np.sort(v)
        return None if np.isnan(s[-1]) else [s[k] for k in ks]
    lo, hi = v.min(), v.max()
    if np.isnan(hi):
        return None
    if lo == hi:
        return [lo for _ in ks]
    span = float(hi) - float(lo)
    scale = (SELECT_BINS - 1) / span if 0 < span < math.inf else math.inf
    if not scale < math.inf or depth == SELECT_DEPTH:
        s = np.sort(v)
        return [s[k] for k in ks]
    at = np.subtract(v, float(lo), dtype=np.float64)
    at *= scale
    bins = at.astype(np.intp)
    counts = np.bincount(bins)
    before = np.cumsum(counts) - counts
    where = [int(np.searchsorted(before, k, side="right")) - 1 for k in ks]
    picked: dict[tuple[int, int], Any] = {}
    for b in set(where):            # the median's two middle values mostly share a bin: one look at it
        ranks = tuple(k - int(before[b]) for k, at_b in zip(ks, where, strict=True) if at_b == b)
        inside = v[bins == b]
        # a bin that holds most of the values: ties (a clean scan's zeros) or a far value that took the span
        got = _tied(inside, ranks) if 2 * inside.size > v.size else None
        got = got or _kth(inside, ranks, depth + 1)
        assert got is not None      # no nan here
        picked.update(zip(((b, r) for r in ranks), got, strict=True))
    return [picked[b, k - int(before[b])] for k, b in zip(ks, where, strict=True)]


def _tied(v: np.ndarray, ranks: tuple[int, ...]) -> list[Any] | None:
    """The ``ranks``-th smallest of the values ``v`` where one value is all of them, else None: the middle value of
    ``v`` as they lie (where one value fills most of them, likely it) and the values below it and equal to it
    counted."""
    c = v[v.size // 2]
    below = int(np.count_nonzero(v < c))
    if all(below <= r for r in ranks):
        equal = int(np.count_nonzero(v == c))
        if all(r < below + equal for r in ranks):
            return [c for _ in ranks]
    return None


__all__ = ["MAD_TO_SIGMA", "difference_noise_sigma", "median", "percentile", "percentiles", "robust_std"]
