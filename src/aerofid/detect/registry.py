"""The methods a user can name: each seed's detector with its parameter class, and ``auto``.

:data:`METHODS` maps a method name to its :class:`Method`; every method has the same signature,
``detect(window, params) -> <Method>Result`` (``window``: 2-D float32 on [0, 1], the mark brighter than its
ground; the answer in window pixels). :func:`route_params` sends a user's parameters to the methods that take
them (one place for "which names belong to which method").
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from aerofid.detect.params import MethodParams
from aerofid.detect.result import Detection
from aerofid.errors import AerofidInputError


@dataclass(frozen=True)
class Method:
    """A method: its name, the seed it implements, its module and its parameter class."""

    name: str
    seed: str
    module: str
    params_class: str

    def load(self) -> ModuleType:
        """The method's module."""
        return importlib.import_module(self.module)

    @property
    def params_type(self) -> type[MethodParams]:
        """The method's parameter class (a :class:`~aerofid.detect.params.MethodParams`)."""
        cls: type[MethodParams] = getattr(self.load(), self.params_class)
        return cls

    def detect(self, window: np.ndarray, params: MethodParams | None = None) -> Detection:
        """Run the method on ``window`` with ``params`` (its defaults when None)."""
        result: Detection = self.load().detect(window, params if params is not None else self.params_type())
        return result


METHODS: dict[str, Method] = {
    "hough": Method("hough", "Hunt, Ryan & Gifford (seed 001, thesis 000)", "aerofid.detect.hough", "HoughParams"),
    "symmetry": Method("symmetry", "Cho & Kim (seed 002)", "aerofid.detect.symmetry", "SymmetryParams"),
    "circles": Method("circles", "Seedahmed (seed 003)", "aerofid.detect.circles", "CirclesParams"),
    "lines": Method("lines", "Sohn et al. (seed 004)", "aerofid.detect.lines", "LinesParams"),
    "auto": Method("auto", "aerofid: the seeds' methods cross-checked", "aerofid.detect.auto", "AutoParams"),
}
"""Every method a user can name (``locate(method=...)``, ``--method``)."""

SEED_METHODS = ("hough", "symmetry", "circles", "lines")
"""The methods of the seeds (all but ``auto``)."""


def method(name: str) -> Method:
    """The :class:`Method` called ``name``; an unknown name is an input error naming the valid ones."""
    if name not in METHODS:
        raise AerofidInputError(f"unknown method {name!r}; use one of {', '.join(METHODS)}")
    return METHODS[name]


def route_params(values: Mapping[str, Any], methods: Sequence[str]) -> dict[str, MethodParams]:
    """Each method's parameters from the user's ``values``: a name goes to every one of ``methods`` whose
    parameter class has it (``auto`` passes e.g. ``max_asymmetry`` to ``symmetry`` and ``theta_step`` to
    ``hough`` and ``lines``); a name that none of them takes is an input error listing the valid names.
    """
    types = {m: method(m).params_type for m in methods}
    unknown = sorted(set(values) - {n for t in types.values() for n in t.names()})
    if unknown:
        s = "s" if len(unknown) > 1 else ""
        valid = sorted({n for t in types.values() for n in t.names()})
        raise AerofidInputError(f"unknown parameter{s} {', '.join(map(repr, unknown))} for method "
                                f"{'/'.join(methods)}; valid: {', '.join(valid)}")
    return {m: t.from_mapping({k: v for k, v in values.items() if k in t.names()}, m) for m, t in types.items()}


__all__ = ["METHODS", "SEED_METHODS", "Method", "method", "route_params"]
