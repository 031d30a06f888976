"""The grid a frame is resampled onto: the camera's fiducial (film mm) frame sampled every ``pixel_size_mm``, with
MicMac ReSampFid's geometry (``mm3d ReSampFid``, ``cAppliOneReechMarqFid`` in MicMac's
``src/uti_phgrm/CPP_CreateEpip.cpp``).

ReSampFid maps output pixel ``P`` to film ``mm = p0 + P * resolution`` (``ChambrePixel2ChambreMm``), ``p0`` the
lower corner of its box in mm (``BoxCh``, by default the fiducials' bounding box), integer pixel coordinates
at pixel centres as everywhere in aerofid (the centre of the top-left output pixel is exactly ``p0``). The
rows therefore run along the film's +y: right for MicMac's image-like camera files (y down, origin in a
corner), a mirror image for a certificate's y-up coordinates. :class:`ResampleGrid` keeps MicMac's mapping for
a y-down camera and runs the rows along -y from ``ymax`` for a y-up camera, so the output is never mirrored.

Size: ReSampFid writes ``round((max - min) / resolution)`` pixels per axis (its box's size converted to
integers), so a fiducial on the box's upper edge falls half a pixel outside the image; here every pixel centre
inside the box is kept, ``floor((max - min) / resolution) + 1`` pixels (one more row and column for a box that is
a whole number of pixels; the mapping of each pixel is the same).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from aerofid.errors import AerofidInputError
from aerofid.orientation.transform import ProjectiveTransform

MAX_SIDE_PX = 200_000
"""Largest side of a resampled frame: a 240 mm film at 1.2 um, far finer than any scanner; a larger grid is a
wrong pixel size (a micrometre value given in mm) or extent."""
EDGE_TOLERANCE = 1e-9
"""Relative slack for a box that is a whole number of pixels (floating point of (max - min) / size)."""


@dataclass(frozen=True)
class ResampleGrid:
    """Output pixels of a resampled frame: ``extent_mm`` = (xmin, ymin, xmax, ymax) in the camera's film mm,
    ``pixel_size_mm``, and the camera's ``y_axis`` (``"down"``: rows along +y from ymin as MicMac ReSampFid;
    ``"up"``: rows along -y from ymax, the same picture unmirrored).

    Examples
    --------
    >>> g = ResampleGrid(0.5, (-10.0, -5.0, 10.0, 5.0), "up")
    >>> g.width, g.height
    (41, 21)
    >>> g.to_mm([[0, 0], [40, 20]]).tolist()       # top-left pixel at (xmin, ymax), bottom-right at (xmax, ymin)
    [[-10.0, 5.0], [10.0, -5.0]]
    >>> g.to_pixel([[0.0, 0.0]]).tolist()
    [[20.0, 10.0]]
    """

    pixel_size_mm: float
    extent_mm: tuple[float, float, float, float]
    y_axis: str = "down"

    def __post_init__(self) -> None:
        s = float(self.pixel_size_mm)
        if not (math.isfinite(s) and s > 0):
            raise AerofidInputError(f"pixel size {self.pixel_size_mm!r} mm must be a positive number of mm")
        ext = tuple(float(v) for v in self.extent_mm)
        if len(ext) != 4 or not all(math.isfinite(v) for v in ext) or ext[2] <= ext[0] or ext[3] <= ext[1]:
            raise AerofidInputError(f"extent {self.extent_mm!r} must be XMIN YMIN XMAX YMAX in mm with XMAX > XMIN "
                                    "and YMAX > YMIN")
        if self.y_axis not in ("up", "down"):
            raise AerofidInputError(f"y axis must be 'up' or 'down', not {self.y_axis!r}")
        object.__setattr__(self, "pixel_size_mm", s)
        object.__setattr__(self, "extent_mm", ext)
        if max(self.width, self.height) > MAX_SIDE_PX:
            raise AerofidInputError(
                f"a {ext[2] - ext[0]:g} x {ext[3] - ext[1]:g} mm extent at {s:g} mm per pixel is {self.width} x "
                f"{self.height} px, more than {MAX_SIDE_PX} px a side: give the pixel size in mm (e.g. 0.015 for "
                "15 um)")

    def _count(self, span: float) -> int:
        return math.floor(span / self.pixel_size_mm * (1 + EDGE_TOLERANCE)) + 1

    @property
    def width(self) -> int:
        return self._count(self.extent_mm[2] - self.extent_mm[0])

    @property
    def height(self) -> int:
        return self._count(self.extent_mm[3] - self.extent_mm[1])

    @property
    def pixel_to_mm(self) -> np.ndarray:
        """3x3 matrix: output pixel (x = column, y = row, centres at integers) -> film mm."""
        s = self.pixel_size_mm
        xmin, ymin, _, ymax = self.extent_mm
        if self.y_axis == "down":
            return np.array([[s, 0.0, xmin], [0.0, s, ymin], [0.0, 0.0, 1.0]])
        return np.array([[s, 0.0, xmin], [0.0, -s, ymax], [0.0, 0.0, 1.0]])

    @property
    def mm_to_pixel(self) -> np.ndarray:
        """3x3 matrix: film mm -> output pixel."""
        return np.linalg.inv(self.pixel_to_mm)

    @property
    def transform(self) -> ProjectiveTransform:
        """Output pixel -> film mm as a transformation object."""
        return ProjectiveTransform(self.pixel_to_mm)

    def to_mm(self, xy: ArrayLike) -> np.ndarray:
        """Output pixels (n x 2) -> film mm."""
        return self.transform(xy)

    def to_pixel(self, xy_mm: ArrayLike) -> np.ndarray:
        """Film mm (n x 2) -> output pixels."""
        return self.transform.inverse(xy_mm)

    def scan_to_output(self, pixel_to_mm: ProjectiveTransform) -> np.ndarray:
        """3x3 homography scan pixel -> output pixel (``[2, 2]`` = 1) for a scan whose interior orientation is
        ``pixel_to_mm``: what ``cv2.warpAffine`` / ``cv2.warpPerspective`` take as ``M`` (``dst = M src``, pixel
        centres at integers in both)."""
        M = self.mm_to_pixel @ pixel_to_mm.matrix
        return M / M[2, 2]

    def to_dict(self) -> dict:
        return {"pixel_size_mm": self.pixel_size_mm, "extent_mm": list(self.extent_mm), "y_axis": self.y_axis,
                "width": self.width, "height": self.height}


def bounding_extent(xy_mm: ArrayLike) -> tuple[float, float, float, float]:
    """The bounding box (xmin, ymin, xmax, ymax) of points in mm: ReSampFid's default extent, its fiducials'.

    Examples
    --------
    >>> bounding_extent([(-106.0, -106.0), (106.0, 105.5), (0.0, 110.0)])
    (-106.0, -106.0, 106.0, 110.0)
    """
    xy = np.asarray(xy_mm, dtype=float).reshape(-1, 2)
    if len(xy) < 2:
        raise AerofidInputError("the default extent is the fiducials' bounding box, and there are fewer than 2 "
                                "fiducials: give --extent XMIN YMIN XMAX YMAX in mm")
    return float(xy[:, 0].min()), float(xy[:, 1].min()), float(xy[:, 0].max()), float(xy[:, 1].max())


__all__ = ["MAX_SIDE_PX", "ResampleGrid", "bounding_extent"]
