"""The covariance of a least-squares estimate under correlated noise (:func:`correlated_covariance`), against the
spread of the estimate over noise realisations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from aerofid.detect.noise import correlated_covariance

SIDE = 40
TRIALS = 300


def _estimates(smooth_px: float) -> tuple[float, np.ndarray]:
    """The mean and the x-slope of a SIDE x SIDE window (least squares on 1, x) over TRIALS realisations of unit
    noise smoothed over ``smooth_px`` (0: white): their standard deviations and the median of the sigmas
    :func:`correlated_covariance` gives from each realisation's residuals."""
    rng = np.random.default_rng(1)
    yy, xx = np.mgrid[0:SIDE, 0:SIDE]
    px, py = xx.ravel().astype(float), yy.ravel().astype(float)
    J = np.c_[np.ones(px.size), px - px.mean()]
    Q = np.linalg.inv(J.T @ J)
    rows = Q @ J.T
    got, sig = [], []
    for _ in range(TRIALS):
        noise = rng.normal(0.0, 1.0, (SIDE + 20, SIDE + 20))
        if smooth_px:
            noise = ndimage.gaussian_filter(noise, smooth_px)
        g = noise[10:-10, 10:-10].ravel()
        est = rows @ g
        v = g - J @ est
        white = (v @ v / (px.size - 2)) * Q
        got.append(est)
        sig.append(np.sqrt(np.diag(correlated_covariance(px, py, v, rows, white))))
    return np.std(got, axis=0, ddof=1), np.median(sig, axis=0)


@pytest.mark.parametrize("smooth_px", [0.0, 0.7, 1.2])
def test_the_sigmas_match_the_spread_of_the_estimates_under_white_and_correlated_noise(smooth_px):
    spread, sigma = _estimates(smooth_px)
    np.testing.assert_allclose(sigma / spread, 1.0, atol=0.2)


def test_white_noise_keeps_the_white_covariance_and_a_narrowing_sum_is_refused():
    px, py = (a.ravel().astype(float) for a in np.mgrid[0:10, 0:10][::-1])
    rows = np.ones((1, px.size)) / px.size
    white = np.array([[0.01]])
    alternating = np.where((px + py) % 2 == 0, 1.0, -1.0)      # neighbours anticorrelate: the lags would narrow it
    assert correlated_covariance(px, py, alternating, rows, white) is white
    smooth = np.sin(px / 3.0)                                      # neighbours correlate: widened
    assert correlated_covariance(px, py, smooth, rows, white)[0, 0] > white[0, 0]
