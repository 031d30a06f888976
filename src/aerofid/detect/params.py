"""One parameter model for every method: a frozen, validated, documented dataclass per method.

Each method's parameters subclass :class:`MethodParams`: the seed's values are the defaults (the field's
docstring cites the section), :meth:`MethodParams.validate` refuses bad values with a one-line
``ValueError``, and :meth:`MethodParams.from_mapping` turns user input (``locate(**params)``, ``--param``)
into parameters or one :class:`~aerofid.errors.AerofidInputError` line naming the valid names.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from aerofid.errors import AerofidInputError

P = TypeVar("P", bound="MethodParams")

MAX_PX = 10_000
"""Largest length (px) or count any parameter may take: beyond every window aerofid measures (4096 px at most),
so that no value makes a detector allocate or loop without bound."""
MAX_SIGMA_PX = 100.0
"""Largest Gaussian sigma (px) a smoothing parameter may take: a wider blur leaves no mark in any window, and its
kernel (6 sigma across) costs minutes per window (canny_sigma=1e6 ran past 60 s)."""


@dataclass(frozen=True)
class MethodParams:
    """Base of every method's parameters (no fields of its own).

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class DemoParams(MethodParams):
    ...     radius: float = 3.0
    ...     def validate(self) -> None:
    ...         if not self.radius > 0:
    ...             raise ValueError(f"radius must be > 0 px, not {self.radius}")
    >>> DemoParams.from_mapping({"radius": 5}, "demo").radius
    5
    >>> DemoParams.from_mapping({"size": 5}, "demo")
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: unknown parameter 'size' for method 'demo'; valid: radius
    >>> DemoParams.from_mapping({"radius": -1}, "demo")
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: bad parameter for method 'demo': radius must be > 0 px, not -1
    """

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` (one line: which parameter, which values are allowed) for a bad value."""

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The parameter names, in declaration order."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @classmethod
    def from_mapping(cls: type[P], values: Mapping[str, Any], method: str) -> P:
        """Parameters from user input; unknown names or bad values raise one AerofidInputError line."""
        unknown = sorted(set(values) - set(cls.names()))
        if unknown:
            s = "s" if len(unknown) > 1 else ""
            raise AerofidInputError(f"unknown parameter{s} {', '.join(map(repr, unknown))} for method {method!r}; "
                                    f"valid: {', '.join(cls.names())}")
        try:
            return cls(**values)
        except (TypeError, ValueError, OverflowError) as e:
            raise AerofidInputError(f"bad parameter for method {method!r}: {e}") from None

    def replace(self: P, **changes: Any) -> P:
        """A copy with ``changes`` (validated)."""
        return dataclasses.replace(self, **changes)


def is_number(v: Any) -> bool:
    """``v`` is a real number (int, float or a numpy scalar of those kinds; not a bool)."""
    if isinstance(v, bool):
        return False
    return isinstance(v, (int, float, np.integer, np.floating))


def is_int(v: Any) -> bool:
    """``v`` is an integer (int or numpy integer; not a bool)."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, bool)


def number_in(v: Any, lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> bool:
    """``v`` is a finite number between ``lo`` and ``hi`` (inclusive unless ``lo_open`` / ``hi_open``)."""
    if not is_number(v) or not math.isfinite(float(v)):
        return False
    x = float(v)
    return (x > lo if lo_open else x >= lo) and (x < hi if hi_open else x <= hi)


def check(condition: bool, message: str) -> None:
    """``validate`` helper: raise ``ValueError(message)`` unless ``condition``."""
    if not condition:
        raise ValueError(message)


__all__ = ["MAX_PX", "MAX_SIGMA_PX", "MethodParams", "check", "is_int", "is_number", "number_in"]
