"""``method="auto"``: run the detectors that apply, cross-check them, and answer only when the answer is trusted.

A confident wrong centre is the worst outcome for a user (Cho & Kim, seed 002, report 1 erroneous answer in
284 marks; our goal is none), so :func:`detect` prefers an explicit ``not_found`` to any centre it
cannot corroborate. The rule, applied deterministically to one grey window (mark brighter than its ground):

1. **Candidates.** ``symmetry`` (Cho & Kim) runs on the whole window, and ``circles`` (Seedahmed) on the crop
   about its answer that step 2 would re-examine a lone answer on: an answer there that agrees stands for the whole
   window's; where ``symmetry`` found nothing, or ``circles`` nothing that agrees on the crop, ``circles`` runs on
   the whole window (:func:`circles_about`). If neither found a mark, ``hough`` (Hunt, Ryan & Gifford) runs on the
   whole window too, when the user named the kind of mark (``mark="external"`` or ``"panel"``) or the ground is
   plain (film border: at least ``min_plain`` of the box within 4 noise sigma of its median; with ``mark="auto"`` on
   textured ground a lone ``hough`` answer could not be accepted anyway, see below, and its search is slow
   there); it gives up after ``fallback_rejections`` refused candidates (a true '+' is the first it verifies).
   With ``mark="panel"`` ``hough`` and ``symmetry`` run (a cloth panel is a '+': an answer without ``hough``'s
   '+' is not a panel, step 2). ``lines`` (Sohn et al.) is never run on the whole window (it returns confident
   wrong centres on dots and bull's-eyes); it is a corroborator only (step 2). Each detector must first pass its
   own self-diagnosis (status found).
2. **Cross-check.** Found answers within ``max(0.5 px, 3 sqrt(s1^2 + s2^2))`` (capped at ``max_agree`` px) of
   each other form a group. A group with a single member is re-examined on a crop of the window centred on
   it (half-size = the mark's extent + ``crop_margin``): a '+' from ``hough`` by ``lines`` (not for cloth
   panels, whose thin low-contrast strips on textured ground ``lines`` does not resolve), any answer by
   ``symmetry`` and, for rings, ``circles``, in the order of :data:`CROSS_CHECKERS` (after one agrees, only
   those that come first in :data:`PRIORITY`). Two or more independent methods agreeing is strong evidence
   (*corroborated*). A lone answer is kept only when its
   method applies to what the window shows (and it passes step 3): a ``hough`` answer (its verification has
   already checked four balanced arms of a '+'; ``lines`` does not survive JPEG blocks, so its silence is no
   evidence), a ``circles`` answer (two concentric circles, each covered on 60 % of its circumference), or a
   ``symmetry`` answer whose centre holds a compact core that stands out of the ground (a dot:
   :func:`core_contrast`). Two found answers that disagree while both lie on the same mark (closer than its
   extent) mean that at least one is wrong: nothing is answered.
3. **Verification, independent of the methods** (:func:`verify_centre`), on the group's centre and the
   mark's extent R (from the detectors' own models: the cross fit's arm lengths, the circles' radii; else a
   radial profile of the grey levels):

   - *containment*: the disc of radius R + ``edge_margin`` lies inside the window (half a mark cut by the
     box edge fails here);
   - *point symmetry*: the share of the structure in that disc that changes under a 180-degree rotation
     about the centre, net of noise, is at most ``max_disc_asymmetry`` (every supported mark style is
     centrally symmetric about its centre; a mark lying on the film border's edge, a wrong centre, a half
     mark fail here);
   - *uniqueness*: the disc is blanked out with the ground's grey level; a compact feature of the mark's
     size left in the rest of the window (:func:`structure_left`), or a second answer there of the group's
     methods, ``symmetry`` or ``circles`` (:func:`second_marks`), makes the box ambiguous. For a cloth panel
     the second '+' is sought by the panel's own image, turned, instead of ``hough``'s search
     (:func:`panel_twins`), and ``circles`` does not search (concentric circles are no panel).

4. **Compact dots with no method** (the Zeiss dot in a notch, whose frame edge spoils the whole-window
   methods): when nothing was found, the single strongest compact blob (difference of Gaussians, not an
   edge point) whose surroundings are flat (a moat of at least ``min_moat`` px) is isolated (everything
   beyond its moat, at most ``isolate_factor`` x its radius + 2 px, replaced by the ground level) and
   ``symmetry`` runs on it; its answer must agree with an intensity-weighted centroid of
   the blob and pass step 3.

**Score** (comparable across methods, in [0, 1]): with s_m the detectors' own scores, the group's evidence
is ``1 - prod(1 - s_m)`` over its members (independent methods), times ``lone_factor`` for a lone answer,
times the verification quality ``1 - asymmetry / (2 max_disc_asymmetry)``. The centre is that of the member with
the first in :data:`PRIORITY` (its ``method`` is reported), the ``sigma`` that member's.

The names in ``code`` are the fields of :class:`AutoParams`; each seed method runs with its own parameters
(:func:`detect`'s ``methods``, e.g. from :func:`aerofid.detect.registry.route_params`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from aerofid.conventions import FOUND, MARKS, Box
from aerofid.detect.asymmetry import KEPT_RADII, disc_box, distances, in_disc, offset_radii, point_asymmetry
from aerofid.detect.asymmetry import patch as _patch
from aerofid.detect.hough.cross_fit import CrossFit
from aerofid.detect.hough.detector import HoughResult, Verified, verify_like
from aerofid.detect.hough.params import HoughParams
from aerofid.detect.hough.search import WINDOW_EXTERNAL, WINDOW_PANEL
from aerofid.detect.lines_params import LinesParams
from aerofid.detect.noise import laplacian_noise_sigma
from aerofid.detect.params import MAX_PX, MethodParams, check, is_int, number_in
from aerofid.detect.registry import METHODS, SEED_METHODS
from aerofid.detect.result import Detection, unusable_window
from aerofid.detect.twins import PEAK_SEPARATION, match_peaks, turned_matches
from aerofid.robust import median

if TYPE_CHECKING:
    from matplotlib.figure import Figure

METHOD = "auto"

PRIORITY = ("hough", "symmetry", "circles", "lines", "centroid")
"""Whose centre a corroborated group returns: the first of its members in this order (docs/benchmarks_marks.md:
the cross fit of ``hough`` is the most accurate on '+' marks, ``symmetry`` with its point-symmetry refinement on
rings, dots and bull's-eyes: RMS 0.012 px against 0.019 px for ``circles`` on 20 Wild corner marks, 0.014
against 0.047 px with a speck on the ring; ``circles`` is better only under heavy noise, 0.024 against 0.032 px.
Picking the member with the smallest sigma, or the sigma-weighted mean, did worse: 0.019 and 0.014 px)."""

MIN_SIDE = 16
"""Smallest window side (px) ``auto`` looks at."""
MIN_CROP_SIDE = 17
"""A lone answer is re-examined on its crop only when the crop is at least this many px on each side."""
CROSS_CHECKERS = {"hough": ("lines", "symmetry"), "circles": ("symmetry", "hough"), "symmetry": ("circles", "hough")}
"""Step 2: which methods re-examine a lone answer of each method on its crop, in this order (``symmetry`` for
others; a cloth panel's lone ``hough`` answer only by ``symmetry``); after one agrees, only those that could give
the centre (:func:`cross_check`)."""
SEED = 12345
"""Seed of the noise that fills a blanked or isolated area (deterministic answers)."""

Blob = tuple[int, int, int, int, int]
"""A connected component (x0, y0, x1, y1, area) in window pixels, x1 and y1 exclusive."""


@dataclass(frozen=True)
class AutoParams(MethodParams):
    """``auto``'s own settings (the seed methods' parameters are passed separately, see :func:`detect`).

    Every default is aerofid's (no seed has this rule); the module docstring names the step that uses each.

    Examples
    --------
    >>> AutoParams().max_disc_asymmetry, AutoParams(mark="panel").mark
    (0.2, 'panel')
    >>> AutoParams(mark="ring")
    Traceback (most recent call last):
    ...
    ValueError: mark must be one of auto, external, panel, not 'ring'
    """

    mark: str = "auto"
    """Kind of mark: ``"auto"``, ``"external"`` (film fiducial) or ``"panel"`` (cloth ground panel); also
    passed to every seed method that takes a ``mark`` (``hough``). Step 1."""
    max_agree: float = 1.0
    """Largest distance (px) at which two methods' centres count as agreeing, whatever their sigmas. Step 2."""
    min_agree: float = 0.5
    """Two centres within this distance (px) always agree. Step 2."""
    crop_margin: int = 8
    """A lone answer is re-examined on a crop of half-size extent + this many px. Step 2."""
    edge_margin: float = 3.0
    """The mark's disc, this much beyond its extent (px), must lie inside the window. Step 3."""
    max_disc_asymmetry: float = 0.2
    """Largest share of the mark disc's structure that may change under a 180-degree rotation (step 3; not
    ``symmetry``'s own ``max_asymmetry``)."""
    cross_check_crossing_gap: float = 1.0
    """``hough`` re-examining a lone answer on its crop refuses before its cross fit a candidate whose Hough lines
    cross more than this many px from any bright pixel of its thresholded window (``HoughParams.max_crossing_gap``;
    a lower one of the user's is kept). There it can only confirm, refine or contradict a centre that two methods
    already agree on; the real RC20 rings' X, open at its centre, gave two such candidates on the ring, whose fits
    were refused and cost scipy.optimize's import in a one-box ``aerofid locate``. ``benchmarks/bench_fits.py --n 8
    --seed 7 --marks 30`` (docs/benchmarks_peers.md, session 19): every accepted '+' had a bright pixel within
    0.69 px of its Hough centre. The search of a whole box fits every candidate: a dust speck may hide the crossing
    of a '+'. Step 2."""
    cross_check_converged: float = 0.01
    """``lines`` re-examining a lone '+' on its crop ends its refinement when an iteration moves the intersection less
    than this many px (``LinesParams.converged``, 0.001 px for ``lines`` alone; a looser one of the user's is kept).
    Its answer only has to agree with ``hough``'s, within ``min_agree`` (0.5 px) at least, and ``hough``'s centre is
    the one returned: on bench_peers.py's 20 cross boxes the iterations moved it 0.03-0.1, then 0.006-0.045, 0.002-0.015
    px, and stopping below 0.01 px instead of 0.001 px took ``auto`` from 14.7-15.8 to 13.5-13.7 ms a box with the same
    answers (scratch ``/tmp/s51/conv2.py``). Step 2."""
    cross_check_rejections: int = 2
    """``hough`` re-examining a lone answer on its crop gives up after this many refused candidates (its own
    ``max_rejections`` is 8 for a whole box; a lower one of the user's is kept): a true '+' is the first candidate
    it verifies (measured in ``HoughParams.max_rejections``), and on the real RC20 rings every verified candidate
    was refused. Step 2."""
    fallback_rejections: int = 2
    """``hough`` run in step 1 because ``circles`` and ``symmetry`` found no mark gives up after this many refused
    candidates (its own ``max_rejections`` is 8 for a whole box; a lower one of the user's is kept). A true '+' is
    the first candidate it verifies (measured in ``HoughParams.max_rejections``; the frames' searches run with 2,
    :data:`aerofid.frame.orient.HOUGH_REJECTIONS`), and a box of a mark that is no '+' (a Zeiss dot in its notch)
    refused 8: ``hough`` took 27-32 ms of its ``auto`` call with 8, 14 ms with 2 (20 of bench_peers.py's boxes,
    scratch ``/tmp/s52/nh2.py``; ``auto`` 40.9 ms with 8, 35.3 with 4, 29.8 with 2, ``tfr.py``, both windows
    searched). The uniqueness pass's search of the blanked box keeps 8 (a second '+' there refuses the box). On the
    2210 boxes of bench_marks.py's scenes and rejection cases (n = 30) and bench_peers.py's, every status, centre,
    sigma and score is the same with 2 as with 8; 5 refusals give a vaguer reason ("no method found a mark" where the
    search went on to a ring's '+' and refused it as "ambiguous, draw a tighter box", 3 of 60 boxes with two ring
    marks, or as "cut by the box edge", 2 of 30 half rings; with 4: 2 of them; scratch ``boxes_dump.py``). Step 1."""
    lone_factor: float = 0.8
    """A lone (uncorroborated) answer's evidence is scaled by this. Score."""
    min_lone_score_hough: float = 0.2
    """A lone ``hough`` answer needs at least this score (its own minimum metric, seed 001); also the least
    metric of a second '+' in the uniqueness check. Step 2."""
    min_lone_score_circles: float = 0.5
    """A lone ``circles`` answer needs at least this score. Step 2."""
    min_lone_score_symmetry: float = 0.5
    """A lone ``symmetry`` answer needs at least this score. Step 2."""
    second_ratio: float = 0.5
    """Uniqueness: a second answer of a method counts when its score reaches this fraction of the mark's own
    score by that method (any score when the method did not answer for the mark). Step 3."""
    second_size: float = 2.0
    """... and when its extent is within this factor of the mark's (:func:`similar_size`). Step 3."""
    twin_match: float = 0.5
    """Uniqueness of a cloth panel (:func:`panel_twins`): places where the panel's own image, turned, correlates
    with the blanked window at least this much are fitted (in 20 scratch boxes with two panels the other
    correlated 0.75-0.94; in 20 of bench_peers.py's boxes with one, the best place of the aerial clutter
    0.63-0.81: the fit decides). Step 3."""
    twin_fits: int = 3
    """... at most this many of them, the best first. Step 3."""
    twin_slack: float = 2.0
    """... and a fitted '+' there counts with twice ``hough``'s limits on its centre's sigma and its misfit
    (``quality_refusal``'s ``slack``): to refuse a box is the safe side (a panel beside another, correlating 0.90 with
    it, had a misfit of 1.9 times the noise against ``hough``'s 1.8). Step 3."""
    extent_percentile: float = 75.0
    """The mark's extent from the radial profile (:func:`profile_extent`) uses this percentile over each
    circle. Step 3."""
    min_core_snr: float = 8.0
    """A lone ``symmetry`` answer needs a core (radius ``max(1.5, R/4)``) this many noise sigma above the ground
    (:func:`core_contrast`; the mark is bright, a darker core is a blob of the other polarity). Step 2."""
    isolate_factor: float = 2.0
    """Step 4 isolates a blob within this many times its radius (plus 2 px)."""
    min_plain: float = 0.5
    """Step 4 runs only on plain ground (film border): at least this fraction of the box within 4 noise sigma
    of its median grey level (aerial ground, an image-area edge in the box: no isolated-dot search); the
    same share lets ``hough`` run in step 1 with ``mark="auto"``."""
    plain_floor: float = 0.02
    """... or within this many grey levels (of 1) of it: JPEG blocks make plain film exceed 4 noise sigma (the
    noise estimate sees the smoothed blocks), while aerial ground stays below 25 % of the box within 0.02."""
    blob_edge_ratio: float = (10.0 + 1.0) ** 2 / 10.0
    """Step 4: a blob's DoG Hessian must have trace^2 / det below this (Lowe 2004, principal-curvature ratio
    10): points on the frame's straight edges are not blobs."""
    min_blob_snr: float = 10.0
    """Step 4: a compact blob's peak must stand this many noise sigma above the ground."""
    min_moat: float = 2.5
    """Step 4: flat ground must surround the blob from its radius out to at least this many px beyond it."""

    def validate(self) -> None:
        """One line for a bad value: which parameter, which values are allowed."""
        check(self.mark in MARKS, f"mark must be one of {', '.join(MARKS)}, not {self.mark!r}")
        check(number_in(self.min_agree, 0, MAX_PX, lo_open=True) and number_in(self.max_agree, self.min_agree, MAX_PX),
              f"need 0 < min_agree <= max_agree <= {MAX_PX}, not {self.min_agree!r} and {self.max_agree!r}")
        for name in ("cross_check_rejections", "fallback_rejections", "twin_fits"):
            check(is_int(getattr(self, name)) and getattr(self, name) >= 1,
                  f"{name} must be a whole number >= 1, not {getattr(self, name)!r}")
        check(isinstance(self.crop_margin, int) and 0 <= self.crop_margin <= MAX_PX,
              f"crop_margin must be a whole number of px in [0, {MAX_PX}], not {self.crop_margin!r}")
        for name in ("edge_margin", "min_moat", "cross_check_crossing_gap", "cross_check_converged"):
            check(number_in(getattr(self, name), 0, MAX_PX), f"{name} must be in [0, {MAX_PX}] px, "
                  f"not {getattr(self, name)!r}")
        for name in ("max_disc_asymmetry", "second_size", "min_core_snr", "isolate_factor", "blob_edge_ratio",
                     "min_blob_snr", "twin_slack"):
            check(number_in(getattr(self, name), 0, MAX_PX, lo_open=True), f"{name} must be in (0, {MAX_PX}], "
                  f"not {getattr(self, name)!r}")
        for name in ("lone_factor", "min_lone_score_hough", "min_lone_score_circles", "min_lone_score_symmetry",
                     "second_ratio", "twin_match", "min_plain", "plain_floor"):
            check(0 <= getattr(self, name) <= 1, f"{name} must be in [0, 1], not {getattr(self, name)}")
        check(0 < self.extent_percentile <= 100,
              f"extent_percentile must be in (0, 100], not {self.extent_percentile}")

    def min_lone_score(self, method: str) -> float:
        """The least score of a lone answer of ``method`` (0.5 for a method without its own)."""
        return float(getattr(self, f"min_lone_score_{method}", 0.5))


@dataclass(frozen=True)
class Check:
    """Outcome of :func:`verify_centre`: passed or not, why not, the disc's asymmetry and the mark's extent, and
    whether it failed because the mark reaches the box edge (``cut``: its asymmetry is then not measured)."""

    ok: bool
    reason: str
    asymmetry: float
    extent: float
    cut: bool = False


@dataclass(frozen=True)
class AutoResult(Detection):
    """``auto``'s answer: the centre and ``sigma`` of the member whose centre is returned (its ``method``),
    auto's own ``score``, and how the rule decided.

    Attributes
    ----------
    answers : Mapping[str, Detection]
        Every detector's answer, in window pixels: ``"circles"``, ``"symmetry"``, ``"hough"`` on the whole
        window, ``"circles@crop"`` (step 1's, about ``symmetry``'s answer, or step 2's), ``"<method>@crop"`` (step
        2), ``"symmetry@isolated"`` and ``"centroid"`` (step 4).
    windows : Mapping[str, Box]
        The part of the window (x0, y0, x1, y1) an answer's method saw, for the answers that saw a crop.
    groups : tuple of tuple of Detection
        The found answers grouped by agreement (step 2).
    members : tuple of Detection
        The group whose centre is returned (empty when nothing was found).
    check : Check or None
        The verification (step 3) of the group's centre.
    rule : str
        Which step decided (``"lone hough"``, ``"corroborated by symmetry, circles"``, ...).
    mark_extent : float
        The mark's radius (px) used in the verification (NaN before step 3).
    noise, plain_ground, ground_level, core_snr : float
        The window's noise sigma (Immerkaer), its share of plain ground and that ground's grey level, the
        contrast of a lone ``symmetry`` answer's core in noise sigma (NaN unless measured).
    structure_left : int or None
        Significant pixels left once the mark is blanked out (None: not measured).
    mark_like : tuple of Blob
        The mark-like components among them.
    second_marks : tuple of Detection
        Answers found on the rest of the window (step 3, uniqueness).
    ambiguous_at : (x, y) or None
        The centre (in the window ``auto`` saw) of the mark it verified but refused for the second mark-like
        feature beside it (step 3, uniqueness): where the tighter box that the refusal asks for would lie (the search
        of a whole frame, whose geometry judges which feature is the fiducial, draws it: :mod:`aerofid.frame.marks`).
        None when no mark was refused so.
    cut_at : (x, y) or None
        The centre (in the window ``auto`` saw) of the mark its verification refused as cut by the window's edge
        (:attr:`Check.cut`): where the larger box that the refusal asks for would be centred, for a mark of radius
        :attr:`mark_extent` (:mod:`aerofid.frame.marks` draws it where the frame's geometry expects a mark). None
        when no mark was refused so.
    """

    answers: Mapping[str, Detection] = field(default_factory=dict, compare=False, repr=False)
    windows: Mapping[str, Box] = field(default_factory=dict, compare=False, repr=False)
    groups: tuple[tuple[Detection, ...], ...] = field(default=(), compare=False, repr=False)
    members: tuple[Detection, ...] = field(default=(), compare=False, repr=False)
    check: Check | None = field(default=None, compare=False, repr=False)
    rule: str = ""
    mark_extent: float = field(default=float("nan"), compare=False)
    noise: float = field(default=float("nan"), compare=False, repr=False)
    plain_ground: float = field(default=float("nan"), compare=False, repr=False)
    ground_level: float = field(default=float("nan"), compare=False, repr=False)
    core_snr: float = field(default=float("nan"), compare=False, repr=False)
    structure_left: int | None = field(default=None, compare=False, repr=False)
    mark_like: tuple[Blob, ...] = field(default=(), compare=False, repr=False)
    second_marks: tuple[Detection, ...] = field(default=(), compare=False, repr=False)
    ambiguous_at: tuple[float, float] | None = field(default=None, compare=False, repr=False)
    cut_at: tuple[float, float] | None = field(default=None, compare=False, repr=False)

    @property
    def extent(self) -> float | None:
        """The mark's radius (px) that passed the verification (step 3), None when nothing was verified."""
        return float(self.mark_extent) if self.found and np.isfinite(self.mark_extent) else None

    @property
    def rivals(self) -> tuple[tuple[float, float], ...]:
        """Where the features that made the mark at :attr:`ambiguous_at` ambiguous lie (the window ``auto`` saw): the
        centres of the mark-like components left beside it, and the second marks' centres."""
        blobs = tuple(((x0 + x1 - 1) / 2.0, (y0 + y1 - 1) / 2.0) for x0, y0, x1, y1, _ in self.mark_like)
        return blobs + tuple((d.x, d.y) for d in self.second_marks)

    @property
    def member(self) -> Detection | None:
        """The member whose centre is returned (None when nothing was found)."""
        return _by_priority(self.members) if self.members else None

    def plot(self, fig: Figure, window: np.ndarray) -> None:
        """The returned member's own figure (on the part of ``window`` it saw) with auto's rule and score in
        the title; when nothing was found, ``window`` with every method's answer marked and the reason."""
        member = self.member
        if member is None:
            _plot_answers(fig, window, self)
            return
        key = next((k for k, d in self.answers.items() if d is member), member.method)
        x0, y0, x1, y1 = self.windows.get(key, (0, 0, window.shape[1], window.shape[0]))
        member.plot(fig, window[y0:y1, x0:x1])
        line = f"auto: {self.rule}, score {self.score:.2f}"
        old = fig.get_suptitle()
        fig.suptitle(f"{old}\n{line}" if old else line, fontsize=10)


def _plot_answers(fig: Figure, window: np.ndarray, res: AutoResult) -> None:
    """``window`` with every found answer marked, and the reason nothing was answered."""
    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(window, cmap="gray", interpolation="nearest")
    for (key, d), marker in zip(res.answers.items(), "+x1234"):
        if d.found:
            ax.plot([d.x], [d.y], marker, ms=12, mew=2, label=f"{key} ({d.x:.1f}, {d.y:.1f})")
    if any(d.found for d in res.answers.values()):
        ax.legend(fontsize=7, loc="lower right")
    ax.set_title(f"auto: not found: {res.reason}"[:110], fontsize=8, wrap=True)


@dataclass(eq=False)
class _Trace:
    """What the rule has learnt so far (becomes the :class:`AutoResult`'s typed fields)."""

    noise: float
    answers: dict[str, Detection] = field(default_factory=dict)
    windows: dict[str, Box] = field(default_factory=dict)
    plain_ground: float = float("nan")
    ground_level: float = float("nan")
    groups: list[list[Detection]] = field(default_factory=list)
    core_snr: float = float("nan")
    check: Check | None = None
    rule: str = ""
    mark_extent: float = float("nan")
    structure_left: int | None = None
    mark_like: list[Blob] = field(default_factory=list)
    second_marks: list[Detection] = field(default_factory=list)
    ambiguous_at: tuple[float, float] | None = None
    cut_at: tuple[float, float] | None = None

    def fields(self) -> dict[str, Any]:
        return {"answers": dict(self.answers), "windows": dict(self.windows),
                "groups": tuple(tuple(g) for g in self.groups), "check": self.check, "rule": self.rule,
                "mark_extent": self.mark_extent, "noise": self.noise, "plain_ground": self.plain_ground,
                "ground_level": self.ground_level, "core_snr": self.core_snr,
                "structure_left": self.structure_left, "mark_like": tuple(self.mark_like),
                "second_marks": tuple(self.second_marks), "ambiguous_at": self.ambiguous_at,
                "cut_at": self.cut_at}

    def on_crop(self, method: str, d: Detection, crop: np.ndarray, x0: int, y0: int) -> None:
        """Record ``method``'s answer ``d`` on ``crop`` (origin x0, y0) as ``<method>@crop``, with its window."""
        self.answers[f"{method}@crop"] = d
        self.windows[f"{method}@crop"] = (x0, y0, x0 + crop.shape[1], y0 + crop.shape[0])

    def not_found(self, reason: str) -> AutoResult:
        return AutoResult.not_found(METHOD, reason, **self.fields())

    def found(self, best: Detection, score: float, members: list[Detection]) -> AutoResult:
        return AutoResult(status=FOUND, x=best.x, y=best.y, score=score, sigma=best.sigma, method=best.method,
                          sigma_x=best.sigma_x, sigma_y=best.sigma_y, cov_xy=best.cov_xy,
                          members=tuple(members), **self.fields())


@dataclass(frozen=True, eq=False)
class _Context:
    """One call of :func:`detect`: the window, its noise, auto's parameters and each seed method's."""

    img: np.ndarray
    noise: float
    params: AutoParams
    seeds: Mapping[str, MethodParams]
    _extents: dict[tuple[tuple[str, float, float], ...], float] = field(default_factory=dict, init=False, repr=False)
    _crops: dict[tuple[str, int, int, int, int], Detection] = field(default_factory=dict, init=False, repr=False)

    @functools.cached_property
    def level(self) -> float:
        """The window's median grey level (step 1's plain ground and step 3's significance both start from it)."""
        return float(median(self.img))

    def run(self, name: str, window: np.ndarray, **overrides: Any) -> Detection:
        """Seed method ``name`` on ``window`` with its parameters, changed by ``overrides`` for this call."""
        p = self.seeds[name]
        return METHODS[name].detect(window, p.replace(**overrides) if overrides else p)

    def extent(self, members: list[Detection]) -> float:
        """:func:`group_extent` of ``members``, once per group (step 1's crop about ``symmetry``'s answer and step 2's
        are the same)."""
        key = tuple((d.method, d.x, d.y) for d in members)
        if key not in self._extents:
            self._extents[key] = group_extent(self.img, members, self.noise, self.params)
        return self._extents[key]

    def crop_about(self, d: Detection, extent: float) -> tuple[np.ndarray, int, int]:
        """The crop a lone answer ``d`` of a mark of radius ``extent`` is re-examined on (half-size ``extent +
        crop_margin``, step 2; step 1's ``circles`` about ``symmetry``'s answer), and its origin."""
        return _crop(self.img, d.x, d.y, int(np.ceil(extent + self.params.crop_margin)))

    def on_crop(self, name: str, crop: np.ndarray, x0: int, y0: int, **overrides: Any) -> Detection:
        """:meth:`run` on ``crop``, the part of the window from column ``x0``, row ``y0``; a found answer in window
        pixels. Without ``overrides``, once per crop and method (step 1's ``circles`` and step 2's)."""
        key = (name, x0, y0, *crop.shape)
        got = None if overrides else self._crops.get(key)
        if got is None:
            d = self.run(name, crop, **overrides)
            got = d.shifted(x0, y0) if d.found else d
            if not overrides:
                self._crops[key] = got
        return got


def seed_params(params: AutoParams, methods: Mapping[str, MethodParams] | None) -> dict[str, MethodParams]:
    """Each seed method's parameters: those given (defaults when absent), with auto's ``mark`` for the
    methods that take one."""
    out: dict[str, MethodParams] = {}
    for name in SEED_METHODS:
        ptype = METHODS[name].params_type
        p = (methods or {}).get(name) or ptype()
        if not isinstance(p, ptype):
            raise TypeError(f"parameters of {name!r} must be {ptype.__name__}, not {type(p).__name__}")
        out[name] = p.replace(mark=params.mark) if "mark" in p.names() else p
    return out


# --- the rule --------------------------------------------------------------------------------------------

def detect(window: np.ndarray, params: AutoParams = AutoParams(),
           methods: Mapping[str, MethodParams] | None = None) -> AutoResult:
    """The most reliable centre in ``window`` by the rule of the module docstring, or ``not_found``.

    Parameters
    ----------
    window : ndarray
        2-D grey levels on [0, 1], the mark brighter than its ground (at least 16 x 16 px); not modified.
    params : AutoParams
        ``auto``'s own settings.
    methods : Mapping[str, MethodParams], optional
        Each seed method's parameters by name (e.g. from :func:`aerofid.detect.registry.route_params`);
        a method not named runs with its defaults.

    Returns
    -------
    AutoResult
        In window pixels; ``method`` is the detector whose centre is returned, ``score`` auto's.

    Examples
    --------
    >>> from aerofid import synth
    >>> sc = synth.mark_scene("dot", size=24, window=64, rng=np.random.default_rng(1), noise_sigma=0.02)
    >>> res = detect(sc.image)
    >>> res.found, res.rule, bool(abs(res.x - sc.marks[0].x) < 0.1 and abs(res.y - sc.marks[0].y) < 0.1)
    (True, 'lone symmetry', True)
    >>> detect(np.zeros((64, 64), np.float32)).reason
    'homogeneous window (grey range below 0.02): no mark'
    """
    img = np.asarray(window, np.float32)
    bad = unusable_window(img, min_side=MIN_SIDE)
    if bad is not None:
        return AutoResult.not_found(METHOD, bad + (": no mark" if bad.startswith("homogeneous") else ""))
    noise = max(laplacian_noise_sigma(img), 1e-4)
    ctx = _Context(img, noise, params, seed_params(params, methods))
    trace = _Trace(noise=noise)
    run_candidates(ctx, trace)
    groups = group_answers([d for d in trace.answers.values() if d.found], params)
    trace.groups = groups
    why = disagreement(img, groups, noise, params)
    if why is not None:
        return trace.not_found(why)
    if not groups:
        if params.mark == "panel":
            return trace.not_found(_reasons(trace.answers))
        return compact_dot(ctx, trace)
    return _decide_group(ctx, trace, list(groups[0]))


def _decide_group(ctx: _Context, trace: _Trace, group: list[Detection]) -> AutoResult:
    """Steps 2 (a lone answer cross-checked, or accepted alone) and 3 for the one group of found answers."""
    extent = ctx.extent(group)
    if len(group) == 1:
        why = cross_check(ctx, trace, group, extent)
        if why is not None:
            return trace.not_found(why)
    if len(group) == 1:
        why = lone_answer_refused(ctx, trace, group[0], extent)
        if why is not None:
            return trace.not_found(why)
        rule = f"lone {group[0].method}"
    else:
        rule = "corroborated by " + ", ".join(d.method for d in group)
        extent = ctx.extent(group)
    return conclude(ctx, trace, group, extent, rule)


def run_candidates(ctx: _Context, trace: _Trace) -> None:
    """Step 1: run the whole-window methods (``circles`` first on the crop about ``symmetry``'s answer,
    :func:`circles_about`) into ``trace.answers``, and measure the plain ground."""
    p = ctx.params
    if p.mark == "panel":
        for m in ("hough", "symmetry"):
            trace.answers[m] = ctx.run(m, ctx.img)
    else:
        sym = ctx.run("symmetry", ctx.img)
        if not (sym.found and circles_about(ctx, trace, sym)):
            trace.answers["circles"] = ctx.run("circles", ctx.img)
        trace.answers["symmetry"] = sym
    trace.plain_ground, trace.ground_level = plain_ground(ctx.img, ctx.noise, p, ctx.level)
    nothing = not any(d.found for d in trace.answers.values())
    if nothing and "hough" not in trace.answers and (p.mark != "auto" or trace.plain_ground >= p.min_plain):
        trace.answers["hough"] = ctx.run("hough", ctx.img, **_fallback_params(ctx))


def circles_about(ctx: _Context, trace: _Trace, sym: Detection) -> bool:
    """Step 1: whether ``circles``, run on the crop about ``symmetry``'s answer that step 2 would re-examine it on
    (half-size its extent + ``crop_margin``), found a mark there that agrees with it (then in ``trace.answers`` as
    ``circles@crop``; its answer is kept for step 2's cross-check on the same crop). Where it agrees, the whole
    window's search is not run: on a ring or bull's-eye in a 200 px box it took 6.8-7.1 ms against 3.5-4.2 on the crop
    (scratch ``/tmp/s52/parts.py``).

    That search could also find another mark in the box, and the box was then refused ("2 different marks"). The
    uniqueness pass (step 3) does not count a second complete mark more than ``second_size`` times larger or smaller
    than this one (:func:`similar_size`), nor one the box edge cuts (:func:`structure_left`), and the old refusal
    came only where ``circles`` happened to answer that other mark. A review ran 6940 scenes of 64-200 px boxes with
    the old and this rule (two marks of other sizes, contrasts and styles, a second cut by the box edge, touching and
    concentric marks, aerial ground, tiny rings, noise, blur, JPEG, the traps of :mod:`aerofid.testing`; scratch
    ``/tmp/review53``). 20 statuses changed, each from refused to found on a real mark (within 0.02 px):
    15 boxes of a ring beside a complete mark 2.6-3.4 times smaller, 4 with a second ring cut by the box edge (found
    before by ``hough``, which had joined the group through the cross-check), and one dot that the old rule refused
    for two answers 0.59 px apart, now found 0.08 px from the truth. The old rule found 205 of 700 such
    larger-beside-smaller boxes too. 193 centres of two-mark and broken-ring boxes moved by up to 0.063 px
    (``symmetry``'s centre where the cross-check had added ``hough``'s; RMS from the truth 0.013 against 0.017 px).
    On the 2210 boxes of bench_marks.py's scenes and rejection cases (n = 30) and bench_peers.py: every status,
    centre and sigma the same, 129 scores changed by at most 0.0046 (``circles``' own score on the crop), 2 rules
    list the members in another order (scratch ``/tmp/s53/boxes_dump.py``).

    Skipping the whole window's search also where the crop holds no circle (a dot: 2.4 ms) was tried and not
    adopted: it changed 18 scores of blurred and heavy-noise rings and bull's-eyes by up to 0.21, and one centre by
    0.10 px. ``circles`` found those rings on the whole window but not on the crop, and the lone ``symmetry``
    answer's cross-check went on to ``hough``."""
    crop, x0, y0 = ctx.crop_about(sym, ctx.extent([sym]))
    if min(crop.shape) < MIN_CROP_SIDE:
        return False
    d = ctx.on_crop("circles", crop, x0, y0)
    if not (d.found and agree(sym, d, ctx.params)):
        return False
    trace.on_crop("circles", d, crop, x0, y0)
    return True


def _fallback_params(ctx: _Context) -> dict[str, Any]:
    """The parameters of step 1's ``hough`` (run because ``circles`` and ``symmetry`` found no mark) that ``auto``
    changes: ``max_rejections`` (``fallback_rejections``, or the user's own where it is lower). Its windows stay
    those of ``mark``: searching with the external window alone (``mark="auto"`` runs it only on plain ground, where
    no cloth panel lies) took ``auto`` on bench_peers.py's notch dots from 29.8 to 22.2 ms with every answer of the
    2210 boxes the same, but a review found small '+' marks on plain ground that only the panel window finds: 27 of
    1152 scenes of 8-16 px crosses in 32-96 px boxes (noise 0.05, contrast 0.5) were lost (scratch
    ``/tmp/review52/fb6.py``)."""
    return {"max_rejections": _lower(getattr(ctx.seeds["hough"], "max_rejections", None),
                                     ctx.params.fallback_rejections)}


def plain_ground(img: np.ndarray, noise: float, params: AutoParams = AutoParams(),
                 level: float | None = None) -> tuple[float, float]:
    """(share, grey level) of the window's plain ground: the pixels within max(4 noise, ``plain_floor``)
    of its median grey level (``level`` where it is known), and their median (the window's when there are none).

    Examples
    --------
    >>> img = np.full((20, 20), 0.1, np.float32); img[5:9, 5:9] = 0.9
    >>> share, level = plain_ground(img, 0.01)
    >>> share, round(level, 3)
    (0.96, 0.1)
    """
    g = float(median(img)) if level is None else level
    flat = np.abs(img - g) <= max(4.0 * noise, params.plain_floor)
    return float(flat.mean()), float(median(img[flat])) if flat.any() else g


def agree(a: Detection, b: Detection, params: AutoParams = AutoParams()) -> bool:
    """Step 2: two centres agree within ``max(min_agree, 3 sqrt(sa^2 + sb^2))``, capped at ``max_agree``
    (a sigma that is not finite counts as 0.1 px).

    Examples
    --------
    >>> a = Detection(status="found", x=10.0, y=10.0, sigma=0.05)
    >>> agree(a, Detection(status="found", x=10.4, y=10.0, sigma=0.05)), agree(a, Detection(x=11.2, y=10.0))
    (True, False)
    """
    d = float(np.hypot(a.x - b.x, a.y - b.y))
    sa = a.sigma if np.isfinite(a.sigma) else 0.1
    sb = b.sigma if np.isfinite(b.sigma) else 0.1
    return d <= min(params.max_agree, max(params.min_agree, 3.0 * np.hypot(sa, sb)))


def group_answers(found: list[Detection], params: AutoParams = AutoParams()) -> list[list[Detection]]:
    """Step 2: the found answers grouped by agreement (:func:`agree`) with each group's first member, taken
    in order of increasing sigma."""
    groups: list[list[Detection]] = []
    for d in sorted(found, key=lambda d: d.sigma if np.isfinite(d.sigma) else 1e9):
        for g in groups:
            if agree(g[0], d, params):
                g.append(d)
                break
        else:
            groups.append([d])
    return groups


def disagreement(img: np.ndarray, groups: list[list[Detection]], noise: float,
                 params: AutoParams = AutoParams()) -> str | None:
    """Step 2: why the groups cannot be trusted (two of them on the same mark, closer than its extent, or
    several marks in the box), or None for at most one group."""
    for i, a in enumerate(groups):
        for b in groups[i + 1:]:
            dist = float(np.hypot(a[0].x - b[0].x, a[0].y - b[0].y))
            reach = max(group_extent(img, a, noise, params), group_extent(img, b, noise, params))
            if dist < reach:
                return (f"methods disagree: {a[0].method} at ({a[0].x:.2f}, {a[0].y:.2f}) and {b[0].method} at "
                        f"({b[0].x:.2f}, {b[0].y:.2f}), {dist:.2f} px apart on the same mark")
    if len(groups) > 1:
        return (f"{len(groups)} different marks answered in the box ("
                + "; ".join(f"{g[0].method} at ({g[0].x:.1f}, {g[0].y:.1f})" for g in groups)
                + "): ambiguous, draw a tighter box")
    return None


def cross_check(ctx: _Context, trace: _Trace, group: list[Detection], extent: float) -> str | None:
    """Step 2 for a lone answer: the methods of :data:`CROSS_CHECKERS` run in turn on a crop of half-size
    ``extent + crop_margin`` around it; an agreeing answer joins ``group``, a disagreeing one is the reason
    returned (None otherwise). Once one agrees, only checkers that come before every member in :data:`PRIORITY`
    still run: they could give the centre (``hough`` after ``symmetry`` and ``circles`` agreed on a ring with a
    '+'), the others could only add evidence to a corroborated answer (``symmetry`` after ``lines`` confirmed a
    '+'; on 300 cross-checks of ``benchmarks/bench_fits.py``'s scenes a later checker never disagreed)."""
    lone = group[0]
    crop, x0, y0 = ctx.crop_about(lone, extent)
    if lone.method == "hough" and ctx.params.mark == "panel":
        checkers: tuple[str, ...] = ("symmetry",)
    else:
        checkers = CROSS_CHECKERS.get(lone.method, ("symmetry",))
    for m in checkers:
        if min(crop.shape) < MIN_CROP_SIDE or (len(group) > 1 and not _outranks(m, group)):
            continue
        d = ctx.on_crop(m, crop, x0, y0, **_cross_check_params(ctx, m, extent))
        if not d.found:
            continue
        trace.on_crop(m, d, crop, x0, y0)
        if not agree(lone, d, ctx.params):
            dist = float(np.hypot(d.x - lone.x, d.y - lone.y))
            return (f"methods disagree: {lone.method} at ({lone.x:.2f}, {lone.y:.2f}) and {m} on a crop around it "
                    f"at ({d.x:.2f}, {d.y:.2f}), {dist:.2f} px apart")
        group.append(d)
    return None


def _cross_check_params(ctx: _Context, method: str, extent: float) -> dict[str, Any]:
    """The parameters of ``method`` that a cross-check of a mark of radius ``extent`` changes: ``hough``'s
    ``max_rejections`` and ``max_crossing_gap`` (``cross_check_rejections`` and ``cross_check_crossing_gap``, or the
    user's own values where they are lower) and, for a mark wider than the panel window (``2 extent > WINDOW_PANEL``)
    with ``mark="auto"`` and no window size of the user's, ``window_size`` = ``WINDOW_EXTERNAL``: a window that cannot
    box the mark in (seed 001) does not search for it, and that spiral was 90 % of the cross-check of bench_peers.py's
    dots (3.35 -> 0.18 ms, median of 20 crops, neither finding a '+'); ``lines``' ``converged``
    (``cross_check_converged``, or the user's where it is higher)."""
    own = ctx.seeds[method]
    if isinstance(own, LinesParams):
        return {"converged": max(own.converged, ctx.params.cross_check_converged)}
    if not isinstance(own, HoughParams):
        return {}
    out: dict[str, Any] = {name: _lower(getattr(own, name), limit)
                           for name, limit in (("max_rejections", ctx.params.cross_check_rejections),
                                               ("max_crossing_gap", ctx.params.cross_check_crossing_gap))}
    if own.mark == "auto" and own.window_size is None and 2.0 * extent > WINDOW_PANEL:
        out["window_size"] = WINDOW_EXTERNAL
    return out


def _lower(mine: Any, limit: Any) -> Any:
    """``limit``, or the user's own value ``mine`` where it is lower (None: no limit of the user's)."""
    return limit if mine is None else min(mine, limit)


def _outranks(method: str, group: list[Detection]) -> bool:
    """Would an answer of ``method`` give the group's centre (it comes first in :data:`PRIORITY`)?"""
    return PRIORITY.index(method) < PRIORITY.index(_by_priority(group).method)


def lone_answer_refused(ctx: _Context, trace: _Trace, lone: Detection, extent: float) -> str | None:
    """Step 2: why a lone (uncorroborated) answer is not kept - a score below its method's
    ``min_lone_score_<method>``, a ``symmetry`` answer without a compact core (:func:`core_contrast`), or with
    ``mark="panel"`` an answer without ``hough``'s '+' (a compact blob of aerial ground 80 px from the panel in
    bench_boxes.py's panel scene 4) - or None."""
    if lone.score < ctx.params.min_lone_score(lone.method):
        return f"lone {lone.method} answer with a low score ({lone.score:.2f})"
    if ctx.params.mark == "panel" and lone.method != "hough":
        return (f"a lone {lone.method} answer at ({lone.x:.1f}, {lone.y:.1f}) and no '+' of hough there: a cloth "
                "panel is a '+'")
    if lone.method == "symmetry":
        c = core_contrast(ctx.img, lone.x, lone.y, extent, ctx.noise)
        trace.core_snr = c
        if not c >= ctx.params.min_core_snr:
            return (f"a lone symmetry answer at ({lone.x:.1f}, {lone.y:.1f}) with no compact core brighter than "
                    f"its ground ({c:.1f} noise sigma): not corroborated")
    return None


def conclude(ctx: _Context, trace: _Trace, group: list[Detection], extent: float, rule: str,
             dot: float | None = None) -> AutoResult:
    """Step 3 and the score for the accepted ``group``: the centre of its first member in :data:`PRIORITY`.
    ``dot`` is the plain ground level around an isolated dot (step 4), which also fills its blank: the
    annulus just outside a dot in a small notch holds the notch's walls."""
    best = _by_priority(group)
    chk = verify_centre(ctx.img, best.x, best.y, extent, ctx.noise, ctx.params)
    trace.check, trace.rule, trace.mark_extent = chk, rule, extent
    if not chk.ok:
        trace.cut_at = (float(best.x), float(best.y)) if chk.cut else None
        return trace.not_found(chk.reason)
    why = uniqueness(ctx, trace, group, best, extent, dot)
    if why is not None:
        trace.ambiguous_at = (float(best.x), float(best.y))
        return trace.not_found(why)
    return trace.found(best, auto_score(group, chk, ctx.params), group)


def auto_score(group: list[Detection], chk: Check, params: AutoParams = AutoParams()) -> float:
    """The score (module docstring): ``1 - prod(1 - s_m)`` over the group, times ``lone_factor`` for a single
    method, times ``1 - asymmetry / (2 max_disc_asymmetry)``, clipped to [0, 1].

    Examples
    --------
    >>> two = [Detection(score=0.5, method="circles"), Detection(score=0.5, method="symmetry")]
    >>> auto_score(two, Check(True, "", 0.1, 10.0))
    0.5625
    """
    evidence = 1.0 - float(np.prod([1.0 - float(np.clip(d.score, 0, 1)) for d in group]))
    if len({d.method for d in group}) < 2:
        evidence *= params.lone_factor
    quality = 1.0 - chk.asymmetry / (2.0 * params.max_disc_asymmetry)
    return float(np.clip(evidence * quality, 0.0, 1.0))


def _by_priority(group: list[Detection] | tuple[Detection, ...]) -> Detection:
    return min(group, key=lambda d: PRIORITY.index(d.method) if d.method in PRIORITY else len(PRIORITY))


# --- step 3: verification --------------------------------------------------------------------------------

def verify_centre(img: np.ndarray, x: float, y: float, extent: float, noise: float,
                  params: AutoParams = AutoParams()) -> Check:
    """Containment and point symmetry (module docstring, step 3) of the mark of radius ``extent`` at (x, y).

    Examples
    --------
    >>> img = np.full((40, 40), 0.1, np.float32); img[17:24, 17:24] = 0.9
    >>> verify_centre(img, 20.0, 20.0, 5.0, 0.01).ok, verify_centre(img, 20.0, 20.0, 18.0, 0.01).ok
    (True, False)
    """
    h, w = img.shape
    r = extent + params.edge_margin
    room = min(x, y, w - 1 - x, h - 1 - y)
    if room < r:
        return Check(False, f"the mark (radius {extent:.1f} px) at ({x:.1f}, {y:.1f}) is cut by the box edge "
                            f"(only {room:.1f} px of room): enlarge or move the box", float("nan"), extent, cut=True)
    asym = point_asymmetry(img, x, y, r, noise)
    if not asym <= params.max_disc_asymmetry:
        return Check(False, f"the mark at ({x:.1f}, {y:.1f}) is not centrally symmetric ({asym:.2f} of its "
                            f"disc's structure changes under a half turn; limit {params.max_disc_asymmetry}): "
                            "partly hidden, on an edge or a wrong centre", asym, extent)
    return Check(True, "", asym, extent)


def uniqueness(ctx: _Context, trace: _Trace, group: list[Detection], best: Detection, extent: float,
               dot: float | None = None) -> str | None:
    """Step 3, uniqueness: why the box holds another mark besides the one at ``best`` (a mark-like feature
    left once it is blanked out, :func:`structure_left`, or a method's second answer, :func:`second_marks`),
    or None. A cloth panel (``mark="panel"``) on textured ground is judged by the second answers only."""
    p = ctx.params
    blanked = blank_disc(ctx.img, best.x, best.y, extent + p.edge_margin, ctx.noise, level=dot)
    rest, blobs = structure_left(blanked, ctx.img, best.x, best.y, extent, ctx.noise, any_size=dot is not None,
                                 edge_margin=p.edge_margin, level=ctx.level)
    trace.structure_left, trace.mark_like = rest, blobs
    if blobs and p.mark != "panel":
        x0, y0, x1, y1, area = blobs[0]
        return (f"a second mark-like feature ({area} px in ({x0}, {y0})-({x1}, {y1})) besides the mark at "
                f"({best.x:.1f}, {best.y:.1f}): ambiguous, draw a tighter box")
    trace.second_marks = second_marks(ctx, blanked, group, best, extent) if rest else []
    if trace.second_marks:
        d = trace.second_marks[0]
        return (f"a second mark-like feature ({d.method}) at ({d.x:.1f}, {d.y:.1f}) besides the one at "
                f"({best.x:.1f}, {best.y:.1f}): ambiguous, draw a tighter box")
    return None


def second_marks(ctx: _Context, blanked: np.ndarray, group: list[Detection], best: Detection,
                 extent: float) -> list[Detection]:
    """Step 3, uniqueness: the answers of the group's methods, ``symmetry`` and ``circles`` on the window
    with the mark blanked out that are another mark: beyond ``extent`` from it, scoring at least
    ``second_ratio`` of the method's score on the mark, of a similar size (:func:`similar_size` of
    :func:`answer_extent`). For a cloth panel that ``hough`` fitted, :func:`panel_twins` takes the place of
    ``hough``'s search of the blanked window where it can look (not when the panel is too close to the window's
    edge for its turned image). A cloth panel's box (``mark="panel"``) is not searched by ``circles``: two concentric
    circles are no panel, and on aerial ground it found nothing in any of the 198 blanked windows of
    bench_marks.py's and bench_peers.py's panel boxes that reached this search (n = 30 per condition, scratch
    ``/tmp/s53/pc.py``), at 3-5 ms each. Beside a ring-like object (a tank, a roundabout) it refused the box: 71 of a
    review's 2100 such boxes are now found, 70 on the panel (within 0.114 px), one on a '+' of a panel's shape in a
    box without a panel (scratch ``/tmp/review53b``)."""
    p = ctx.params
    own = {d.method: d.score for d in group}
    fitted = next((d for d in group if isinstance(getattr(d, "refinement", None), CrossFit)), None)
    again = []
    for m in sorted(set(own) | ({"symmetry"} if p.mark == "panel" else {"symmetry", "circles"})):
        if m not in SEED_METHODS or m == "lines":
            continue
        twins = panel_twins(ctx, blanked, fitted, extent) if m == "hough" and p.mark == "panel" and fitted else None
        if twins is not None:
            again += twins
            continue
        floor = p.second_ratio * own.get(m, 0.0)
        # hough need not verify (fit) candidates too weak to count as a second mark
        d = ctx.run(m, blanked, min_metric=max(p.min_lone_score_hough, floor)) if m == "hough" else ctx.run(m, blanked)
        if d.found and np.hypot(d.x - best.x, d.y - best.y) > extent and d.score >= floor \
                and similar_size(answer_extent(blanked, d, extent, ctx.noise, p), extent, p):
            again.append(d)
    return again


TWIN_MARGIN = 1.0
"""The template of :func:`panel_twins` reaches this many px beyond the panel's extent: in 20 scratch boxes with two
panels the other panel then correlated best of all places (0.75-0.94); 2 px (more of the ground around the panel)
ranked it second or seventh twice, 0 or -1 px second or third once."""


def panel_twins(ctx: _Context, blanked: np.ndarray, panel: Detection, extent: float) -> list[Detection] | None:
    """Uniqueness of a cloth panel (beyond the seeds): a second panel of the same survey looks like this one
    (:func:`twin_panels` at the panel's own size on the window ``auto`` measured, the panel blanked out; a box's
    search by :func:`aerofid.locate.locate` looks for panels of other sizes too). None when the panel is
    too near the window's edge (or flat) for its turned image: then ``hough``'s search runs as before. ``hough``'s own
    search of the blanked window, which this replaces, stopped after 8 refused candidates of the aerial clutter and
    scored a second panel's window 0.03-0.9: it let 3 of 20 boxes with two panels through as found (scratch scenes of
    bench_peers.py's kind, the second panel 2.5-6 sizes away, turned at random, its size within 10 %)."""
    hp = ctx.seeds["hough"]
    assert isinstance(hp, HoughParams)
    return twin_panels(ctx.img, blanked, panel, extent, ctx.params, hp)


TWIN_SCALES = (1.0, 0.75, 1.333, 1.778)
"""Sizes of a second panel, relative to the found one, that :func:`twin_panels` matches where it is asked to look for
panels of other sizes (:func:`aerofid.locate.box_twin`): its own first, then steps of 4/3 (a twin between two of them
is at most 15 % off one) from 0.65 to 2 (``second_size``) times its size. Each scale's correlation costs the window's
area over the scale squared (0.75: 1.8 times the panel's own)."""


def twin_panels(img: np.ndarray, blanked: np.ndarray, panel: Detection, extent: float, params: AutoParams,
                hp: HoughParams, inside: Callable[[float, float], bool] | None = None,
                scales: tuple[float, ...] = (1.0,), slack: float | None = None) -> list[Detection] | None:
    """A second panel like ``panel`` (a ``hough`` answer with its :class:`CrossFit`) in ``blanked`` (``img`` with the
    panel blanked out), ``scales`` times the panel's size (the first: 1), whose centre satisfies ``inside`` (default:
    anywhere). The panel's own image (a square of half-size ``extent`` + :data:`TWIN_MARGIN` around its centre) is
    turned in 10 degree steps through a quarter turn and correlated with the blanked window
    (:func:`aerofid.detect.twins.turned_matches`), at another scale with the window resized by its inverse (a twin
    twice as large matches the panel's image in the window halved). The ``twin_fits`` best places of each scale
    correlating at least ``twin_match`` outside the blanked disc, one per place (its best scale: a structure matches
    at neighbouring scales alike), the ``twin_fits`` best of them, are fitted with the blurred-cross model started
    from the panel's own fit, turned and scaled (:func:`aerofid.detect.hough.detector.verify_like`); each '+' that
    passes ``hough``'s verification, shaped like the panel (:func:`twin_shape`) and clear of its disc (centres further
    apart than the two extents), is a second panel (score: its correlation; the first found ends the search).
    ``slack``: of the verification's quality limits (default ``twin_slack``). None when the panel is too near the
    window's edge (or flat) for its turned image; ``[]`` when no twin is found."""
    model = getattr(panel, "refinement", None)
    assert isinstance(model, CrossFit)
    places = _twin_places(img, blanked, panel, extent, params, inside, scales)
    if places is None:
        return None
    fitted: list[tuple[float, float, float]] = []
    for score, x, y, turn, scale in sorted(places, key=lambda p: -p[0]):
        if len(fitted) == params.twin_fits:
            break
        if any(s != scale and np.hypot(x - tx, y - ty) <= 2 * PEAK_SEPARATION for tx, ty, s in fitted):
            continue
        fitted.append((x, y, scale))
        like = model if scale == 1.0 else replace(model, length1=scale * model.length1,
                                                  length2=scale * model.length2, width=scale * model.width)
        got = verify_like(blanked, x, y, like, turn, hp, params.twin_slack if slack is None else slack)
        if isinstance(got, Verified) and twin_shape(got.refinement, model, params):
            f = got.refinement
            twin = HoughResult(status=FOUND, x=got.x, y=got.y, score=score, sigma=f.sigma, sigma_x=f.sigma_x,
                               sigma_y=f.sigma_y, cov_xy=f.cov_xy, method="hough", refinement=f)
            # two panels lie side by side: a '+' reaching into the panel's own disc is not another one
            if np.hypot(twin.x - panel.x, twin.y - panel.y) > extent + (twin.extent or 0.0):
                return [twin]   # one second panel makes the box ambiguous
    return []


def _twin_places(img: np.ndarray, blanked: np.ndarray, panel: Detection, extent: float, params: AutoParams,
                 inside: Callable[[float, float], bool] | None, scales: tuple[float, ...]
                 ) -> list[tuple[float, float, float, float, float]] | None:
    """:func:`twin_panels`' places to fit: (correlation, x, y, turn, scale) of each scale's best matches in ``blanked``
    whose centres satisfy ``inside``; None where the panel's turned image does not fit at the first scale."""
    half = int(np.ceil(extent + TWIN_MARGIN))
    h, w = blanked.shape
    places: list[tuple[float, float, float, float, float]] = []
    for scale in scales:
        if scale == 1.0:
            target, fx, fy = blanked, 1.0, 1.0
        else:
            size = (max(1, round(w / scale)), max(1, round(h / scale)))
            target = cv2.resize(blanked, size, interpolation=cv2.INTER_AREA if scale > 1 else cv2.INTER_LINEAR)
            fx, fy = w / size[0], h / size[1]
        matches = turned_matches(img, target, panel.x, panel.y, half)
        if matches is None:
            if scale == scales[0]:
                return None
            continue
        px, py = (panel.x + 0.5) / fx - 0.5, (panel.y + 0.5) / fy - 0.5
        for score, x, y, turn in match_peaks(matches, px, py, (extent + params.edge_margin) / max(fx, fy),
                                             params.twin_match, params.twin_fits):
            if scale != 1.0:
                x, y = (x + 0.5) * fx - 0.5, (y + 0.5) * fy - 0.5
            if inside is None or inside(x, y):
                places.append((score, x, y, turn, scale))
    return places


TWIN_MIN_BLUR = 0.5
"""Least blur (px) :func:`twin_shape` takes for the panel's: a fit of a sharp scan can end near 0."""


def twin_shape(other: CrossFit, panel: CrossFit, params: AutoParams = AutoParams()) -> bool:
    """A fitted '+' is shaped like the panel when its stroke width and its longer bar are each within
    ``second_size`` times the panel's (:func:`similar_size`), and it is blurred at most ``second_size`` times as much
    (the panel's blur taken as at least :data:`TWIN_MIN_BLUR`): one scan blurs both panels of a survey alike. A
    crossing of two roads, 3 times as wide as a strongly blurred panel beside it, correlated 0.57 with it and passed
    ``hough``'s verification (bench_marks.py, strong blur). Matched at other sizes too
    (:func:`aerofid.locate.box_twin`), blurred texture beside a lone panel was fitted as a '+' 0.8-1.6 times its size
    with a blur of 1.4-2.5 px against the panel's 0.6, and 14 of a review's 100 boxes with one panel were "2 marks in
    the box"; the second panels of its boxes with two were fitted with 0.64-0.73 px beside 0.54-0.65.

    Examples
    --------
    >>> from aerofid.detect.hough.cross_fit import CrossFit
    >>> panel = CrossFit(0, 0, .1, .1, 0, 90, 10.9, 10.5, 1.46, 1.48, .37, .01, .01, (.3, .3, .3, .3))
    >>> road = CrossFit(0, 0, .1, .1, 0, 90, 18.2, 20.0, 4.74, 1.55, .2, .01, .01, (.2, .2, .2, .2))
    >>> blurred = CrossFit(0, 0, .1, .1, 0, 90, 10.9, 10.5, 1.46, 3.1, .37, .01, .01, (.3, .3, .3, .3))
    >>> twin_shape(road, panel), twin_shape(panel, panel), twin_shape(blurred, panel)
    (False, True, False)
    """
    return similar_size(other.width, panel.width, params) and similar_size(
        max(other.length1, other.length2), max(panel.length1, panel.length2), params) \
        and other.blur <= params.second_size * max(panel.blur, TWIN_MIN_BLUR)


def answer_extent(img: np.ndarray, d: Detection, extent: float, noise: float,
                  params: AutoParams = AutoParams()) -> float:
    """The size of a second answer: its method's model of it, else the radial profile around it
    (:func:`profile_extent`, out to ``second_size`` times the mark's ``extent``): a column of printed index dots
    beside a corner mark is symmetric about its middle dot, but a third of the mark's size."""
    if d.extent is not None:
        return d.extent
    return profile_extent(img, d.x, d.y, noise, params.second_size * extent + 2.0, params.extent_percentile)


def similar_size(other: float | None, extent: float, params: AutoParams = AutoParams()) -> bool:
    """Uniqueness: a second answer is another *mark* only when its size (from its detector's model) is within
    ``second_size`` times the mark's (or unknown); a crossing of two field boundaries whose '+' arms run out
    of the box, or a broad blurred cross in aerial texture around a small cloth panel, is not.

    Examples
    --------
    >>> similar_size(12.0, 10.0), similar_size(30.0, 10.0), similar_size(None, 10.0)
    (True, False, True)
    """
    return other is None or 1.0 / params.second_size <= other / max(extent, 1e-6) <= params.second_size


# --- geometry helpers ------------------------------------------------------------------------------------

def ground_level(img: np.ndarray, x: float, y: float, r_in: float, r_out: float) -> float:
    """Median grey level in the annulus r_in..r_out around (x, y) (whole window when it is empty)."""
    x0, y0, x1, y1 = disc_box(x, y, r_out, img.shape)
    near = img[y0:y1, x0:x1]
    d = distances(x, y, near.shape, (x0, y0))
    sel = (d >= r_in) & (d <= r_out)
    return float(median(near[sel])) if sel.sum() >= 8 else float(median(img))


def profile_extent(img: np.ndarray, x: float, y: float, noise: float, r_max: float,
                   percentile: float = 75.0) -> float:
    """Radius (px) of the structure around (x, y): the last radius at which the ``percentile``-th percentile
    (``extent_percentile``) of the absolute deviation from the ground over the circle (smoothed by 1 px)
    exceeds max(0.25 x its largest value, 5 noise). A percentile, not the largest value: a thin line running
    through a dot (the real EarthExplorer block mark) or a '+' beyond a ring crosses every circle at a few
    points and would make the mark as large as the box."""
    k = int(np.ceil(r_max))
    p = cv2.GaussianBlur(_patch(img, x, y, k), (0, 0), 1.0)
    edge, order, layout = _profile_rings(k)
    g = float(median(p[edge])) if edge.any() else float(median(p))
    prof = _percentiles_by_ring(np.abs(p - g).ravel()[order], layout, percentile)
    thr = max(0.25 * prof.max(), 5.0 * noise)
    above = np.flatnonzero(prof > thr)
    return float(above[-1] + 1) if above.size else 1.0


RingLayout = tuple[np.ndarray, np.ndarray, np.ndarray, int]
"""Values ordered by ring laid out as the rows of a table (:func:`_ring_layout`): each ring's count, and each value's
row (its ring) and column (its place in the ring), and the longest ring's count."""


def _profile_rings(k: int) -> tuple[np.ndarray, np.ndarray, RingLayout]:
    """:func:`_rings_of_square`, made once per size up to :data:`~aerofid.detect.asymmetry.KEPT_RADII` (a box's radial
    profiles ask for the same few; 2.7 MB at 256 px, read-only), as :func:`offset_radii` keeps its squares."""
    return _kept_rings(k) if k <= KEPT_RADII else _rings_of_square(k)


@functools.lru_cache(maxsize=16)
def _kept_rings(k: int) -> tuple[np.ndarray, np.ndarray, RingLayout]:
    return _rings_of_square(k)


def _rings_of_square(k: int) -> tuple[np.ndarray, np.ndarray, RingLayout]:
    """The radial profile's rings of the (2k+1)-square about its centre: the outer ring's mask (radius in (k - 2,
    k]: the ground), the flat indices of the pixels within k ordered by ring (``floor`` of the radius; numpy's stable
    radix sort of 16-bit ring numbers, so in row-major order within a ring), and their layout."""
    rr = offset_radii(k)
    inside = rr <= k
    ring = np.floor(rr[inside]).astype(np.int32)
    order = np.flatnonzero(inside)[np.argsort(ring.astype(np.int16), kind="stable")].astype(np.int32)
    counts, rows, cols, width = _ring_layout(np.bincount(ring, minlength=k + 1))
    edge, rows, cols = (rr > k - 2) & inside, rows.astype(np.int32), cols.astype(np.int32)
    for a in (edge, order, counts, rows, cols):
        a.flags.writeable = False           # kept (:func:`_profile_rings`): nobody may change them
    return edge, order, (counts, rows, cols, width)


def ring_percentiles(values: np.ndarray, ring: np.ndarray, n: int, percentile: float) -> np.ndarray:
    """The ``percentile``-th percentile (linear interpolation, as :func:`numpy.percentile`) of ``values`` on each
    ring ``0 .. n - 1`` (0 for a ring without values): the values ordered by ring (numpy's stable sort of the ring
    numbers), then :func:`_percentiles_by_ring`.

    Examples
    --------
    >>> ring_percentiles(np.array([1.0, 3.0, 2.0, 9.0]), np.array([0, 0, 0, 2]), 3, 50.0).tolist()
    [2.0, 0.0, 9.0]
    """
    ring = np.asarray(ring)
    if ring.size and not (ring.min() >= 0 and ring.max() < n):
        raise ValueError(f"ring numbers must lie in 0 .. {n - 1}")
    if not 0 <= percentile <= 100:
        raise ValueError(f"percentile {percentile!r} is not in [0, 100]")
    numbers = ring.astype(np.int16) if n <= np.iinfo(np.int16).max else ring
    order = np.argsort(numbers, kind="stable")
    return _percentiles_by_ring(np.asarray(values)[order], _ring_layout(np.bincount(ring, minlength=n)), percentile)


def _ring_layout(counts: np.ndarray) -> RingLayout:
    """:data:`RingLayout` of values ordered by ring, ``counts`` of them on each."""
    ends = np.cumsum(counts)
    rows = np.repeat(np.arange(counts.size, dtype=np.intp), counts)
    cols = np.arange(int(ends[-1]) if ends.size else 0, dtype=np.intp) - np.repeat(ends - counts, counts)
    return counts, rows, cols, int(counts.max(initial=0))


def _percentiles_by_ring(ordered: np.ndarray, layout: RingLayout, percentile: float) -> np.ndarray:
    """Each ring's ``percentile``-th percentile of ``ordered`` (values ordered by ring, as ``layout`` lays them out):
    the rings as the rows of a table padded with nan, each row sorted (a sorted row holds its ring's values in order,
    nan last, as a selection within the ring places them), its two neighbours read in float64 and interpolated as
    numpy does (0 for a ring without values). One sort of the table instead of a selection per ring: 0.98 -> 0.55 ms for
    a 200 px box's profile (100 rings; scratch ``/tmp/s53/pe3.py``), the same bytes on 5000 random cases and 1344
    profiles (``/tmp/s53/rpid.py``)."""
    counts, rows, cols, width = layout
    n = counts.size
    kind = ordered.dtype if ordered.dtype in (np.float32, np.float64) else np.dtype(np.float64)
    table = np.full((n, max(width, 1)), np.nan, kind)
    table[rows, cols] = ordered
    table.sort(axis=1)
    pos = (counts - 1) * (percentile / 100.0)
    below = np.floor(pos).astype(np.intp)
    frac = pos - below
    top = np.minimum(below + 1, counts - 1)             # the last value twice, as numpy
    every = np.arange(n)
    lo = table[every, np.maximum(below, 0)].astype(np.float64)
    hi = table[every, np.maximum(top, 0)].astype(np.float64)
    return np.where(counts > 0, lo + (hi - lo) * frac, 0.0)


def group_extent(img: np.ndarray, members: list[Detection], noise: float,
                 params: AutoParams = AutoParams()) -> float:
    """The mark's radius (px): the largest of the members' own models (:attr:`Detection.extent`), else the
    radial profile around the first member (:func:`profile_extent`)."""
    ext = [e for e in (m.extent for m in members) if e is not None]
    if ext:
        return max(ext)
    h, w = img.shape
    m = members[0]
    r_max = max(4.0, min(m.x, m.y, w - 1 - m.x, h - 1 - m.y, 0.5 * min(h, w)))
    return profile_extent(img, m.x, m.y, noise, r_max, params.extent_percentile)


def core_contrast(img: np.ndarray, x: float, y: float, extent: float, noise: float) -> float:
    """Mean grey level within max(1.5, extent/4) px of (x, y) minus the ground just outside the extent, in
    noise sigma (per-pixel noise over sqrt of the pixels averaged)."""
    k = int(np.ceil(extent + 4))
    p = _patch(img, x, y, k)
    rr = offset_radii(k)
    core = rr <= max(1.5, extent / 4.0)
    ground = (rr > extent + 1) & (rr <= extent + 4)
    if not ground.any():
        return 0.0
    return float((p[core].mean() - median(p[ground])) / (max(noise, 1e-4) / np.sqrt(core.sum())))


def blank_disc(img: np.ndarray, x: float, y: float, radius: float, noise: float = 0.0,
               level: float | None = None) -> np.ndarray:
    """A copy of ``img`` with the disc of ``radius`` around (x, y) replaced by ``level`` (default: the ground
    level around it, :func:`ground_level`) plus white noise of std ``noise`` (a fixed seed: deterministic), so
    that the blank looks like plain ground."""
    block, d = in_disc(x, y, radius, img.shape)
    out = img.copy()
    fill = np.random.default_rng(SEED).normal(0.0, noise, int(d.sum())) if noise > 0 else 0.0
    if level is None:
        level = ground_level(img, x, y, radius, radius + 5)
    out[block][d] = np.asarray(level + fill, np.float32)
    return out


def _significance(img: np.ndarray, x: float, y: float, extent: float, noise: float,
                  level: float | None = None) -> tuple[np.ndarray, float, float]:
    """(smoothed image, ground level, threshold): a pixel of the image smoothed by 1 px is significant when it
    differs from the window's median (``level`` where it is known) by more than max(6 x its noise, a quarter of the
    mark's amplitude)."""
    g = float(median(img)) if level is None else level
    sm = cv2.GaussianBlur(img, (0, 0), 1.0)
    k = int(np.ceil(extent))
    amp = float(np.abs(cv2.GaussianBlur(_patch(img, x, y, k), (0, 0), 1.0) - g).max())
    return sm, g, max(6.0 * noise * 0.28, 0.25 * amp)


def structure_left(blanked: np.ndarray, img: np.ndarray, x: float, y: float, extent: float, noise: float,
                   any_size: bool = False, edge_margin: float = 3.0, level: float | None = None
                   ) -> tuple[int, list[Blob]]:
    """What remains of the window once the mark is blanked out (:func:`blank_disc`): the number of significant
    pixels (:func:`_significance`) and the *mark-like* connected components among them (:data:`Blob`): at
    least a quarter of the mark's own significant area (within ``extent + edge_margin``) and 6 px, and compact
    (bounding box at most 1.5 mark diameters across, not touching the box edge: an image-area edge or corner,
    or a frame running through the box, is not mark-like); with ``any_size`` (an isolated dot) any component
    up to half the box across counts: the 'dot' may be a piece of a larger mark, e.g. an arm's tip cut off by
    a speck. None left means the box holds nothing but the mark and plain ground. ``level``: the window's median,
    where it is known."""
    sm0, g, thr = _significance(img, x, y, extent, noise, level)
    h, w = img.shape
    block, near = in_disc(x, y, extent + edge_margin, img.shape)
    own = int(((np.abs(sm0[block] - g) > thr) & near).sum())
    sig = (np.abs(cv2.GaussianBlur(blanked, (0, 0), 1.0) - g) > thr).astype(np.uint8)
    n, _, stats, _ = cv2.connectedComponentsWithStats(sig, connectivity=8)
    largest = 0.5 * max(h, w) if any_size else 1.5 * 2 * (extent + edge_margin)
    marks = []
    for i in range(1, n):
        x0, y0, bw, bh, area = (int(v) for v in stats[i])
        inside = x0 > 0 and y0 > 0 and x0 + bw < w and y0 + bh < h
        if inside and area >= max(6, 0.25 * own) and max(bw, bh) <= largest:
            marks.append((x0, y0, x0 + bw, y0 + bh, area))
    return int(sig.sum()), marks


def _crop(img: np.ndarray, x: float, y: float, half: int) -> tuple[np.ndarray, int, int]:
    """The part of ``img`` within ``half`` px of the pixel nearest (x, y) (a view), and its origin."""
    h, w = img.shape
    cx, cy = int(round(x)), int(round(y))
    x0, y0 = max(0, cx - half), max(0, cy - half)
    x1, y1 = min(w, cx + half + 1), min(h, cy + half + 1)
    return img[y0:y1, x0:x1], x0, y0


def _reasons(answers: Mapping[str, Detection]) -> str:
    return "no method found a mark: " + "; ".join(f"{m}: {d.reason}" for m, d in answers.items() if not d.found)


# --- step 4: a compact dot that no method found ----------------------------------------------------------

def compact_dot(ctx: _Context, trace: _Trace) -> AutoResult:
    """Step 4 of the module docstring (nothing was found by the whole-window methods)."""
    p, img, noise = ctx.params, ctx.img, ctx.noise
    if trace.plain_ground < p.min_plain:
        return trace.not_found(_reasons(trace.answers) + f"; the ground is not plain (only {trace.plain_ground:.0%} "
                               "of the box is within 4 noise sigma of its median): no isolated dot is looked for")
    blob = find_flat_blob(img, noise, trace.ground_level, p)
    if isinstance(blob, str):
        return trace.not_found(_reasons(trace.answers) + f"; {blob}")
    bx, by, r_blob, iso = blob
    det = isolated_symmetry(ctx, trace, bx, by, iso)
    if not det.found:
        return trace.not_found(_reasons(trace.answers) + f"; isolated compact blob: {det.reason}")
    centroid = blob_centroid(img, det, iso, r_blob)
    if centroid is None:
        return trace.not_found(_reasons(trace.answers))
    trace.answers["centroid"] = centroid
    if not agree(det, centroid, p):
        return trace.not_found(f"isolated dot: symmetry ({det.x:.2f}, {det.y:.2f}) and centroid "
                               f"({centroid.x:.2f}, {centroid.y:.2f}) disagree")
    group = [det, centroid]
    trace.groups = [group]
    return conclude(ctx, trace, group, r_blob + 1.0, "isolated compact dot: symmetry + centroid",
                    dot=trace.ground_level)


def blob_peaks(img: np.ndarray, params: AutoParams = AutoParams()) -> list[tuple[float, int, int]]:
    """Step 4: (strength, x, y) of the blob-like local maxima of the scale-normalised difference of Gaussians
    at sigma 1, 1.5, 2 and 2.5 px, strongest first. Lowe's edge-response test on the DoG's Hessian: a blob
    curves both ways (det > 0, trace^2 / det below ``blob_edge_ratio``), a point on a straight edge or frame
    line only across it."""
    found: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for s in (1.0, 1.5, 2.0, 2.5):
        dog = (cv2.GaussianBlur(img, (0, 0), s) - cv2.GaussianBlur(img, (0, 0), 1.6 * s)) * s
        dil = cv2.dilate(dog, np.ones((5, 5), np.uint8))
        dxx = cv2.Sobel(dog, cv2.CV_32F, 2, 0, ksize=3)
        dyy = cv2.Sobel(dog, cv2.CV_32F, 0, 2, ksize=3)
        dxy = cv2.Sobel(dog, cv2.CV_32F, 1, 1, ksize=3)
        det, tr = dxx * dyy - dxy * dxy, dxx + dyy
        blobby = (det > 0) & (tr < 0) & (tr * tr < params.blob_edge_ratio * det)
        ys, xs = np.nonzero((dog >= dil) & (dog > 0) & blobby)
        found.append((dog[ys, xs], xs, ys))
    strength, xs, ys = (np.concatenate(a) for a in zip(*found))
    order = np.lexsort((xs, ys, -strength))   # stable: equal peaks of two scales in the order of the scales
    return list(zip(strength[order].tolist(), xs[order].tolist(), ys[order].tolist()))


def find_flat_blob(img: np.ndarray, noise: float, ground: float,
                   params: AutoParams = AutoParams()) -> tuple[int, int, float, float] | str:
    """Step 4: (x, y, radius, moat) of the strongest compact blob (:func:`blob_peaks`, at most 12 distinct
    places tried) with flat surroundings (:func:`flat_blob`), or why there is none."""
    seen: list[tuple[int, int]] = []
    why = "no compact blob with flat surroundings"
    for _, bx, by in blob_peaks(img, params):
        if any(abs(bx - sx) <= 3 and abs(by - sy) <= 3 for sx, sy in seen):
            continue
        seen.append((bx, by))
        if len(seen) > 12:
            break
        got = flat_blob(img, bx, by, noise, ground, params)
        if isinstance(got, str):
            why = got
            continue
        return bx, by, got[0], got[1]
    return why


def flat_blob(img: np.ndarray, bx: int, by: int, noise: float, ground: float,
              params: AutoParams = AutoParams()) -> tuple[float, float] | str:
    """(radius, moat) of a compact bright blob at pixel (bx, by), or why it is not one. The radius is the
    half maximum of its radial profile above the plain ground level ``ground``; the moat is the radius out to
    which its surroundings are flat: every 1-px ring from radius + 1.5 px on, up to ``isolate_factor`` x the
    radius + 2 px, has at least 95 % of its pixels within 4 noise of the ground. A moat narrower than
    ``min_moat`` px means the blob is part of a larger structure (a small Zeiss notch is allowed to come
    closer than ``isolate_factor`` radii)."""
    h, w = img.shape
    k = int(min(20, bx, by, w - 1 - bx, h - 1 - by))
    if k < 5:
        return "a compact blob at the box edge"
    p = _patch(img, bx, by, k)
    if p[k, k] - ground < params.min_blob_snr * noise:   # the profile's value at radius 0, in the window's type
        return "the brightest compact blob is too faint"
    rr = offset_radii(k)
    prof = np.array([p[(rr >= r - 0.5) & (rr < r + 0.5)].mean() for r in range(k + 1)])
    half = np.flatnonzero(prof - ground < 0.5 * (prof[0] - ground))
    if not half.size:
        return "a blob larger than 20 px"
    r_blob = max(1.0, float(half[0]))
    reach = params.isolate_factor * r_blob + 2.0
    if reach + 2 > k:
        return "a compact blob too close to the box edge"
    flat = np.abs(p - ground) <= 4.0 * noise
    moat = r_blob + 1.5
    while moat + 1.0 <= reach:
        ring = (rr > moat) & (rr <= moat + 1.0)
        if flat[ring].mean() < 0.95:
            break
        moat += 1.0
    if moat < r_blob + params.min_moat:
        return "the compact blob's surroundings are not flat"
    return r_blob, moat


def isolated_symmetry(ctx: _Context, trace: _Trace, bx: int, by: int, iso: float) -> Detection:
    """Step 4: ``symmetry`` on the blob at (bx, by) isolated within ``iso`` px (everything beyond replaced by
    its ground level plus noise), twice, the second time around the first answer; in window pixels, also
    stored in ``trace.answers["symmetry@isolated"]``."""
    cx, cy = float(bx), float(by)
    det: Detection = Detection()
    for _ in range(2):
        sub, x0, y0 = _crop(ctx.img, cx, cy, max(24, int(np.ceil(iso + 12))))
        sy, sx = np.mgrid[0:sub.shape[0], 0:sub.shape[1]]
        gl = ground_level(sub, cx - x0, cy - y0, iso, iso + 3)
        fill = gl + np.random.default_rng(SEED).normal(0.0, ctx.noise, sub.shape)
        iso_img = np.where(np.hypot(sx - (cx - x0), sy - (cy - y0)) <= iso, sub, fill).astype(np.float32)
        det = ctx.run("symmetry", iso_img)
        trace.answers["symmetry@isolated"] = det
        if not det.found:
            return det
        det = det.shifted(x0, y0)
        trace.answers["symmetry@isolated"] = det
        trace.windows["symmetry@isolated"] = (x0, y0, x0 + sub.shape[1], y0 + sub.shape[0])
        cx, cy = det.x, det.y
    return det


def blob_centroid(img: np.ndarray, det: Detection, iso: float, r_blob: float) -> Detection | None:
    """Step 4: the intensity-weighted centroid (above the ground around ``iso``) of the blob within
    ``r_blob + 2`` px of ``det``'s centre, as a ``"centroid"`` answer (None when nothing is above ground)."""
    k = int(np.ceil(iso))
    pc = _patch(img, det.x, det.y, k)
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    wgt = np.clip(pc - ground_level(img, det.x, det.y, iso, iso + 3), 0, None) * (offset_radii(k) <= r_blob + 2)
    if wgt.sum() <= 0:
        return None
    return Detection(status=FOUND, x=det.x + float((wgt * xx).sum() / wgt.sum()),
                     y=det.y + float((wgt * yy).sum() / wgt.sum()), score=0.8, sigma=max(det.sigma, 0.05),
                     method="centroid")


__all__ = ["PRIORITY", "AutoParams", "AutoResult", "Check", "agree", "auto_score", "blank_disc", "core_contrast",
           "detect", "group_answers", "plain_ground", "point_asymmetry", "profile_extent", "structure_left",
           "verify_centre"]
