"""``aerofid.find_marks``: every mark in a region of a scan (or the whole scan), coarse to fine.

The search (aerofid's; the seeds locate one mark in a window the operator drew round it):

1. **Screen** (:mod:`aerofid.detect.screen`): the region, with a margin of context around it, is read reduced
   by block means (so that at most :data:`SCREEN_PIXELS` pixels are held, whatever the region's size) and
   screened for centrally symmetric, compact structure on an image pyramid. Cost grows with the region's
   area only here, a few multiply-adds per reduced pixel.
2. **Measure** each candidate (strongest first, at most ``max_candidates``) with the chosen method on a
   window read around it at full resolution, as large as the candidate's scale needs (clipped only by the
   image, never by the region: the region says where a centre may be, not which pixels may be read).
3. **Re-centre**: a found mark is measured again on a window centred on its own centre, sized by its own
   extent (the method's model of it), so that the answer does not depend on where the region's edges or
   the candidate fell (box-to-box spread, issue 9).
4. **One answer per mark**: answers closer than the larger mark's extent are one mark (the better kept); a
   mark much smaller than a neighbouring one and beside it (printed index dots or digits, a centre dot,
   the end of an arm) is an *accessory* of it, not a mark of its own.

:func:`aerofid.locate` is this search on the operator's box plus the one-mark rule.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from aerofid.conventions import FOUND, NOT_FOUND, POLARITIES, Box, Polarity
from aerofid.detect.auto import blank_disc
from aerofid.detect.params import is_int, is_number
from aerofid.detect.result import Detection
from aerofid.detect.screen import Candidate, merge_candidates, screen
from aerofid.errors import AerofidInputError
from aerofid.io.array import open_image
from aerofid.io.colour import COLOUR_POLICIES, first_look_white, luminance_first, to_grey
from aerofid.io.raster import clip_box
from aerofid.io.reduce import read_reduced_levels
from aerofid.io.source import ImageSource
from aerofid.methods import AutoDetector, Detector, MethodDetector, check_choice, check_polarity, make_detector
from aerofid.windows import MIN_HALF, rows_read, window_half

SCREEN_PIXELS = 2_000_000
"""Most pixels of the reduced region that screening holds (a power-of-two reduction is chosen to fit)."""
CONTEXT = 64
"""Pixels of context screened around a region (at most; clipped by the image)."""
FIRST_WINDOW = (2.5, 8)
"""Half-size of the first window around a candidate: 2.5 x its radius + 8 px."""
RECENTRED_WINDOW = (2.5, 8)
"""Half-size of the re-centred window: 2.5 x the mark's extent + 8 px."""
RECENTRE_ROUNDS = 3
"""At most this many re-centred measurements per mark."""
SETTLED = 0.15
"""The re-centring settles when the window's half-size from the answer's extent is within this fraction of the
half-size it was measured on."""
LADDER_STEP = 0.75
"""Ratio of successive window sizes tried on one candidate."""
CONFIRMED = 1e-9
"""A remeasured centre within this many px of the answer gives it back (:meth:`Measurer.confirms`)."""
WINDOW_TERM_SIZES = (LADDER_STEP, 1 / LADDER_STEP)
"""Half-sizes of the two windows of the window term, relative to the final re-centred window's: one step of the
ladder smaller and larger (on the real RC20 marks the centre moves by 0.15-0.3 px between these sizes; windows
0.6 times the size were refused on all 8 marks, 1.6 times on 3 of them)."""
MIN_RECENTRED_HALF = 24
"""Smallest half-size of the re-centred window (px): a small blob is judged with its surroundings (texture
around a compact blob of aerial ground is what tells it from a dot on plain film)."""
MAX_MARK_RADIUS = 160.0
"""Largest mark radius (px) sought when the caller gives none: fiducials and panels are a few to ~150 px."""
ACCESSORY_RATIO = 0.5
"""A mark whose extent is below this fraction of a neighbour's is its accessory..."""
ACCESSORY_REACH = 8.0
"""... when it lies within this many of the neighbour's extents of its centre (index dots and digits sit 1-2
extents from an RC20 corner mark; dust on the film border a few more; two fiducials of one frame lie a hundred
extents apart)."""
WEAK_CANDIDATE = 0.4
"""Once a mark is found, candidates weaker than this fraction of its screening strength are not measured
(a second mark of the same kind screens about as strong)."""


@dataclass(frozen=True, eq=False)
class Located:
    """One measured mark (full-image pixels): the detector's answer moved to the image, the window it saw."""

    detection: Detection
    polarity: Polarity
    box: Box
    window: np.ndarray = field(repr=False, compare=False)
    candidate: Candidate | None = None

    @property
    def found(self) -> bool:
        return self.detection.found

    @property
    def x(self) -> float:
        return self.detection.x

    @property
    def y(self) -> float:
        return self.detection.y

    def reason_in_window(self, width: int, height: int) -> str:
        """The detector's reason with the window it speaks of (its coordinates are the window's), and whether the
        image's edge (an image of ``width`` x ``height`` px) cut the window: then pixels of the mark may really be
        missing from the scan."""
        x0, y0, x1, y1 = self.box
        edge = x0 == 0 or y0 == 0 or x1 == width or y1 == height
        where = f"in the window ({x0}, {y0}, {x1}, {y1})" + (", which the image's edge cuts" if edge else "")
        return f"{self.detection.reason or 'no mark'} [{where}]"

    @property
    def extent(self) -> float:
        """The mark's radius by its method's model, else the screening radius, else a quarter of the window."""
        e = self.detection.extent
        if e is not None and math.isfinite(e) and e > 0:
            return float(e)
        if self.candidate is not None:
            return self.candidate.radius
        return min(self.box[2] - self.box[0], self.box[3] - self.box[1]) / 4.0


@dataclass(frozen=True)
class MarkSearch:
    """The answer of :func:`find_marks`: the marks found (strongest first) and how the search went.

    Iterating over it, ``len`` and indexing reach :attr:`marks`.
    """

    region: Box
    marks: tuple[Located, ...]
    accessories: tuple[Located, ...]
    attempts: tuple[Located, ...]
    candidates: tuple[Candidate, ...]
    reduction: int
    width: int
    height: int
    """The image's size (px)."""
    path: str | None = None

    def __iter__(self) -> Iterator[Located]:
        return iter(self.marks)

    def __len__(self) -> int:
        return len(self.marks)

    def __getitem__(self, i: int) -> Located:
        return self.marks[i]


@dataclass(frozen=True)
class Measurer:
    """Measures a mark on a window of ``source`` around a point: the configured detector, colour policy and
    polarities (the more reliable answer of the polarities wins)."""

    source: ImageSource
    detector: Detector
    polarities: tuple[Polarity, ...]
    colour: str = "auto"
    luma_first: bool = True
    """Whether ``colour="auto"`` takes luminance first in a file that calls for it (:meth:`takes_luminance_first`);
    false: the mix that shows the mark best, the search that follows one in luminance that found too little
    (:func:`colour_again`)."""
    white: float | None = None
    """The full scale this search reads the source's integer samples at (:func:`with_white`; None: their dtype's
    largest value)."""

    def at(self, x: float, y: float, half: float, candidate: Candidate | None = None,
           blank: tuple[float, float, float] | None = None) -> Located:
        """The detector's answer on the window of half-size ``half`` centred on the pixel nearest (x, y)."""
        box, samples = self._window(x, y, half)
        best: Located | None = None
        for pol in self.polarities:
            grey = self._grey(samples, pol)
            if blank is not None:
                grey = blank_disc(grey, blank[0] - box[0], blank[1] - box[1], blank[2])
            det = self.detector(grey).shifted(box[0], box[1])
            got = Located(det, pol, box, grey, candidate)
            if best is None or better(got.detection, best.detection):
                best = got
        assert best is not None
        return best

    def again(self, final: Located, half: float) -> Located:
        """``final``'s mark measured on the window of half-size ``half`` centred on it: in ``final``'s polarity by the
        seed method's :meth:`~aerofid.methods.MethodDetector.remeasure` from its centre where it has one, else by
        :meth:`at` (a new measurement, every polarity it tries)."""
        method = self._remeasurer()
        if method is None:
            return self.at(final.x, final.y, half, final.candidate)
        box, grey = self.grey(final.x, final.y, half, final.polarity)
        det = method.remeasure(grey, final.x - box[0], final.y - box[1], final.detection)
        det = det.shifted(box[0], box[1])
        return Located(det, final.polarity, box, grey, final.candidate)

    def _remeasurer(self) -> MethodDetector | None:
        """The detector, where it is a seed method that measures a known mark again from its centre; else None."""
        d = self.detector
        return d if isinstance(d, MethodDetector) and d.remeasures else None

    def grey(self, x: float, y: float, half: float, polarity: Polarity) -> tuple[Box, np.ndarray]:
        """The window :meth:`at` reads at (x, y) with half-size ``half``, and its grey levels, the mark bright for
        ``polarity``."""
        box, samples = self._window(x, y, half)
        return box, self._grey(samples, polarity)

    def window_box(self, x: float, y: float, half: float) -> Box:
        """The window of half-size ``half`` (:func:`~aerofid.windows.window_half`) centred on the pixel nearest (x, y),
        clipped to the image: the pixels :meth:`at` reads."""
        h = window_half(half)
        cx, cy = int(round(x)), int(round(y))
        box, _ = clip_box((cx - h, cy - h, cx + h + 1, cy + h + 1), self.source.width, self.source.height)
        return box

    def _window(self, x: float, y: float, half: float) -> tuple[Box, np.ndarray]:
        """The window :meth:`window_box` and its samples."""
        box = self.window_box(x, y, half)
        return box, self.source.read_window(box)

    def _grey(self, samples: np.ndarray, pol: Polarity) -> np.ndarray:
        """The window's grey levels, the mark bright for polarity ``pol``."""
        grey = to_grey(samples, self.colour, pol, luma_first=self.luma_first and self.takes_luminance_first(),
                       white=self.white)
        return 1.0 - grey if pol == "dark" else grey

    def takes_luminance_first(self) -> bool:
        """Whether the source is a file whose marks go to luminance first
        (:func:`~aerofid.io.colour.luminance_first`)."""
        return luminance_first(self.source.chroma_subsampled, self.source.luma_step)

    def candidate(self, c: Candidate, blank: tuple[float, float, float] | None = None,
                  settle: bool = True) -> Located:
        """Steps 2 and 3 of the search for one candidate: windows from the candidate's largest radius down to
        its smallest (:func:`window_ladder`) until one is found, then (``settle``, and no ``blank``) re-centred
        windows sized by the mark's own extent until the size settles."""
        first: Located | None = None
        tried: set[int] = set()
        for half in window_ladder(c.radius, c.inner):
            h = window_half(half)
            if h in tried:                      # the same window as a rung before (both beyond MAX_HALF)
                continue
            tried.add(h)
            got = self.at(c.x, c.y, half, c, blank)
            first = first or got
            if got.found:
                return self.recentre(got, c) if settle and blank is None else got
        assert first is not None
        return first

    def recentre(self, got: Located, c: Candidate | None,
                 window: tuple[float, float] = RECENTRED_WINDOW) -> Located:
        """Step 3: measure again on a window centred on the answer, of half-size from its extent (``window``:
        :func:`recentred_half`), until the size settles; the answer's covariance gains the window term
        (:meth:`window_term`)."""
        half = recentred_half(got.extent, window)
        for _ in range(RECENTRE_ROUNDS):
            again = self.at(got.x, got.y, half, c)
            if not again.found:
                return again
            got, seen = again, half
            half = recentred_half(again.extent, window)
            if abs(half - seen) <= SETTLED * seen:
                break
        return self.window_term(got, half)

    def confirms(self, got: Located, half: float) -> bool:
        """Whether the seed method's :meth:`~aerofid.methods.MethodDetector.remeasure` on the window of half-size
        ``half`` centred on ``got`` gives back its centre (symmetry: stage 1 finds the kernel the centre was measured
        with, so the disc about it holds the same pixels, :func:`aerofid.detect.symmetry.remeasure`), at the cost of
        that stage 1. A new measurement there then gives the centre within 1e-3 px, or, rarely, refuses the mark
        (its search ends on the range's limit: 1 of 188 faint crosses beside aerial texture in a review of session
        17), so the frames' search, whose geometry checks every mark, takes it as re-centred
        (:func:`aerofid.frame.marks._alone`), and the search of a box does not. False where the detector does not
        remeasure."""
        if self._remeasurer() is None:
            return False
        again = self.again(got, half)
        return again.found and math.hypot(again.x - got.x, again.y - got.y) <= CONFIRMED

    def alone(self, method: str) -> Measurer:
        """This measurer with ``auto``'s member ``method`` alone as its detector (itself when its detector is not
        ``auto`` or ``method`` is no seed method)."""
        member = self.detector.member(method) if isinstance(self.detector, AutoDetector) else None
        return self if member is None else replace(self, detector=member)

    def window_term(self, final: Located, half: float) -> Located:
        """``final`` with the window term: the mark measured again on windows :data:`WINDOW_TERM_SIZES` times
        ``half`` (the re-centred half-size from ``final``'s own extent), centred on ``final``'s answer, by the
        method whose centre ``final`` is (:meth:`alone`), and the differences of the found answers from ``final``
        added to its covariance (:func:`with_window_term`). These windows are placed and sized by the final answer
        alone (not by the window it was measured on, whose size came from the round before: 64 or 65 px on RC20
        midside R by the box), so the term, like the centre, does not depend on the box or on where the candidate
        fell. The method alone measures how its centre moves with the window without ``auto``'s cross-checks and
        uniqueness pass (they answered the mark already); on a window where it alone finds nothing, or something
        further from ``final`` than the mark's extent (another feature), the detector measures it (``auto`` then
        answers with what it corroborates, e.g. ``symmetry`` on a crop)."""
        alone = self.alone(final.detection.method)
        others = []
        for f in WINDOW_TERM_SIZES:
            got = alone.again(final, f * half)
            same = got.found and math.hypot(got.x - final.x, got.y - final.y) <= final.extent
            others.append(got if same or alone is self else self.at(final.x, final.y, f * half, final.candidate))
        return with_window_term(final, [(o.x - final.x, o.y - final.y) for o in others if o.found])


def with_window_term(final: Located, differences: Sequence[tuple[float, float]]) -> Located:
    """``final`` with the mean square of ``differences`` (dx, dy) - its centre minus the same mark's on other
    windows - added to its covariance: mean dx^2 and dy^2 to the variances, mean dx dy to the covariance,
    mean (dx^2 + dy^2) / 2 to ``sigma^2``. The methods' own sigmas speak of the noise in one window; how much the
    centre moves with the window (0.15-0.3 px on each real RC20 mark between windows 0.75 and 1.33 times the
    re-centred one, against method sigmas of 0.01-0.08 px) is part of the uncertainty too. No found difference:
    ``final`` unchanged."""
    if not differences:
        return final
    d = np.asarray(differences, dtype=float)
    vx, vy, cxy = float(np.mean(d[:, 0] ** 2)), float(np.mean(d[:, 1] ** 2)), float(np.mean(d[:, 0] * d[:, 1]))
    det = final.detection
    det = replace(det, sigma=float(np.sqrt(det.sigma ** 2 + (vx + vy) / 2)),
                  sigma_x=float(np.sqrt(det.sigma_x ** 2 + vx)), sigma_y=float(np.sqrt(det.sigma_y ** 2 + vy)),
                  cov_xy=float(det.cov_xy + cxy))
    return replace(final, detection=det)


def recentred_half(extent: float, window: tuple[float, float] = RECENTRED_WINDOW) -> float:
    """Half-size of the window a mark of radius ``extent`` is measured on again: ``window`` = (times the
    extent, plus px), :data:`RECENTRED_WINDOW` by default."""
    return max(window[0] * extent + window[1], MIN_RECENTRED_HALF)


def window_ladder(radius: float, inner: float) -> list[float]:
    """Half-sizes of the windows tried on a candidate: FIRST_WINDOW of its radius, then :data:`LADDER_STEP`
    times smaller each, down to FIRST_WINDOW of ``inner`` (at least :data:`~aerofid.windows.MIN_HALF`)."""
    low = max(FIRST_WINDOW[0] * inner + FIRST_WINDOW[1], MIN_HALF)
    half = max(FIRST_WINDOW[0] * radius + FIRST_WINDOW[1], low)
    out = [half]
    while out[-1] * LADDER_STEP >= low * 0.9:
        out.append(out[-1] * LADDER_STEP)
    return out


def colour_again(measurer: Measurer) -> Measurer | None:
    """The measurer of the search that follows a frame's in luminance that failed: by the mix that shows the mark
    best (:attr:`Measurer.luma_first` false); None where the first was no such search (not ``colour="auto"``, or no
    file whose marks go to luminance first). Luminance is a 4:2:0 JPEG's one plane at full resolution, but quantised
    like the rest: on the real RC20 frame saved again at JPEG quality 15 its blocks hid 2 of the 4 red corner rings,
    which the red channel, with 3 times their contrast in luminance, still showed (a helper's audit, session 57).
    Such a file goes to the best mix first (:data:`~aerofid.io.colour.LUMA_STEP_MAX`); this is the net behind that
    rule. A box's search is not made again: a box without a mark on the RC20 JPEG took twice as long so (360 against
    190 ms)."""
    if measurer.colour != "auto" or not measurer.luma_first or not measurer.takes_luminance_first():
        return None
    return replace(measurer, luma_first=False)


def better(a: Detection, b: Detection) -> bool:
    """Is ``a`` a more reliable answer than ``b``? Found beats not found, then the higher score."""
    if a.found != b.found:
        return a.found
    return a.score > b.score


def reduction_for(width: int, height: int, budget: int = SCREEN_PIXELS) -> int:
    """The smallest power of two f with (width / f) * (height / f) <= ``budget``."""
    f = 1
    while math.ceil(width / f) * math.ceil(height / f) > budget:
        f *= 2
    return f


def with_white(measurer: Measurer, region: Box) -> Measurer:
    """``measurer`` with its search's full scale (:attr:`Measurer.white`) from its first look: ``region`` read reduced
    as its screening reads it, where the source's samples are integers wider than 8 bits and no scale is set yet
    (:func:`~aerofid.io.colour.first_look_white`: a 16-bit file of fewer than 12 bits is read at the scale of the
    bits it uses); else ``measurer`` itself. Only ``region`` is read."""
    dtype = measurer.source.dtype
    if measurer.white is not None or dtype.kind not in "ui" or np.iinfo(dtype).max <= 255:
        return measurer
    x0, y0, x1, y1 = region
    levels, _ = read_reduced_levels(measurer.source, region, reduction_for(x1 - x0, y1 - y0))
    return replace(measurer, white=first_look_white(levels, dtype) or float(np.iinfo(dtype).max))


def screen_region(source: ImageSource, region: Box, colour: str, polarity: Polarity,
                  min_radius: float, max_radius: float | None,
                  max_candidates: int, white: float | None = None) -> tuple[tuple[Candidate, ...], int]:
    """Step 1: candidates whose centres lie in ``region`` (full-image pixels), and the reduction used (``white``: the
    search's full scale, :attr:`Measurer.white`)."""
    margin = int(min(CONTEXT, max_radius if max_radius is not None else CONTEXT))
    x0, y0, x1, y1 = region
    ctx, _ = clip_box((x0 - margin, y0 - margin, x1 + margin, y1 + margin), source.width, source.height)
    f = reduction_for(ctx[2] - ctx[0], ctx[3] - ctx[1])
    reduced, step = read_reduced_levels(source, ctx, f, white=white)
    found: list[Candidate] = []
    for grey in screening_greys(reduced, colour, polarity):
        found += screen(grey, scale=f, min_radius=min_radius, max_radius=max_radius,
                        max_candidates=4 * max_candidates, noise_floor=step / f)
    found = list(merge_candidates(found, 4 * max_candidates))
    inside = [replace(c, x=c.x + ctx[0], y=c.y + ctx[1]) for c in found]
    inside = [c for c in inside if in_box(c.x, c.y, region)]
    return tuple(inside[:max_candidates]), f


def screening_greys(reduced: np.ndarray, colour: str, polarity: Polarity) -> list[np.ndarray]:
    """The grey images screened: with ``colour="auto"`` an RGB region is screened in each channel (the policy
    that picks one mix per measuring window cannot judge a region of many things: a red mark beside cyan
    water), else the policy's one grey image."""
    if reduced.ndim == 3 and colour == "auto":
        return [np.ascontiguousarray(reduced[:, :, i]) for i in range(3)]
    return [to_grey(reduced, colour, polarity)]


def one_per_mark(found: list[Located]) -> tuple[list[Located], list[Located]]:
    """Step 4: (marks, accessories) from the found answers."""
    marks: list[Located] = []
    for a in sorted(found, key=lambda a: -a.detection.score):
        if all(math.hypot(a.x - m.x, a.y - m.y) > max(a.extent, m.extent) for m in marks):
            marks.append(a)
    accessories = [a for a in marks if any(
        a.extent < ACCESSORY_RATIO * m.extent and math.hypot(a.x - m.x, a.y - m.y) < ACCESSORY_REACH * m.extent
        for m in marks if m is not a)]
    return [m for m in marks if all(m is not a for a in accessories)], accessories


def measure_candidates(measurer: Measurer, candidates: Sequence[Candidate],
                       measured: Sequence[Located] = ()) -> list[Located]:
    """Step 2-3 for each candidate, strongest first, skipping those much weaker than a mark already found
    (:data:`WEAK_CANDIDATE`) and those inside a mark already measured (its parts: arms, ring, centre dot); the
    ``measured`` answers (made before, e.g. on a box's whole window) come first."""
    attempts: list[Located] = list(measured)
    strongest = 0.0
    for c in candidates:
        if c.strength < WEAK_CANDIDATE * strongest:
            continue
        done = [a for a in attempts if a.found]
        if any(math.hypot(c.x - a.x, c.y - a.y) < a.extent for a in done):
            continue
        got = measurer.candidate(c)
        attempts.append(got)
        if got.found:
            strongest = max(strongest, c.strength)
    return attempts


def find_marks(image: str | os.PathLike[str] | np.ndarray | Any, region: Sequence[float] | None = None,
               mark: str = "auto", method: str = "auto", polarity: str = "bright", colour: str = "auto",
               min_radius: float = 2.0, max_radius: float = MAX_MARK_RADIUS, max_candidates: int = 16,
               **params: Any) -> MarkSearch:
    """Every mark in ``region`` of ``image`` (or the whole image), each with its sub-pixel centre and sigma.

    Parameters
    ----------
    image : path, ndarray or open raster
        As :func:`aerofid.locate` takes it.
    region : (x0, y0, x1, y1), optional
        Where the marks' centres may lie (full-image pixels, x1 and y1 exclusive); the whole image if None.
        Pixels around it are read as context (a JPEG whose region lies near its top is not decoded whole:
        :func:`~aerofid.windows.rows_read`).
    mark, method, polarity, colour, **params
        As :func:`aerofid.locate`.
    min_radius, max_radius : float
        The marks' radii sought (px); a large region is screened reduced, and marks much smaller than the
        reduction cannot be seen (:attr:`MarkSearch.reduction`).
    max_candidates : int
        At most this many candidates are measured.

    Returns
    -------
    MarkSearch
        ``marks`` (found, one per mark, accessories apart), every attempt, the screening candidates.

    Examples
    --------
    >>> import numpy as np, aerofid
    >>> from aerofid import synth
    >>> frame = synth.demo_frame(np.random.default_rng(0), size=900, mark_size=40)
    >>> got = aerofid.find_marks(frame.image, (0, 0, 900, 150), mark="external")
    >>> len(got)
    3
    """
    check_search(min_radius, max_radius, max_candidates)
    detector, polarities = configure(method, mark, polarity, colour, params)
    with open_image(image, None if region is None else rows_read(region)) as source:
        area = (0, 0, source.width, source.height) if region is None else clip_box(region, source.width,
                                                                                  source.height)[0]
        measurer = with_white(Measurer(source, detector, polarities, colour), area)
        candidates, f = screen_region(source, area, colour, polarities[0], min_radius, max_radius,
                                      max_candidates, measurer.white)
        return search(measurer, area, candidates, f)


def configure(method: str, mark: str, polarity: str, colour: str,
              params: Mapping[str, Any]) -> tuple[Detector, tuple[Polarity, ...]]:
    """The options of a search checked (one line each, before any pixel is read): the configured detector and
    the polarities to try (``"auto"``: both, the more reliable answer wins)."""
    check_polarity(polarity)
    check_choice(colour, COLOUR_POLICIES, "colour")
    detector = make_detector(method, mark, params)
    polarities: tuple[Polarity, ...] = POLARITIES if polarity == "auto" else (polarity,)  # type: ignore[assignment]
    return detector, polarities


def search(measurer: Measurer, region: Box, screened: tuple[Candidate, ...], reduction: int,
           last: tuple[Candidate, ...] = (), measured: tuple[Located, ...] = ()) -> MarkSearch:
    """Steps 2-4 on the ``screened`` candidates of ``region`` (then the ``last`` ones), with the answers
    ``measured`` before: the marks whose centres lie in the region, one per mark, accessories apart."""
    attempts = measure_candidates(measurer, (*screened, *last), measured)
    marks, accessories = one_per_mark([a for a in attempts if a.found and in_box(a.x, a.y, region)])
    source = measurer.source
    return MarkSearch(region, tuple(marks), tuple(accessories), tuple(attempts), screened, reduction,
                      source.width, source.height, None if source.path is None else str(source.path))


MAX_CANDIDATES = 1000
"""Most candidates one search may be asked to measure."""


def check_search(min_radius: float, max_radius: float, max_candidates: int) -> None:
    """The search's own parameters, refused in one line before anything is read or allocated."""
    if not (is_number(min_radius) and is_number(max_radius) and 0 < min_radius <= max_radius <= MAX_MARK_RADIUS):
        raise AerofidInputError(f"mark radii {min_radius!r}..{max_radius!r} px: give 0 < min_radius <= max_radius "
                                f"<= {MAX_MARK_RADIUS:g}")
    if not (is_int(max_candidates) and 1 <= max_candidates <= MAX_CANDIDATES):
        raise AerofidInputError(f"max_candidates {max_candidates!r}: give an integer from 1 to {MAX_CANDIDATES}")


def in_box(x: float, y: float, box: Box) -> bool:
    """Does the point (x, y) lie in ``box``, i.e. in one of its pixels (x1, y1 exclusive)?"""
    return box[0] - 0.5 <= x < box[2] - 0.5 and box[1] - 0.5 <= y < box[3] - 0.5


__all__ = ["FOUND", "NOT_FOUND", "Located", "MarkSearch", "Measurer", "configure", "find_marks", "in_box",
           "recentred_half", "search", "with_white"]
