"""Step 3 of :func:`aerofid.frame.orient.orient_frame`: the marks of a layout found on a scan.

Each fiducial of a layout (:class:`aerofid.frame.layout.LayoutMatch`) is measured at full resolution on windows
around its screened feature or its prediction (:class:`aerofid.find.Measurer`, as for a box): the first by ``auto``
(on the scan reduced, then alone at full resolution), the later ones by the method that found the marks so far,
alone, from predictions refined by the marks found (:func:`measure_marks`); a mark not found there is sought in its
predicted area like a region (:func:`measure_fiducial`), and the marks of the film's format that the camera file
does not list where the frame's orientation puts them (:func:`measure_extra_marks`). The adjustment and the verdict
(step 4) judge what these find.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from aerofid.conventions import Box, Polarity, opposite
from aerofid.detect.auto import AutoResult
from aerofid.detect.screen import Candidate
from aerofid.find import (
    RECENTRED_WINDOW,
    SETTLED,
    Located,
    Measurer,
    in_box,
    recentred_half,
    screen_region,
    search,
)
from aerofid.frame.layout import LayoutMatch
from aerofid.frame.profile import METHODS, RollProfile
from aerofid.frame.result import (
    FOUND_MARK,
    MISSING_MARK,
    FiducialFinding,
    FrameOrientation,
    standing,
)
from aerofid.frame.templates import MarkTemplate, match_template, reduction_keeping
from aerofid.frame.verdict import adjusted_pixel_mm
from aerofid.io.raster import clip_box
from aerofid.io.reduce import ReducedView
from aerofid.robust import median

AREA_MARGIN = 2.0
"""A predicted fiducial area reaches this many mark radii beyond the layout's tolerance."""
AREA_CANDIDATES = 8
"""Candidates measured in a predicted fiducial area."""
MIN_REFIT = 3
"""Marks found before the others are predicted from them (an affine transformation)."""
AREA_PROBES = 2
"""Fiducial areas searched in vain, before :data:`MIN_REFIT` marks are found, after which a layout's other areas
are not searched (:func:`measure_marks`): the features it matched are not the frame's marks, and each area searched
around a prediction that wrong costs seconds of failed searches. On 120 perturbed synthetic frames (session 25's
review: marks erased, displaced, covered, clutter painted on them, bright borders, noise; scratch, session 26), none
of the 140 areas searched before 3 marks were found held one, and the 15 frames that then failed took 7-124 s, 72 %
of it in those areas."""
VAIN_STARTS = 4
"""Fiducials that held no mark at their predicted places, while none is found, after which a layout's other
fiducials are not sought there and no area is searched (:func:`measure_marks`; not on a roll's layout, whose film may
have moved): its features are not the frame's marks. Of 92 layouts that found 3 marks or more (session 47: the 25
benchmark frames, the RC20 frame and its 8 lies, 60 random frames turned up to 10 degrees), 90 found their first mark
at the first fiducial sought and 2 (marks painted over) at the second; the chance layouts of noisy frames that fail
sought every fiducial at its place, 0.3 s each, and (session 47) one area, 2.2 s. The '+' marks of the demo frame
(``orient_frame``'s example), once found in their areas only, are found at their features since their refusal as cut
by a feature's window is measured again (:func:`_in_a_larger_box`, session 48)."""
UNSOUGHT = "not sought"
"""How the reason of a fiducial that :func:`measure_marks` did not seek at its predicted place begins."""
REFINED_TOLERANCE_MM = 1.0
"""How far (film mm) a mark may lie from its prediction by the found marks (a camera file's nominal values,
the film's deformation)."""
MIN_TOLERANCE_PX = 8.0
"""Least tolerance (px) of a prediction by the found marks."""
FRAME_METHOD_TOLERANCE_MM = 0.3
"""How far (film mm) a mark measured by the frame's own method alone may lie from its prediction by the found
marks: the scanner's affinity across an edge a similarity cannot follow, 0.1 % of the frame."""
ALONE_WINDOWS = ((1.0, 8.0), (1.5, 8.0))
"""The windows (half-size: times the marks' radius, plus px) a mark is measured on by the frame's method alone, in
turn: the mark and little else, then a little of its ground; both tighter than a box's re-centred window
(:data:`aerofid.find.RECENTRED_WINDOW`, 2.5 times), whose ground around the mark is there for ``auto`` to see a
second mark. The marks' radius is that of the marks found so far, which may be of another, larger kind (the Wild
cameras' corner marks beside their midside crosses): a wider window then reaches the mark's surroundings (the film's
edge, the data strip), where symmetry may refuse it. On the 23 synthetic 11000^2 frames of
``benchmarks/bench_frames.py`` (session 22, against the 1.5 times alone): error RMS per axis 0.0086 px against
0.011, the same share of errors within 3 sigma, a fifth less time per frame (the cost of symmetry falls with the
area). The real RC20 frame's marks are mostly refused on the first (a busy border) and measured on the second as
before; where neither takes them, the re-centred window (corner P3 there lies 0.27 px from its centre on the second
and from the person's click)."""
COARSE_RADIUS = 16.0
"""The first mark's ``auto`` runs on the scan reduced (by a power of two) so that the marks' radius stays at least
this many px (:func:`_coarse_first`): ``auto`` tries every method, and its cost grows with the window's area."""
EXTRA_TOLERANCE_MM = 2.0
"""How far (film mm) a mark the camera file does not list may lie from where the orientation puts its nominal
position (:func:`measure_extra_marks`; the 23 cm layout's marks lie within a few tenths of a mm of it on the
Wild cameras: the real RC20 frame's midside marks 0.1-0.2 mm)."""


def measure_marks(measurer: Measurer, layout: LayoutMatch, fiducials_mm: np.ndarray,
                  features: tuple[Candidate, ...], profile: RollProfile | None = None,
                  follow: bool = False, radii: Sequence[float] | None = None,
                  templates: Sequence[MarkTemplate | None] = ()) -> list[tuple[Located | None, str]]:
    """Step 3: each fiducial's mark (None if not found) and, if not found, why. Fiducials with a feature go first,
    strongest first. The first mark is measured by ``auto`` (on the reduced scan, :func:`_coarse_first`, else at full
    resolution, :func:`measure_fiducial`) and fixes the polarity tried first for the rest. Each later mark is measured
    first by the method that found most of the marks so far, alone (:func:`_by_method`; on its first window only while
    no mark of its kind is found), on a window sized by their extent, from its coarse answer (:func:`_coarse`) until
    :data:`MIN_REFIT` marks are found, then from the refined prediction (within 3 px of the mark on the benchmark's
    synthetic frames, where the method's first window settles: :func:`_alone`); if that fails, like the first: within
    the layout's tolerance until :data:`MIN_REFIT` marks are found, then at the prediction of a transformation fitted to
    them (:meth:`LayoutMatch.predict_from`; to a few px, :data:`REFINED_TOLERANCE_MM`), on a window sized by its own
    screening feature where it has one, or by the features of the marks of its kind found where those are smaller, never
    below the marks' extent (:func:`_fallback_start`; one of a kind none of whose marks is found yet, with a feature,
    waits once until the others of its kind have been sought). A mark not found there either is sought in its area
    (:func:`measure_fiducial`), but before :data:`MIN_REFIT` marks are found only after the fiducials that follow it
    have been measured (then sought again first where the others put it, by ``auto`` as the first marks are, in their
    polarity first: not by the frame's method alone, which lacks ``auto``'s checks and took a square of clutter left
    where a mark was erased; unless none of them was found): a feature that is no mark (an erased or hidden corner's
    clutter) is the strongest one on some frames, and its area, searched in both polarities within the layout's
    tolerance, took seconds that the refined prediction and tolerance save. Before :data:`MIN_REFIT` marks are found,
    areas are searched until :data:`AREA_PROBES` of them held no mark, the others not; while none is found, fiducials
    are sought at their places until :data:`VAIN_STARTS` held none, the others not, nor areas (:func:`_given_up`). The
    adjustment's blunder tests check them all. A roll ``profile`` gives the polarity, the method and the marks' size
    from the first mark on. With ``follow`` (a roll's layout, whose film may have moved: no features), the predictions
    before :data:`MIN_REFIT` marks are moved by the found marks' mean shift from theirs, and each is sought first where
    its learnt template correlates best within the layout's tolerance (``templates``, per fiducial:
    :mod:`aerofid.frame.templates`); ``radii`` (px, per fiducial: a roll's learnt sizes) size each mark's window."""
    n = len(fiducials_mm)
    strength = [0.0 if m is None else features[m].strength for m in layout.matched]
    order = sorted(range(n), key=lambda k: (layout.matched[k] is None, -strength[k]))
    out: list[tuple[Located | None, str]] = [(None, "")] * n
    other: Polarity | None = None               # the polarity tried when the frame's (fixed by its first mark) fails
    if profile is not None and len(measurer.polarities) > 1:
        measurer = replace(measurer, polarities=(profile.polarity,))
        other = opposite(profile.polarity)
    later: dict[int, tuple[int, Candidate, str]] = {}   # an area search put off: the marks found then, start, why
    vain: list[int] = []                        # fiducials whose areas held no mark before MIN_REFIT were found
    waiting: set[int] = set()                   # put off from MIN_REFIT on until the others of their kind are sought
    kinds = fiducial_kinds(fiducials_mm)
    for i, k in enumerate(order):               # (a put-off fiducial is appended to ``order``)
        done = [j for j in range(n) if out[j][0] is not None]
        at, start, tolerance, alone_tolerance, name = _sought(k, out, done, layout, fiducials_mm, features, profile,
                                                              follow, radii)
        if outside := _outside(measurer, at):
            out[k] = (None, outside)
            continue
        if k in later and later[k][0] == len(done):  # no mark found since: the same measurements would fail again
            out[k] = _probed_area(measurer, later[k][1], at, tolerance, later[k][2], len(done), vain, k, follow,
                                  len(later))
            continue
        reach = tolerance if follow and len(done) < MIN_REFIT else 0.0          # a roll's film may have moved
        quick, why = None, ""
        if name is not None and len(measurer.polarities) == 1 and k not in later:
            template = templates[k] if templates and reach > 0 else None
            near = start if len(done) >= MIN_REFIT else _coarse(measurer, name, start, reach, template)
            alike = profile is not None or any(kinds[j] == kinds[k] for j in done)
            quick = _by_method(measurer, name, near, at, alone_tolerance, windows=None if alike else 1)
        if quick is None and radii is None and profile is None:
            if k not in waiting and _waits(k, done, order[i + 1:], kinds, layout):
                waiting.add(k)                  # sought again once the others of its kind are (_fallback_start)
                order.append(k)
                continue
            start = _fallback_start(start, k, done, layout, kinds, features)
        if quick is None and not (unsought := _vain_starts(k, done, later, follow)):
            quick = _coarse_first(measurer, start, at, tolerance)
        if quick is None:
            quick, why = (None, unsought) if unsought else _at_start(measurer, start, at, tolerance, other)
            if quick is None and len(done) < MIN_REFIT and k not in later and k != order[-1]:
                later[k] = (len(done), start, why)  # sought in its area after the others (:data:`MIN_REFIT`)
                order.append(k)
                continue
        out[k] = (quick, "") if quick is not None else _probed_area(measurer, start, at, tolerance, why, len(done),
                                                                     vain, k, follow, len(later))
        if out[k][0] is not None and len(measurer.polarities) > 1:
            polarity = out[k][0].polarity  # type: ignore[union-attr]
            measurer = replace(measurer, polarities=(polarity,))
            other = opposite(polarity)
    return out


class _Sought(NamedTuple):
    """Where and how :func:`measure_marks` seeks a fiducial: the prediction, the window's centre and size, the
    tolerances (px) of any method and of the frame's method alone, and that method (None: not known yet)."""

    at: tuple[float, float]
    start: Candidate
    tolerance: float
    alone_tolerance: float
    name: str | None


def _sought(k: int, out: list[tuple[Located | None, str]], done: list[int], layout: LayoutMatch,
            fiducials_mm: np.ndarray, features: tuple[Candidate, ...], profile: RollProfile | None, follow: bool,
            radii: Sequence[float] | None) -> _Sought:
    """:func:`measure_marks`' :class:`_Sought` for fiducial ``k`` once the marks ``done`` are found (``out``)."""
    name = profile.method if profile is not None else None
    if len(done) >= MIN_REFIT:
        found = np.array([_xy(out[j][0]) for j in done])
        p = layout.predict_from(fiducials_mm, done, found)[k]
        at = (float(p[0]), float(p[1]))
        start = Candidate(at[0], at[1], radii[k] if radii is not None else _median_extent(out, done), 0.0)
        return _Sought(at, start, max(REFINED_TOLERANCE_MM / layout.pixel_size_mm, MIN_TOLERANCE_PX),
                       max(FRAME_METHOD_TOLERANCE_MM / layout.pixel_size_mm, MIN_TOLERANCE_PX),
                       name or _frame_method(out, done))
    moved = [np.subtract(_xy(out[j][0]), layout.predicted[j]) for j in done] if follow else []
    shift = np.mean(moved, axis=0) if moved else np.zeros(2)
    at = (float(layout.predicted[k][0] + shift[0]), float(layout.predicted[k][1] + shift[1]))
    m = layout.matched[k]
    start = (Candidate(at[0], at[1], radii[k], 0.0) if radii is not None
             else Candidate(at[0], at[1], profile.mark_radius_px(layout.pixel_size_mm), 0.0)
             if profile is not None
             else Candidate(at[0], at[1], _median_extent(out, done), 0.0) if done
             else _first_window(features[m]) if m is not None
             else Candidate(at[0], at[1], _median_radius(layout, features), 0.0))
    return _Sought(at, start, layout.tolerance_px, layout.tolerance_px,
                   name or (_frame_method(out, done) if done else None))


def measure_extra_marks(measurer: Measurer, res: FrameOrientation,
                        extras: dict[str, tuple[float, float]]) -> tuple[FiducialFinding, ...]:
    """The marks of the film's format that the camera file does not list (``extras``: name -> nominal film mm,
    :func:`aerofid.frame.nominal.extra_marks`), each measured like a later fiducial of :func:`measure_marks`
    (:func:`_sought_where_oriented`) from where the frame's orientation puts its nominal position, within
    :data:`EXTRA_TOLERANCE_MM` of it. They are not used in the adjustment (their positions are not calibrated): a
    finding's ``predicted_x, predicted_y`` is the nominal position, ``residual_px`` the mark's distance from it."""
    assert res.orientation is not None
    tolerance = max(EXTRA_TOLERANCE_MM / adjusted_pixel_mm(res.orientation), MIN_TOLERANCE_PX)
    out = []
    for mark, p in zip(extras, res.orientation.to_pixel(list(extras.values())), strict=True):
        at = (float(p[0]), float(p[1]))
        got, why = _sought_where_oriented(measurer, res, at, tolerance)
        if got is None:
            out.append(FiducialFinding(mark, MISSING_MARK, None, None, None, None, *at, reason=why))
            continue
        d = got.detection
        out.append(FiducialFinding(mark, FOUND_MARK, got.x, got.y, d.sigma_x, d.sigma_y, *at,
                                   residual_px=math.hypot(got.x - at[0], got.y - at[1]), method=d.method,
                                   located=got))
    return tuple(out)


def _sought_where_oriented(measurer: Measurer, res: FrameOrientation, at: tuple[float, float],
                           tolerance: float) -> tuple[Located | None, str]:
    """A mark sought at ``at``, where the frame's orientation ``res`` puts it, like a later fiducial of
    :func:`measure_marks`: sized like the frame's found marks, in their polarity first, by the frame's method alone
    from its coarse answer, else :func:`measure_fiducial` within ``tolerance`` px; and why not where it is not
    found."""
    marks: list[tuple[Located | None, str]] = [(f.located, "") for f in res.fiducials
                                               if f.status == FOUND_MARK and f.located is not None]
    if not marks:
        return None, "no mark of the frame found to measure it like"
    done = list(range(len(marks)))
    name = _frame_method(marks, done)
    other: Polarity | None = None
    if len(measurer.polarities) > 1:
        polarity = marks[0][0].polarity  # type: ignore[union-attr]
        measurer, other = replace(measurer, polarities=(polarity,)), opposite(polarity)
    start = Candidate(at[0], at[1], _median_extent(marks, done), 0.0)
    got = (None if name is None or _outside(measurer, at)
           else _by_method(measurer, name, _coarse(measurer, name, start), at, tolerance))
    return (got, "") if got is not None else measure_fiducial(measurer, start, at, tolerance, other)


def _xy(m: Located | None) -> tuple[float, float]:
    assert m is not None
    return m.x, m.y


def _median_extent(out: list[tuple[Located | None, str]], done: list[int]) -> float:
    return float(median(np.array([out[j][0].extent for j in done])))  # type: ignore[union-attr]


def _waits(k: int, done: list[int], pending: list[int], kinds: Sequence[int], layout: LayoutMatch) -> bool:
    """Whether :func:`measure_marks` puts off fiducial ``k``, which the frame's method alone missed: from
    :data:`MIN_REFIT` marks on (``done``), where it has a feature, no mark of its kind is found yet and another of its
    kind is still to be sought (``pending``), by whose feature :func:`_fallback_start` will size its search."""
    return (len(done) >= MIN_REFIT and layout.matched[k] is not None and all(kinds[j] != kinds[k] for j in done)
            and any(kinds[j] == kinds[k] and j != k for j in pending))


def _fallback_start(start: Candidate, k: int, done: list[int], layout: LayoutMatch, kinds: Sequence[int],
                    features: tuple[Candidate, ...]) -> Candidate:
    """Where and how large :func:`measure_marks` seeks fiducial ``k`` by ``auto`` once the frame's method alone has
    not found it (``start``: its prediction, sized like the marks found, ``done``): as large as its own screening
    feature, but from :data:`MIN_REFIT` marks on (the prediction within a few px) no larger than the features of the
    marks of its kind found (``kinds``, :func:`fiducial_kinds`: corners or midsides; their median), and never smaller
    than ``start`` (the marks' extent so far can be another style's: a '+' that ``hough`` measured on a ring and
    cross gives its arms' half length, a third of the ring's radius that a ring and X in the corners has). A
    camera's marks of one kind are alike, and the feature the layout matched there may be something else (a blot
    painted over the mark, 2.4-2.9 times the marks' radius on the damaged frames of ``benchmarks/bench_frames.py``,
    whose windows and areas of that size took seconds of failed searches)."""
    m = layout.matched[k]
    if not done or m is None:
        return start
    size = _first_window(features[m]).radius
    alike = [j for j in done if kinds[j] == kinds[k]]
    if len(done) >= MIN_REFIT and any(layout.matched[j] is not None for j in alike):
        size = min(size, _median_radius(layout, features, alike))
    return replace(start, radius=max(start.radius, size))


def fiducial_kinds(fiducials_mm: np.ndarray) -> list[int]:
    """Each fiducial's kind by its direction on the film from the middle of the layout (the centre of the fiducials'
    bounding box: a certificate's origin may be a corner): 1 a corner (nearer a diagonal), 0 a midside (nearer an
    axis). A camera's marks of one kind are alike (the Wild cameras' corner rings with an X and a dot, their
    midside rings with a '+'; a film that lies turned by 90 degrees in the scanner turns one axis's midsides into
    the other's).

    Examples
    --------
    >>> fiducial_kinds(np.array([[-106.0, -106.0], [0.0, -110.0], [110.0, 0.5], [106.0, 106.0], [-110.0, 0.0]]))
    [1, 0, 0, 1, 0]
    >>> fiducial_kinds(np.array([[10.0, 10.0], [116.0, 10.0], [222.0, 10.0], [222.0, 116.0], [222.0, 222.0]]))
    [1, 0, 1, 0, 1]
    """
    xy = np.asarray(fiducials_mm, float)
    d = xy - (xy.min(axis=0) + xy.max(axis=0)) / 2.0
    angle = np.degrees(np.arctan2(np.abs(d[:, 1]), np.abs(d[:, 0])))
    return (np.abs(angle - 45.0) < 22.5).astype(int).tolist()


def _frame_method(out: list[tuple[Located | None, str]], done: list[int]) -> str | None:
    """The seed method that found most of the marks ``done``, of a tie the one of the first fiducial (not a set's
    order, which follows the process's string hashing); None if ``auto``'s own answers: none."""
    methods = [out[j][0].detection.method for j in done]  # type: ignore[union-attr]
    name = max(methods, key=methods.count)
    return name if name in METHODS else None


def _by_method(measurer: Measurer, name: str, start: Candidate, at: tuple[float, float],
               tolerance: float, windows: int | None = None) -> Located | None:
    """A mark measured by the method ``name`` alone (the marks of one frame, or of one roll, are alike), on the
    window the marks' extent (``start.radius``) sizes at ``start`` (the prediction, or a coarse answer):
    :data:`ALONE_WINDOWS` in turn, else a box's re-centred window (:data:`aerofid.find.RECENTRED_WINDOW`: the real
    RC20 frame's marks, on a busy border, are refused on some of the tight ones); re-centred and with
    its window term (:meth:`aerofid.find.Measurer.recentre`); kept only when it lies within ``tolerance`` px of the
    prediction ``at``, else None (then ``auto`` measures it). The geometry of the marks found (or the layout) is what
    replaces ``auto``'s cross-checks and uniqueness pass here, three quarters of its time on a ring and cross.
    ``windows``: only the first so many of these (None: all); :func:`measure_marks` asks for one on a fiducial of a kind
    (:func:`fiducial_kinds`) none of whose marks is found yet: ``hough``, which measured a midside's ring and '+',
    spent 0.4-1.4 s per window failing on a corner's ring and X on a frame of ``benchmarks/bench_frames.py``'s roll."""
    alone = measurer.alone(name)
    for window in (*ALONE_WINDOWS, RECENTRED_WINDOW)[:windows]:
        got = _alone(alone, start, at, tolerance, window)
        if got is not None:
            return got
    return None


def _alone(alone: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
           window: tuple[float, float]) -> Located | None:
    """:func:`_by_method` on one window law. A first answer on the pixel its window is centred on, whose extent
    sizes the window within :data:`aerofid.find.SETTLED`, is already the re-centred answer (the round is not
    repeated); so is one that the method's remeasure on the re-centred window gives back
    (:meth:`aerofid.find.Measurer.confirms`: within 3 px of the mark, as the refined predictions are, the first
    window gives the centre the re-centred one does)."""
    half = recentred_half(start.radius, window)
    got = alone.at(start.x, start.y, half, start)
    if not got.found or math.hypot(got.x - at[0], got.y - at[1]) > tolerance:
        return None
    own = recentred_half(got.extent, window)
    settled = (round(got.x), round(got.y)) == (round(start.x), round(start.y)) and abs(own - half) <= SETTLED * half
    if not settled and alone.confirms(got, own):
        settled, half = True, own
    got = alone.window_term(got, half) if settled else alone.recentre(got, start, window)
    return got if got.found and math.hypot(got.x - at[0], got.y - at[1]) <= tolerance else None


def _coarse_first(measurer: Measurer, start: Candidate, at: tuple[float, float],
                  tolerance: float) -> Located | None:
    """The first mark, and a later one the frame's method alone did not find: ``auto`` (every method, the
    measurer's polarities) on the scan reduced by :func:`_coarse_factor`, then the method and polarity it chose
    measure the mark alone at full resolution (:func:`_by_method`) from its coarse centre. None when the marks are
    too small to reduce, or either stage finds nothing (then ``auto`` measures it at full resolution). A mark ``auto``
    refuses only for another mark-like feature in its window is measured again in tighter boxes about it
    (:func:`_in_a_tighter_box`)."""
    f = _coarse_factor(start.radius)
    if f == 1:
        return None
    view = ReducedView(measurer.source, f, measurer.white)
    reduced = replace(measurer, source=view)
    coarse = reduced.candidate(_reduced(start, view), settle=False)
    if not coarse.found:
        coarse = _in_a_tighter_box(reduced, coarse, view.from_full(*at))
    if not coarse.found or coarse.detection.method not in METHODS:
        return None
    return _by_method(replace(measurer, polarities=(coarse.polarity,)), coarse.detection.method, _full(coarse, view),
                      at, tolerance)


RIVAL_SHARE = 0.5
""":func:`_in_a_tighter_box` measures again a mark ``auto`` refused for the features beside it only when the mark lies
at most this share of each one's distance from the prediction: the prediction, not the box, picks the fiducial."""


def _in_a_tighter_box(measurer: Measurer, refused: Located, at: tuple[float, float]) -> Located:
    """A mark that ``auto`` verified but refused for a second mark-like feature in its window
    (:attr:`~aerofid.detect.auto.AutoResult.ambiguous_at`), measured again, as the refusal asks of a person, in tighter
    boxes centred on it (the candidate's windows, :meth:`aerofid.find.Measurer.candidate`, from the one refused down to
    the mark's extent, until one finds it), where the prediction ``at`` (the measurer's pixels) picks it: it lies at
    most :data:`RIVAL_SHARE` of the distance of every rival feature (:attr:`~aerofid.detect.auto.AutoResult.rivals`)
    from ``at``. Else, and when nothing was refused so, ``refused`` itself. Before :data:`MIN_REFIT` marks are found the
    layout's tolerance can exceed the distance between a mark and a like feature beside it: a review's frame with a copy
    of each mark 108-125 px beside it had a copy taken within the tolerance for a second fiducial (its mark nearer the
    prediction), and the frame was doubtful instead of ok. The real RC20 frame in two of its 8 lies (turned three
    quarters, or flipped top to bottom): the strongest feature, a corner mark merged with its number dots at the
    screening's scale, 46 px from the mark and 200-270 px from the dots, made a first window that held both, and the
    fiducial's search at full resolution then took 0.25 s to fail (``tests/test_frame.py``)."""
    d = refused.detection
    if not isinstance(d, AutoResult) or d.ambiguous_at is None or not math.isfinite(d.mark_extent):
        return refused
    x, y = d.origin[0] + d.ambiguous_at[0], d.origin[1] + d.ambiguous_at[1]
    near = math.hypot(x - at[0], y - at[1])
    if any(near > RIVAL_SHARE * math.hypot(d.origin[0] + rx - at[0], d.origin[1] + ry - at[1]) for rx, ry in d.rivals):
        return refused
    c = refused.candidate
    assert c is not None
    return measurer.candidate(replace(c, x=x, y=y, inner=min(c.inner, d.mark_extent)), settle=False)


def _coarse(measurer: Measurer, name: str, start: Candidate, reach: float = 0.0,
            template: MarkTemplate | None = None) -> Candidate:
    """Where a later mark is measured at full resolution: ``start`` (its prediction, sized like the marks) moved
    to the centre and extent the method ``name`` finds there on the scan reduced by :func:`_coarse_factor`, so
    that the full-resolution window is the re-centred one at once (:func:`_by_method`); ``start`` when the marks
    are too small to reduce or the coarse measurement finds nothing. The reduced window is the first of
    :data:`ALONE_WINDOWS` (the mark and little else; 1.5 times the radius before session 22, whose change of both
    is measured in docs/benchmarks_frames.md). ``reach``: how far (px) the mark may lie from
    ``start``, added to the window's half-size (then marks too small to reduce are sought so too, unreduced); there
    the mark's learnt ``template`` is tried first (:func:`_matched`)."""
    matched = _matched(measurer, template, start, reach) if template is not None else None
    if matched is not None:
        return matched
    f = _coarse_factor(start.radius)
    if f == 1 and reach <= 0:
        return start
    view = ReducedView(measurer.source, f, measurer.white)
    small = _reduced(start, view)
    half = recentred_half(small.radius, ALONE_WINDOWS[0]) + reach / view.factor
    coarse = replace(measurer.alone(name), source=view).at(small.x, small.y, half, small)
    return _full(coarse, view) if coarse.found else start


def _matched(measurer: Measurer, template: MarkTemplate, start: Candidate, reach: float) -> Candidate | None:
    """``start`` moved to where the mark's ``template`` correlates best within ``reach`` px of it, on the scan
    reduced by the template's factor, in the measurer's (first) polarity
    (:func:`aerofid.frame.templates.match_template`); None where nothing there correlates enough."""
    view = ReducedView(measurer.source, template.factor, measurer.white)
    small = _reduced(start, view)
    half = max(template.shape) / 2 + reach / view.factor
    box, grey = replace(measurer, source=view).grey(small.x, small.y, half, measurer.polarities[0])
    found = match_template(grey, template)
    if found is None:
        return None
    x, y = view.to_full(box[0] + found[0], box[1] + found[1])
    return Candidate(x, y, start.radius, 0.0)


def _coarse_factor(radius: float) -> int:
    """The power of two that reduces marks of ``radius`` px to at least :data:`COARSE_RADIUS` px (1: none)."""
    return reduction_keeping(radius, COARSE_RADIUS)


def _reduced(c: Candidate, view: ReducedView) -> Candidate:
    x, y = view.from_full(c.x, c.y)
    return replace(c, x=x, y=y, radius=c.radius / view.factor, inner=c.inner / view.factor)


def _full(coarse: Located, view: ReducedView) -> Candidate:
    x, y = view.to_full(coarse.x, coarse.y)
    return Candidate(x, y, coarse.extent * view.factor, 0.0)


def _first_window(c: Candidate) -> Candidate:
    """A screened feature sized for its first window: the geometric mean of its largest radius (coarse levels
    see the mark's surroundings too) and its smallest (the real RC20 marks: 80-96 and 12 px; the marks are about
    40 px in radius)."""
    return replace(c, radius=math.sqrt(c.radius * c.inner))


def _median_radius(layout: LayoutMatch, features: tuple[Candidate, ...], among: Sequence[int] | None = None) -> float:
    """The median first-window radius (:func:`_first_window`) of the features matched to the fiducials ``among``
    (default: all of them)."""
    matched = layout.matched if among is None else [layout.matched[j] for j in among]
    return float(median(np.array([_first_window(features[m]).radius for m in matched if m is not None])))


def measure_fiducial(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
                     other_polarity: Polarity | None = None) -> tuple[Located | None, str]:
    """One fiducial: the mark measured from ``start`` (a feature, or the prediction sized like the marks), else in
    ``other_polarity`` (a ring and cross on film is a mark in both: each loses some windows), else the mark
    nearest the prediction ``at`` in its area searched like a region, within ``tolerance`` px."""
    outside = _outside(measurer, at)
    if outside:
        return None, outside
    got, why = _at_start(measurer, start, at, tolerance, other_polarity)
    return (got, "") if got is not None else _in_area(measurer, start, at, tolerance, why)


def _at_start(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
              other_polarity: Polarity | None) -> tuple[Located | None, str]:
    """:func:`measure_fiducial`'s measurements from ``start`` (in the measurer's polarities, then in
    ``other_polarity``): the mark found within ``tolerance`` px of ``at``, else None and why not there (where the
    first measurement found a mark, how far off; else its reason, with the box of the window it speaks of:
    :meth:`aerofid.find.Located.reason_in_window`)."""
    others = () if other_polarity is None else (replace(measurer, polarities=(other_polarity,)),)
    first: Located | None = None
    for m in (measurer, *others):
        got = _in_a_larger_box(m, m.candidate(start), at, tolerance)
        first = first or got
        if got.found and math.hypot(got.x - at[0], got.y - at[1]) <= tolerance:
            return got, ""
    assert first is not None
    if first.found:
        return None, (f"the mark found there, at ({first.x:.1f}, {first.y:.1f}), lies "
                      f"{math.hypot(first.x - at[0], first.y - at[1]):.0f} px from the prediction")
    return None, first.reason_in_window(measurer.source.width, measurer.source.height)


def _in_a_larger_box(measurer: Measurer, refused: Located, at: tuple[float, float], tolerance: float) -> Located:
    """A mark that ``auto`` found but refused as cut by its window's edge
    (:attr:`~aerofid.detect.auto.AutoResult.cut_at`), measured again, as the refusal asks of a person, on windows
    centred on it and sized by its extent (:meth:`aerofid.find.Measurer.candidate`), where it lies within
    ``tolerance`` px of the prediction ``at`` and the scan holds its extent about it (not a mark cut by the scan's
    edge); else ``refused`` itself. The screening gives a thin '+' the radius of its crossing (3 px on the 40 px '+'
    marks of ``synth.demo_frame``, the doctest of :func:`~aerofid.frame.orient.orient_frame`): its first window
    holds the crossing, and the mark (radius 21 px) was refused there and found only by its area's search."""
    d = refused.detection
    if not isinstance(d, AutoResult) or d.cut_at is None or not math.isfinite(d.mark_extent):
        return refused
    x, y = d.origin[0] + d.cut_at[0], d.origin[1] + d.cut_at[1]
    room = min(x, y, measurer.source.width - 1 - x, measurer.source.height - 1 - y)   # a mark cut by the scan's edge
    if math.hypot(x - at[0], y - at[1]) > tolerance or room < d.mark_extent:
        return refused
    return measurer.candidate(Candidate(x, y, d.mark_extent, 0.0))


def _in_area(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
             why: str) -> tuple[Located | None, str]:
    """:func:`measure_fiducial`'s area search: the mark nearest ``at`` within ``tolerance`` px in the area around
    it, else None and why not (``why``: why not at ``start``)."""
    half = tolerance + AREA_MARGIN * start.radius
    area, _ = clip_box((at[0] - half, at[1] - half, at[0] + half + 1, at[1] + half + 1), measurer.source.width,
                       measurer.source.height)
    nearest = _nearest_mark(measurer, area, at, tolerance, start.radius)
    if nearest is not None:
        return nearest, ""
    return None, (f"no mark within {tolerance:.0f} px of the predicted ({at[0]:.0f}, {at[1]:.0f}) in the area "
                  f"{area[0]},{area[1]},{area[2]},{area[3]} (at the prediction: {why})")


def _probed_area(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float, why: str,
                 found: int, vain: list[int], k: int, follow: bool, put_off: int) -> tuple[Located | None, str]:
    """:func:`_in_area` for fiducial ``k`` of :func:`measure_marks` once ``found`` marks are found: before
    :data:`MIN_REFIT`, only until :data:`AREA_PROBES` fiducials' areas have held no mark (``vain``: ``k`` is appended
    when its area holds none); while no mark is found, one, and none once :data:`VAIN_STARTS` fiducials held no mark at
    their predicted places (``put_off``: the fiducials put off so far); not so on a roll's layout (``follow``), whose
    film may have moved. Then not searched, and why. With no mark found, a fiducial reaches its area only once the
    others were sought at their places (or :data:`VAIN_STARTS` of them) and none held one: a scan with no fiducials in
    it, or a camera file that is not the scan's, spent 1.2-1.7 s of each layout it tried in two areas; a noisy frame
    that fails (seed 5009 of ``benchmarks/bench_sweep.py``) 2.2 s of each of its 24 chance layouts in one (118 s in
    all, 54 s without them, session 48)."""
    if found >= MIN_REFIT:
        return _in_area(measurer, start, at, tolerance, why)
    if _given_up(found, put_off, follow):
        place = f"the predicted ({at[0]:.0f}, {at[1]:.0f})"
        there = (f"{UNSOUGHT} at {place} nor in its area" if why.startswith(UNSOUGHT)
                 else f"no mark at {place} ({why}); its area was not searched")
        return None, (f"{there}: {VAIN_STARTS} fiducials held no mark at their predicted places and none was found "
                      "(the features the layout matched are probably not the frame's marks)")
    if len(vain) >= (1 if found == 0 and not follow else AREA_PROBES):
        return None, (f"no mark at the predicted ({at[0]:.0f}, {at[1]:.0f}) ({why}); its area was not searched: "
                      f"the areas of {len(vain)} fiducials held none and {found} marks were found, too few to "
                      "predict the others (the features the layout matched are probably not the frame's marks)")
    got = _in_area(measurer, start, at, tolerance, why)
    if got[0] is None:
        vain.append(k)
    return got


def _vain_starts(k: int, done: list[int], later: dict[int, tuple[int, Candidate, str]], follow: bool) -> str:
    """Why :func:`measure_marks` does not seek fiducial ``k`` at its predicted place: none is found (``done``) and
    :data:`VAIN_STARTS` fiducials held none at theirs (``later``: those put off), but on a roll's layout (``follow``);
    "" when it seeks it there."""
    if k in later or not _given_up(len(done), len(later), follow):
        return ""
    return f"{UNSOUGHT}: {VAIN_STARTS} fiducials held no mark at their predicted places"


def _given_up(found: int, put_off: int, follow: bool) -> bool:
    """Whether :func:`measure_marks` gives a layout up, seeking no more fiducials at their places nor in their areas:
    none is ``found`` and :data:`VAIN_STARTS` fiducials held none at their places (``put_off``), but on a roll's
    layout (``follow``)."""
    return not found and not follow and put_off >= VAIN_STARTS


def _outside(measurer: Measurer, at: tuple[float, float]) -> str:
    """Why no mark is sought at ``at``: it lies outside the scan; "" when it lies inside."""
    if in_box(at[0], at[1], (0, 0, measurer.source.width, measurer.source.height)):
        return ""
    return f"the predicted ({at[0]:.0f}, {at[1]:.0f}) lies outside the scan"


def _nearest_mark(measurer: Measurer, area: Box, at: tuple[float, float], tolerance: float,
                  radius: float) -> Located | None:
    """The predicted area searched like a region: the found mark nearest ``at`` within ``tolerance``."""
    cands, f = screen_region(measurer.source, area, measurer.colour, measurer.polarities[0], 2.0,
                             max(4.0 * radius, 8.0), AREA_CANDIDATES, measurer.white)
    marks = [m for m in search(measurer, area, cands, f).marks if math.hypot(m.x - at[0], m.y - at[1]) <= tolerance]
    return min(marks, key=lambda m: math.hypot(m.x - at[0], m.y - at[1]), default=None)


def second_look(measurer: Measurer, layout: LayoutMatch, fiducials_mm: np.ndarray,
                 located: list[tuple[Located | None, str]], res: FrameOrientation,
                 judged: Callable[[LayoutMatch, list[tuple[Located | None, str]]], FrameOrientation]
                 ) -> FrameOrientation:
    """``res`` (the frame judged on ``layout``'s marks ``located`` of ``fiducials_mm``) or the frame judged again with
    the fiducials it left unfound sought where its orientation puts them (:func:`_sought_where_oriented`, within the
    refined tolerance), wherever that is further than the refined tolerance from where :func:`measure_marks` may have
    sought them (:func:`_sought_places`): the layout's lie is a hypothesis that the adjustment's F test may overturn,
    and its fit to coarse features, or the marks of a wrong lie refitted, may put a fiducial beyond the tolerance of
    its mark, which is then not found, although the orientation of the others puts it plainly elsewhere (a camera file
    with one fiducial 2 mm off: two marks 11 and 19 px from where they were sought, within 0.05 px of where the
    orientation put them). A new mark goes to the layout's fiducial nearest it (of the camera's: ``res``'s fiducials
    come first in a layout with the format's other marks), whose prediction becomes the orientation's; the adjustment
    names the marks again and its blunder tests check the new one with the others. The new frame is kept only where
    it stands as well (:func:`standing`) and has more marks found and used (a mark the blunder tests reject is not
    one)."""
    if res.orientation is None:
        return res
    tolerance = max(REFINED_TOLERANCE_MM / adjusted_pixel_mm(res.orientation), MIN_TOLERANCE_PX)
    marks, predicted, added = list(located), layout.predicted.copy(), False
    places = _sought_places(layout, fiducials_mm, located)
    n = len(res.fiducials)
    for f in res.fiducials:
        if f.status != MISSING_MARK:
            continue
        at = (f.predicted_x, f.predicted_y)
        k = int(np.argmin(np.hypot(*(layout.predicted[:n] - at).T)))
        if marks[k][0] is not None or all(math.hypot(*(p[k] - at)) <= tolerance for p in places):
            continue                                            # sought there already, or its place is taken
        got, _ = _sought_where_oriented(measurer, res, at, tolerance)
        if got is not None:
            marks[k], predicted[k], added = (got, ""), at, True
    if not added:
        return res
    second = judged(replace(layout, predicted=predicted), marks)
    used = sum(f.status == FOUND_MARK for f in second.fiducials) > sum(f.status == FOUND_MARK for f in res.fiducials)
    return second if used and standing(second) >= standing(res) else res


def _sought_places(layout: LayoutMatch, fiducials_mm: np.ndarray,
                   located: list[tuple[Located | None, str]]) -> list[np.ndarray]:
    """Where :func:`measure_marks` sought ``layout``'s fiducials (n x 2 px each): at the layout's predictions, and from
    :data:`MIN_REFIT` marks found on, at those of the layout's lie refitted to the marks found then (here: to all the
    marks ``located``, which the later fiducials' refits approach)."""
    done = [j for j, (m, _) in enumerate(located) if m is not None]
    if len(done) < MIN_REFIT:
        return [layout.predicted]
    return [layout.predicted, layout.predict_from(fiducials_mm, done, np.array([_xy(located[j][0]) for j in done]))]


__all__ = ["fiducial_kinds", "measure_extra_marks", "measure_fiducial", "measure_marks", "second_look"]
