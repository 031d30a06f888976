"""Where the camera's fiducials lie on a scan: the calibrated layout matched to the mark-like features that
screening finds on the whole frame read reduced.

Seeds 002 (section 2), 003 and 004 (section 3) search *predicted fiducial areas*: the camera file's layout,
the scan's pixel size and the frame's approximate position predict where each mark lies. A scan's frame
position, its rotation in the scanner (a fraction of a degree to a few degrees), the film's lie (4 rotations x
2 sides) and, without resolution tags, its pixel size are not known in advance, so they are found here from
the features themselves, like a star tracker identifies a constellation:

1. Every pair of features (i, k) is paired with every ordered pair of fiducials (j, l) whose calibrated
   distance, divided by the pixel size, matches the features' distance (:data:`SCALE_TOLERANCE`).
2. For each lie (:func:`aerofid.orientation.correspondence.arrangement_matrix`) the similarity that maps
   fiducials j, l onto features i, k is kept when it rotates the frame by at most :data:`MAX_ROTATION_DEG`;
   it predicts every fiducial on the scan, and the fiducials with a feature within the tolerance are counted.
3. The hypothesis with the most such fiducials (then the least mean distance) wins; an affine
   transformation fitted to its matches predicts every fiducial, the matches found again with a tighter
   tolerance.

When the pixel size is unknown, every pair of pairs votes for the pixel size its distances imply; the
:data:`SCALE_PEAKS` strongest votes are each tried.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from aerofid.orientation.correspondence import ARRANGEMENTS, arrangement_matrix

SCALE_TOLERANCE = 0.03
"""Relative difference allowed between a pair of features' distance and a pair of fiducials' distance at the
known pixel size: scanners' and films' scale errors are a few tenths of a per cent, a coarse feature's position
a few reduced pixels over a baseline of a hundred."""
MAX_ROTATION_DEG = 4.0
"""Largest rotation of the frame in the scanner beyond the lie's multiple of 90 degrees."""
PIXEL_SIZE_RANGE_MM = (0.004, 0.2)
"""Pixel sizes considered when the scan says none: 4 um (6350 dpi) to 200 um (127 dpi)."""
MIN_SPAN = 0.5
"""Least share of the scan's shorter side that the fiducials span (bounds an unknown pixel size)."""
SCALE_BIN = 0.01
"""Width of a pixel-size vote's bin, in natural log (1 %)."""
SCALE_PEAKS = 3
"""The strongest pixel-size votes tried when the pixel size is unknown."""
MIN_SPREAD = 0.3
"""Least ratio of matched points' extents across and along their main direction for an affine fit (three
fiducials along one edge fix no affinity across it)."""
MIN_MATCHED = 3
"""Fewest fiducials with a feature for a layout to count as found (an affine transformation needs 3)."""
MAX_HYPOTHESES = 400_000
"""Most (pair of features, pair of fiducials) hypotheses scored per pixel size (in chunks)."""
CHUNK = 20_000
"""Hypotheses scored at once."""


@dataclass(frozen=True)
class LayoutMatch:
    """The camera's layout found on the scan.

    Attributes
    ----------
    predicted : ndarray, n x 2
        Every fiducial's predicted pixel centre (x, y), in the camera's order.
    matched : tuple of int or None
        For each fiducial, the index of the feature taken for it (None: no feature there).
    mm_to_px : ndarray, 2 x 3
        The transformation fitted to the matches (:func:`fit_points`): px = A @ [x_mm, y_mm, 1].
    rotation_deg, mirrored : int, bool
        The lie of the winning hypothesis. A layout symmetric under the lies (4 corners, 8 marks) fits
        several equally: the lie is decided later by the measured marks (:func:`aerofid.orient`).
    pixel_size_mm : float
        Mean pixel size of the fitted transformation (mm per px).
    tolerance_px : float
        How far (px) a feature may lie from its prediction to be taken for the fiducial.
    """

    predicted: np.ndarray
    matched: tuple[int | None, ...]
    mm_to_px: np.ndarray
    rotation_deg: int
    mirrored: bool
    pixel_size_mm: float
    tolerance_px: float

    @property
    def n_matched(self) -> int:
        return sum(m is not None for m in self.matched)


def match_layout(features: np.ndarray, fiducials_mm: np.ndarray, y_axis: str = "up",
                 pixel_size_mm: float | None = None, position_error_px: float = 0.0,
                 tolerance_mm: float = 2.0, scan_size: tuple[int, int] | None = None) -> LayoutMatch | None:
    """The camera's fiducial layout on the scan (module docstring), or None when fewer than
    :data:`MIN_MATCHED` fiducials coincide with features.

    Parameters
    ----------
    features : ndarray, m x 2
        Pixel centres of the mark-like features, strongest first (ties go to the stronger).
    fiducials_mm : ndarray, n x 2
        The calibrated fiducial coordinates.
    y_axis : str
        The camera's film y axis, "up" or "down".
    pixel_size_mm : float or None
        The scan's pixel size if known (mm per px).
    position_error_px : float
        How far a feature's centre may lie from the mark's (the screening's reduction): added to the tolerance.
    tolerance_mm : float
        How far (film mm) a fiducial may lie from its prediction by a similarity (the scanner's affinity,
        the film's deformation).
    scan_size : (width, height), optional
        The scan's size (px): bounds an unknown pixel size (:func:`pixel_size_range`).

    Examples
    --------
    Four corner fiducials of a 212 mm frame at 21 um, the frame shifted, among unrelated features:

    >>> mm = np.array([[-106, 106], [106, 106], [106, -106], [-106, -106]], float)
    >>> px = np.array([[300.0, 200.0], [10396.0, 200.0], [10396.0, 10296.0], [300.0, 10296.0]])
    >>> clutter = np.array([[5000.0, 5000.0], [777.0, 4000.0], [9000.0, 1234.0]])
    >>> m = match_layout(np.vstack([clutter, px]), mm, pixel_size_mm=0.021)
    >>> m.matched, m.predicted.round(3).tolist()[0]
    ((3, 4, 5, 6), [300.0, 200.0])
    """
    features = np.asarray(features, float).reshape(-1, 2)
    fiducials_mm = np.asarray(fiducials_mm, float).reshape(-1, 2)
    if len(features) < 2 or len(fiducials_mm) < 2:
        return None
    scales = ([pixel_size_mm] if pixel_size_mm is not None
              else pixel_size_votes(features, fiducials_mm, pixel_size_range(fiducials_mm, scan_size)))
    best: tuple[tuple[int, float], LayoutMatch] | None = None
    for s in scales:
        tol = tolerance_mm / s + position_error_px
        got = _best_hypothesis(features, fiducials_mm, y_axis, s, tol)
        if got is not None and (best is None or got[0] > best[0]):
            best = got
    if best is None or best[1].n_matched < MIN_MATCHED:
        return None
    return best[1]


def pixel_size_range(fiducials_mm: np.ndarray, scan_size: tuple[int, int] | None) -> tuple[float, float]:
    """The pixel sizes (mm/px) a scan of ``scan_size`` px can have: its fiducials fit in the scan, and they
    span at least :data:`MIN_SPAN` of its shorter side (a scan holds one frame); :data:`PIXEL_SIZE_RANGE_MM`
    without a size."""
    lo, hi = PIXEL_SIZE_RANGE_MM
    if scan_size is None:
        return lo, hi
    extent = float(np.ptp(fiducials_mm, axis=0).max())
    return max(lo, extent / max(scan_size)), min(hi, extent / (MIN_SPAN * min(scan_size)))


def pixel_size_votes(features: np.ndarray, fiducials_mm: np.ndarray,
                     size_range: tuple[float, float] = PIXEL_SIZE_RANGE_MM) -> list[float]:
    """The :data:`SCALE_PEAKS` pixel sizes (mm/px) most voted for by pairs of features and pairs of fiducials
    (each fiducial distance / feature distance within ``size_range`` is a vote)."""
    d_px = _pair_distances(features)
    d_mm = np.unique(np.round(_pair_distances(fiducials_mm), 6))
    ratio = d_mm[None, :] / np.maximum(d_px[:, None], 1e-9)
    lo, hi = size_range
    if lo >= hi:
        return []
    logs = np.log(ratio[(ratio >= lo) & (ratio <= hi)])
    if logs.size == 0:
        return []
    edges = np.arange(math.log(lo), math.log(hi) + SCALE_BIN, SCALE_BIN)
    votes, _ = np.histogram(logs, edges)
    votes = votes + np.roll(votes, 1) + np.roll(votes, -1)    # a true scale straddling two bins
    peaks = np.argsort(-votes, kind="stable")[:SCALE_PEAKS]
    return [float(math.exp(edges[i] + SCALE_BIN / 2)) for i in peaks if votes[i] > 0]


def _pair_distances(p: np.ndarray) -> np.ndarray:
    i, k = np.triu_indices(len(p), 1)
    return np.hypot(*(p[k] - p[i]).T)


def _hypotheses(features: np.ndarray, fiducials_mm: np.ndarray, s: float) -> np.ndarray:
    """(i, k, j, l) with |features i-k| * s within :data:`SCALE_TOLERANCE` of |fiducials j-l|, features by
    strength (the first :data:`MAX_HYPOTHESES`)."""
    i, k = np.triu_indices(len(features), 1)
    d_px = np.hypot(*(features[k] - features[i]).T) * s
    j, l = np.nonzero(~np.eye(len(fiducials_mm), dtype=bool))
    d_mm = np.hypot(*(fiducials_mm[l] - fiducials_mm[j]).T)
    order = np.lexsort((k, i + k))                                 # pairs of strong features first
    i, k, d_px = i[order], k[order], d_px[order]
    a, b = np.nonzero(np.abs(d_px[:, None] - d_mm[None, :]) <= SCALE_TOLERANCE * d_mm[None, :])
    return np.stack([i[a], k[a], j[b], l[b]], axis=1)[:MAX_HYPOTHESES]


def _best_hypothesis(features: np.ndarray, fiducials_mm: np.ndarray, y_axis: str, s: float,
                     tol: float) -> tuple[tuple[int, float], LayoutMatch] | None:
    """The best-scoring hypothesis at pixel size ``s``, refined (score: matched fiducials, -mean distance)."""
    hyp = _hypotheses(features, fiducials_mm, s)
    if len(hyp) == 0:
        return None
    tree = cKDTree(features)
    best_key: tuple[int, float] = (0, 0.0)
    best: tuple[np.ndarray, int, bool] | None = None
    for rot, mir in ARRANGEMENTS:
        cp = fiducials_mm @ np.linalg.inv(arrangement_matrix(rot, mir, y_axis)).T / s   # layout in scan axes, px
        for c0 in range(0, len(hyp), CHUNK):
            pred = _predict(features, cp, hyp[c0:c0 + CHUNK])
            if pred is None:
                continue
            d, _ = tree.query(pred.reshape(-1, 2), distance_upper_bound=tol)
            d = d.reshape(pred.shape[:2])
            hit = np.isfinite(d)
            count = hit.sum(axis=1)
            mean_d = np.where(hit, d, 0.0).sum(axis=1) / np.maximum(count, 1)
            h = int(np.lexsort((mean_d, -count))[0])
            key = (int(count[h]), -float(mean_d[h]))
            if key > best_key:
                best_key, best = key, (pred[h], rot, mir)
    if best is None:
        return None
    return best_key, _refine(features, fiducials_mm, best[0], best[1], best[2], y_axis, tol)


def _predict(features: np.ndarray, cp: np.ndarray, hyp: np.ndarray) -> np.ndarray | None:
    """Each hypothesis's prediction of every fiducial (h x n x 2 px): the similarity mapping fiducials j, l
    (``cp``: the layout turned by the lie, in px) onto features i, k; hypotheses that rotate the frame more
    than :data:`MAX_ROTATION_DEG` are dropped (NaN predictions)."""
    i, k, j, l = hyp.T
    dp = (features[k, 0] - features[i, 0]) + 1j * (features[k, 1] - features[i, 1])
    dc = (cp[l, 0] - cp[j, 0]) + 1j * (cp[l, 1] - cp[j, 1])
    z = dp / dc                                                   # scale x rotation as a complex number
    keep = np.abs(np.angle(z)) <= math.radians(MAX_ROTATION_DEG)
    if not keep.any():
        return None
    z, i, j = z[keep], i[keep], j[keep]
    c = cp[:, 0] + 1j * cp[:, 1]
    p = (features[i, 0] + 1j * features[i, 1])[:, None] + z[:, None] * (c[None, :] - c[j][:, None])
    return np.stack([p.real, p.imag], axis=2)


def _refine(features: np.ndarray, fiducials_mm: np.ndarray, pred: np.ndarray, rot: int, mir: bool, y_axis: str,
            tol: float) -> LayoutMatch:
    """The hypothesis's matches refitted (:func:`fit_points`), and the matches found again around its
    predictions, twice."""
    turn = np.linalg.inv(arrangement_matrix(rot, mir, y_axis))
    matched = _nearest(features, pred, tol)
    A = _fit_mm_to_px(fiducials_mm, features, matched, turn)
    for _ in range(2):
        pred = np.c_[fiducials_mm, np.ones(len(fiducials_mm))] @ A.T
        matched = _nearest(features, pred, tol)
        A = _fit_mm_to_px(fiducials_mm, features, matched, turn)
    pred = np.c_[fiducials_mm, np.ones(len(fiducials_mm))] @ A.T
    pixel_mm = 1.0 / math.sqrt(abs(np.linalg.det(A[:, :2])))
    return LayoutMatch(pred, matched, A, rot, mir, pixel_mm, tol)


def _nearest(features: np.ndarray, pred: np.ndarray, tol: float) -> tuple[int | None, ...]:
    """For each prediction the nearest feature within ``tol``, each feature taken once (nearest pairs first)."""
    d = np.hypot(*(pred[:, None, :] - features[None, :, :]).transpose(2, 0, 1))
    out: list[int | None] = [None] * len(pred)
    taken: set[int] = set()
    for f, k in zip(*np.unravel_index(np.argsort(d, axis=None), d.shape), strict=True):
        if d[f, k] > tol:
            break
        if out[f] is None and int(k) not in taken:
            out[f] = int(k)
            taken.add(int(k))
    return tuple(out)


def fit_points(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Least-squares ``src`` -> ``dst`` (n x 2 each) as a 2 x 3 matrix: affine when 3 or more points span both
    directions (:data:`MIN_SPREAD`), else a similarity (2 points, or 3 along one edge of the frame), which keeps
    the handedness of the points (turn mirrored points first).

    Examples
    --------
    >>> fit_points(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[5.0, 5.0], [5.0, 7.0]])).round(12).tolist()
    [[0.0, -2.0, 5.0], [2.0, 0.0, 5.0]]
    """
    sv = np.linalg.svd(src - src.mean(axis=0), compute_uv=False)
    if len(src) >= 3 and sv[-1] > MIN_SPREAD * sv[0]:
        sol, *_ = np.linalg.lstsq(np.c_[src, np.ones(len(src))], dst, rcond=None)
        return np.asarray(sol.T)
    z_src, z_dst = src[:, 0] + 1j * src[:, 1], dst[:, 0] + 1j * dst[:, 1]
    m_src, m_dst = z_src.mean(), z_dst.mean()
    c = np.vdot(z_src - m_src, z_dst - m_dst) / np.vdot(z_src - m_src, z_src - m_src)
    t = m_dst - c * m_src
    return np.array([[c.real, -c.imag, t.real], [c.imag, c.real, t.imag]])


def _fit_mm_to_px(fiducials_mm: np.ndarray, features: np.ndarray, matched: tuple[int | None, ...],
                  turn: np.ndarray) -> np.ndarray:
    """The matches' mm -> px (2 x 3) by :func:`fit_points` on the fiducials turned by the lie (``turn``, the
    inverse of its arrangement matrix: a similarity cannot mirror)."""
    idx = [(f, m) for f, m in enumerate(matched) if m is not None]
    A = fit_points(fiducials_mm[[f for f, _ in idx]] @ turn.T, features[[m for _, m in idx]])
    return np.c_[A[:, :2] @ turn, A[:, 2]]


__all__ = ["LayoutMatch", "MIN_MATCHED", "MIN_SPREAD", "fit_points", "match_layout", "pixel_size_votes"]
