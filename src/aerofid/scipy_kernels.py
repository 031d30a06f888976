"""Three of scipy's compiled kernels without scipy's package start-up: MINPACK's Levenberg-Marquardt (``lmder``) and
the standard normal distribution function (``ndtr``), which the cross fit of a '+' needs, and the optimal assignment
(``linear_sum_assignment``) that names a frame's marks where their nearest fiducials collide.

``from scipy.optimize import least_squares`` runs the ``__init__`` of scipy.optimize, which imports most of scipy
(scipy.sparse, scipy.linalg, scipy.special, scipy.stats' pieces): 0.6-0.7 s of a cold ``aerofid locate`` or
``aerofid orient`` that fits one '+' (``python -X importtime``, this machine, 2026-11-28), against a few
milliseconds for the extension modules that hold the kernels, ``scipy/optimize/_minpack``,
``scipy/special/_special_ufuncs`` and ``scipy/optimize/_lsap``. This module loads those files by themselves, under
their own names (without the ``__init__`` of scipy.optimize or scipy.special; ``_minpack`` imports scipy's light top
package and ``scipy._lib._ccallback``), and calls them as
``scipy.optimize.least_squares(..., method="lm")``, ``scipy.special.ndtr`` and
``scipy.optimize.linear_sum_assignment`` call them: the same compiled code on the same numbers, so the same answers to
the bit (the tests compare them).

Each kernel is checked once on a problem whose answer is known before it is used; where a file is missing, loads
differently or fails the check (another scipy version), the public functions are used instead (slower to import,
the same answers). A later import of scipy itself loads its own copies: nothing is left in ``sys.modules``.
"""

from __future__ import annotations

import functools
import importlib.machinery
import importlib.util
import math
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

LM_TOLERANCE = 1e-8
"""MINPACK's ``ftol``, ``xtol`` and ``gtol``: scipy.optimize.least_squares' defaults."""
LM_STEP_BOUND = 100.0
"""MINPACK's ``factor`` (the initial step bound), as least_squares passes it."""
FROM_MINPACK = {0: -1, 1: 2, 2: 3, 3: 4, 4: 1, 5: 0}
"""MINPACK's ``info`` -> least_squares' ``status`` (scipy.optimize._lsq.least_squares.FROM_MINPACK_TO_COMMON):
-1 improper input, 0 the evaluations ran out, 1-4 converged. MINPACK's 6-8 (no further reduction possible at
machine precision) would count as converged here (scipy's table has no entry for them); with tolerances of 1e-8 the
tests for 1, 2 and 4 end a run before them."""


@dataclass(frozen=True, eq=False)
class LMSolution:
    """The end of a least-squares pass: the parameters, least_squares' ``status`` and the model evaluations it made."""

    x: np.ndarray
    status: int
    nfev: int

    @property
    def success(self) -> bool:
        """Converged (least_squares' ``success``: ``status > 0``)."""
        return self.status > 0


def levenberg_marquardt(residuals: Callable[[np.ndarray], np.ndarray], jacobian: Callable[[np.ndarray], np.ndarray],
                        x0: np.ndarray, max_evaluations: int) -> LMSolution:
    """``scipy.optimize.least_squares(residuals, x0, jac=jacobian, method="lm", x_scale="jac",
    max_nfev=max_evaluations)``: MINPACK's ``lmder`` with the parameters scaled by the Jacobian's column norms.

    The functions are given copies of the parameters (MINPACK's own arrays change under a function that kept them).
    Raises ValueError, as least_squares does, for a start that is not a vector, no evaluations, residuals at ``x0``
    that are not finite or fewer than the parameters, and a Jacobian at ``x0`` that is not (residuals x parameters)."""
    x = np.atleast_1d(np.asarray(x0, dtype=float))
    if x.ndim > 1:
        raise ValueError("`x0` must have at most 1 dimension.")
    if max_evaluations < 1:
        raise ValueError("`max_nfev` must be None or positive integer.")
    f0 = np.atleast_1d(residuals(x.copy()))
    if not np.all(np.isfinite(f0)):
        raise ValueError("Residuals are not finite in the initial point.")
    if f0.size < x.size:
        raise ValueError("Method 'lm' doesn't work when the number of residuals is less than the number of variables.")
    if np.shape(jacobian(x.copy())) != (f0.size, x.size):
        raise ValueError(f"The return value of `jac` has wrong shape: expected {(f0.size, x.size)}.")
    lmder = _minpack()
    if lmder is None:
        from scipy.optimize import least_squares

        sol = least_squares(residuals, x, jac=jacobian, method="lm", x_scale="jac", max_nfev=max_evaluations)
        return LMSolution(np.asarray(sol.x, float), int(sol.status), int(sol.nfev))
    end, info, code = lmder(lambda p: residuals(p.copy()), lambda p: jacobian(p.copy()), x.copy(), (), True, False,
                            LM_TOLERANCE, LM_TOLERANCE, LM_TOLERANCE, max_evaluations, LM_STEP_BOUND, None)
    return LMSolution(np.asarray(end, float), FROM_MINPACK.get(int(code), 1), int(info["nfev"]))


def ndtr(x: np.ndarray) -> np.ndarray:
    """The standard normal distribution function at ``x`` (``scipy.special.ndtr``)."""
    return _ndtr()(x)


def linear_sum_assignment(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows and columns of the least-cost assignment of the rows of ``cost`` to distinct columns
    (``scipy.optimize.linear_sum_assignment``)."""
    rows, cols = _lsap()(cost)
    return np.asarray(rows), np.asarray(cols)


@functools.cache
def _minpack() -> Callable[..., Any] | None:
    """scipy's ``_minpack._lmder`` where it loads and passes :func:`_lmder_works`, else None."""
    return _compiled("scipy.optimize._minpack", ("optimize", "_minpack"), "_lmder", _lmder_works)


@functools.cache
def _ndtr() -> Callable[[np.ndarray], np.ndarray]:
    """scipy's ``ndtr`` ufunc from ``_special_ufuncs`` where it loads and gives known values, else
    ``scipy.special.ndtr``."""
    return _compiled("scipy.special._special_ufuncs", ("special", "_special_ufuncs"), "ndtr", _ndtr_works,
                     public="scipy.special")


@functools.cache
def _lsap() -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """scipy's ``_lsap.linear_sum_assignment`` where it loads and solves a known problem, else the public one."""
    return _compiled("scipy.optimize._lsap", ("optimize", "_lsap"), "linear_sum_assignment", _lsap_works,
                     public="scipy.optimize")


def _compiled(name: str, parts: tuple[str, ...], attribute: str, works: Callable[[Any], bool],
              public: str | None = None) -> Any:
    """The function ``attribute`` of the extension module ``name`` (:func:`_extension`) where it has one that passes
    its check ``works``, else the same name of the package ``public`` (imported then), or None without one."""
    fn = getattr(_extension(name, parts), attribute, None)
    if fn is not None and works(fn):
        return fn
    return None if public is None else getattr(importlib.import_module(public), attribute)


_LOADING = threading.Lock()
"""One extension loaded at a time (the first calls of two threads, each registering and removing it)."""


def _extension(name: str, parts: tuple[str, ...]) -> ModuleType | None:
    """The extension module ``name`` of the installed scipy (``parts``: its path under scipy's folder): the one
    already imported, else its file loaded by itself and not left in ``sys.modules``; None where there is none or it
    does not load."""
    with _LOADING:
        return sys.modules.get(name) or _load(name, parts)


def _load(name: str, parts: tuple[str, ...]) -> ModuleType | None:
    """:func:`_extension`'s loading of the file."""
    module: ModuleType | None = None
    try:
        spec = importlib.util.find_spec("scipy")          # finds the package without importing it
        if spec is None or spec.origin is None:
            return None
        folder = Path(spec.origin).parent.joinpath(*parts[:-1])
        path = next((folder / (parts[-1] + s) for s in importlib.machinery.EXTENSION_SUFFIXES
                     if (folder / (parts[-1] + s)).is_file()), None)
        if path is None:
            return None
        loader = importlib.machinery.ExtensionFileLoader(name, str(path))
        found = importlib.util.spec_from_file_location(name, path, loader=loader)
        if found is None:
            return None
        module = importlib.util.module_from_spec(found)
        loader.exec_module(module)
    except Exception:  # another scipy's layout: the public functions answer
        return None
    finally:
        if module is not None and sys.modules.get(name) is module:
            del sys.modules[name]   # a single-phase extension registers itself; scipy loads its own copy later
    return module


def _lmder_works(lmder: Callable[..., Any]) -> bool:
    """Whether ``lmder``, called as :func:`levenberg_marquardt` calls it, fits y = 2 + 3 t - t^2 exactly (another
    scipy's argument order or meaning fails here)."""
    t = np.linspace(-1.0, 2.0, 7)
    y = 2.0 + 3.0 * t - t * t
    design = np.column_stack([np.ones_like(t), t, t * t])
    try:
        end, info, code = lmder(lambda p: design @ p - y, lambda p: design, np.zeros(3), (), True, False,
                                LM_TOLERANCE, LM_TOLERANCE, LM_TOLERANCE, 50, LM_STEP_BOUND, None)
        return (int(code) in FROM_MINPACK and FROM_MINPACK[int(code)] > 0 and int(info["nfev"]) >= 1
                and np.allclose(end, [2.0, 3.0, -1.0], rtol=0.0, atol=1e-9))
    except Exception:
        return False


def _lsap_works(fn: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]) -> bool:
    """Whether ``fn`` assigns a 3 x 4 cost matrix as its least cost does (rows 0-2 to columns 3, 1, 2), where rows 0
    and 2 have the same nearest column."""
    cost = np.array([[4.0, 1.0, 3.0, 0.5], [2.0, 0.0, 5.0, 6.0], [3.0, 2.0, 2.0, 0.4]])
    try:
        rows, cols = fn(cost)
        return np.asarray(rows).tolist() == [0, 1, 2] and np.asarray(cols).tolist() == [3, 1, 2]
    except Exception:
        return False


def _ndtr_works(fn: Callable[[np.ndarray], np.ndarray]) -> bool:
    """Whether ``fn`` gives the normal distribution function at a few points (``math.erfc``)."""
    x = np.array([-3.0, -1.0, 0.0, 0.5, 2.0])
    try:
        got = np.asarray(fn(x), float)
    except Exception:
        return False
    want = [0.5 * math.erfc(-v / math.sqrt(2.0)) for v in x.tolist()]
    return got.shape == x.shape and bool(np.allclose(got, want, rtol=1e-14, atol=0.0))


__all__ = ["LMSolution", "levenberg_marquardt", "linear_sum_assignment", "ndtr"]
