"""Estimators of the grey-level noise of a window, robust to the mark's edges.

Two estimators, with different names because they measure different things once the noise is not white:

- :func:`~aerofid.robust.difference_noise_sigma` (first differences, in :mod:`aerofid.robust`: the colour policy
  uses it too): the robust std of horizontal and vertical first
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

What correlated noise does to a least-squares fit's covariance, :func:`correlated_covariance` measures from the
fit's own residuals.
"""

from __future__ import annotations

import cv2
import numpy as np

from aerofid.robust import median


def laplacian_noise_sigma(img: np.ndarray) -> float:
    """Robust standard deviation of white noise in ``img`` (Immerkaer 1996: the 3x3 Laplacian-difference kernel
    [[1,-2,1],[-2,4,-2],[1,-2,1]] has gain 6 on white noise; the median of its absolute response, /0.6745,
    resists the mark's edges)."""
    k = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
    resp = cv2.filter2D(img.astype(np.float32), -1, k, borderType=cv2.BORDER_REFLECT)[1:-1, 1:-1]
    return float(median(np.abs(resp)) / 0.6745 / 6.0)


CORRELATION_LAG = 4
"""Largest lag (px, per axis) at which the residuals' correlation enters :func:`correlated_covariance`: film grain
(``synth.add_grain``, white noise smoothed over 1.2 px) still correlates 0.06 at 4 px, white noise blurred by
0.7 px 0.0002."""


def correlated_covariance(px: np.ndarray, py: np.ndarray, v: np.ndarray, rows: np.ndarray, white: np.ndarray,
                          lag: int = CORRELATION_LAG) -> np.ndarray:
    """The covariance of estimates linear in the pixels' grey values, ``x = rows @ g`` (``rows`` k x n, e.g. a
    least-squares fit's ``(J'J)^-1 J'`` for the parameters wanted), when the noise is stationary but not white:

        Cov(x) = sum_h r(h) sum_i rows_i rows_(i+h)'

    over the lags ``h`` with ``|h_x|, |h_y| <= lag``, ``r(h)`` the autocovariance of the fit's residuals ``v``
    (less their mean) at lag ``h``: the mean of ``v_i v_(i+h)`` over the pairs of pixels both fitted, averaged with
    its mirror image, ``r(h_x, h_y) = r(-h_x, h_y)`` (grain and a scanner's blur correlate alike along either
    diagonal, and a mark symmetric about the pixel axes keeps uncorrelated axes). This is the heteroscedasticity
    and autocorrelation consistent ("sandwich") estimator in two dimensions, with a flat window of lags. Its lag-0
    term is the white-noise covariance ``sigma0^2 (J'J)^-1`` (``white``, k x k, given as the fit computed it); the
    other lags add what the noise's correlation adds. Beyond the seeds, which fit with white-noise covariances:
    film grain, scanner blur and JPEG correlate neighbouring pixels, and a white-noise sigma is then several times
    too small (docs/noise.md).

    The other lags' sum may narrow the covariance along some direction: for white noise it is about 0, of either
    sign, and a flat window of lags (unlike Newey & West's (1987) Bartlett weights) does not keep it positive. Only
    its positive part (its eigenvalues clipped at 0) is added, so no sigma is smaller than the white-noise one.
    Residuals estimate the noise's correlation a little low: on a 21 x 21 px patch of noise smoothed over 0.7 px
    with 4 parameters fitted, the sigma was 0.85 of the true one (docs/noise.md).

    Parameters
    ----------
    px, py : ndarray
        The fitted pixels' integer coordinates (n), each pixel once.
    v : ndarray
        The fit's (weighted) residuals (n).
    rows : ndarray
        k x n: each estimate's weights on the pixels' values.
    white : ndarray
        k x k white-noise covariance.
    lag : int
        :data:`CORRELATION_LAG`.
    """
    ix, iy = (px - px.min()).astype(np.intp), (py - py.min()).astype(np.intp)
    h, w = int(iy.max()) + 1, int(ix.max()) + 1
    k = rows.shape[0]
    # sum_i X_i X_(i+h) for every lag h at once: X (zero padded by ``lag``) correlated with itself
    grids = np.zeros((2, h + 2 * lag, w + 2 * lag), np.float32)
    grids[0, iy + lag, ix + lag], grids[1, iy + lag, ix + lag] = v - np.mean(v), 1.0
    auto = [cv2.matchTemplate(g, g[lag:lag + h, lag:lag + w], cv2.TM_CCORR) for g in grids]
    pairs = np.rint(auto[1])                                    # fitted with fitted: the pairs at each lag
    r = np.where(pairs > 0.5, auto[0] / np.maximum(pairs, 1.0), 0.0)
    r[lag, lag] = 0.0                                 # lag 0 is the white-noise term, given
    r = 0.5 * (r + r[:, ::-1])                        # mirror-symmetric: r(h_x, h_y) = r(-h_x, h_y)
    # sum_h r(h) sum_i a_i a_(i+h)' = sum_i a_i b_i' with b = the rows correlated with the kernel r
    a = np.zeros((k, h, w), np.float32)
    a[:, iy, ix] = rows
    kernel = r.astype(np.float32)
    b = np.stack([cv2.filter2D(a_k, -1, kernel, borderType=cv2.BORDER_CONSTANT) for a_k in a])
    extra = np.einsum("kij,lij->kl", a.astype(np.float64), b.astype(np.float64))
    values, vectors = np.linalg.eigh(0.5 * (extra + extra.T))
    if not np.all(np.isfinite(values)) or values.max() <= 0:
        return white
    return white + (vectors * np.maximum(values, 0.0)) @ vectors.T


__all__ = ["CORRELATION_LAG", "correlated_covariance", "laplacian_noise_sigma"]
