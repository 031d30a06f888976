"""The F tests' critical values (:mod:`aerofid.orientation.f_distribution`) against scipy's, which the module spares
a one-frame process importing, and against the closed form of F(2, n); its regularized beta function against
mpmath's."""

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid.errors import AerofidInputError
from aerofid.orientation import f_distribution as fd


@pytest.mark.parametrize("alpha", [0.9999999, 0.9, 0.5, 0.2, 0.05, 0.01, 0.005, 0.001])
def test_the_critical_values_are_scipys(alpha):
    """Every pair of degrees of freedom the adjustments use (2 and up to 40 for a blunder, r and r for the lie) and
    more: within 2e-13 of scipy.special.fdtri up to 100 degrees of freedom, 1e-12 at 150 and 500 (the worst,
    6.6e-13, is F(1, 500); the log of the beta function from log-gammas near 1000 limits it)."""
    import scipy.special
    for dfd, rel in ((np.r_[1:101], 2e-13), (np.r_[150, 500], 1e-12)):
        m, k = (a.ravel() for a in np.meshgrid(np.r_[1:31, 40, 60, 100], dfd, indexing="ij"))
        got = np.array([fd.f_critical(alpha, int(mi), int(ki)) for mi, ki in zip(m, k, strict=True)])
        assert np.all(np.abs(got - scipy.special.fdtri(m, k, 1.0 - alpha)) <= rel * got)


@given(alpha=st.floats(1e-100, 0.5), dfd=st.integers(1, 300))
@settings(max_examples=300, deadline=None)
def test_the_critical_value_of_f_2_n_is_its_closed_form(alpha, dfd):
    """F(2, n)'s upper tail at f is (1 + 2 f / n)^(-n / 2), so its critical value is n / 2 (alpha^(-2 / n) - 1)."""
    exact = dfd / 2 * math.expm1(-2 / dfd * math.log(alpha))
    assert fd.f_critical(alpha, 2, dfd) == (pytest.approx(exact, rel=1e-12) if exact < 1e290 else math.inf)


@given(a=st.floats(0.5, 60), b=st.floats(0.5, 60), x=st.floats(0, 1))
@settings(max_examples=300, deadline=None)
def test_the_regularized_beta_is_exact(a, b, x):
    """Against mpmath's at 30 digits (``scipy.special.betainc`` is 2.8e-9 off at a = b = 1/2, x = 1 - 2^-53, where
    the closed form 1 - (2/pi) asin(sqrt(1 - x)) and this function agree)."""
    with mpmath.workdps(30):
        exact = float(mpmath.betainc(a, b, 0, mpmath.mpf(x), regularized=True))
    assert fd.regularized_beta(a, b, x) == pytest.approx(exact, abs=1e-13)


def test_the_regularized_beta_of_one_half_is_the_arcsine_law_next_to_one():
    """``I_x(1/2, 1/2) = (2/pi) asin(sqrt(x))``: its distance from 1 at x = 1 - 2^-53 is (2/pi) asin(2^-26.5)."""
    x = 1.0 - 2.0 ** -53
    tail = 2.0 / math.pi * math.asin(math.sqrt(2.0 ** -53))
    assert 1.0 - fd.regularized_beta(0.5, 0.5, x) == pytest.approx(tail, rel=1e-7)


@pytest.mark.parametrize("bad", [(0.0, 2, 3), (1.0, 2, 3), (0.05, 0, 3), (0.05, 2, -1), (math.nan, 2, 3),
                                 (0.05, math.inf, 3), (0.05, 2, math.inf), (0.05, 2, math.nan)])
def test_a_critical_value_outside_the_distribution_is_refused(bad):
    with pytest.raises(AerofidInputError, match="positive, finite degrees of freedom"):
        fd.f_critical(*bad)


def test_a_critical_value_beyond_1e300_is_infinite():
    assert fd.f_critical(1e-100, 0.01, 0.01) == math.inf and fd.f_critical(0.05, 3, 0.01) == pytest.approx(9.877e257,
                                                                                                            rel=1e-3)
