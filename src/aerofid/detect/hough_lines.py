"""The Hough transform of straight lines, shared by the ``hough`` (seed 001) and ``lines`` (seed 004) methods.

A line is written in normal form, rho = x cos(theta) + y sin(theta) (Hunt, Ryan & Gifford, seed 001, eq. 1;
Sohn et al., seed 004, eq. 3), theta the direction of its normal on [0, 180) degrees (seed 004, eq. 5) and
rho its signed distance from the window's top-left pixel centre. :func:`accumulate` votes every point into
the cells of a (theta, rho) grid; :func:`intersection` inverts two such lines into the point where they cross
(seed 001, eq. 2, "the inverse transform"; seed 004: "we calculated the intersection of the lines").
"""

from __future__ import annotations

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
        t = np.asarray(thetas[start:start + block], np.float64)
        rho = np.outer(np.cos(t), xs) + np.outer(np.sin(t), ys)          # (block, n_points)
        j = np.floor((rho - rho_min) / rho_step).astype(np.int64)
        np.clip(j, 0, n_rho - 1, out=j)
        j += (np.arange(t.size) + start)[:, None] * n_rho                # each row's cells: its theta's
        votes = np.bincount(j.ravel(), minlength=n_theta * n_rho)
        acc = votes if acc is None else acc + votes
    assert acc is not None
    return acc.reshape(n_theta, n_rho).astype(np.float64)


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


__all__ = ["accumulate", "intersection", "theta_grid"]
