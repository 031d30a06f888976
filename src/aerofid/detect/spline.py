"""Cubic B-spline interpolation on a shifted grid: the values of an interpolated image at ``(x0 + i, y0 + j)``.

Every point of such a grid has the same fractional offset, so the B-spline weights are the same for all of them
and the interpolation is one separable 4-tap filter of the coefficients (Unser 1999, "Splines: a perfect fit for
signal and image processing", eq. 2 with the cubic B-spline): the same sums as
``scipy.ndimage.map_coordinates(coeffs, ..., order=3, prefilter=False)`` takes point by point, about ten times
cheaper for a whole grid.

The coefficients themselves (:func:`cubic_prefilter`) are the image filtered by the inverse of the sampled cubic
B-spline, whose impulse response is ``-6 z / (1 - z^2) z^|k|`` with the pole ``z = sqrt(3) - 2`` (Unser, Aldroubi
& Eden 1991, "Fast B-spline transforms for continuous image representation and interpolation", IEEE PAMI 13(3);
Unser 1999), mirrored at the edges: what ``scipy.ndimage.spline_filter(image, order=3, mode="mirror")``
computes by its causal and anticausal recursions, here one separable filter of OpenCV, so that the symmetry
method does not import scipy (a one-mark ``aerofid locate`` pays for scipy's start-up only when it fits a '+').
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["EDGE_PAD", "NEAR_REACH", "SplinePart", "bspline3_weights", "cubic_coefficients", "cubic_prefilter",
           "grid_differences", "grid_values", "near", "square_grid"]

POLE = math.sqrt(3.0) - 2.0
"""The pole of the cubic B-spline's inverse filter."""
PREFILTER_REACH = 15
"""The inverse filter is truncated beyond this many px: the taps left out sum to t = 3.3e-9 in absolute value per
axis, and the filter's taps to 3 (they alternate in sign), so the coefficients differ from the untruncated
filter's by at most 6 t - t^2 = 2.005e-8 of the image's largest grey level: below the resolution of a measuring
window's float32 grey levels (6e-8 on [0, 1]) and far below a 16-bit scan's quantisation step (1.5e-5). Truncated
at 27 px (to float64's resolution) the filter took twice as long."""
_K = np.arange(-PREFILTER_REACH, PREFILTER_REACH + 1)
PREFILTER = (-6.0 * POLE / (1.0 - POLE * POLE)) * POLE ** np.abs(_K)
"""The truncated impulse response of the inverse filter (its taps sum to 1)."""
NEAR_REACH = PREFILTER_REACH + 4
"""Values of the spline within r px of a point need the image within r + this many px of it (:func:`near`): the
spline's support (2 px), rounding, and the inverse filter's reach, beyond which where the image is cut changes
the coefficients by at most 2.005e-8 of its grey levels. A measuring window is often several times larger."""

EDGE_PAD = 12
"""Edge pixels repeated around an image before its cubic spline coefficients are computed, as
``scipy.ndimage.map_coordinates(..., mode="nearest")`` does: the boundary's pull on a coefficient falls by
2 - sqrt(3) = 0.27 per pixel, 1.4e-7 at 12 px."""


def bspline3_weights(t: float) -> np.ndarray:
    """The cubic B-spline's weights of the coefficients ``k - 1, k, k + 1, k + 2`` at ``k + t`` (0 <= t < 1).

    Examples
    --------
    >>> bspline3_weights(0.0).round(4).tolist()
    [0.1667, 0.6667, 0.1667, 0.0]
    >>> float(bspline3_weights(0.3).sum())
    1.0
    """
    s = 1.0 - t
    return np.array([s ** 3, 4.0 - 6.0 * t * t + 3.0 * t ** 3, 4.0 - 6.0 * s * s + 3.0 * s ** 3, t ** 3]) / 6.0


def grid_values(coeffs: np.ndarray, x0: float, y0: float, shape: tuple[int, int], order: int = 3
                ) -> np.ndarray | None:
    """The spline of ``order`` 3 with coefficients ``coeffs`` (``scipy.ndimage.spline_filter(image, order=3)``),
    or the bilinear interpolation (``order`` 1) of the image ``coeffs``, at the points ``(x0 + i, y0 + j)``,
    ``i < shape[1]``, ``j < shape[0]`` (x = column, y = row): an array of ``shape``. None when the support reaches
    outside ``coeffs`` (then the edge mode decides: pad ``coeffs`` further, as :func:`square_grid` does)."""
    ny, nx = shape
    ix, iy = math.floor(x0), math.floor(y0)
    if order == 3:
        first, wx, wy = 1, bspline3_weights(x0 - ix), bspline3_weights(y0 - iy)
    else:
        first, wx, wy = 0, np.array([1.0 - (x0 - ix), x0 - ix]), np.array([1.0 - (y0 - iy), y0 - iy])
    taps = len(wx)
    if ix < first or iy < first or ix - first + nx + taps - 1 > coeffs.shape[1] or (
            iy - first + ny + taps - 1 > coeffs.shape[0]):
        return None
    block = coeffs[iy - first:iy - first + ny + taps - 1, ix - first:ix - first + nx + taps - 1]
    return _taps(_taps(block, wy, ny, axis=0), wx, nx, axis=1)


def grid_differences(coeffs: np.ndarray, x0: float, y0: float, shape: tuple[int, int]
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The cubic spline ``S`` of ``coeffs`` at the points ``(x0 + i, y0 + j)`` as :func:`grid_values` gives it, and
    its central differences there, ``S(x + 1/2, y) - S(x - 1/2, y)`` and ``S(x, y + 1/2) - S(x, y - 1/2)``; None
    when their support reaches outside ``coeffs``.

    The points half a pixel either side of a grid share one set of weights (their fractions are equal, their
    first taps one coefficient apart), so a difference is one pass of those weights over the differences of
    neighbouring partial sums, not two grids: 22 passes over the grid for the three, against 40 for five grids.
    """
    ny, nx = shape
    ix, iy = math.floor(x0), math.floor(y0)
    jx, jy = math.floor(x0 + 0.5), math.floor(y0 + 0.5)       # x + 1/2 starts at tap jx - 1, x - 1/2 at jx - 2
    if min(ix - 1, iy - 1, jx - 2, jy - 2) < 0 or max(ix, jx) + nx + 2 > coeffs.shape[1] or (
            max(iy, jy) + ny + 2 > coeffs.shape[0]):
        return None
    wx, wy = bspline3_weights(x0 - ix), bspline3_weights(y0 - iy)
    hx, hy = bspline3_weights(x0 + 0.5 - jx), bspline3_weights(y0 + 0.5 - jy)
    # along y at y0 first, on the columns jx - 2 ... that the value and the x-differences need
    rows = _taps(coeffs[iy - 1:iy + ny + 2, jx - 2:jx + nx + 2], wy, ny, axis=0)
    value = _taps(rows[:, ix - 1 - (jx - 2):], wx, nx, axis=1)
    dx = _taps(np.diff(rows, axis=1), hx, nx, axis=1)
    # along x at x0 first, on the rows jy - 2 ... that the y-differences need
    cols = _taps(coeffs[jy - 2:jy + ny + 2, ix - 1:ix + nx + 2], wx, nx, axis=1)
    dy = _taps(np.diff(cols, axis=0), hy, ny, axis=0)
    return value, dx, dy


def _taps(block: np.ndarray, w: np.ndarray, n: int, axis: int) -> np.ndarray:
    """``sum_t w[t] block[t:t + n]`` along ``axis`` (0: rows, 1: columns), float64: one correlation of OpenCV
    (the same sums, term by term, as a loop over the taps of numpy's slices takes, 2.5-10 times faster on a
    measuring window's grid)."""
    kernel = np.asarray(w, np.float64).reshape((-1, 1) if axis == 0 else (1, -1))
    out = cv2.filter2D(np.asarray(block, np.float64), cv2.CV_64F, kernel, anchor=(0, 0),
                       borderType=cv2.BORDER_CONSTANT)
    return out[:n] if axis == 0 else out[:, :n]


def cubic_coefficients(img: np.ndarray) -> np.ndarray:
    """Cubic spline coefficients of ``img`` (float64) with :data:`EDGE_PAD` edge pixels repeated around it: index
    ``(y + EDGE_PAD, x + EDGE_PAD)`` is pixel (x, y)."""
    return cubic_prefilter(np.pad(np.asarray(img, np.float64), EDGE_PAD, mode="edge"))


def cubic_prefilter(img: np.ndarray) -> np.ndarray:
    """Cubic B-spline coefficients of ``img`` (float64), mirrored at its edges (module docstring): equal to
    ``scipy.ndimage.spline_filter(img, order=3, mode="mirror")`` within 2.005e-8 of the image's
    largest grey level (:data:`PREFILTER_REACH`).

    Examples
    --------
    >>> c = cubic_prefilter(np.full((5, 7), 0.25))
    >>> bool(np.allclose(c, 0.25))
    True
    """
    return cv2.sepFilter2D(np.asarray(img, np.float64), cv2.CV_64F, PREFILTER, PREFILTER,
                           borderType=cv2.BORDER_REFLECT_101)


def near(img: np.ndarray, xc: float, yc: float, reach: int) -> tuple[np.ndarray, int, int]:
    """The part of ``img`` within ``reach`` px of the pixel nearest (xc, yc), clipped to the image (a view), and
    its origin (x0, y0).

    Examples
    --------
    >>> part, x0, y0 = near(np.zeros((50, 60)), 5.2, 30.7, 10)
    >>> part.shape, x0, y0
    ((21, 16), 0, 21)
    """
    h, w = img.shape[:2]
    cx, cy = int(round(xc)), int(round(yc))
    x0, y0 = min(max(0, cx - reach), w), min(max(0, cy - reach), h)
    return img[y0:max(y0, min(h, cy + reach + 1)), x0:max(x0, min(w, cx + reach + 1))], x0, y0


def square_grid(img: np.ndarray, xc: float, yc: float, r: int, order: int = 3,
                coeffs: np.ndarray | None = None) -> np.ndarray:
    """``img`` interpolated (``order`` 1 or 3; edge pixels repeated beyond it) on the (2r+1)-square of points
    centred on (xc, yc), float64: what ``scipy.ndimage.map_coordinates(img, ..., order=order, mode="nearest")``
    gives there, by whole grids (:func:`grid_values`). ``coeffs``: :func:`cubic_coefficients` of ``img``, if
    known; else, for a centre inside the image, those of the part of ``img`` the square needs (:func:`near`,
    :data:`NEAR_REACH`)."""
    n = 2 * r + 1
    h, w = np.shape(img)
    if order == 3 and coeffs is None and 0 <= xc <= w - 1 and 0 <= yc <= h - 1:
        part, x0, y0 = near(img, xc, yc, r + NEAR_REACH)
        if part.shape != np.shape(img):
            return square_grid(part, xc - x0, yc - y0, r, 3)
    if order == 3:
        c = cubic_coefficients(img) if coeffs is None else coeffs
        got = grid_values(c, xc - r + EDGE_PAD, yc - r + EDGE_PAD, (n, n))
    else:
        got = grid_values(np.pad(np.asarray(img, np.float64), 1, mode="edge"), xc - r + 1, yc - r + 1, (n, n), 1)
    if got is not None:
        return got
    # the square reaches beyond the padding: more edge values (far outside, the spline of the edge-padded image
    # is the edge pixel's value, as scipy's mode="nearest" gives there)
    extra = r + 3 + math.ceil(max(0.0, -xc, -yc, xc - (w - 1), yc - (h - 1)))
    if order == 3:
        c = np.pad(cubic_coefficients(img) if coeffs is None else coeffs, extra, mode="edge")
        got = grid_values(c, xc - r + EDGE_PAD + extra, yc - r + EDGE_PAD + extra, (n, n))
    else:
        got = grid_values(np.pad(np.asarray(img, np.float64), 1 + extra, mode="edge"), xc - r + 1 + extra,
                          yc - r + 1 + extra, (n, n), 1)
    assert got is not None
    return got


@dataclass(frozen=True, eq=False)
class SplinePart:
    """The cubic spline coefficients of the part of an image within some px of a pixel (:func:`near`), mirrored at
    the part's edges (:func:`cubic_prefilter`), with 2 edge values more around them (the spline's support reaches
    1-2 px beyond a grid point on the part's edge, where the edge coefficient repeats, as scipy's mode="nearest"):
    ``coeffs[y - y0 + 2, x - x0 + 2]`` is pixel (x, y)'s."""

    coeffs: np.ndarray
    x0: int
    y0: int

    @classmethod
    def about(cls, img: np.ndarray, xc: float, yc: float, reach: int) -> SplinePart:
        """The coefficients of ``img`` within ``reach`` px of the pixel nearest (xc, yc)."""
        part, x0, y0 = near(img, xc, yc, reach)
        return cls(np.pad(cubic_prefilter(part), 2, mode="edge"), x0, y0)

    def square(self, xc: float, yc: float, r: int) -> np.ndarray | None:
        """The (2r + 1)-square of the image's spline about (xc, yc) (image pixels), as :func:`square_grid` gives it,
        where every coefficient it takes lies :data:`PREFILTER_REACH` px or more inside the part: such a coefficient
        is the image's own, whatever part of it was filtered (the same taps over the same pixels, to the last bit),
        and the grid's fractions are too (the centre less whole numbers). Else None."""
        h, w = self.coeffs.shape[0] - 4, self.coeffs.shape[1] - 4
        fx, fy = math.floor(xc) - self.x0, math.floor(yc) - self.y0      # the taps: fx - r - 1 .. fx + r + 2
        if min(fx, fy) - r - 1 < PREFILTER_REACH or fx + r + 2 > w - 1 - PREFILTER_REACH or (
                fy + r + 2 > h - 1 - PREFILTER_REACH):
            return None
        return grid_values(self.coeffs, xc - self.x0 - r + 2, yc - self.y0 - r + 2, (2 * r + 1, 2 * r + 1))
