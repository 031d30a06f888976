"""The result every mark detector returns: :class:`Detection`, subclassed by each method.

Each method module in :mod:`aerofid.detect` offers ``detect(window, params) -> <Method>Result``: ``window`` is
a 2-D float32 array (grey levels on [0, 1], the mark brighter than its ground; the caller inverts dark
marks), and the centre is returned in *window* pixel coordinates (x = column, y = row, centre of the
top-left pixel at (0, 0)). A detector never raises for "no mark": it returns ``status="not_found"`` with a
``reason``. Each result type carries its method's intermediate results as typed fields (never a dictionary
read by other modules), says how large the mark is by its own model (:attr:`Detection.extent`) and draws
its own diagnostic figure (:meth:`Detection.plot`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from aerofid.conventions import FOUND, NOT_FOUND, finite_or_none

if TYPE_CHECKING:
    from matplotlib.figure import Figure

D = TypeVar("D", bound="Detection")


@dataclass(frozen=True)
class Detection:
    """A detector's answer for one window (the base of every method's result type).

    Attributes
    ----------
    status : str
        ``"found"`` or ``"not_found"``.
    x, y : float
        Centre in window pixels (NaN when not found).
    score : float
        The detector's self-diagnosis in [0, 1] (1 = certain).
    sigma : float
        Standard deviation of the centre in pixels (per axis), NaN if unknown. Where a method reports
        per-axis values it is their RMS, ``sqrt((sigma_x^2 + sigma_y^2) / 2)``, unless the method's
        docstring says otherwise (``symmetry``, ``circles`` and ``lines`` report their mean).
    sigma_x, sigma_y, cov_xy : float
        The centre's covariance ``[[sigma_x^2, cov_xy], [cov_xy, sigma_y^2]]`` (window pixels; NaN if
        unknown): :attr:`covariance`.
    method : str
        Name of the method that produced it.
    reason : str
        Why nothing was found (empty when found).
    origin : tuple of float
        Where the window the method saw lies in the caller's window (``(0, 0)`` unless the answer was
        :meth:`shifted`); the typed diagnostics of subclasses stay in the coordinates of the window the
        method saw.

    Examples
    --------
    >>> d = Detection(status="found", x=10.25, y=4.5, score=0.9, sigma=0.02, method="demo")
    >>> d.found, d.shifted(100, 200).x
    (True, 110.25)
    >>> Detection.not_found("demo", "homogeneous window").to_dict()["status"]
    'not_found'
    >>> Detection(status="found", x=1.0, y=2.0, sigma_x=0.03, sigma_y=0.04, cov_xy=0.0005).covariance.tolist()
    [[0.0009, 0.0005], [0.0005, 0.0016]]
    """

    status: str = NOT_FOUND
    x: float = float("nan")
    y: float = float("nan")
    score: float = 0.0
    sigma: float = float("nan")
    method: str = ""
    reason: str = ""
    origin: tuple[float, float] = (0.0, 0.0)
    sigma_x: float = float("nan")
    sigma_y: float = float("nan")
    cov_xy: float = float("nan")

    @property
    def covariance(self) -> np.ndarray:
        """The centre's 2 x 2 covariance (px^2) ``[[sigma_x^2, cov_xy], [cov_xy, sigma_y^2]]``, NaN where
        unknown. A translation (:meth:`shifted`) leaves it as it is."""
        return np.array([[self.sigma_x ** 2, self.cov_xy], [self.cov_xy, self.sigma_y ** 2]], dtype=float)

    @property
    def found(self) -> bool:
        """True when a mark was located."""
        return self.status == FOUND

    @property
    def extent(self) -> float | None:
        """The mark's radius (px) by the method's own model of it, or None when the method has none."""
        return None

    @classmethod
    def not_found(cls: type[D], method: str, reason: str, **fields: Any) -> D:
        """An explicit not-found answer of this type, with any of its typed diagnostic ``fields``."""
        return cls(status=NOT_FOUND, method=method, reason=reason, **fields)

    def shifted(self: D, dx: float, dy: float) -> D:
        """The same answer in a window whose origin is (-dx, -dy) from this one's (e.g. from a crop back
        to the window it was cut from). The covariance stays: a translation does not change it."""
        return dataclasses.replace(self, x=self.x + dx, y=self.y + dy,
                                   origin=(self.origin[0] + dx, self.origin[1] + dy))

    def to_dict(self) -> dict[str, Any]:
        """Scalars only (no arrays), ready for JSON (NaN becomes None)."""
        n = finite_or_none
        return {"status": self.status, "x": n(self.x), "y": n(self.y), "score": n(self.score),
                "sigma": n(self.sigma), "sigma_x": n(self.sigma_x), "sigma_y": n(self.sigma_y),
                "cov_xy": n(self.cov_xy), "method": self.method, "reason": self.reason}

    def plot(self, fig: Figure, window: np.ndarray) -> None:
        """Draw this method's diagnostic figure into ``fig`` for the ``window`` it saw (window pixels).

        The base draws the window with the centre; methods with intermediate results override it."""
        ax = fig.add_subplot(1, 1, 1)
        ax.imshow(window, cmap="gray", interpolation="nearest")
        if self.found:
            ax.plot([self.x - self.origin[0]], [self.y - self.origin[1]], "+", color="orange", ms=14, mew=2)
            ax.set_title(f"{self.method}: ({self.x:.3f}, {self.y:.3f}) sigma {self.sigma:.3f} px", fontsize=9)
        else:
            ax.set_title(f"{self.method}: not found: {self.reason}"[:90], fontsize=9)


class Refused(Exception):
    """A method's step cannot go on (a method's own control flow, never seen by a caller): ``reason`` becomes
    the reason of the method's not-found answer."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


def unusable_window(window: np.ndarray, min_side: int = 8, min_range: float = 0.02) -> str | None:
    """Why no detector can use ``window`` (not 2-D, smaller than ``min_side``, NaN or infinite values, grey
    range below ``min_range``), or None when it is usable.

    Examples
    --------
    >>> unusable_window(np.zeros((4, 4)))
    'window must be a 2-D array of at least 8 x 8 px'
    >>> unusable_window(np.eye(10)) is None
    True
    """
    w = np.asarray(window)
    if w.ndim != 2 or min(w.shape) < min_side:
        return f"window must be a 2-D array of at least {min_side} x {min_side} px"
    if not np.isfinite(w).all():
        return "window holds NaN or infinite grey levels"
    if float(w.max() - w.min()) < min_range:
        return f"homogeneous window (grey range below {min_range})"
    return None


__all__ = ["FOUND", "NOT_FOUND", "Detection", "Refused", "unusable_window"]
