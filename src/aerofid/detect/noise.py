"""Estimators of the grey-level noise of a window, robust to the mark's edges.

Two estimators, with different names because they measure different things once the noise is not white:

- :func:`difference_noise_sigma` (first differences): the robust std of horizontal and vertical first
  differences / sqrt(2). Used by ``circles`` (a floor under its gradient-noise estimate), ``lines`` and the
  local dynamic threshold.
- :func:`laplacian_noise_sigma` (Immerkaer 1996): the median response of a 3x3 Laplacian-difference kernel.
  Used by ``symmetry`` and ``auto``.

Where each holds (docs/noise.md, ``python benchmarks/bench_noise.py --n 20 --seed 0``, estimate / true sigma):
on white Gaussian noise both are exact on flat ground (1.00) and the first differences read 4-7 % high with a
mark in the window (the Laplacian 0-2 %). Correlated noise has little power at the highest frequencies, which
the Laplacian kernel sees most, so both read low and the Laplacian much lower: white noise blurred by 0.7 px
0.64-0.69 against 0.26-0.28; JPEG (quality 75) of noise 0.53-0.90 against 0.13-0.43; film grain
(``synth.add_grain``) 0.40-0.43 against 0.04-0.05. Neither is the pixel sigma of correlated noise.
"""

from __future__ import annotations

import cv2
import numpy as np

from aerofid.robust import median, robust_std


def difference_noise_sigma(window: np.ndarray) -> float:
    """Robust estimate of the window's white-noise standard deviation: the robust std of the horizontal
    and vertical first differences divided by sqrt(2) (edges are a minority of differences, so the MAD
    ignores them)."""
    w = np.asarray(window, np.float64)
    d = np.concatenate([np.diff(w, axis=0).ravel(), np.diff(w, axis=1).ravel()])
    return robust_std(d) / np.sqrt(2.0)


def laplacian_noise_sigma(img: np.ndarray) -> float:
    """Robust standard deviation of white noise in ``img`` (Immerkaer 1996: the 3x3 Laplacian-difference kernel
    [[1,-2,1],[-2,4,-2],[1,-2,1]] has gain 6 on white noise; the median of its absolute response, /0.6745,
    resists the mark's edges)."""
    k = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
    resp = cv2.filter2D(img.astype(np.float32), -1, k, borderType=cv2.BORDER_REFLECT)[1:-1, 1:-1]
    return float(median(np.abs(resp)) / 0.6745 / 6.0)


__all__ = ["difference_noise_sigma", "laplacian_noise_sigma"]
