"""The F distribution's upper quantiles, the critical values of the adjustments' F tests (a blunder's leave-one-out
test, the film's lie): what ``scipy.stats.f.isf`` and ``scipy.special.fdtri`` compute, in plain Python. Importing
scipy.special cost a cold ``aerofid orient`` about half a second, as much as the rest of the frame's adjustment
and layout search together; these few numbers need none of it.

The upper tail of F with ``dfn`` and ``dfd`` degrees of freedom at ``f`` is the regularized incomplete beta
function ``I_y(dfd / 2, dfn / 2)`` at ``y = dfd / (dfd + dfn f)`` (Abramowitz & Stegun 26.6.2), evaluated by its
continued fraction (A&S 26.5.8; modified Lentz, Press et al., Numerical Recipes, 3rd ed., section 6.4); the quantile
is the root of ``I_y = alpha`` by Newton's method on the logarithm of ``y`` or of ``1 - y``, kept inside a bisection
bracket."""

from __future__ import annotations

import functools
import math

from aerofid.errors import AerofidInputError

TINY = 1e-300
"""What the modified Lentz method puts in place of a zero denominator."""
EPS = 1e-16
"""The continued fraction stops when a step changes it by less than this, relatively."""
MAX_TERMS = 10_000
"""Most terms of the continued fraction (it needs O(sqrt(max(a, b))) of them)."""
MAX_STEPS = 200
"""Most Newton or bisection steps of the quantile (a few Newton steps settle it; halving the bracket of its
logarithm, 60 at most)."""
SETTLED = 1e-15
"""The quantile's root is settled when a step moves its logarithm by less than this."""
SMALLEST = 1e-300
"""The least ``y`` (or ``1 - y``) the root is sought above: an F quantile beyond 1e300 is infinite here."""


def _log_beta(a: float, b: float) -> float:
    return math.lgamma(a) + math.lgamma(b) - math.lgamma(a + b)


def _continued_fraction(a: float, b: float, x: float) -> float:
    """A&S 26.5.8's continued fraction of ``I_x(a, b)`` (without its prefactor), by the modified Lentz method."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > TINY else TINY)
    h = d
    for m in range(1, MAX_TERMS + 1):
        m2 = 2 * m
        for num in (m * (b - m) * x / ((qam + m2) * (a + m2)), -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):
            d = 1.0 + num * d
            d = 1.0 / (d if abs(d) > TINY else TINY)
            c = 1.0 + num / c
            c = c if abs(c) > TINY else TINY
            step = d * c
            h *= step
        if abs(step - 1.0) < EPS:
            break
    return h


def regularized_beta(a: float, b: float, x: float, xc: float | None = None) -> float:
    """``I_x(a, b)``, the regularized incomplete beta function (``scipy.special.betainc``), for a, b > 0 and x in
    [0, 1], ``xc`` = 1 - x given where it is known more precisely than ``1 - x`` rounds it (x near 1): the continued
    fraction on whichever side of the mean converges fast.

    >>> round(regularized_beta(2.0, 3.0, 0.4), 12)      # 1 - (1 - x)^4 - 4 x (1 - x)^3
    0.5248
    """
    xc = 1.0 - x if xc is None else xc
    if x <= 0.0:
        return 0.0
    if xc <= 0.0:
        return 1.0
    log_x = math.log(x) if x < 0.5 else math.log1p(-xc)
    log_xc = math.log(xc) if xc < 0.5 else math.log1p(-x)
    front = math.exp(a * log_x + b * log_xc - _log_beta(a, b))
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _continued_fraction(a, b, x) / a
    return 1.0 - front * _continued_fraction(b, a, xc) / b


def _tail_root(a: float, b: float, alpha: float, near_one: bool) -> float:
    """The ``t`` in (0, 1) where the tail ``I_y(a, b)`` is ``alpha``, with ``t = y``, or ``t = 1 - y`` where the root
    lies near y = 1 (``near_one``: ``t`` keeps its own precision, which ``1 - y`` would not). The tail is evaluated
    as the smaller of ``I_y(a, b)`` and ``I_{1-y}(b, a) = 1 - I_y(a, b)`` (``alpha`` above 1/2), which the continued
    fraction gives to its own precision. Newton's method on ``log t``, a step that leaves the bisection bracket
    replaced by halving it, until a step moves ``log t`` by less than :data:`SETTLED`; 0 where the root lies below
    :data:`SMALLEST`."""
    log_beta = _log_beta(a, b)
    upper = alpha <= 0.5

    def excess(t: float) -> float:                      # the tail at t minus alpha's, increasing with y
        y, yc = (1.0 - t, t) if near_one else (t, 1.0 - t)
        return regularized_beta(a, b, y, yc) - alpha if upper else (1.0 - alpha) - regularized_beta(b, a, yc, y)

    sign = -1.0 if near_one else 1.0                    # the tail grows with y, so falls with 1 - y
    lo, hi = math.log(SMALLEST), 0.0                    # the bracket of log t
    if sign * excess(SMALLEST) > 0.0:
        return 0.0
    u = 0.5 * (lo + hi)
    for _ in range(MAX_STEPS):
        t = math.exp(u)
        g = sign * excess(t)
        if g == 0.0:
            return t
        if g > 0.0:
            hi = u
        else:
            lo = u
        y, yc = (1.0 - t, t) if near_one else (t, 1.0 - t)
        slope = t * math.exp((a - 1.0) * math.log(y) + (b - 1.0) * math.log(yc) - log_beta)   # d(excess)/d(log t)
        new = u - g / slope if slope > 0.0 else math.nan
        if not lo < new < hi:                           # outside the bracket (or no slope): halve it
            new = 0.5 * (lo + hi)
        if abs(new - u) < SETTLED:
            return math.exp(new)
        u = new
    raise AerofidInputError(f"the F quantile did not settle (I_y({a}, {b}) = {alpha}): report this")


@functools.lru_cache(maxsize=256)
def f_critical(alpha: float, dfn: float, dfd: float) -> float:
    """The critical value of the F test at significance ``alpha`` (0 < alpha < 1): the ``f`` whose upper tail under
    F(``dfn``, ``dfd``) is ``alpha``, ``scipy.stats.f.isf(alpha, dfn, dfd)`` (within 2e-13 of it relatively for
    degrees of freedom up to 100, 7e-13 at 500: the beta function's log from log-gammas limits it). The tail is
    ``I_y(dfd / 2, dfn / 2)`` at ``y = dfd / (dfd + dfn f)``; where the root lies beyond y = 1/2 it is found as
    ``w = 1 - y``.

    >>> round(f_critical(0.05, 2, 10), 4)
    4.1028
    """
    if not (0.0 < alpha < 1.0 and 0.0 < dfn < math.inf and 0.0 < dfd < math.inf):
        raise AerofidInputError(f"an F test needs a significance between 0 and 1 and positive, finite degrees of "
                                f"freedom, not {alpha}, {dfn} and {dfd}")
    a, b = 0.5 * dfd, 0.5 * dfn
    if regularized_beta(a, b, 0.5) >= alpha:
        y = _tail_root(a, b, alpha, near_one=False)
        return dfd * (1.0 - y) / (dfn * y) if y > 0.0 else math.inf
    w = _tail_root(a, b, alpha, near_one=True)
    return dfd * w / (dfn * (1.0 - w))


__all__ = ["f_critical", "regularized_beta"]
