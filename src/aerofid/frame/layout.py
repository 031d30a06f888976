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
3. The hypotheses with the most such fiducials (then the least mean distance) are each refined: a
   transformation fitted to its matches predicts every fiducial and the matches are found again. The one with
   the most support from features within a tight tolerance of the refined prediction (:func:`support`: each counts
   less the further it lies; then the least RMS distance) wins.

When the pixel size is unknown, the pixel sizes the scan's size allows are tried on a grid (:func:`scale_grid`)
and the layouts found are ranked alike (:func:`layout_candidates`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from aerofid.frame.nearest import NearestWithin, nearest_other
from aerofid.orientation.correspondence import ARRANGEMENTS, arrangement_matrix

SCALE_TOLERANCE = 0.03
"""Relative difference allowed between a pair of features' distance and a pair of fiducials' distance at the
known pixel size: scanners' and films' scale errors are a few tenths of a per cent, a coarse feature's position
a few reduced pixels over a baseline of a hundred."""
MAX_ROTATION_DEG = 4.0
"""Largest rotation of the frame in the scanner beyond the lie's multiple of 90 degrees that the search allows
(:data:`USUAL_TURNS`; a film laid by hand lies within a degree or two)."""
USUAL_TURNS = (0.0, MAX_ROTATION_DEG)
"""The frame's rotation beyond its lie's multiple of 90 degrees that the search allows by default (``turns`` of
:func:`layout_candidates`): more than the first and at most the second (degrees)."""
PIXEL_SIZE_RANGE_MM = (0.004, 0.2)
"""Pixel sizes considered when the scan says none: 4 um (6350 dpi) to 200 um (127 dpi)."""
MIN_SPAN = 0.5
"""Least share of the scan's shorter side that the fiducials span (bounds an unknown pixel size)."""
SCALE_STEP = 1.05
"""Ratio of successive pixel sizes tried when the scan says none: a hypothesis allows :data:`SCALE_TOLERANCE`
either way, so a step of 5 % misses no scale."""
MIN_SPREAD = 0.3
"""Least ratio of matched points' extents across and along their main direction for an affine fit (three
fiducials along one edge fix no affinity across it)."""
MIN_MATCHED = 3
"""Fewest fiducials with a feature for a layout to count as found (an affine transformation needs 3)."""
MAX_HYPOTHESES = 400_000
"""Most (pair of features, pair of fiducials) hypotheses scored per pixel size (in chunks)."""
CHUNK = 20_000
"""Hypotheses scored at once."""
SHORTLIST = 64
"""Hypotheses per chunk and lie, and in all, that are refined and scored again (:func:`_best_hypothesis`)."""
DECISIVE = 4
"""Hypotheses of a chunk with every fiducial on a feature within the loose tolerance (or all but one:
:data:`NEARLY_COMPLETE`) refined at once, those with the most first, then the closest: one that keeps every fiducial
within :data:`FIT_TOLERANCE_MM` after its refit ends the search (no chance match does that on the benchmark's frames
at their pixel size, but a complete layout has no bound on its support: chance features can make one; the true
layout is usually among the first chunks), else the best that keeps all but one there, closely."""
NEARLY_COMPLETE = 7
"""Fewest fiducials, all of the layout's but one, whose features lie within :data:`FIT_TOLERANCE_MM` of a refined
hypothesis's predictions, closely enough (:data:`NEARLY_SHORTFALL`), for it to end the search as a complete one
does (:func:`_decisive`; :attr:`LayoutMatch.decisive`): a camera of 8 or more fiducials. A faint midside mark ranks
below the 512 strongest features on 5 of the 20 frames of ``benchmarks/bench_frames.py``, and a painted-over one is
no feature at all; the search then ran through every hypothesis (0.5-0.8 s of an 11000^2 frame) to the same layout
(docs/benchmarks_frames.md, session 32). Such an end is not proof: chance features along a frame's border can make
such a layout before the complete one is formed, so where the pixel size is known a frame whose search ended there
and whose marks do not make it ok is measured again on the whole search's best layout where that one lies on other
features, and is reported from it unless the first stands better (:func:`aerofid.frame.orient._attempts`; with the
size unknown, the whole search's other layouts follow an early end, as a complete one's). Fewer do not end it:
session 23's early end on all but one of six fiducials stopped on chance features (tests/test_frame.py)."""
NEARLY_SHORTFALL = 1.0
"""Most that the support (:func:`support`) of a layout with all its fiducials but one on features may fall short of
their number for it to end the search (:data:`NEARLY_COMPLETE`): the true layouts of the benchmark's frames fall
short by 0.05-0.7; chance layouts, seven clutter features 30-40 px from a layout shifted 300 px, by 0.4-1.9 after
their refit, and one along a frame's border on the benchmark's frame with a mark painted over by 2.3. It keeps out
many chance layouts, not all (straight border edges: 0.3-0.8, session 32's review)."""
PRIOR_SPAN = 0.85
"""Share of a scan's longer side that its fiducials usually span (a 23 cm frame's marks 212-226 mm apart, scanned
with a margin): the pixel size tried first when the scan says none (:func:`prior_order`); of the features' extent,
the one a camera of few fiducials measures first (:func:`by_prior`)."""
UNMATCHED_RATIO = 1.04
"""A layout of a camera of fewer than :data:`SETTLING_FIDUCIALS` fiducials with one of them on no feature (or not on
one closely, :func:`_shortfall`) ranks as a complete one whose pixel size lies this ratio further from the usual one
(:func:`by_prior`). On the RC20 frame's 18 file variants of session 57's audit without their pixel size (scratch
``/tmp/s58/pen.py``), the true layouts lay 0.1-3.3 % from the usual size of their features' extent, complete, or
1.8-2.3 % with 3 of their 4 corners on features (the corner marks merge with their number dots at the screening's
scale: at quality 40, turned by 270 degrees, at half the area); complete chance layouts 4.3 % from it or further
(8.4-9.6 % on those three), incomplete ones 0.3 % or further. The ratio lies between what the first needs (above
1.015: a chance layout of 3 corners 0.3 % off must not come before a complete true one 1.8 % off) and what the
second allows (below 1.065), with a margin of 2.4 % of scale either way. Before session 58 the complete layouts took
the places of complete ones nearest the usual size first and the incomplete ones kept theirs: on those three files
4-6 complete chance layouts were measured before the true one (4.4-8.7 s)."""
SETTLING_FIDUCIALS = 5
"""Fewest fiducials for a layout with every one of them on a feature (:attr:`LayoutMatch.complete`, or
:attr:`LayoutMatch.decisive`) to end the search over unknown pixel sizes: four corners can be mimicked by the image's
own corners at another scale."""
FIT_TOLERANCE_MM = 0.3
"""How far (film mm) a fiducial may lie from the prediction of the transformation fitted to the matches, beyond
the features' own position error: the scanner's and the film's residual distortion, a few hundredths of a mm."""
DECLARED_SCALE_ERROR = 0.005
"""How far (relative) a frame's scale may depart from the pixel size the scan declares or the user gives, beyond what
its features' position error allows (:func:`on_declared_scale`): a film's shrinkage and a scanner's calibration, a
few tenths of a per cent."""


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
    turn: np.ndarray
    """The inverse of the lie's arrangement matrix: the fiducials turned into the scan's axes (mm)."""
    complete: bool = False
    """Every fiducial has a feature within :data:`FIT_TOLERANCE_MM` (plus the features' position error) of the
    refined prediction."""
    decisive: bool = False
    """Complete, or the search ended on it with all fiducials but one on features there, closely
    (:data:`NEARLY_COMPLETE`; a layout the whole search ranks first is decisive only when complete): it ends an unknown
    pixel size's search too (:func:`layout_candidates`)."""

    @property
    def n_matched(self) -> int:
        return sum(m is not None for m in self.matched)

    def predict_from(self, fiducials_mm: np.ndarray, which: list[int], points: np.ndarray) -> np.ndarray:
        """Every fiducial's pixel centre predicted from measured ``points`` (k x 2) of the fiducials ``which``: the
        calibrated layout turned by the lie and fitted to them (:func:`fit_points`: a similarity when they lie
        along one edge, so that only the scanner's small affinity is left to extrapolate, not the coarse
        features' error in this layout's own fit)."""
        return _apply(_fit_turned(fiducials_mm[which], np.asarray(points, float), self.turn), fiducials_mm)


def match_layout(features: np.ndarray, fiducials_mm: np.ndarray, y_axis: str = "up",
                 pixel_size_mm: float | None = None, position_error_px: float = 0.0,
                 tolerance_mm: float = 2.0, scan_size: tuple[int, int] | None = None) -> LayoutMatch | None:
    """The camera's fiducial layout on the scan (module docstring), or None when fewer than
    :data:`MIN_MATCHED` fiducials coincide with features: the first of :func:`layout_candidates` (whose search may
    end at all fiducials but one on features: :attr:`LayoutMatch.decisive`, not complete, says it did).

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
    found = layout_candidates(features, fiducials_mm, y_axis, pixel_size_mm, position_error_px, tolerance_mm,
                              scan_size)
    return found[0] if found else None


def layout_candidates(features: np.ndarray, fiducials_mm: np.ndarray, y_axis: str = "up",
                      pixel_size_mm: float | None = None, position_error_px: float = 0.0,
                      tolerance_mm: float = 2.0, scan_size: tuple[int, int] | None = None,
                      first_complete: bool = False, nearly: bool = True,
                      size_range: tuple[float, float] | None = None,
                      turns: tuple[float, float] = USUAL_TURNS) -> list[LayoutMatch]:
    """The layouts found (:func:`match_layout`'s parameters), best first, each with at least :data:`MIN_MATCHED`
    matches and a different set of them: one per pixel size tried. An unknown pixel size is tried on a
    geometric grid of step :data:`SCALE_STEP` over ``size_range`` (default: :func:`pixel_size_range`; each layout's
    fit then gives its own); the second and later are what the frame's measurement tries when the first one's marks
    are not found (a frame's image corners and edges can mimic a square layout at another scale).

    With ``first_complete``, unknown sizes are tried nearest the usual one first (:func:`prior_order`; nearest the
    middle of a ``size_range`` given) and the search ends at the first :attr:`~LayoutMatch.decisive` layout of at
    least :data:`SETTLING_FIDUCIALS` fiducials, which is then the one returned (the frame's measurement asks for the
    whole search when its marks do not make the frame ok). A camera of fewer fiducials at an unknown size has its
    layouts ranked by :func:`by_prior` (nearest the usual size of the features' extent first).

    ``turns``: the frame's rotation beyond its lie's multiple of 90 degrees is more than the first and at most the
    second (degrees; each hypothesis that turns it otherwise is dropped, step 2 of the module docstring).

    With ``nearly`` (the default) a layout with all its fiducials but one on close features ends a pixel size's
    search (:data:`NEARLY_COMPLETE`); without, only a complete one does (the whole search, which the frame's
    measurement asks for when such a layout's marks do not make the frame ok: a chance layout can end the search
    before the complete one is formed, tests/test_frame.py)."""
    features = np.asarray(features, float).reshape(-1, 2)
    fiducials_mm = np.asarray(fiducials_mm, float).reshape(-1, 2)
    if len(features) < 2 or len(fiducials_mm) < 2:
        return []
    settle = first_complete and can_end_early(fiducials_mm, pixel_size_mm)
    scales = ([pixel_size_mm] if pixel_size_mm is not None
              else scale_grid(size_range or pixel_size_range(fiducials_mm, scan_size)))
    if settle:
        scales = (prior_order(scales, fiducials_mm, scan_size) if size_range is None
                  else nearest_first(scales, math.sqrt(size_range[0] * size_range[1])))
    found: dict[tuple[int | None, ...], tuple[tuple[float, float], LayoutMatch]] = {}
    pairs = _Pairs.of(features)
    for s in scales:
        got = _best_hypothesis(features, pairs, fiducials_mm, y_axis, s, tolerance_mm / s + position_error_px,
                               position_error_px, nearly, turns, declared=pixel_size_mm is not None)
        if got is None or got[1].n_matched < MIN_MATCHED:
            continue
        if settle and got[1].decisive:
            return [got[1]]
        key = got[1].matched + (got[1].rotation_deg, got[1].mirrored)
        if key not in found or got[0] > found[key][0]:
            found[key] = got
    ranked = [m for _, m in sorted(found.values(), key=lambda g: g[0], reverse=True)]
    if pixel_size_mm is None and len(fiducials_mm) < SETTLING_FIDUCIALS:
        return by_prior(ranked, fiducials_mm, features_extent(features))
    return ranked


def by_prior(ranked: list[LayoutMatch], fiducials_mm: np.ndarray, extent: tuple[float, float]) -> list[LayoutMatch]:
    """Layouts of a camera of fewer than :data:`SETTLING_FIDUCIALS` fiducials found over unknown pixel sizes,
    ``ranked`` by their fit, taken nearest first (by ratio) to the pixel size at which the fiducials span
    :data:`PRIOR_SPAN` of the features' ``extent`` (:func:`features_extent`; the scan's size until session 58: 10 %
    off on a padded scan), those with a fiducial on no feature as if :data:`UNMATCHED_RATIO` further (of equals, the
    better fit first). An affine transformation fits four points near any square closely, and a frame's features form
    many such squares at other scales: on the real RC20 frame (4 calibrated corners) without a pixel size, 11 of its
    14 layouts were complete, and three chance ones at 0.077, 0.051 and 0.051 mm per px (the fiducials spanning 47-70 %
    of the scan) fitted their features more closely than the true one at 0.042 (86 %), and were each measured first
    (4.7-4.9 s in a fresh process against 0.5 s with the pixel size given)."""
    if not ranked or max(extent) <= 0.0:
        return ranked
    prior = usual_pixel_size(fiducials_mm, extent)
    unmatched = math.log(UNMATCHED_RATIO)
    n = len(fiducials_mm)
    return sorted(ranked, key=lambda m: ratio_distance(m.pixel_size_mm, prior) + unmatched * _shortfall(m, n))


def _shortfall(m: LayoutMatch, n: int) -> int:
    """How many of a layout's ``n`` fiducials lie on no feature, at least one where it is not complete (its refit can
    keep loose matches: :func:`_scored`)."""
    return max(n - m.n_matched, 0 if m.complete else 1)


def features_extent(features: np.ndarray) -> tuple[float, float]:
    """The extent (px, along x and y) of the mark-like features screened on a frame: its picture's, where the scan
    has margins (a scanner's bed, padding), which hold none."""
    width, height = np.ptp(features, axis=0)
    return float(width), float(height)


def can_end_early(fiducials_mm: np.ndarray, pixel_size_mm: float | None) -> bool:
    """Whether ``first_complete`` can end :func:`layout_candidates`'s search: the pixel size unknown, and at
    least :data:`SETTLING_FIDUCIALS` fiducials."""
    return pixel_size_mm is None and len(fiducials_mm) >= SETTLING_FIDUCIALS


def prior_order(scales: list[float], fiducials_mm: np.ndarray, scan_size: tuple[int, int] | None) -> list[float]:
    """``scales`` nearest first (by ratio) to the pixel size at which the fiducials span :data:`PRIOR_SPAN` of the
    scan's longer side; as given without a scan size.

    >>> fiducials = np.array([[-85.0, 0.0], [85.0, 0.0]])           # 170 mm apart: 0.0215 mm on 9300 px
    >>> [round(s, 3) for s in prior_order([0.02, 0.021, 0.022, 0.023], fiducials, (9300, 9000))]
    [0.022, 0.021, 0.023, 0.02]
    """
    if scan_size is None:
        return list(scales)
    return nearest_first(scales, usual_pixel_size(fiducials_mm, scan_size))


def usual_pixel_size(fiducials_mm: np.ndarray, size: tuple[float, float]) -> float:
    """The pixel size (mm/px) at which the fiducials span :data:`PRIOR_SPAN` of the longer side of ``size`` (px: a
    scan's, or its features' extent)."""
    return fiducial_span(fiducials_mm) / (PRIOR_SPAN * max(size))


def fiducial_span(fiducials_mm: np.ndarray) -> float:
    """The fiducials' larger extent (mm), along x or y."""
    return float(np.ptp(fiducials_mm, axis=0).max())


def nearest_first(scales: list[float], prior: float) -> list[float]:
    """``scales`` nearest ``prior`` first, by ratio (of equals the first given).

    >>> nearest_first([0.02, 0.021, 0.022], 0.0218)
    [0.022, 0.021, 0.02]
    """
    return sorted(scales, key=lambda s: ratio_distance(s, prior))


def ratio_distance(size: float, prior: float) -> float:
    """How far the pixel size ``size`` lies from ``prior``, by ratio: ``|log(size / prior)|``."""
    return abs(math.log(size / prior))


def pixel_size_range(fiducials_mm: np.ndarray, scan_size: tuple[int, int] | None) -> tuple[float, float]:
    """The pixel sizes (mm/px) a scan of ``scan_size`` px can have: its fiducials fit in the scan, and they
    span at least :data:`MIN_SPAN` of its shorter side (a scan holds one frame); :data:`PIXEL_SIZE_RANGE_MM`
    without a size."""
    lo, hi = PIXEL_SIZE_RANGE_MM
    if scan_size is None:
        return lo, hi
    extent = fiducial_span(fiducials_mm)
    return max(lo, extent / max(scan_size)), min(hi, extent / (MIN_SPAN * min(scan_size)))


def scale_grid(size_range: tuple[float, float]) -> list[float]:
    """Pixel sizes from ``size_range``'s low end up to its high end by factors :data:`SCALE_STEP`.

    >>> [round(s, 4) for s in scale_grid((0.02, 0.022))]
    [0.02, 0.021, 0.022]
    """
    lo, hi = size_range
    n = max(int(math.ceil(math.log(hi / lo) / math.log(SCALE_STEP) - 1e-9)), 0) if hi > lo else -1
    return [lo * SCALE_STEP ** i for i in range(n + 1)]


class _Pairs:
    """Every pair of features (i < k), pairs of strong features first, with their distances (px, :meth:`distances`)
    and directions (radians, from i to k, :meth:`directions`): what :func:`_hypothesis_chunks` and the rotation limit
    need at every pixel size, computed as far as the search reaches (it usually ends within the first fifth of a
    frame's 130816 pairs, and 17 ms of their arithmetic); and each feature's distance to its nearest other (0 for a
    feature given twice), which :class:`_NearFeatures` needs at every pixel size."""

    def __init__(self, features: np.ndarray, i: np.ndarray, k: np.ndarray):
        self.i, self.k = i, k
        self._x, self._y = np.ascontiguousarray(features[:, 0]), np.ascontiguousarray(features[:, 1])
        self.count = len(i)
        self._d_px, self._direction, self._done = np.empty(self.count), np.empty(self.count), 0
        self.clearance = nearest_other(features)

    @classmethod
    def of(cls, features: np.ndarray) -> _Pairs:
        # pairs of strong features first: by i + k, then k; for each sum s = i + k, k runs from s // 2 + 1 up
        n = len(features)
        s = np.arange(1, 2 * n - 2)
        first, count = s // 2 + 1, np.minimum(s, n - 1) - s // 2
        k = np.arange(count.sum()) + np.repeat(first - np.cumsum(count) + count, count)
        return cls(features, np.repeat(s, count) - k, k)

    def _reach(self, end: int) -> None:
        """The distances and directions of the pairs up to ``end`` (exclusive) computed: at least twice as many as
        before, so that a search through every pair computes them in a few passes."""
        if end > self._done:
            end = min(max(end, 2 * self._done), self.count)
            a = slice(self._done, end)
            k, i = self.k[a], self.i[a]
            dx, dy = self._x[k] - self._x[i], self._y[k] - self._y[i]      # the columns apart: 5x faster gathers
            self._d_px[a], self._direction[a] = np.hypot(dx, dy), np.arctan2(dy, dx)
            self._done = end

    def distances(self, a0: int, a1: int) -> np.ndarray:
        """The distances (px) of pairs ``a0 .. a1 - 1``."""
        self._reach(a1)
        return self._d_px[a0:a1]

    def directions(self, pair: np.ndarray) -> np.ndarray:
        """The directions (radians) of the pairs ``pair`` (indices)."""
        if len(pair):
            self._reach(int(pair.max()) + 1)
        return self._direction[pair]


PAIR_BLOCK = 4096
"""Pairs of features whose hypotheses are formed at once (:func:`_hypothesis_chunks`): the search usually ends in its
first chunks, so the hypotheses of later pairs are not formed."""


class _DistanceBand:
    """The ordered pairs of fiducials whose distance ``d_mm`` (mm) agrees with a pair of features' distance ``d``
    (px times the pixel size): ``|d - d_mm| <= SCALE_TOLERANCE * d_mm``, the pairs that ``np.nonzero`` of that test
    over every ``(d, d_mm)`` gives, in its order (pairs of features in turn, the fiducial pairs of each in their
    order). A pair of features agrees with a few of a camera's fiducial pairs (56 for 8 fiducials), so they are found
    by bisection in the sorted distances, among those within ``d / (1 + SCALE_TOLERANCE) .. d / (1 -
    SCALE_TOLERANCE)`` and a rounding's worth more, on which the test itself then decides (formed by the test of
    every pair, the hypotheses took 0.4 of an 11000^2 frame's layout search, docs/benchmarks_frames.md, session 41)."""

    def __init__(self, d_mm: np.ndarray):
        self.d_mm, self.band = d_mm, SCALE_TOLERANCE * d_mm
        self.order = np.argsort(d_mm, kind="stable")
        self.sorted = d_mm[self.order]

    def __call__(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(a, b)``: each pair of features ``a`` (an index into ``d``) with each fiducial pair ``b`` that agrees."""
        lo = np.searchsorted(self.sorted, d / (1 + SCALE_TOLERANCE) * (1 - ROUNDING), "left")
        hi = np.searchsorted(self.sorted, d / (1 - SCALE_TOLERANCE) * (1 + ROUNDING), "right")
        count = hi - lo
        a = np.repeat(np.arange(len(d)), count)
        b = self.order[np.arange(len(a)) - np.repeat(np.cumsum(count) - count - lo, count)]
        keep = np.abs(d[a] - self.d_mm[b]) <= self.band[b]
        key = a[keep] * len(self.d_mm) + b[keep]        # each pair of features' fiducial pairs in their order
        key.sort()
        return np.divmod(key, len(self.d_mm))


ROUNDING = 1e-9
"""Relative margin of :class:`_DistanceBand`'s bisection beyond the exact bounds (the test's own rounding is some
1e-14 of them)."""


def _hypothesis_chunks(pairs: _Pairs, fiducials_mm: np.ndarray, s: float) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """(i, k, j, l) with |features i-k| * s within :data:`SCALE_TOLERANCE` of |fiducials j-l|, pairs of strong
    features first, then by (j, l) (the first :data:`MAX_HYPOTHESES`), :data:`CHUNK` at a time, each with the index
    of its pair of features; formed :data:`PAIR_BLOCK` pairs at a time, as the search asks for them."""
    j, l = _fiducial_pairs(len(fiducials_mm))
    agree = _DistanceBand(np.hypot(*(fiducials_mm[l] - fiducials_mm[j]).T))
    held: list[np.ndarray] = []              # pair indices and fiducial pairs not yet given out, in order
    n_held = given = 0
    for a0 in range(0, pairs.count, PAIR_BLOCK):
        a, b = agree(pairs.distances(a0, a0 + PAIR_BLOCK) * s)
        a = a[:MAX_HYPOTHESES - given - n_held]
        held.append(np.stack([a + a0, b[:len(a)]]))
        n_held += len(a)
        last = given + n_held >= MAX_HYPOTHESES or a0 + PAIR_BLOCK >= pairs.count
        if n_held < CHUNK and not last:
            continue
        ab = np.concatenate(held, axis=1)
        cut = n_held if last else n_held - n_held % CHUNK
        for c0 in range(0, cut, CHUNK):
            a_c, b_c = ab[:, c0:min(c0 + CHUNK, cut)]
            yield np.stack([pairs.i[a_c], pairs.k[a_c], j[b_c], l[b_c]], axis=1), a_c
        held, n_held, given = [ab[:, cut:]], n_held - cut, given + cut
        if last:
            return


def _best_hypothesis(features: np.ndarray, pairs: _Pairs, fiducials_mm: np.ndarray, y_axis: str, s: float,
                     tol: float, position_error_px: float, nearly: bool,
                     turns: tuple[float, float] = USUAL_TURNS, declared: bool = False
                     ) -> tuple[tuple[float, float], LayoutMatch] | None:
    """The best hypothesis at pixel size ``s`` (module docstring, step 3). The :data:`SHORTLIST` hypotheses with
    the most fiducials on a feature within ``tol`` (then the least mean distance), one per set of matches, are
    each refined (:func:`_refine`) and scored again by the support (:func:`support`) of the fiducials whose feature
    lies within :data:`FIT_TOLERANCE_MM` (plus ``position_error_px``) of the refined prediction, then by the RMS of
    those distances: ``tol`` must allow for a two-feature similarity's error, within which a frame dense with dots and
    texture offers chance matches for all 8 fiducials (tests/test_frame.py: 512 features with 6 true marks),
    while the true features fit a transformation to a few reduced pixels. The hypotheses are scored a chunk at
    a time, pairs of strong features first; a refined hypothesis that puts every fiducial within that tight
    tolerance of a feature ends the search (:data:`DECISIVE`), as does, with ``nearly``, one that puts all but one
    there, closely (:data:`NEARLY_COMPLETE`); with ``s`` ``declared`` (the scan's or the user's pixel size), only on
    that scale (:func:`on_declared_scale`)."""
    near: _NearFeatures | None = None
    fit_tol = FIT_TOLERANCE_MM / s + position_error_px
    scale = _DeclaredScale(s, position_error_px) if declared else None
    turned = [fiducials_mm @ np.linalg.inv(arrangement_matrix(rot, mir, y_axis)).T / s  # layout in scan axes, px
              for rot, mir in ARRANGEMENTS]
    j, l = _fiducial_pairs(len(fiducials_mm))
    directions = [np.arctan2(*(cp[l] - cp[j]).T[::-1]) for cp in turned]       # each lie's fiducial pairs'
    shortlist: dict[tuple[int, ...], tuple[int, float, int, np.ndarray]] = {}
    enough = -_decisive_count(len(fiducials_mm), nearly)        # minus the count of a hypothesis refined at once
    for hyp, pair in _hypothesis_chunks(pairs, fiducials_mm, s):
        near = near or _NearFeatures(features, tol, pairs)
        fid_pair = _pair_index(hyp[:, 2], hyp[:, 3], len(fiducials_mm))
        feature_directions = pairs.directions(pair)
        decisive: list[tuple[int, float, int, np.ndarray, tuple[int, ...]]] = []
        for a, cp in enumerate(turned):
            turning = np.compress(_may_turn_within(feature_directions, directions[a][fid_pair], turns[1]), hyp,
                                  axis=0)
            pred, kept = _predict(features, cp, turning, turns)
            if pred is None:
                continue
            d, idx = near.query_predictions(pred, np.compress(kept, turning, axis=0))
            hit = np.isfinite(d)
            count = hit.sum(axis=1)
            mean_d = np.where(hit, d, 0.0).sum(axis=1) / np.maximum(count, 1)
            top = np.lexsort((mean_d, -count))[:SHORTLIST]
            matches = np.where(hit[top], idx[top], -1).tolist()
            for h, match, c, md in zip(top.tolist(), matches, (-count[top]).tolist(), mean_d[top].tolist(),
                                       strict=True):
                key = (*match, a)
                if key not in shortlist or (c, md, a) < shortlist[key][:3]:
                    shortlist[key] = (c, md, a, pred[h])
                if c <= enough:
                    decisive.append((c, md, a, pred[h], tuple(match)))
        ended = _decisive(features, fiducials_mm, decisive, y_axis, tol, fit_tol, nearly, scale)
        if ended is not None:
            return ended
    if near is None:                                            # no hypotheses
        return None
    best: tuple[tuple[float, float], LayoutMatch] | None = None
    for _, _, a, pred_h in sorted(shortlist.values(), key=lambda g: g[:3])[:SHORTLIST]:
        scored = _scored(features, fiducials_mm, pred_h, a, y_axis, tol, fit_tol, False, scale)  # decisive: complete
        if best is None or scored[0] > best[0]:      # ties: the first lie
            best = scored
    return best


def _decisive_count(n: int, nearly: bool) -> int:
    """Fewest of ``n`` fiducials on a feature for a hypothesis or a refined layout that may end the search: all of
    them, or with ``nearly`` all but one where those are :data:`NEARLY_COMPLETE`."""
    return n - 1 if nearly and n - 1 >= NEARLY_COMPLETE else n


def _decisive(features: np.ndarray, fiducials_mm: np.ndarray,
              decisive: list[tuple[int, float, int, np.ndarray, tuple[int, ...]]], y_axis: str, tol: float,
              fit_tol: float, nearly: bool, scale: _DeclaredScale | None = None
              ) -> tuple[tuple[float, float], LayoutMatch] | None:
    """What ends :func:`_best_hypothesis`'s search in a chunk: of its hypotheses with enough fiducials on a feature
    within ``tol`` (:func:`_decisive_count`; ``decisive``: minus their count, mean distance, lie, prediction and
    matches), the :data:`DECISIVE` first, those with the most first, then the closest, refined: the first complete
    one, else the best scored :attr:`~LayoutMatch.decisive` one (``nearly``: :func:`_decisive_count`); else None.
    Off a declared ``scale`` none is decisive, and none counts among the :data:`DECISIVE`: nor does any other of the
    same features in another lie (a square's 8 lies match its 4 features alike, and its hypotheses come in eights,
    of which the first four filled the places)."""
    closest: tuple[tuple[float, float], LayoutMatch] | None = None
    off_scale: set[frozenset[int]] = set()
    refined = 0
    for _, _, a, pred_h, match in sorted(decisive, key=lambda c: c[:3]):
        if refined == DECISIVE:
            break
        if frozenset(match) in off_scale:
            continue
        scored = _scored(features, fiducials_mm, pred_h, a, y_axis, tol, fit_tol, nearly, scale)
        m = scored[1]
        if not _on_scale(m, scale):
            off_scale.add(frozenset(match))
            continue
        refined += 1
        if m.complete:
            return scored
        if m.decisive and (closest is None or scored[0] > closest[0]):
            closest = scored
    return closest


@functools.lru_cache(maxsize=8)
def _fiducial_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair (j, l) of n fiducials, j != l, in row-major order (:func:`_pair_index` numbers them)."""
    j, l = np.nonzero(~np.eye(n, dtype=bool))
    return j, l


def _pair_index(j: np.ndarray, l: np.ndarray, n: int) -> np.ndarray:
    """The number of each ordered pair (j, l) of n fiducials in :func:`_fiducial_pairs`' order."""
    return j * (n - 1) + l - (l > j)


@functools.lru_cache(maxsize=8)
def _others(n: int) -> np.ndarray:
    """For each ordered pair of n fiducials (j, l) in :func:`_fiducial_pairs`' order, the n - 2 others, in order."""
    j, l = _fiducial_pairs(n)
    keep = (np.arange(n) != j[:, None]) & (np.arange(n) != l[:, None])
    return np.nonzero(keep)[1].reshape(len(j), n - 2)


class _NearFeatures:
    """Each point's nearest feature within ``tol`` px (:class:`aerofid.frame.nearest.NearestWithin`: distance ``inf``
    and index ``len(features)`` where there is none), and each feature's distance to its nearest other."""

    def __init__(self, features: np.ndarray, tol: float, pairs: _Pairs | None = None):
        """``pairs``: the features' :class:`_Pairs`, whose clearances serve every pixel size (else made)."""
        self.query = NearestWithin(features, tol)
        self.clearance = pairs.clearance if pairs is not None else nearest_other(features)
        self.features = features

    def query_predictions(self, pred: np.ndarray, hyp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:attr:`query` of every fiducial a hypothesis predicts (``pred``, h x n x 2, of hypotheses ``hyp``: i, k, j,
        l), as h x n arrays. Fiducials j and l are predicted on features i and k (j exactly, l to rounding): their
        answers are those features, at the distance :attr:`query` computes (the square root of the sum of squared
        coordinate differences), without a look-up, wherever that is what it answers: within the tolerance, and no
        other feature as near (i's nearest other feature further than 0, k's further than twice the distance to l);
        :attr:`query` answers the rest."""
        h, n = pred.shape[:2]
        rows = np.arange(h)
        i, k, j, l = hyp.T
        dx, dy = (np.take(pred.reshape(-1, 2), rows * n + l, axis=0) - np.take(self.features, k, axis=0)).T
        square = dx * dx + dy * dy
        d_l = np.sqrt(square)
        # within the tolerance as the query tests it, on squares
        plain = (square < self.query.limit) & (self.clearance[i] > 0) & (self.clearance[k] > 2 * d_l)
        d, idx = np.empty(h * n), np.empty(h * n, np.intp)
        if plain.all():                    # each row's other fiducials (of the n - 2 that are neither j nor l)
            ask = (rows[:, None] * n + np.take(_others(n), _pair_index(j, l, n), axis=0)).ravel()
        else:
            ask = np.ones((h, n), bool)
            ask[rows[plain], j[plain]] = ask[rows[plain], l[plain]] = False
            ask = np.flatnonzero(ask)
        d[ask], idx[ask] = self.query(np.take(pred.reshape(-1, 2), ask, axis=0))
        d, idx = d.reshape(h, n), idx.reshape(h, n)
        d[rows[plain], j[plain]], idx[rows[plain], j[plain]] = 0.0, i[plain]
        d[rows[plain], l[plain]], idx[rows[plain], l[plain]] = d_l[plain], k[plain]
        return d, idx


def _scored(features: np.ndarray, fiducials_mm: np.ndarray, pred: np.ndarray, a: int, y_axis: str, tol: float,
            fit_tol: float, nearly: bool, scale: _DeclaredScale | None = None
            ) -> tuple[tuple[float, float], LayoutMatch]:
    """A hypothesis of lie ``ARRANGEMENTS[a]`` refined (:func:`_refine`) and its score: the support of the fiducials
    within ``fit_tol`` of a feature (:func:`support`), then minus the RMS of those distances; whether it is
    :attr:`~LayoutMatch.complete` and :attr:`~LayoutMatch.decisive` (with ``nearly``: else decisive when complete;
    never off a declared ``scale``, :func:`on_declared_scale`)."""
    rot, mir = ARRANGEMENTS[a]
    m = _refine(features, fiducials_mm, pred, rot, mir, y_axis, tol, fit_tol)
    d = np.array([math.hypot(*(features[k] - m.predicted[f])) for f, k in enumerate(m.matched) if k is not None])
    close = d[d <= fit_tol]
    held = round(support(d, fit_tol), 6)
    n = len(fiducials_mm)
    closely = len(close) >= _decisive_count(n, nearly) and held >= len(close) - NEARLY_SHORTFALL
    return ((held, -round(float(np.sqrt(np.mean(close ** 2))), 6) if len(close) else 0.0),
            replace(m, complete=len(close) == n, decisive=_on_scale(m, scale) and (len(close) == n or closely)))


class _DeclaredScale(NamedTuple):
    """The pixel size the scan declares or the user gives, and the features' position error (px)."""

    pixel_size_mm: float
    position_error_px: float


def _on_scale(m: LayoutMatch, scale: _DeclaredScale | None) -> bool:
    """Whether refined layout ``m`` lies on the declared ``scale`` (:func:`on_declared_scale`; None: none declared)."""
    return scale is None or on_declared_scale(m.predicted, m.pixel_size_mm, *scale)


def on_declared_scale(predicted: np.ndarray, pixel_size_mm: float, declared_mm: float,
                      position_error_px: float) -> bool:
    """Whether a layout refitted to features, its fiducials at ``predicted`` (n x 2 px) and its scale ``pixel_size_mm``,
    lies on the scale ``declared_mm`` (the scan's resolution tags, or the user's): within
    :data:`DECLARED_SCALE_ERROR` and what features ``position_error_px`` off their marks can make of the fiducials'
    span (twice the error over the largest distance between two of them). Features that are not the marks but lie
    beside each alike can form the layout too, on another scale: on the real RC20 frame mirrored, or turned by a
    quarter, the marks merged with their number dots at the screening's scale (68-80 px off each mark, outwards) made
    a layout 2.1 % larger than the scan's 600 dpi, which ended the search; the marks themselves, 0.4 % off (the
    tolerance there: 1.2 %), were then sought 71-82 px from their predictions and not found, 3 s of failed searches
    before the format's layout of 8 marks found them (scratch ``/tmp/s57/tr3.py``).

    >>> square = np.array([[0.0, 0.0], [1000.0, 0.0], [1000.0, 1000.0], [0.0, 1000.0]])
    >>> on_declared_scale(square, 0.1008, 0.1, 3.0), on_declared_scale(square, 0.1012, 0.1, 3.0)
    (True, False)
    """
    p = np.asarray(predicted, float)
    span = float(np.max(np.hypot(*(p[:, None, :] - p[None, :, :]).transpose(2, 0, 1))))
    allowed = DECLARED_SCALE_ERROR + (2.0 * position_error_px / span if span > 0 else math.inf)
    return abs(pixel_size_mm / declared_mm - 1.0) <= allowed


def support(distances: np.ndarray, tol: float) -> float:
    """How much features at ``distances`` (px; inf: none) from a refined layout's predictions support it: each within
    ``tol`` counts 1 - (d / tol)^2, the truncated quadratic cost of MSAC (Torr & Zisserman 2000) turned into a count.
    The tolerance allows for coarse features a few reduced pixels off their marks, and a frame's clutter offers chance
    matches within it, spread over it: about one half each (the mean of 1 - (d / tol)^2 for d uniform in a disc).
    Counted whole, six such (RMS 10 px within 16 px) outnumbered five marks 4.5 px from their predictions on a noisy
    3125^2 frame with a bright border (session 26), whose marks were then sought where there were none.

    >>> support(np.array([0.0, 1.0, 2.0, np.inf]), 4.0)
    2.6875
    """
    d = np.asarray(distances, float)
    with np.errstate(invalid="ignore"):
        return float(np.where(d <= tol, 1.0 - (d / tol) ** 2, 0.0).sum())


def _predict(features: np.ndarray, cp: np.ndarray, hyp: np.ndarray,
             turns: tuple[float, float] = USUAL_TURNS) -> tuple[np.ndarray | None, np.ndarray]:
    """Each hypothesis's prediction of every fiducial (h x n x 2 px): the similarity mapping fiducials j, l
    (``cp``: the layout turned by the lie, in px) onto features i, k; hypotheses that rotate the frame by no more
    than the first of ``turns`` or more than the second are dropped, and which were kept is the second answer (None
    and no hypothesis when none is)."""
    i, k, j, l = hyp.T
    dp = (features[k, 0] - features[i, 0]) + 1j * (features[k, 1] - features[i, 1])
    dc = (cp[l, 0] - cp[j, 0]) + 1j * (cp[l, 1] - cp[j, 1])
    z = dp / dc                                                   # scale x rotation as a complex number
    keep = _within_rotation(z, turns[1])
    if turns[0] > 0:
        keep &= ~_within_rotation(z, turns[0])
    if not keep.any():
        return None, keep
    z, i, j = z[keep], i[keep], j[keep]
    c = cp[:, 0] + 1j * cp[:, 1]
    p = (features[i, 0] + 1j * features[i, 1])[:, None] + z[:, None] * (c[None, :] - c[j][:, None])
    return np.stack([p.real, p.imag], axis=2), keep


ANGLE_MARGIN = 1e-9
"""Radians beyond the largest rotation that :func:`_may_turn_within` lets through (the rounding of two arctangents
and their difference is some 1e-15): :func:`_within_rotation` decides."""


def _may_turn_within(feature_direction: np.ndarray, fiducial_direction: np.ndarray,
                     max_turn_deg: float = MAX_ROTATION_DEG) -> np.ndarray:
    """Whether hypotheses may turn the frame by at most ``max_turn_deg`` (their pair of features' and pair of
    fiducials' directions, radians): a superset of :func:`_within_rotation`'s, from the directions' difference, so
    that the similarity is computed only for the few that can pass (1 in 16 of a lie's hypotheses on a frame's 512
    features)."""
    turn = np.abs(feature_direction - fiducial_direction)                  # in [0, 2 pi]: either way round
    limit = math.radians(max_turn_deg) + ANGLE_MARGIN
    return (turn <= limit) | (turn >= 2 * math.pi - limit)


def _within_rotation(z: np.ndarray, max_turn_deg: float = MAX_ROTATION_DEG) -> np.ndarray:
    """``|angle(z)| <= max_turn_deg``, as ``np.angle`` reads it: the angle computed only where the cheap test
    ``|Im z| <= tan(max_turn_deg) Re z`` is within rounding of its limit (most hypotheses turn the frame far more,
    and ``np.angle`` is an arctan2 per hypothesis), or where ``z`` is not a finite number well above underflow (zero,
    subnormal, infinite or NaN: none of a similarity between distinct points)."""
    tan_max = math.tan(math.radians(max_turn_deg))
    re, im = np.abs(z.real), np.abs(z.imag)
    plain = np.isfinite(re) & np.isfinite(im) & (np.maximum(re, im) > 1e-290)
    near = (z.real > 0) & (im <= tan_max * (1 + 1e-9) * re)
    keep = plain & near & (im <= tan_max * (1 - 1e-9) * re)
    doubt = np.flatnonzero((near | ~plain) & ~keep)
    keep[doubt] = np.abs(np.angle(z[doubt])) <= math.radians(max_turn_deg)
    return keep


def _refine(features: np.ndarray, fiducials_mm: np.ndarray, pred: np.ndarray, rot: int, mir: bool, y_axis: str,
            tol: float, fit_tol: float) -> LayoutMatch:
    """The hypothesis's matches within ``tol`` refitted (:func:`fit_points`); then, twice, the matches found again
    within ``fit_tol`` of the fit's predictions and refitted (so that a feature that is not the mark, taken within
    the loose ``tol``, does not bend the fit), as long as :data:`MIN_MATCHED` remain."""
    turn = np.linalg.inv(arrangement_matrix(rot, mir, y_axis))
    matched = _nearest(features, pred, tol)
    A = _fit_mm_to_px(fiducials_mm, features, matched, turn)
    for _ in range(2):
        pred = _apply(A, fiducials_mm)
        close = _nearest(features, pred, fit_tol)
        if sum(m is not None for m in close) < MIN_MATCHED:
            break
        matched = close
        A = _fit_mm_to_px(fiducials_mm, features, matched, turn)
    pred = _apply(A, fiducials_mm)
    pixel_mm = 1.0 / math.sqrt(abs(np.linalg.det(A[:, :2])))
    return LayoutMatch(pred, matched, A, rot, mir, pixel_mm, tol, turn)


def layout_at(points: np.ndarray, fiducials_mm: np.ndarray, rotation_deg: int, mirrored: bool, y_axis: str,
              tolerance_px: float) -> LayoutMatch:
    """The layout whose fiducials lie at ``points`` (n x 2 px, in the camera's order; e.g. where a roll's profile
    had them) in the lie ``(rotation_deg, mirrored)``, with no feature matched: ``tolerance_px`` says how far a
    mark may lie from its point.

    >>> m = layout_at(np.array([[100.0, 100.0], [300.0, 100.0], [300.0, 300.0]]),
    ...               np.array([[-10.0, 10.0], [10.0, 10.0], [10.0, -10.0]]), 0, False, "up", 50.0)
    >>> round(m.pixel_size_mm, 3), m.matched
    (0.1, (None, None, None))
    """
    turn = np.linalg.inv(arrangement_matrix(rotation_deg, mirrored, y_axis))
    A = _fit_turned(fiducials_mm, points, turn)
    det = abs(float(np.linalg.det(A[:, :2])))
    pixel_mm = 1.0 / math.sqrt(det) if det > 0 else math.inf
    return LayoutMatch(np.asarray(points, float), (None,) * len(points), A, rotation_deg, mirrored, pixel_mm,
                       tolerance_px, turn)


def _nearest(features: np.ndarray, pred: np.ndarray, tol: float) -> tuple[int | None, ...]:
    """For each prediction the nearest feature within ``tol``, each feature taken once (nearest pairs first; of equal
    distances, the prediction's and then the feature's order); a prediction that is not finite (a degenerate fit)
    matches none."""
    d = np.hypot(*(pred[:, None, :] - features[None, :, :]).transpose(2, 0, 1))
    within = np.flatnonzero(d <= tol)
    out: list[int | None] = [None] * len(pred)
    taken: set[int] = set()
    for f, k in zip(*np.unravel_index(within[np.argsort(d.flat[within], kind="stable")], d.shape), strict=True):
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
    """The matches' mm -> px (2 x 3) (:func:`_fit_turned`)."""
    idx = [(f, m) for f, m in enumerate(matched) if m is not None]
    return _fit_turned(fiducials_mm[[f for f, _ in idx]], features[[m for _, m in idx]], turn)


def _fit_turned(mm: np.ndarray, px: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """mm -> px (2 x 3) by :func:`fit_points` on the fiducials ``mm`` turned by the lie (``turn``, the inverse of
    its arrangement matrix: a similarity cannot mirror), onto the points ``px``."""
    A = fit_points(mm @ turn.T, px)
    return np.c_[A[:, :2] @ turn, A[:, 2]]


def _apply(A: np.ndarray, mm: np.ndarray) -> np.ndarray:
    """The pixel positions (n x 2) a 2 x 3 mm -> px transformation gives the fiducials ``mm``."""
    return np.c_[mm, np.ones(len(mm))] @ A.T


__all__ = ["LayoutMatch", "MIN_MATCHED", "MIN_SPREAD", "fit_points", "layout_at", "layout_candidates", "match_layout",
           "USUAL_TURNS", "nearest_first", "pixel_size_range", "can_end_early", "prior_order", "scale_grid",
           "on_declared_scale"]
