"""The answer of :func:`aerofid.orient_frame`: a verdict per fiducial and per frame, and the orientation."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from aerofid.conventions import finite_or_none
from aerofid.find import Located
from aerofid.orientation.result import InteriorOrientation

FOUND_MARK = "found"
"""The mark was found and used in the adjustment."""
REJECTED_MARK = "rejected"
"""The mark was found but the adjustment rejected it (its residual says why)."""
MISSING_MARK = "not_found"
"""No mark was found where the frame's geometry puts the fiducial."""

WHOLE_FRAME, ROLL_AREAS = "whole frame", "roll areas"
"""Where the frame's features were screened: the whole frame read reduced, or only the areas around where a roll
profile's frame had its fiducials (:mod:`aerofid.frame.roll_areas`)."""
OK, DOUBTFUL, FAILED = "ok", "doubtful", "failed"
"""A frame's verdict: the orientation can be used / should be looked at / there is none."""


@dataclass(frozen=True)
class FiducialFinding:
    """One calibrated fiducial on the scan (pixels: x = column, y = row, centre of the top-left pixel (0, 0)): its
    mark's centre (None where none was found) and where the frame puts it (``predicted_x, predicted_y``: the
    orientation's prediction, the layout's where the frame has no orientation), with ``residual_px`` the adjustment's
    residual of a mark used or rejected."""

    name: str
    status: str
    x: float | None
    y: float | None
    sigma_x: float | None
    sigma_y: float | None
    predicted_x: float
    predicted_y: float
    residual_px: float | None = None
    reason: str = ""
    method: str = ""
    located: Located | None = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "status": self.status, "x": finite_or_none(self.x), "y": finite_or_none(self.y),
                "sigma_x": finite_or_none(self.sigma_x), "sigma_y": finite_or_none(self.sigma_y),
                "predicted_x": finite_or_none(self.predicted_x), "predicted_y": finite_or_none(self.predicted_y),
                "residual_px": finite_or_none(self.residual_px), "reason": self.reason, "method": self.method}


LIE_TOLD = "fiducials"
"""``FrameOrientation.lie_source`` of a lie the marks fit significantly better than every other."""
LIE_GIVEN = "given"
"""... of a lie taken as given (by the user or the roll's profile) where the marks fit several lies equally."""
LIE_ASSUMED = "assumed"
"""... of the nominal lie taken where the marks fit several equally and none was given (the frame is doubtful)."""


@dataclass(frozen=True)
class FrameOrientation:
    """A whole frame's fiducials and interior orientation.

    Attributes
    ----------
    status : str
        ``"ok"``, ``"doubtful"`` (an orientation exists but something is wrong or unproven: the reasons say what)
        or ``"failed"`` (no orientation).
    reasons : tuple of str
        Why the frame is doubtful or failed (empty when ok).
    fiducials : tuple of FiducialFinding
        One per camera fiducial, in the camera's order.
    orientation : InteriorOrientation or None
        The adjustment of the found marks (None when failed).
    rotation_deg, mirrored : int or None, bool or None
        The film's lie in the scanner (:data:`aerofid.orientation.correspondence.ARRANGEMENTS`), and how it was
        decided (``lie_source``): :data:`LIE_TOLD` (the marks fit it significantly better than every other lie),
        :data:`LIE_GIVEN` (the marks fit several lies equally, a symmetric layout: the lie given, by the user or the
        roll's profile, was taken, and the fiducials cannot check it), :data:`LIE_ASSUMED` (the same, none given: the
        nominal one, and the frame is doubtful), empty without an orientation.
    pixel_size_mm : float or None
        The pixel size the search assumed, and where it came from (``pixel_size_source``: "given", "tags",
        "camera" or "estimated" from the marks' layout).
    features, reduction, searched : int, int, str
        How many mark-like features the layout was sought among, the reduction they were screened at, and where:
        :data:`WHOLE_FRAME` or :data:`ROLL_AREAS`.
    """

    image: str
    camera: str
    width: int
    height: int
    status: str
    reasons: tuple[str, ...]
    fiducials: tuple[FiducialFinding, ...]
    orientation: InteriorOrientation | None
    rotation_deg: int | None
    mirrored: bool | None
    pixel_size_mm: float | None
    pixel_size_source: str
    features: int = 0
    reduction: int = 1
    searched: str = WHOLE_FRAME
    extra_marks: tuple[FiducialFinding, ...] = ()
    """The marks of the film's format that the camera file does not list (the midside marks of a 23 cm camera
    whose certificate calibrates its corners), found at their nominal positions by the orientation
    (``predicted_x, predicted_y``; ``residual_px``: the mark's distance from it); not used in the adjustment."""

    lie_source: str = ""
    """How the lie was decided (``rotation_deg``): :data:`LIE_TOLD`, :data:`LIE_GIVEN`, :data:`LIE_ASSUMED` or empty."""

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def found(self) -> tuple[FiducialFinding, ...]:
        return tuple(f for f in self.fiducials if f.status != MISSING_MARK)

    def to_dict(self) -> dict[str, Any]:
        return {"image": self.image, "camera": self.camera, "width": self.width, "height": self.height,
                "status": self.status, "reasons": list(self.reasons),
                "fiducials": [f.to_dict() for f in self.fiducials],
                "rotation_deg": self.rotation_deg, "mirrored": self.mirrored, "lie_source": self.lie_source,
                "pixel_size_mm": finite_or_none(self.pixel_size_mm), "pixel_size_source": self.pixel_size_source,
                "screening": {"features": self.features, "reduction": self.reduction, "searched": self.searched},
                "orientation": None if self.orientation is None else self.orientation.to_dict(),
                "extra_marks": [f.to_dict() for f in self.extra_marks]}


def standing(res: FrameOrientation) -> tuple[int, int]:
    """How good a frame's answer is, for comparing two (larger is better): ok, doubtful, failed; then the more
    fiducials found."""
    return (res.ok + (res.status != FAILED), len(res.found))


__all__ = ["DOUBTFUL", "FAILED", "FOUND_MARK", "LIE_ASSUMED", "LIE_GIVEN", "LIE_TOLD", "MISSING_MARK", "OK",
           "REJECTED_MARK", "ROLL_AREAS", "WHOLE_FRAME", "FiducialFinding", "FrameOrientation", "standing"]
