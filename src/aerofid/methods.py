"""The configured method: a method's name, the kind of mark and the user's parameters -> one detector.

A detector is a function of one grey window (float32 on [0, 1], mark bright) returning the method's typed
answer in window pixels (:class:`~aerofid.detect.result.Detection`). Parameters are checked here, before any
pixel is read: unknown names and bad values are one-line input errors naming the valid ones.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from aerofid.conventions import MARKS, METHOD_NAMES, POLARITY_CHOICES
from aerofid.detect import auto
from aerofid.detect.params import MethodParams
from aerofid.detect.registry import METHODS, Method, route_params
from aerofid.detect.result import Detection
from aerofid.errors import AerofidInputError

Detector = Callable[[np.ndarray], Detection]
"""One configured method: grey window (mark bright) -> its answer."""



@dataclass(frozen=True)
class MethodDetector:
    """One seed method configured (:func:`make_detector`, :meth:`AutoDetector.member`): called on a grey window it
    runs the method with ``params``; :meth:`remeasure` measures a mark it found again on another window."""

    method: Method
    params: MethodParams

    def __call__(self, grey: np.ndarray) -> Detection:
        return self.method.detect(grey, self.params)

    @property
    def remeasures(self) -> bool:
        """Whether the method measures a known mark on another window more cheaply (:meth:`remeasure`)."""
        return self.method.again is not None

    def remeasure(self, grey: np.ndarray, x: float, y: float, final: Detection) -> Detection:
        """The mark the method measured at (x, y) (window pixels) as ``final`` on another window, measured on
        ``grey`` (:attr:`aerofid.detect.registry.Method.again`; only where :attr:`remeasures`)."""
        assert self.method.again is not None
        return self.method.again(grey, x, y, self.params, final)


@dataclass(frozen=True)
class AutoDetector:
    """``auto`` configured (:func:`make_detector`): called on a grey window it runs :func:`aerofid.detect.auto.detect`
    with ``params`` and the seed methods' ``methods``; :meth:`member` is one of those methods alone, with the
    parameters ``auto`` gives it."""

    params: auto.AutoParams
    methods: Mapping[str, MethodParams]

    def __call__(self, grey: np.ndarray) -> Detection:
        return auto.detect(grey, self.params, methods=self.methods)

    def member(self, name: str) -> MethodDetector | None:
        """The seed method ``name`` as ``auto`` runs it (None for a name that is no seed method, e.g.
        ``"centroid"``)."""
        if name not in METHODS:
            return None
        return MethodDetector(METHODS[name], auto.seed_params(self.params, self.methods)[name])


def make_detector(method_name: str, mark: str, params: Mapping[str, Any]) -> Detector:
    """The configured method ``method_name`` for ``mark`` with the user's ``params``.

    ``auto`` routes each parameter to the methods that take it (:func:`~aerofid.detect.registry.route_params`).

    Examples
    --------
    >>> make_detector("hough", "external", {"window_size": 24}) is not None
    True
    >>> make_detector("hough", "external", {"size": 24})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: unknown parameter 'size' for method 'hough'; valid: ...
    """
    check_choice(method_name, METHOD_NAMES, "method")
    check_choice(mark, MARKS, "mark")
    if method_name == "auto":
        types: dict[str, type[MethodParams]] = {"auto": auto.AutoParams}
        types.update({m: METHODS[m].params_type for m in METHODS})
        routed = route_params({"mark": mark, **params}, types)
        auto_params = routed.pop("auto")
        assert isinstance(auto_params, auto.AutoParams)
        return AutoDetector(auto_params, routed)
    m = METHODS[method_name]
    values = dict(params)
    if "mark" in m.params_type.names():
        values["mark"] = mark
    return MethodDetector(m, m.params_type.from_mapping(values, method_name))


def check_choice(value: str, choices: Sequence[str], what: str) -> None:
    """Raise one :class:`AerofidInputError` line unless ``value`` is one of ``choices``."""
    if value not in choices:
        raise AerofidInputError(f"unknown {what} {value!r}; use one of {', '.join(choices)}")


def check_polarity(polarity: str) -> None:
    """``polarity`` must be one of :data:`aerofid.conventions.POLARITY_CHOICES`."""
    check_choice(polarity, POLARITY_CHOICES, "polarity")


__all__ = ["METHOD_NAMES", "AutoDetector", "Detector", "MethodDetector", "check_choice", "check_polarity",
           "make_detector"]
