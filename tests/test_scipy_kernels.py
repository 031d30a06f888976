"""scipy's Levenberg-Marquardt and normal distribution function loaded without scipy's packages
(:mod:`aerofid.scipy_kernels`): the answers of ``scipy.optimize.least_squares(method="lm")`` and
``scipy.special.ndtr``, to the bit, with the public functions where the kernels cannot be loaded."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.optimize
import scipy.special

from aerofid import scipy_kernels
from aerofid.detect.hough import cross_fit


def _cross_problem(seed: int, shift: float) -> tuple[object, object, np.ndarray]:
    """Residuals and Jacobian of the blurred-cross model (:func:`aerofid.detect.hough.cross_fit.cross_model`) on a
    noisy synthetic '+' with its centre at a random sub-pixel position, and a start ``shift`` px off it."""
    rng = np.random.default_rng(seed)
    xc, yc = 20.0 + rng.uniform(-0.5, 0.5), 20.0 + rng.uniform(-0.5, 0.5)
    yy, xx = np.mgrid[0:41, 0:41]
    px, py = xx.ravel().astype(float), yy.ravel().astype(float)
    theta = rng.uniform(-0.3, 0.3)
    truth = np.array([xc, yc, theta, theta + np.pi / 2, 30.0, 30.0, 2.0, 0.8, 0.6, 0.2, 0.0, 0.0])
    g = cross_fit.cross_model(truth, px, py, 20.0, 20.0) + rng.normal(0.0, 0.02, px.size)
    start = truth + np.r_[shift, -shift, 0.05, -0.05, -4.0, 3.0, 0.6, 0.3, -0.1, 0.05, 0.0, 0.0]

    def residuals(p: np.ndarray) -> np.ndarray:
        return cross_fit.cross_model(p, px, py, 20.0, 20.0) - g

    def jacobian(p: np.ndarray) -> np.ndarray:
        return cross_fit.cross_model(p, px, py, 20.0, 20.0, jacobian=True)[1]

    return residuals, jacobian, start


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("max_evaluations", [3, 100])
def test_levenberg_marquardt_is_least_squares_lm_to_the_bit(seed, max_evaluations):
    """The same parameters, status and evaluations as least_squares on a '+' fit, converged (100 evaluations) or cut
    short (3: status 0, the evaluations ran out). The same compiled code on the same numbers gives the same bits;
    the comparison allows 1e-10 px, as MINPACK itself was seen to propose, rarely, a step differing in the last bit
    between two calls in one process (docs/benchmarks_peers.md, session 19)."""
    residuals, jacobian, start = _cross_problem(seed, shift=0.4 + 0.2 * seed)
    ours = scipy_kernels.levenberg_marquardt(residuals, jacobian, start, max_evaluations)
    theirs = scipy.optimize.least_squares(residuals, start, jac=jacobian, method="lm", x_scale="jac",
                                          max_nfev=max_evaluations)
    np.testing.assert_allclose(ours.x, theirs.x, rtol=0.0, atol=1e-10)
    assert (ours.status, ours.success, ours.nfev) == (theirs.status, theirs.success, theirs.nfev)
    assert ours.success == (max_evaluations == 100)


def test_levenberg_marquardt_refuses_a_start_where_the_residuals_are_not_finite():
    """A ValueError where least_squares raises one (which :func:`aerofid.detect.hough.cross_fit._robust_solve`
    takes for a failed fit): residuals that are not finite at the start, a start that is not finite, fewer residuals
    than parameters."""
    def residuals(p):
        return np.full(5, np.nan) if p[0] == 0 else p[0] - np.arange(5.0)

    def jacobian(p):
        return np.ones((5, 1))

    for solve in (lambda x0: scipy_kernels.levenberg_marquardt(residuals, jacobian, x0, 100),
                  lambda x0: scipy.optimize.least_squares(residuals, x0, jac=jacobian, method="lm", x_scale="jac",
                                                          max_nfev=100)):
        with pytest.raises(ValueError, match="not finite in the initial point"):
            solve(np.array([0.0]))
        with pytest.raises(ValueError):
            solve(np.array([np.nan]))
        with pytest.raises(ValueError, match="less than the number of variables"):
            solve(np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]))
        assert solve(np.array([1.0])).x[0] == pytest.approx(2.0)


def test_ndtr_is_scipys_to_the_bit():
    x = np.r_[np.linspace(-40.0, 40.0, 20001), -np.inf, np.inf, np.nan, 1e-300, -1e-300, 0.0, -0.0]
    assert np.array_equal(scipy_kernels.ndtr(x), scipy.special.ndtr(x), equal_nan=True)
    rows = np.linspace(-9.0, 9.0, 64).reshape(4, 16)
    assert np.array_equal(scipy_kernels.ndtr(rows), scipy.special.ndtr(rows))


@pytest.mark.parametrize("seed", range(8))
def test_linear_sum_assignment_is_scipys(seed):
    """The same rows and columns as scipy.optimize.linear_sum_assignment, on square and wide cost matrices with ties
    (rounded costs) and without."""
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 9))
    cost = rng.uniform(0, 10, (m, m + int(rng.integers(0, 4))))
    if seed % 2:
        cost = np.round(cost)
    ours, theirs = scipy_kernels.linear_sum_assignment(cost), scipy.optimize.linear_sum_assignment(cost)
    assert all(np.array_equal(a, b) for a, b in zip(ours, theirs, strict=True))


def _rosenbrock() -> tuple[object, object, np.ndarray]:
    def residuals(p: np.ndarray) -> np.ndarray:
        return np.array([10.0 * (p[1] - p[0] ** 2), 1.0 - p[0]])

    def jacobian(p: np.ndarray) -> np.ndarray:
        return np.array([[-20.0 * p[0], 10.0], [-1.0, 0.0]])

    return residuals, jacobian, np.array([-1.2, 1.0])


def _exponential() -> tuple[object, object, np.ndarray]:
    t = np.linspace(0.0, 4.0, 40)
    y = 2.5 * np.exp(-1.3 * t) + 0.4 + np.random.default_rng(5).normal(0.0, 0.01, t.size)

    def residuals(p: np.ndarray) -> np.ndarray:
        return p[0] * np.exp(-p[1] * t) + p[2] - y

    def jacobian(p: np.ndarray) -> np.ndarray:
        e = np.exp(-p[1] * t)
        return np.column_stack([e, -p[0] * t * e, np.ones_like(t)])

    return residuals, jacobian, np.array([1.0, 0.3, 0.0])


@pytest.mark.parametrize("problem", [_rosenbrock, _exponential])
@pytest.mark.parametrize("max_evaluations", [3, 10, 100])
def test_levenberg_marquardt_is_least_squares_lm_on_classic_problems(problem, max_evaluations):
    """Rosenbrock's valley from (-1.2, 1) and a noisy exponential decay, cut short and converged: the same bits, status
    and evaluations as least_squares (MINPACK's tolerances and step bound each change some of them)."""
    residuals, jacobian, start = problem()
    ours = scipy_kernels.levenberg_marquardt(residuals, jacobian, start, max_evaluations)
    theirs = scipy.optimize.least_squares(residuals, start, jac=jacobian, method="lm", x_scale="jac",
                                          max_nfev=max_evaluations)
    assert np.array_equal(ours.x, theirs.x)
    assert (ours.status, ours.nfev) == (theirs.status, theirs.nfev)


def test_levenberg_marquardt_refuses_bad_calls_as_least_squares_does():
    """A start with two dimensions, no evaluations allowed, a Jacobian of the wrong shape."""
    residuals, jacobian, start = _exponential()
    for solve in (lambda *a: scipy_kernels.levenberg_marquardt(*a),
                  lambda res, jac, x0, n: scipy.optimize.least_squares(res, x0, jac=jac, method="lm", x_scale="jac",
                                                                       max_nfev=n)):
        with pytest.raises(ValueError, match="at most 1 dimension"):
            solve(residuals, jacobian, start[None, :], 100)
        with pytest.raises(ValueError, match="max_nfev"):
            solve(residuals, jacobian, start, 0)
        with pytest.raises(ValueError, match="wrong shape"):
            solve(residuals, lambda p: jacobian(p).T, start, 100)


def test_the_functions_get_copies_of_the_parameters():
    """A residual function that keeps the parameters it was given sees them unchanged after the fit."""
    residuals, jacobian, start = _exponential()
    kept = []
    scipy_kernels.levenberg_marquardt(lambda p: kept.append((p, p.copy())) or residuals(p), jacobian, start, 100)
    assert len(kept) > 3 and all(np.array_equal(p, q) for p, q in kept)


def test_wrong_kernels_fail_their_checks():
    """Another scipy's kernel with other arguments or meaning is not used."""
    assert not scipy_kernels._lmder_works(lambda *args: (np.zeros(3), {"nfev": 1}, 1))
    assert not scipy_kernels._lmder_works(lambda *args: (np.array([2.0, 3.0, -1.0]), {"nfev": 1}, 5))
    assert not scipy_kernels._lmder_works(lambda *args: 1 / 0)
    assert scipy_kernels._lmder_works(scipy.optimize._minpack._lmder)
    assert not scipy_kernels._ndtr_works(np.tanh)
    assert not scipy_kernels._ndtr_works(lambda x: 1 / 0)
    assert scipy_kernels._ndtr_works(scipy.special.ndtr)
    assert not scipy_kernels._lsap_works(lambda c: (np.arange(3), c.argmin(axis=1)))
    assert not scipy_kernels._lsap_works(lambda c: 1 / 0)
    assert scipy_kernels._lsap_works(scipy.optimize.linear_sum_assignment)


def test_without_the_kernels_the_public_functions_answer(monkeypatch):
    """Where the extension modules cannot be loaded (another scipy's layout), least_squares and scipy.special.ndtr
    give the answers."""
    monkeypatch.setattr(scipy_kernels, "_extension", lambda name, parts: None)
    for cached in (scipy_kernels._minpack, scipy_kernels._ndtr, scipy_kernels._lsap):
        cached.cache_clear()
    try:
        assert scipy_kernels._minpack() is None
        assert scipy_kernels._ndtr() is scipy.special.ndtr
        assert scipy_kernels._lsap() is scipy.optimize.linear_sum_assignment
        residuals, jacobian, start = _cross_problem(3, 0.5)
        ours = scipy_kernels.levenberg_marquardt(residuals, jacobian, start, 100)
        theirs = scipy.optimize.least_squares(residuals, start, jac=jacobian, method="lm", x_scale="jac",
                                              max_nfev=100)
        np.testing.assert_allclose(ours.x, theirs.x, rtol=0.0, atol=1e-10)
        assert ours.status == theirs.status
    finally:
        for cached in (scipy_kernels._minpack, scipy_kernels._ndtr, scipy_kernels._lsap):
            cached.cache_clear()


def test_a_missing_extension_file_is_none():
    assert scipy_kernels._extension("scipy.optimize._no_such_module", ("optimize", "_no_such_module")) is None


def test_the_kernels_load_no_scipy_package_and_leave_scipy_to_load_its_own():
    """In a fresh interpreter: a fit, ndtr and an assignment import neither scipy.optimize nor scipy.special (nor
    anything they bring), leave no module of theirs in ``sys.modules``, and scipy.optimize imported afterwards works as
    ever."""
    code = (
        "import sys\n"
        "import numpy as np\n"
        "from aerofid.scipy_kernels import levenberg_marquardt, linear_sum_assignment, ndtr\n"
        "t = np.linspace(0, 1, 20)\n"
        "y = 1.5 * np.exp(-2.0 * t)\n"
        "res = lambda p: p[0] * np.exp(-p[1] * t) - y\n"
        "jac = lambda p: np.column_stack([np.exp(-p[1] * t), -p[0] * t * np.exp(-p[1] * t)])\n"
        "ours = levenberg_marquardt(res, jac, np.array([1.0, 1.0]), 100)\n"
        "from aerofid import scipy_kernels\n"
        "assert scipy_kernels._minpack() is not None  # loaded from its file, not the public fallback\n"
        "half = float(ndtr(np.array([0.0]))[0])\n"
        "rows, cols = linear_sum_assignment(np.array([[1.0, 0.0], [0.0, 5.0]]))\n"
        "print(sorted(m for m in sys.modules if m.startswith(('scipy.optimize', 'scipy.special', 'scipy.sparse',"
        " 'scipy.linalg'))))\n"
        "from scipy.optimize import least_squares\n"
        "theirs = least_squares(res, np.array([1.0, 1.0]), jac=jac, method='lm', x_scale='jac', max_nfev=100)\n"
        "print(bool(np.allclose(ours.x, theirs.x, rtol=0, atol=1e-10)), ours.status == theirs.status, half,"
        " cols.tolist())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines() == ["[]", "True True 0.5 [1, 0]"], out
