"""The result every mark detector returns.

Each detector module in :mod:`aerofid.detect` offers ``detect(window, **params) -> Detection``: ``window`` is
a 2-D float32 array (grey levels, the mark brighter than its ground; the caller inverts dark marks), and
the centre is returned in *window* pixel coordinates (x = column, y = row, centre of the top-left pixel at
(0, 0)). A detector never raises for "no mark": it returns ``status="not_found"`` with a ``reason``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

FOUND = "found"
NOT_FOUND = "not_found"


@dataclass(frozen=True)
class Detection:
    """A detector's answer for one window.

    Attributes:
        status: ``"found"`` or ``"not_found"``.
        x, y: centre in window pixels (NaN when not found).
        score: the detector's self-diagnosis in [0, 1] (1 = certain); comparable across methods.
        sigma: standard deviation of the centre in pixels (per axis, mean of x and y), NaN if unknown.
        method: name of the method that produced it.
        reason: why nothing was found (empty when found).
        diagnostics: intermediate arrays and numbers for plots (never in JSON).
    """

    status: str
    x: float = float("nan")
    y: float = float("nan")
    score: float = 0.0
    sigma: float = float("nan")
    method: str = ""
    reason: str = ""
    diagnostics: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @property
    def found(self) -> bool:
        return self.status == FOUND

    def to_dict(self) -> dict:
        """Scalars only (no arrays), ready for JSON."""
        return {
            "status": self.status,
            "x": _num(self.x),
            "y": _num(self.y),
            "score": _num(self.score),
            "sigma": _num(self.sigma),
            "method": self.method,
            "reason": self.reason,
        }


def not_found(method: str, reason: str, **diagnostics: Any) -> Detection:
    """Shorthand for an explicit not-found answer."""
    return Detection(status=NOT_FOUND, method=method, reason=reason, diagnostics=diagnostics)


def unusable_window(window: np.ndarray, method: str, min_side: int = 8,
                    min_range: float = 0.02) -> Detection | None:
    """An explicit not-found answer for a window no detector can use (not 2-D, smaller than
    ``min_side``, NaN or infinite values, grey range below ``min_range``), else None."""
    w = np.asarray(window)
    if w.ndim != 2 or min(w.shape) < min_side:
        return not_found(method, f"window must be a 2-D array of at least {min_side} x {min_side} px")
    if not np.isfinite(w).all():
        return not_found(method, "window holds NaN or infinite grey levels")
    if float(w.max() - w.min()) < min_range:
        return not_found(method, f"homogeneous window (grey range below {min_range})")
    return None


def _num(v: float) -> float | None:
    v = float(v)
    return None if not np.isfinite(v) else v
