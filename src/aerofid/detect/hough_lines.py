"""The Hough transform of straight lines, shared by the ``hough`` (seed 001) and ``lines`` (seed 004) methods.

A line is written in normal form, rho = x cos(theta) + y sin(theta) (Hunt, Ryan & Gifford, seed 001, eq. 1;
Sohn et al., seed 004, eq. 3), theta the direction of its normal on [0, 180) degrees (seed 004, eq. 5) and
rho its signed distance from the window's top-left pixel centre. :func:`accumulate` votes every point into
the cells of a (theta, rho) grid; :func:`intersection` inverts two such lines into the point where they cross
(seed 001, eq. 2, "the inverse transform"; seed 004: "we calculated the intersection of the lines").
"""

from __future__ import annotations

import functools

import numpy as np

MAX_BLOCK = 1 << 22
"""Most (theta, point) pairs voted at once: larger transforms are voted in blocks of thetas, so that memory
stays bounded (a few tens of MB) whatever the window and the grid (the counts are exact either way)."""

PARALLEL = 1e-6
"""Two lines whose normals' determinant (the sine of the angle between them) is below this are parallel."""


def theta_grid(theta_step: float) -> np.ndarray:
    """Normal directions in degrees: 0, step, ..., below 180 (seed 001: 0..175 by 5 deg; seed 004 eq. 5).

    Examples
    --------
    >>> g = theta_grid(5.0)
    >>> len(g), float(g[0]), float(g[-1])
    (36, 0.0, 175.0)
    """
    return np.arange(0.0, 180.0 - 1e-9, theta_step)


def accumulate(xs: np.ndarray, ys: np.ndarray, thetas: np.ndarray, rho_min: float, rho_step: float,
               n_rho: int) -> np.ndarray:
    """Accumulator A[theta, rho] of the points (xs, ys) by rho = x cos(theta) + y sin(theta).

    Seed 001, eq. 1, and seed 004, eq. 3: every point votes once in each row ``i`` (normal direction
    ``thetas[i]``, radians), in the cell ``j`` whose interval [rho_min + j rho_step, rho_min + (j + 1) rho_step)
    holds its rho; rho outside the ``n_rho`` cells is clipped into the first or last.

    Parameters
    ----------
    xs, ys : ndarray
        Point coordinates (x = column, y = row).
    thetas : ndarray
        Normal directions in radians.
    rho_min, rho_step : float
        Lower edge of cell 0 and the cells' width (px).
    n_rho : int
        Number of rho cells.

    Returns
    -------
    ndarray
        float64 votes of shape ``(len(thetas), n_rho)``.

    Examples
    --------
    Points on the line x cos 30 deg + y sin 30 deg = 12.3 all vote in one cell:

    >>> t = np.deg2rad(30.0)
    >>> s = np.linspace(-15, 15, 61)
    >>> acc = accumulate(12.3 * np.cos(t) - s * np.sin(t), 12.3 * np.sin(t) + s * np.cos(t),
    ...                  np.deg2rad(theta_grid(5.0)), -40.0, 0.5, 161)
    >>> i, j = np.unravel_index(np.argmax(acc), acc.shape)
    >>> int(i), -40.0 + 0.5 * int(j), float(acc[i, j])
    (6, 12.0, 61.0)
    """
    xs, ys = np.asarray(xs, np.float64), np.asarray(ys, np.float64)
    n_theta = len(thetas)
    acc: np.ndarray | None = None
    block = max(1, MAX_BLOCK // max(1, xs.size))
    for start in range(0, n_theta, block):
        j = _cells(xs, ys, np.asarray(thetas[start:start + block], np.float64), start, rho_min, rho_step, n_rho)
        votes = np.bincount(j.ravel(), minlength=n_theta * n_rho)
        acc = votes if acc is None else acc + votes
    assert acc is not None
    return acc.reshape(n_theta, n_rho).astype(np.float64)


def _cells(xs: np.ndarray, ys: np.ndarray, t: np.ndarray, start: int, rho_min: float, rho_step: float,
           n_rho: int) -> np.ndarray:
    """The cell each point (float64 ``xs``, ``ys``) votes in, in each row of the normal directions ``t`` (radians;
    rows ``start``, ``start + 1``, ... of the accumulator), as ``(len(t), n_points)`` indices into the flattened
    accumulator: the rule of :func:`accumulate`."""
    rho = np.outer(np.cos(t), xs) + np.outer(np.sin(t), ys)              # (rows, n_points)
    j = np.floor((rho - rho_min) / rho_step).astype(np.int64)
    np.clip(j, 0, n_rho - 1, out=j)
    j += (np.arange(t.size) + start)[:, None] * n_rho                    # each row's cells: its theta's
    return j


GRID_CELLS = 4096 * 36
"""Most cells (pixels x directions) of a window whose every pixel's cells :func:`accumulate_window` looks up
(:func:`_grid_cells`, kept for the last :data:`GRIDS_KEPT` window shapes and grids: 0.6 MB each at most, as 32-bit
indices: a 64 px window and seed 001's 36 directions); a larger window, or a finer grid, is voted by
:func:`accumulate`."""
GRIDS_KEPT = 32
"""Window shapes and grids whose cells :func:`_grid_cells` keeps (a box's searches meet a few: the 16 and 40 px
windows, their halves, and those clipped by the box's edges)."""


def accumulate_window(binary: np.ndarray, thetas: np.ndarray, rho_min: float, rho_step: float,
                      n_rho: int) -> np.ndarray:
    """:func:`accumulate` of the True pixels of the 2-D ``binary`` (x = column, y = row): the same votes, the cells of
    a small window's pixels (:data:`GRID_CELLS`) looked up instead of computed (a Hough search votes thousands of
    windows of a few shapes: a third of the time)."""
    h, w = binary.shape
    if h * w * len(thetas) > GRID_CELLS:
        ys, xs = np.nonzero(binary)
        return accumulate(xs, ys, thetas, rho_min, rho_step, n_rho)
    cells = _grid_cells(h, w, np.asarray(thetas, np.float64).tobytes(), rho_min, rho_step, n_rho)
    votes = np.bincount(cells[np.flatnonzero(binary)].ravel(), minlength=cells.shape[1] * n_rho)
    return votes.reshape(cells.shape[1], n_rho).astype(np.float64)


@functools.lru_cache(maxsize=GRIDS_KEPT)
def _grid_cells(h: int, w: int, thetas: bytes, rho_min: float, rho_step: float, n_rho: int) -> np.ndarray:
    """The cells (:func:`_cells`) of every pixel of an ``h`` x ``w`` window (row-major) in every row of the grid of
    normal directions ``thetas`` (float64 bytes), as ``(h * w, directions)``: a pixel's cells are one row, 32-bit
    where the accumulator's cells are so numbered (as fast to count, half the memory); read-only."""
    ys, xs = np.divmod(np.arange(h * w), w)
    t = np.frombuffer(thetas, np.float64)
    j = _cells(xs.astype(np.float64), ys.astype(np.float64), t, 0, rho_min, rho_step, n_rho)
    cells = np.ascontiguousarray(j.T, np.int32 if t.size * n_rho <= np.iinfo(np.int32).max else np.int64)
    cells.setflags(write=False)
    return cells


def intersection(theta1: float, rho1: float, theta2: float, rho2: float) -> tuple[float, float] | None:
    """The point (x, y) on both lines x cos(theta_k) + y sin(theta_k) = rho_k (thetas in radians).

    The inverse transform of seed 001, eq. 2 (valid for any angle between the lines); None when the lines
    are parallel (determinant below :data:`PARALLEL`).

    Examples
    --------
    >>> intersection(0.0, 9.0, np.pi / 2, 17.0)
    (9.0, 17.0)
    >>> intersection(0.3, 1.0, 0.3, 2.0) is None
    True
    """
    c1, s1, c2, s2 = np.cos(theta1), np.sin(theta1), np.cos(theta2), np.sin(theta2)
    det = c1 * s2 - c2 * s1
    if abs(det) < PARALLEL:
        return None
    return float((rho1 * s2 - rho2 * s1) / det), float((-rho1 * c2 + rho2 * c1) / det)


__all__ = ["accumulate", "accumulate_window", "intersection", "theta_grid"]
