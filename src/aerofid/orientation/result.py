"""The result of an interior orientation: :class:`InteriorOrientation` (pixel -> film mm with its statistics)
and one :class:`FiducialResidual` per measured point (seed 004, table 4)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from aerofid.conventions import finite_or_none
from aerofid.orientation.correspondence import Correspondence
from aerofid.orientation.transform import ProjectiveTransform

USED = "used"
REJECTED = "rejected"


@dataclass(frozen=True)
class FiducialResidual:
    """One fiducial in the interior orientation (seed 004, table 4, one row).

    Residuals are calibrated minus adjusted (seed 004's sign); for a rejected fiducial they are taken
    against the fit of the used ones.
    """

    name: str
    x_px: float
    y_px: float
    x_mm: float
    y_mm: float
    adjusted_x_mm: float
    adjusted_y_mm: float
    residual_x_mm: float
    residual_y_mm: float
    residual_x_px: float
    residual_y_px: float
    redundancy_number: float
    status: str = USED
    reason: str = ""

    @property
    def residual_um(self) -> tuple[float, float]:
        return self.residual_x_mm * 1000.0, self.residual_y_mm * 1000.0

    def to_dict(self) -> dict:
        return {"name": self.name, "x_px": self.x_px, "y_px": self.y_px, "x_mm": self.x_mm, "y_mm": self.y_mm,
                "adjusted_x_mm": self.adjusted_x_mm, "adjusted_y_mm": self.adjusted_y_mm,
                "residual_x_mm": self.residual_x_mm, "residual_y_mm": self.residual_y_mm,
                "residual_x_um": self.residual_um[0], "residual_y_um": self.residual_um[1],
                "residual_x_px": self.residual_x_px, "residual_y_px": self.residual_y_px,
                "redundancy_number": finite_or_none(self.redundancy_number), "status": self.status,
                "reason": self.reason}


@dataclass(frozen=True)
class InteriorOrientation:
    """The interior orientation of one scan: pixel -> film mm with its statistics.

    ``transform`` is the pixel -> mm transformation object (:mod:`aerofid.orientation.transform`);
    :attr:`pixel_to_mm` and :attr:`mm_to_pixel` are its matrix and its inverse's. In :meth:`to_dict` they
    are row-major nested lists: ``pixel_to_mm`` = [[a, b, c], [d, e, f]] (X = a x + b y + c,
    Y = d x + e y + f) for the similarity and affine models, 3x3 for projective.
    """

    model: str
    camera: str
    image: str
    transform: ProjectiveTransform = field(compare=False)
    params_std: np.ndarray = field(compare=False)            # sigma0 sqrt(diag Q), order of transform.params
    matrix_std: np.ndarray = field(compare=False)            # 3x3, std of the entries of pixel_to_mm
    variance_of_unit_weight: float                           # mm^2
    redundancy: int
    rms_mm: float                                            # sqrt(mean(vx^2 + vy^2)) over used fiducials
    rms_x_mm: float
    rms_y_mm: float
    rms_px: float
    fiducials: tuple[FiducialResidual, ...]
    missing: tuple[str, ...]
    pixel_size_um: tuple[float, float]
    rotation_deg: float
    non_orthogonality_deg: float
    scale_difference_ppm: float
    scale_vs_nominal_ppm: tuple[float, float] | None
    mirrored: bool
    principal_point_px: tuple[float, float]
    principal_point_source: str
    fiducial_centre_mm: tuple[float, float]
    fiducial_centre_px: tuple[float, float]
    correspondence: Correspondence | None = None
    warnings: tuple[str, ...] = ()

    @property
    def pixel_to_mm(self) -> np.ndarray:
        """3x3 matrix pixel -> mm."""
        return self.transform.matrix

    @property
    def mm_to_pixel(self) -> np.ndarray:
        """3x3 matrix mm -> pixel (``[2, 2]`` = 1)."""
        return self.transform.inverse.matrix

    @property
    def params(self) -> np.ndarray:
        """The published parameter vector (affine: a, b, c, d, e, f as seed 004 table 3)."""
        return self.transform.params

    @property
    def sigma0_mm(self) -> float:
        return math.sqrt(self.variance_of_unit_weight) if math.isfinite(self.variance_of_unit_weight) else math.nan

    @property
    def used(self) -> tuple[FiducialResidual, ...]:
        return tuple(f for f in self.fiducials if f.status == USED)

    @property
    def rejected(self) -> tuple[FiducialResidual, ...]:
        return tuple(f for f in self.fiducials if f.status == REJECTED)

    def to_mm(self, xy: ArrayLike) -> np.ndarray:
        """Pixel (x, y) -> film mm."""
        return self.transform(xy)

    def to_pixel(self, xy_mm: ArrayLike) -> np.ndarray:
        """Film mm -> pixel (x, y)."""
        return self.transform.inverse(xy_mm)

    def _layout(self, H: np.ndarray) -> list:
        return _rows(H if self.model == "projective" else H[:2])

    def to_dict(self) -> dict:
        return {
            "model": self.model, "camera": self.camera, "image": self.image,
            "pixel_to_mm": self._layout(self.pixel_to_mm),
            "mm_to_pixel": self._layout(self.mm_to_pixel),
            "parameters": [float(p) for p in self.params],
            "parameters_std": [finite_or_none(s) for s in self.params_std],
            "parameter_std": [[finite_or_none(s) for s in row] for row in
                              (self.matrix_std if self.model == "projective" else self.matrix_std[:2])],
            "variance_of_unit_weight": finite_or_none(self.variance_of_unit_weight),
            "sigma0_mm": finite_or_none(self.sigma0_mm),
            "redundancy": self.redundancy,
            "rms_mm": finite_or_none(self.rms_mm), "rms_x_mm": finite_or_none(self.rms_x_mm),
            "rms_y_mm": finite_or_none(self.rms_y_mm),
            "rms_um": finite_or_none(self.rms_mm * 1000), "rms_px": finite_or_none(self.rms_px),
            "fiducials": [f.to_dict() for f in self.fiducials],
            "missing": list(self.missing),
            "pixel_size_um": [float(v) for v in self.pixel_size_um],
            "rotation_deg": float(self.rotation_deg),
            "non_orthogonality_deg": float(self.non_orthogonality_deg),
            "scale_difference_ppm": float(self.scale_difference_ppm),
            "scale_vs_nominal_ppm": None if self.scale_vs_nominal_ppm is None else list(self.scale_vs_nominal_ppm),
            "mirrored": self.mirrored,
            "principal_point_px": list(self.principal_point_px),
            "principal_point_source": self.principal_point_source,
            "fiducial_centre_mm": list(self.fiducial_centre_mm),
            "fiducial_centre_px": list(self.fiducial_centre_px),
            "correspondence": None if self.correspondence is None else self.correspondence.to_dict(),
            "warnings": list(self.warnings),
        }


def _rows(H: np.ndarray) -> list:
    return [[float(v) for v in row] for row in np.asarray(H)]


__all__ = ["REJECTED", "USED", "FiducialResidual", "InteriorOrientation"]
