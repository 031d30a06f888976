"""The seeds' methods a user can name, each with its parameter class, and which parameter goes where.

:data:`METHODS` maps a method name to its :class:`Method`; every method has the same signature,
``detect(window, params) -> <Method>Result`` (``window``: 2-D float32 on [0, 1], the mark brighter than its
ground; the answer in window pixels). ``auto`` (:mod:`aerofid.detect.auto`) runs these methods; it is not
listed here because it sits above them. :func:`route_params` sends a user's parameters to the methods that
take them: the one place that knows which names belong to which method.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from aerofid.conventions import SEED_METHODS
from aerofid.detect.circles import CirclesParams
from aerofid.detect.hough.params import HoughParams
from aerofid.detect.lines_params import LinesParams
from aerofid.detect.params import MethodParams
from aerofid.detect.result import Detection
from aerofid.detect.symmetry import SymmetryParams
from aerofid.errors import AerofidInputError


@dataclass(frozen=True)
class Method:
    """A seed's method: its name, the seed it implements, the module of its ``detect`` function and its parameter
    class.

    The module is imported at the method's first call where its parameter class has not brought it already: ``lines``'
    parameters are apart (:mod:`aerofid.detect.lines_params`), so that a call that never runs ``lines`` (the RC20
    marks' ``aerofid locate``) does not pay for its import (issue 10's start-up); ``hough``, ``symmetry`` and
    ``circles`` define theirs in their own modules, which ``auto`` runs on every box.
    """

    name: str
    seed: str
    module: str
    """The module that holds the method's ``detect(window, params)``, e.g. ``"aerofid.detect.lines"``."""
    params_type: type[MethodParams]
    remeasures: bool = False
    """Whether the module has ``remeasure(window, x, y, params, final)``, the method's :attr:`again`."""

    @property
    def function(self) -> Callable[..., Detection]:
        """The method's ``detect(window, params)`` (its module imported now if it was not)."""
        return cast("Callable[..., Detection]", importlib.import_module(self.module).detect)

    @property
    def again(self) -> Callable[..., Detection] | None:
        """``again(window, x, y, params, final)``: the answer on another window of a mark the method measured at
        (x, y) (window pixels) as ``final``, cheaper than :attr:`function`
        (:func:`aerofid.detect.symmetry.remeasure`), or None."""
        if not self.remeasures:
            return None
        return cast("Callable[..., Detection]", importlib.import_module(self.module).remeasure)

    def detect(self, window: np.ndarray, params: MethodParams | None = None) -> Detection:
        """Run the method on ``window`` with ``params`` (its defaults when None)."""
        return self.function(window, params if params is not None else self.params_type())


METHODS: dict[str, Method] = {
    "hough": Method("hough", "Hunt, Ryan & Gifford (seed 001, thesis 000)", "aerofid.detect.hough", HoughParams),
    "symmetry": Method("symmetry", "Cho & Kim (seed 002)", "aerofid.detect.symmetry", SymmetryParams,
                       remeasures=True),
    "circles": Method("circles", "Seedahmed (seed 003)", "aerofid.detect.circles", CirclesParams),
    "lines": Method("lines", "Sohn et al. (seed 004)", "aerofid.detect.lines", LinesParams),
}
"""The seeds' methods, by the name a user gives (:data:`aerofid.conventions.SEED_METHODS`, in its order)."""



def route_params(values: Mapping[str, Any], types: Mapping[str, type[MethodParams]]) -> dict[str, MethodParams]:
    """Each method's parameters from the user's ``values``: a name goes to every method of ``types`` (method
    name -> parameter class) that has it (``auto`` passes e.g. ``max_asymmetry`` to ``symmetry`` and
    ``theta_step`` to ``hough`` and ``lines``); a name that none takes is one input error listing the valid
    names, a bad value one naming the method.

    Examples
    --------
    >>> p = route_params({"theta_step": 10.0}, {m: METHODS[m].params_type for m in ("hough", "lines")})
    >>> p["hough"].theta_step, p["lines"].theta_step
    (10.0, 10.0)
    """
    unknown = sorted(set(values) - {n for t in types.values() for n in t.names()})
    if unknown:
        s = "s" if len(unknown) > 1 else ""
        valid = sorted({n for t in types.values() for n in t.names()})
        raise AerofidInputError(f"unknown parameter{s} {', '.join(map(repr, unknown))} for method "
                                f"{'/'.join(types)}; valid: {', '.join(valid)}")
    return {m: t.from_mapping({k: v for k, v in values.items() if k in t.names()}, m) for m, t in types.items()}


__all__ = ["METHODS", "SEED_METHODS", "Method", "route_params"]
