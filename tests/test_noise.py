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


def test_no_sigma_is_smaller_than_the_white_noise_one():
    """The other lags' sum is about 0 for white noise, of either sign: only its positive part widens the white
    covariance (it narrowed one axis of 9 fits in 30 in white noise: a review)."""
    px, py = (a.ravel().astype(float) for a in np.mgrid[0:20, 0:20][::-1])
    rows = np.vstack([np.ones(px.size), px - px.mean()]) / px.size
    white = np.diag([1e-4, 2e-6])
    alternating = np.where((px + py) % 2 == 0, 1.0, -1.0)      # neighbours anticorrelate: every lag would narrow
    assert correlated_covariance(px, py, alternating, rows, white) is white
    rng = np.random.default_rng(3)
    for _ in range(50):
        cov = correlated_covariance(px, py, rng.normal(0.0, 0.01, px.size), rows, white)
        assert np.all(np.linalg.eigvalsh(cov - white) >= -1e-15)
    smooth = np.sin(px / 3.0)                                      # neighbours correlate: widened
    assert correlated_covariance(px, py, smooth, rows, white)[0, 0] > white[0, 0]
