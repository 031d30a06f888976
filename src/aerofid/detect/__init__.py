"""Mark detectors, one module per seed, all with the same signature.

``detect(window, **params) -> Detection``: ``window`` is a 2-D float32 array on a [0, 1] grey scale with the
mark *brighter* than its ground (the caller, :func:`aerofid.locate`, inverts dark marks), and the answer is
in window pixels. :data:`METHODS` maps each public method name to the module that implements it.
"""

from __future__ import annotations

import importlib
from typing import Callable

from aerofid.detect.result import Detection

METHODS: dict[str, str] = {
    "hough": "aerofid.detect.hough",   # Hunt, Ryan & Gifford (seed 001, thesis 000)
    "symmetry": "aerofid.detect.symmetry",   # Cho & Kim (seed 002)
    "circles": "aerofid.detect.circles",     # Seedahmed (seed 003)
    "lines": "aerofid.detect.lines",         # Sohn et al. (seed 004)
}


def available_methods() -> list[str]:
    """Method names whose module is present in this installation."""
    out = []
    for name, module in METHODS.items():
        try:
            importlib.import_module(module)
        except ModuleNotFoundError:
            continue
        out.append(name)
    return out


def detector(method: str) -> Callable[..., Detection]:
    """The ``detect`` function of ``method``."""
    return importlib.import_module(METHODS[method]).detect
