"""Robust statistics shared by every layer (the lowest module of the package: it imports only numpy)."""

from __future__ import annotations

import numpy as np

MAD_TO_SIGMA = 1.4826
"""Median absolute deviation -> standard deviation of a Gaussian."""


def robust_std(values: np.ndarray) -> float:
    """MAD_TO_SIGMA x the median absolute deviation of ``values`` (0 for no values).

    Examples
    --------
    >>> robust_std(np.array([1.0, 2.0, 3.0, 4.0, 100.0]))
    1.4826
    """
    v = np.asarray(values, np.float64).ravel()
    if v.size == 0:
        return 0.0
    return float(MAD_TO_SIGMA * np.median(np.abs(v - np.median(v))))


__all__ = ["MAD_TO_SIGMA", "robust_std"]
