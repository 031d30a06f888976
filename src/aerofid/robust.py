"""Robust statistics shared by every layer (the lowest module of the package: it imports only numpy).

The medians here are numpy's (``np.median``), computed from one sort instead of ``np.partition``: numpy's
vectorised sort of a window's 40 000-80 000 grey levels or differences takes a third to a half of the time of
its selection, and the absolute deviations' median of :func:`robust_std` is read from the same sorted values
(the k-th smallest of two sorted runs) instead of a second selection.
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
    """``np.median(values, axis=axis)``, from a sort: the same values and floating type (float32 values give
    float32 medians, integers float64 ones; nan where a value is nan or there are none; float16 aside, which numpy
    averages in float32). ``axis`` None (or a 1-D ``values``): the median of all the values, a scalar.

    Examples
    --------
    >>> float(median(np.array([3.0, 1.0, 2.0, 10.0])))
    2.5
    >>> median(np.array([[3.0, 1.0, 2.0], [4.0, np.nan, 0.0]]), axis=1).tolist()
    [2.0, nan]
    """
    s = np.sort(np.asarray(values), axis=axis)
    if not np.issubdtype(s.dtype, np.floating):
        s = s.astype(np.float64)
    if axis is None:
        return _middle(s)
    s = np.moveaxis(s, axis, -1)
    n, nan = s.shape[-1], s.dtype.type(np.nan)
    if n == 0:
        return np.full(s.shape[:-1], nan)
    k = n // 2
    middle = s[..., k] if n % 2 else (s[..., k - 1] + s[..., k]) / s.dtype.type(2)
    return np.where(np.isnan(s[..., -1]), nan, middle)[()]


def robust_std(values: np.ndarray) -> float:
    """MAD_TO_SIGMA x the median absolute deviation of ``values`` (0 for no values).

    Equal to ``MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))`` in float64: the absolute deviations below
    and above the median are two sorted runs of the sorted values, and their median is found by bisection.

    Examples
    --------
    >>> robust_std(np.array([1.0, 2.0, 3.0, 4.0, 100.0]))
    1.4826
    """
    s = np.sort(np.asarray(values, np.float64), axis=None)
    n = s.size
    if n == 0:
        return 0.0
    m = float(_middle(s))
    if np.isnan(m):
        return float("nan")
    half = np.searchsorted(s, m)              # s[:half] < m <= s[half:]
    below = m - s[:half][::-1]                # |s - m| of the values below the median, ascending
    above = s[half:] - m                      # and of those from it up, ascending
    k = n // 2
    hi = _kth_of_two(below, above, k)
    mad = hi if n % 2 else (_kth_of_two(below, above, k - 1) + hi) / 2.0
    return float(MAD_TO_SIGMA * mad)


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


def _middle(s: np.ndarray) -> np.floating[Any]:
    """The median of sorted floating values, in their type (numpy sorts nan last; the median of values with a nan
    is nan)."""
    n = s.size
    if n == 0 or np.isnan(s[-1]):
        return s.dtype.type(np.nan)
    k = n // 2
    return s[k] if n % 2 else (s[k - 1] + s[k]) / s.dtype.type(2)


def _kth_of_two(a: np.ndarray, b: np.ndarray, k: int) -> float:
    """The k-th smallest (from 0) of the union of the ascending arrays ``a`` and ``b``: bisection on how many
    of the k + 1 smallest come from ``a``."""
    lo, hi = max(0, k + 1 - b.size), min(k + 1, a.size)
    while lo < hi:
        i = (lo + hi) // 2
        if b[k - i] > a[i]:                  # a[i] is among the k + 1 smallest: take more of a
            lo = i + 1
        else:
            hi = i
    j = k + 1 - lo
    return float(max(a[lo - 1] if lo > 0 else -np.inf, b[j - 1] if j > 0 else -np.inf))


__all__ = ["MAD_TO_SIGMA", "median", "percentile", "percentiles", "robust_std"]
