"""The nearest of a frame's screened features (a few hundred points) to each of many points, within a tolerance:
what the layout search (:mod:`aerofid.frame.layout`) asks of every hypothesis's predicted fiducials.

The features lie in a grid of square cells a little wider than the tolerance; a point's features within the
tolerance lie in its own cell or one of the 8 around it, so each point is compared with those alone. Numpy only:
scipy.spatial's k-d tree answered the same, but importing it (with scipy.sparse) cost a cold ``aerofid orient``
0.3-0.5 s, more than the layout search on an 11000^2 frame takes."""

from __future__ import annotations

import numpy as np

GRID_CELLS = 4_000_000
"""Most cells of a :class:`NearestWithin` grid; a tolerance too small for one (a grid of more cells over the features'
extent) compares the points with every feature."""
BLOCK = 2048
"""Points compared with every feature at once where there is no grid (memory: ``BLOCK`` x features)."""
NEIGHBOURS = 16
"""Points either side in the order of x, and of y, with which :func:`nearest_other` compares each point first."""


class NearestWithin:
    """Each point's nearest feature within ``tol`` px: distance ``sqrt(dx^2 + dy^2)`` and index, ``inf`` and
    ``len(features)`` where no feature lies within the tolerance, tested on squares: ``dx^2 + dy^2 < tol^2``
    (:attr:`limit`; strictly: a tolerance that is not positive, or whose square underflows, holds nothing). Of
    features at the same distance, the first (the stronger of a frame's). These are the answers of
    ``scipy.spatial.cKDTree(features).query(points, distance_upper_bound=tol)`` for a positive tolerance, but for the
    tree's own choice between features at the same distance. Points that are not finite are misses; features must
    be finite."""

    def __init__(self, features: np.ndarray, tol: float):
        self.features = np.asarray(features, np.float64).reshape(-1, 2)
        if not np.all(np.isfinite(self.features)):
            raise ValueError("features must be finite")
        self.n, self.tol = len(self.features), float(tol)
        self.limit = self.tol * self.tol if self.tol > 0 else 0.0
        self.grid = False
        if not (self.n and self.limit > 0):
            return
        self.cell = 1.01 * self.tol     # points within tol differ by less than one cell: their cells are neighbours
        self.origin = self.features.min(axis=0)                     # cells 2 .. w - 3: two empty ones either side
        cells = self._cells(self.features)
        w, h = (cells.max(axis=0) + 3).tolist()
        if not w * h <= GRID_CELLS:
            return
        self.grid, self.w, self.h = True, int(w), int(h)
        # each feature in its cell and the 8 around it: the features a point of cell c may be near are
        # order[start[c]:start[c + 1]], cell by cell and in their order within each
        key = (cells[:, 1].astype(np.intp) * self.w + cells[:, 0].astype(np.intp))[:, None] + _around(self.w)
        self.order = np.argsort(key.ravel(), kind="stable") // key.shape[1]
        self.start = np.zeros(self.w * self.h + 1, np.intp)
        np.cumsum(np.bincount(key.ravel(), minlength=self.w * self.h), out=self.start[1:])

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        points = np.asarray(points, np.float64).reshape(-1, 2)
        d, idx = np.full(len(points), np.inf), np.full(len(points), self.n, np.intp)
        if not (self.n and self.limit > 0 and len(points)):
            return d, idx
        pt, feat = self._pairs(points) if self.grid else self._all_pairs(points)
        dx = points[pt, 0] - self.features[feat, 0]
        dy = points[pt, 1] - self.features[feat, 1]
        square = dx * dx + dy * dy
        hit = square < self.limit
        pt, feat, square = pt[hit], feat[hit], square[hit]
        if not len(pt):
            return d, idx
        # the pairs come point by point: each point's least square, and of the features at it the first
        first = np.flatnonzero(np.concatenate(([True], pt[1:] != pt[:-1])))
        least = np.minimum.reduceat(square, first)
        at_least = square == np.repeat(least, np.diff(first, append=len(pt)))
        chosen = np.minimum.reduceat(np.where(at_least, feat, self.n), first)
        d[pt[first]], idx[pt[first]] = np.sqrt(least), chosen
        return d, idx

    def _pairs(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point, feature) index pairs of every point with each feature in its cell and the 8 around it, point by
        point."""
        cells = self._cells(points)
        look = np.flatnonzero((cells[:, 0] >= 1) & (cells[:, 0] < self.w - 1)
                              & (cells[:, 1] >= 1) & (cells[:, 1] < self.h - 1))
        key = cells[look, 1].astype(np.intp) * self.w + cells[look, 0].astype(np.intp)
        lo = self.start[key]
        count = self.start[key + 1] - lo
        pt = np.repeat(look, count)
        # each pair's place among the features about its cell: lo, lo + 1, ... lo + count - 1
        at = np.arange(len(pt)) - np.repeat(np.cumsum(count) - count - lo, count)
        return pt, self.order[at]

    def _cells(self, points: np.ndarray) -> np.ndarray:
        """Each point's cell (column, row) as floats, the features' least coordinates in cell 2."""
        with np.errstate(invalid="ignore", over="ignore"):
            return np.floor((points - self.origin) / self.cell) + 2

    def _all_pairs(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point, feature) index pairs of every finite point near the features' bounding box (twice the tolerance
        and a rounding's worth beyond it) with every feature within the tolerance (no grid: the tolerance is too small
        for one), point by point, :data:`BLOCK` points at a time."""
        margin = 2 * self.tol + 1e-9 * float(np.abs(self.features).max())
        lo, hi = self.features.min(axis=0) - margin, self.features.max(axis=0) + margin
        inside = np.flatnonzero(np.all((points >= lo) & (points <= hi), axis=1))
        pts, feats = [], []
        for b in range(0, len(inside), BLOCK):
            rows = inside[b:b + BLOCK]
            dx, dy = (points[rows, None, :] - self.features[None]).transpose(2, 0, 1)
            r, f = np.nonzero(dx * dx + dy * dy < self.limit)
            pts.append(rows[r])
            feats.append(f)
        if not pts:
            return np.zeros(0, np.intp), np.zeros(0, np.intp)
        return np.concatenate(pts), np.concatenate(feats)


def _around(w: int) -> np.ndarray:
    """The offsets of a cell's number to its own and the 8 around it in a grid ``w`` cells wide."""
    return (np.array([-1, -1, -1, 0, 0, 0, 1, 1, 1]) * w + np.tile([-1, 0, 1], 3)).astype(np.intp)


def nearest_other(points: np.ndarray) -> np.ndarray:
    """Each point's distance to its nearest other point, ``sqrt(dx^2 + dy^2)`` (0 for a point given twice; 0 for a
    single point). Each point is compared with its :data:`NEIGHBOURS` neighbours either side in the order of x and in
    the order of y, and with every other point only where, in both orders, a point beyond those neighbours could be
    nearer than the nearest found (its difference in that coordinate alone is no larger). The points must be
    finite."""
    p = np.asarray(points, np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(p)):
        raise ValueError("points must be finite")
    n = len(p)
    if n < 2:
        return np.zeros(n)
    best = np.full(n, np.inf)                               # least square distance found
    beyond = np.empty((2, n))                               # per order: least square gap to a point not compared
    reach = min(NEIGHBOURS, n - 1)
    for axis in (0, 1):
        order = np.argsort(p[:, axis], kind="stable")
        u, v = p[order, axis], p[order, 1 - axis]
        near = np.full(n, np.inf)
        for k in range(1, reach + 1):
            du, dv = u[k:] - u[:-k], v[k:] - v[:-k]
            dx, dy = (du, dv) if axis == 0 else (dv, du)
            square = dx * dx + dy * dy
            np.minimum(near[:-k], square, out=near[:-k])
            np.minimum(near[k:], square, out=near[k:])
        best[order] = np.minimum(best[order], near)
        gap = np.full((2, n), np.inf)                       # to the first point beyond the neighbours, either side
        gap[0, :n - reach - 1] = u[reach + 1:] - u[:n - reach - 1]
        gap[1, reach + 1:] = u[reach + 1:] - u[:n - reach - 1]
        beyond[axis, order] = (gap * gap).min(axis=0)
    x, y = p[:, 0], p[:, 1]
    for i in np.flatnonzero((beyond < best).all(axis=0)).tolist():
        dx, dy = x - x[i], y - y[i]
        square = dx * dx + dy * dy
        square[i] = np.inf
        best[i] = square.min()
    return np.sqrt(best)


__all__ = ["NearestWithin", "nearest_other"]
