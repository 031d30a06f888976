"""Correspondence of unnamed measured points to calibrated fiducials: the 8 arrangements of the film in the
scanner (4 rotations x 2 sides), each tested and the best kept only when it is significantly better."""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.orientation.adjustment import adjust
from aerofid.orientation.f_distribution import f_critical
from aerofid.orientation.transform import transform_class
from aerofid.scipy_kernels import linear_sum_assignment

#: Significance level of the test that tells two fiducial arrangements apart.
ALPHA_ARRANGEMENT = 0.01
FILM_TURN_DEG = 15.0
"""The film's largest turn in the scanner beyond its arrangement when points are assigned to fiducials: a film laid
by hand lies within a degree or two of the scanner's axes (a whole frame's layout search allows 4). Any turn (45
degrees either way) cannot be allowed: a square of points fits a square of fiducials at every turn, and the four midside
marks of a frame whose corners were not found were named corners, the frame turned 45 degrees (the real composite
``spymicmac_docs/zeiss_mid.png``, tests/test_frame.py)."""
#: The 8 arrangements: rotation of the film image on the scan (degrees, counter-clockwise as seen on the
#: film's mm frame) and whether the scan is mirrored (film scanned from the other side).
ARRANGEMENTS = tuple((rot, mir) for mir in (False, True) for rot in (0, 90, 180, 270))


def arrangement_matrix(rotation_deg: int, mirrored: bool, y_axis: str = "up") -> np.ndarray:
    """Signed permutation G with pixel -> mm linear part ~ s * G for this arrangement.

    The nominal arrangement (0, False) maps pixel x (column) to film x and pixel y (row, down) to film
    y, reversed when the camera's y axis points up.
    """
    L0 = np.diag([1.0, -1.0]) if y_axis == "up" else np.eye(2)
    t = math.radians(rotation_deg)
    R = np.round(np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]))
    F = np.diag([1.0, -1.0]) if mirrored else np.eye(2)
    return R @ L0 @ F


def lie_of(pixel_to_mm: np.ndarray, y_axis: str = "up") -> tuple[int, bool]:
    """The arrangement (rotation, mirrored) whose :func:`arrangement_matrix` is nearest the linear part of a
    pixel -> mm transformation (a scan turned a few degrees still has its film lie).

    >>> lie_of(0.02 * arrangement_matrix(270, True))
    (270, True)
    """
    A = np.asarray(pixel_to_mm, float)[:2, :2]
    return max(ARRANGEMENTS, key=lambda a: float(np.sum(arrangement_matrix(a[0], a[1], y_axis) * A)))


@dataclass(frozen=True)
class ArrangementFit:
    """The best assignment of the measured points under one arrangement and its fit."""

    rotation_deg: int
    mirrored: bool
    assignment: tuple[int, ...]          # for each measured point, the index of the calibrated fiducial
    sum_sq_mm2: float                    # v^T v of the fit with that assignment
    rms_mm: float
    redundancy: int

    def to_dict(self, fiducial_names: Sequence[str] | None = None) -> dict:
        a = [fiducial_names[j] for j in self.assignment] if fiducial_names is not None else list(self.assignment)
        return {"rotation_deg": self.rotation_deg, "mirrored": self.mirrored, "assignment": a,
                "rms_mm": self.rms_mm, "sum_sq_mm2": self.sum_sq_mm2, "redundancy": self.redundancy}


@dataclass(frozen=True)
class Correspondence:
    """Which calibrated fiducial each measured point is, found by testing the 8 arrangements.

    Attributes
    ----------
    status : str
        ``"unique"`` or ``"ambiguous"``.
    best : ArrangementFit
        The best-fitting arrangement.
    candidates : tuple of ArrangementFit
        All arrangements tested (one per distinct assignment), best first.
    reason : str
        Why it is ambiguous (empty when unique).
    fiducial_names : tuple of str
        The camera's fiducial names, to report assignments by name.
    """

    status: str
    best: ArrangementFit
    candidates: tuple[ArrangementFit, ...]
    reason: str = ""
    fiducial_names: tuple[str, ...] = ()
    tied: tuple[ArrangementFit, ...] = ()
    """The arrangements that fit as well as the best by the F test (the best among them; empty when unique)."""

    @property
    def assignment(self) -> tuple[int, ...]:
        return self.best.assignment

    def to_dict(self) -> dict:
        names = self.fiducial_names or None
        return {"status": self.status, "rotation_deg": self.best.rotation_deg, "mirrored": self.best.mirrored,
                "assignment": self.best.to_dict(names)["assignment"], "reason": self.reason,
                "candidates": [c.to_dict(names) for c in self.candidates]}


class AmbiguousCorrespondenceError(AerofidInputError):
    """Two arrangements of the fiducials fit the measurements equally well; names are needed."""

    def __init__(self, message: str, correspondence: Correspondence):
        super().__init__(message)
        self.correspondence = correspondence


def match_fiducials(px: np.ndarray, mm: np.ndarray, model: str = "affine", *, y_axis: str = "up",
                    fiducial_names: Sequence[str] | None = None, alpha: float = ALPHA_ARRANGEMENT,
                    max_rotation_deg: float = FILM_TURN_DEG) -> Correspondence:
    """Assign unnamed measured points (m x 2 px) to calibrated fiducials (n x 2 mm), m <= n.

    For each of the 8 arrangements (4 rotations x 2 sides) every pair of measured points is matched to every pair of
    calibrated fiducials; the similarity they define (rotation within ``max_rotation_deg`` of the arrangement,
    :data:`FILM_TURN_DEG`; at most 45, so each hypothesis belongs to one arrangement) maps all fiducials onto the scan
    and the measured points are assigned to them (Hungarian method). The best assignment of each arrangement is then
    fitted with ``model`` (similarity when the model has no redundancy) and the arrangements are ranked by ``v^T v``.
    The best is ``unique`` only if the runner-up is worse by the F test ``v2^T v2 / v1^T v1 > F(r, r; 1 - alpha)``;
    otherwise the answer is ``ambiguous``.
    """
    px = np.asarray(px, dtype=float).reshape(-1, 2)
    mm = np.asarray(mm, dtype=float).reshape(-1, 2)
    m, n = len(px), len(mm)
    if m > n:
        raise AerofidInputError(f"{m} measured points but the camera has only {n} fiducials")
    if m < 2:
        raise AerofidInputError("at least 2 measured points are needed to assign them to fiducials")
    cls = transform_class(model)
    rank_model = model if 2 * m - cls.n_params > 0 and m >= cls.min_points else "similarity"
    lim = math.radians(max_rotation_deg) + 1e-9
    fits = [fit for rot, mir in ARRANGEMENTS
            if (fit := _arrangement_fit(px, mm, rot, mir, y_axis, lim, rank_model)) is not None]
    if not fits:
        raise AerofidInputError("the measured points cannot be matched to the camera's fiducials")
    names = tuple(fiducial_names) if fiducial_names is not None else ()
    return _decide(_distinct(fits), alpha, names)


def _arrangement_fit(px: np.ndarray, mm: np.ndarray, rot: int, mir: bool, y_axis: str, lim: float,
                     rank_model: str) -> ArrangementFit | None:
    """The best assignment under one arrangement, fitted with ``rank_model`` (None when none fits)."""
    G = arrangement_matrix(rot, mir, y_axis)
    Cp = mm @ np.linalg.inv(G).T                            # fiducials in the scan's orientation (px-like, scaled)
    assign = _best_assignment(px, Cp, lim)
    if assign is None:
        return None
    try:
        fit = adjust(px, mm[list(assign)], rank_model)
    except AerofidInputError:
        return None
    ss = float(fit.v @ fit.v)
    return ArrangementFit(rot, mir, assign, ss, math.sqrt(ss / len(px)), fit.redundancy)


TIE = 1e-9
"""Relative difference below which two assignments' costs are equal (rounding)."""


def _best_assignment(px: np.ndarray, Cp: np.ndarray, lim: float) -> tuple[int, ...] | None:
    """The assignment of the measured points to the fiducials ``Cp`` with the least squared distance over
    the similarities defined by a pair of each (rotation within ``lim`` radians); of equal costs (within
    :data:`TIE`), the first hypothesis's (pairs of points in order, then ordered pairs of fiducials).

    The projections of every hypothesis within the rotation limit are computed at once (:func:`_pair_similarities`);
    the optimal assignment of one
    (Hungarian method) costs at least the sum of each point's least squared distance, so hypotheses are solved in
    the order of that bound and the rest skipped once the bound exceeds the least cost found."""
    order, proj = _pair_similarities(px, Cp, lim)
    if order.size == 0:
        return None
    dx = px[:, None, None, 0] - proj[:, :, 0].T
    dy = px[:, None, None, 1] - proj[:, :, 1].T
    D = dx * dx + dy * dy                            # m x n x h: the hypotheses last, so that each reduction is
    nearest = D.argmin(axis=1)                       # elementwise across whole rows of them
    # each hypothesis's least distances summed along a row of its own, as np.sum adds a point's (the order of the
    # terms decides ties at the TIE band's edge)
    bound = np.ascontiguousarray(np.take_along_axis(D, nearest[:, None], axis=1)[:, 0].T).sum(axis=1)
    ranked = np.sort(nearest, axis=0)
    plain = (ranked[1:] != ranked[:-1]).all(axis=0)          # each point's nearest fiducial its own: cost = bound
    solved: list[tuple[float, int, tuple[int, ...]]] = []
    least = np.inf
    for h in np.argsort(bound, kind="stable").tolist():
        if bound[h] > least + TIE * max(least, 1.0):
            break
        if plain[h]:
            cost, cols = float(bound[h]), nearest[:, h]
        else:
            rows, cols = _assignment(np.ascontiguousarray(D[:, :, h]))
            cost, cols = float(D[rows, cols, h].sum()), cols[np.argsort(rows)]
        least = min(least, cost)
        solved.append((cost, int(order[h]), tuple(cols.tolist())))
    return min((k, a) for c, k, a in solved if c <= least + TIE * max(least, 1.0))[1]


@functools.lru_cache(maxsize=32)
def _index_pairs(m: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of the m measured points (i1 < i2, in order) and every ordered pair of the n fiducials (j1, j2): a
    hypothesis is one of each, pairs of points first."""
    points = np.array(list(itertools.combinations(range(m), 2)), int).reshape(-1, 2)
    fids = np.array(list(itertools.permutations(range(n), 2)), int).reshape(-1, 2)
    return points, fids


def _assignment(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The optimal assignment of the rows of ``D`` (m <= n) to distinct columns, as ``linear_sum_assignment``
    gives it: each row's nearest column when those are distinct (their sum is the least any assignment can cost),
    else the Hungarian method (scipy's, :func:`aerofid.scipy_kernels.linear_sum_assignment`: loaded only then, and
    without scipy.optimize's start-up)."""
    cols = D.argmin(axis=1)
    if len(set(cols.tolist())) == len(cols):
        return np.arange(len(cols)), cols
    return linear_sum_assignment(D)


def _pair_similarities(px: np.ndarray, Cp: np.ndarray, lim: float) -> tuple[np.ndarray, np.ndarray]:
    """The hypotheses k (:func:`_index_pairs`) whose similarity, mapping the pair of fiducials ``Cp`` onto the pair of
    measured points ``px``, exists and rotates by at most ``lim`` radians; and for each of them the fiducials
    projected into the scan by it (h x n x 2). Each pair's length and direction is computed once."""
    points, fids = _index_pairs(len(px), len(Cp))
    dm, dc = px[points[:, 1]] - px[points[:, 0]], Cp[fids[:, 1]] - Cp[fids[:, 0]]
    nm, nc = np.hypot(dm[:, 0], dm[:, 1]), np.hypot(dc[:, 0], dc[:, 1])
    ang = np.arctan2(dm[:, 1], dm[:, 0])[:, None] - np.arctan2(dc[:, 1], dc[:, 0])
    ang = ((ang + math.pi) % (2 * math.pi) - math.pi).ravel()
    ok = np.flatnonzero(((nm[:, None] > 0) & (nc > 0)).ravel() & (np.abs(ang) <= lim))
    ip, jf = np.divmod(ok, len(fids))
    k, ang, p1, j1 = nm[ip] / nc[jf], ang[ok], px[points[ip, 0]], fids[jf, 0]
    c, s = (k * np.cos(ang))[:, None], (k * np.sin(ang))[:, None]                # the rotation [[c, -s], [s, c]]
    x, y = Cp[:, 0], Cp[:, 1]
    x1, y1 = x[j1][:, None], y[j1][:, None]
    tx, ty = p1[:, :1] - (c * x1 + -s * y1), p1[:, 1:] - (s * x1 + c * y1)
    return ok, np.stack([c * x + -s * y + tx, s * x + c * y + ty], axis=2)    # h x n x 2


def _distinct(fits: list[ArrangementFit]) -> list[ArrangementFit]:
    """One candidate per distinct assignment, best first."""
    fits = sorted(fits, key=lambda f: f.sum_sq_mm2)
    uniq: list[ArrangementFit] = []
    for f in fits:
        if all(f.assignment != g.assignment for g in uniq):
            uniq.append(f)
    return uniq


NAME_THE_POINTS = "name the measured points"
"""How an ambiguous correspondence's reason ends: what to do (the CLI says more where the points are named)."""


def _decide(uniq: list[ArrangementFit], alpha: float, names: tuple[str, ...]) -> Correspondence:
    """Unique when the runner-up fits worse by the F test, else ambiguous with the reason."""
    best = uniq[0]
    if len(uniq) == 1:
        return Correspondence("unique", best, tuple(uniq), "", names)
    second = uniq[1]
    r = best.redundancy
    if r < 1:
        reason = "no redundancy to compare the arrangements: measure more fiducials or give names"
        return Correspondence("ambiguous", best, tuple(uniq), reason, names, tuple(uniq))
    crit = f_critical(alpha, r, r)
    ratio = second.sum_sq_mm2 / max(best.sum_sq_mm2, 1e-30)
    if ratio > crit:
        return Correspondence("unique", best, tuple(uniq), "", names)
    reason = (f"arrangements rotation {best.rotation_deg} deg{' mirrored' if best.mirrored else ''} "
              f"(rms {best.rms_mm * 1000:.2f} um) and rotation {second.rotation_deg} deg"
              f"{' mirrored' if second.mirrored else ''} (rms {second.rms_mm * 1000:.2f} um) fit equally well "
              f"(ratio {ratio:.3g} <= F({r}, {r}; {1 - alpha:g}) = {crit:.3g}): {NAME_THE_POINTS}")
    tied = tuple(f for f in uniq if f.sum_sq_mm2 / max(best.sum_sq_mm2, 1e-30) <= crit)
    return Correspondence("ambiguous", best, tuple(uniq), reason, names, tied)


__all__ = ["ALPHA_ARRANGEMENT", "ARRANGEMENTS", "FILM_TURN_DEG", "NAME_THE_POINTS", "AmbiguousCorrespondenceError",
           "ArrangementFit", "Correspondence", "arrangement_matrix", "lie_of", "match_fiducials"]
