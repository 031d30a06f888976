"""How a box is searched (Hunt, Ryan & Gifford, seed 001; thesis 000, sections 4.2.4-4.2.7, 4.2.9).

The operator's box is partitioned into windows whose centres follow an outward square spiral from the box
centre, overlapping by 30 % (C ``estcoor``). Each window is analysed by the Hough cross detector and the
answer fed back as the new window centre until it stops changing (recursion, C ``fid``). A candidate's
similarity metric decides what happens next (C ``fiducial``):

- below ``stage2_enter`` (0.3): next spiral position;
- above ``stage1_accept`` (0.6): accepted at once;
- in between: stage 2 re-analyses a window of half the size centred on the candidate; the best stage-2
  metric is kept, and one above ``stage2_accept`` (0.4) is accepted at once.

When the spiral is exhausted, the best candidate is returned if its metric exceeds ``min_metric`` (0.2);
otherwise the answer is "no mark identified".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from aerofid.detect.hough.analysis import (
    UNKNOWN,
    Unknown,
    WindowAnalysis,
    analyse_window,
    bright_refusal,
    bright_value,
    similarity,
)
from aerofid.detect.hough.params import DEFAULT, HoughParams
from aerofid.detect.threshold import Threshold, optimum_thresholds

WINDOW_EXTERNAL = 40
"""First-stage window for external fiducials, px (Appendix C: ``WNDSZ1 = 40`` for ``alg_flag == 1``)."""
WINDOW_PANEL = 16
"""First-stage window for cloth panels, px: the first setting of seed 001's Table 1 (16; the C code's
``WNDSZ1 = 12`` is the second, and Table 5.2 shows 16-24 scoring higher for an 8 px panel)."""

Verifier = Callable[["Candidate", int], object]
"""``verify(candidate, stage1_window_size)``: a string (the reason) rejects the candidate, anything else keeps
it (and is returned as :attr:`SearchResult.verified`)."""


@dataclass(frozen=True, eq=False)
class Candidate:
    """A converged candidate of one stage: centre in box pixels and its similarity metric."""

    stage: int
    x: float
    y: float
    metric: float
    model_name: str
    window_size: int
    origin: tuple[int, int]
    analysis: WindowAnalysis = field(repr=False, compare=False)
    window: np.ndarray = field(repr=False, compare=False)
    model: np.ndarray = field(repr=False, compare=False)

    def to_dict(self) -> dict[str, Any]:
        """Scalars of the candidate (stage, centre, metric, model name, window size)."""
        return {"stage": self.stage, "x": self.x, "y": self.y, "metric": self.metric,
                "model": self.model_name, "window_size": self.window_size}


@dataclass(frozen=True)
class SearchResult:
    """The best candidate (None: "no mark identified"), every candidate seen, and, when a verifier was
    given, what it returned for the best one."""

    best: Candidate | None
    candidates: tuple[Candidate, ...]
    reason: str = ""
    verified: object = None
    rejected: tuple[tuple[Candidate, str], ...] = ()


def spiral_coordinates(height: int, width: int, window_size: int, overlap: float = 0.3) -> np.ndarray:
    """Window centres (x, y) in an outward square spiral from the box centre, ``(1 - overlap) * window``
    apart, keeping those whose windows cover the box (C ``estcoor``: steps of .7 * blk_sz1, directions
    alternating)."""
    step = max(1.0, (1.0 - overlap) * window_size)
    dim = int(np.ceil(max(height, width) / step)) + 2
    # leg i: i + 1 steps along y, then i + 1 along x, by +step for even i and -step for odd ones; the centres are
    # the running sums of the steps from the box centre, added one after another (numpy's accumulate), as the C
    # code moves from one to the next, in the type of its steps (a numpy float32 ``overlap`` makes them float32)
    legs = np.repeat(np.arange(1, dim + 1), 2)
    moves = np.repeat(np.repeat(np.where(np.arange(dim) % 2 == 0, step, -step), 2), legs)
    along_y = np.repeat(np.tile([True, False], dim), legs)
    p = np.empty((moves.size + 1, 2), np.asarray(0.0 * step).dtype)
    p[0] = (width - 1) / 2.0, (height - 1) / 2.0
    p[1:, 0] = np.where(along_y, 0.0, moves)
    p[1:, 1] = np.where(along_y, moves, 0.0)
    np.add.accumulate(p, axis=0, out=p)
    # keep every centre whose window's central square (side ``step``) reaches into the box, so the windows
    # cover the box to its edges
    m = step / 2.0
    inside = ((p[:, 0] > -0.5 - m) & (p[:, 0] < width - 0.5 + m) & (p[:, 1] > -0.5 - m)
              & (p[:, 1] < height - 0.5 + m))
    out = p[inside].astype(np.float64)
    out[0] = (width - 1) / 2.0, (height - 1) / 2.0     # the centre, where the walk starts (always inside)
    return out


def extract_window(image: np.ndarray, x: float, y: float, size: int) -> tuple[np.ndarray, tuple[int, int]] | None:
    """The ``size`` x ``size`` window centred on (x, y), clipped to the image; (window, (x0, y0)).

    None when less than half the window lies inside the image."""
    h, w = image.shape
    x0 = math.floor(float(x) - (size - 1) / 2.0 + 0.5)   # Python floats: the same numbers, a tenth of the time
    y0 = math.floor(float(y) - (size - 1) / 2.0 + 0.5)
    xa, ya, xb, yb = max(0, x0), max(0, y0), min(w, x0 + size), min(h, y0 + size)
    if (xb - xa) < size / 2 or (yb - ya) < size / 2:
        return None
    return image[ya:yb, xa:xb], (xa, ya)


Analysed = tuple[WindowAnalysis, np.ndarray, tuple[int, int]]
"""A converged window: its analysis, the window and its origin in the box."""


def recursive_analysis(image: np.ndarray, x: float, y: float, size: int, params: HoughParams = DEFAULT,
                       first: Threshold | None | Unknown = UNKNOWN) -> Analysed | str:
    """Analyse the window at (x, y) and re-centre it on the answer until the answer stops changing
    (seed 001, Recursion; C ``fid``). Returns (analysis, window, origin) or the reason for failure. ``first``:
    the first window's optimum threshold, where it is known (:func:`spiral_thresholds`)."""
    for loop in range(params.max_recursion + 1):
        got = extract_window(image, x, y, size)
        if got is None:
            return "window outside the box"
        window, (x0, y0) = got
        a = analyse_window(window, params, first if loop == 0 else UNKNOWN)
        if isinstance(a, str):
            return a
        nx, ny = a.x + x0, a.y + y0
        if not (-0.5 <= nx < image.shape[1] - 0.5 and -0.5 <= ny < image.shape[0] - 0.5):
            return "decoded centre outside the box"
        if abs(nx - x) + abs(ny - y) < params.convergence or loop == params.max_recursion:
            return a, window, (x0, y0)
        x, y = nx, ny
    raise AssertionError("unreachable")


def make_candidate(stage: int, got: Analysed, size: int, params: HoughParams = DEFAULT) -> Candidate | None:
    """The candidate of a converged window with its similarity metric (None: a projection with no variance)."""
    a, window, origin = got
    metric, model_name, model = similarity(a.projection, a.thetas, a.theta1, params.mark, params.pair_separation)
    if metric is None:
        return None
    return Candidate(stage=stage, x=a.x + origin[0], y=a.y + origin[1], metric=metric, model_name=model_name,
                     window_size=size, origin=origin, analysis=a, window=window, model=model)


SPIRAL_BATCHES = (8, 64, 1024, 16)
"""How the search thresholds its spiral's first windows (:func:`spiral_thresholds`): the first 8 positions one at a
time (a '+' in the box's middle is accepted at once), then 64 at a time, twice as many each time up to 1024 (a box
of 640 px that holds no '+' has some 3600 positions, and each batch costs some 0.3 ms of its own), those of a last
chunk of fewer than 16 positions one at a time (thresholding a handful of windows together is no faster)."""


def spiral_chunks(positions: int) -> list[tuple[int, int]]:
    """The spiral's positions ``[start, end)`` thresholded together (:data:`SPIRAL_BATCHES`).

    Examples
    --------
    >>> spiral_chunks(300)
    [(0, 8), (8, 72), (72, 200), (200, 300)]
    """
    first_alone, size, largest, _ = SPIRAL_BATCHES
    out, start = [(0, min(first_alone, positions))], first_alone
    while start < positions:
        out.append((start, min(start + size, positions)))
        start, size = start + size, min(2 * size, largest)
    return out


def spiral_thresholds(image: np.ndarray, centres: np.ndarray, size: int,
                      params: HoughParams = DEFAULT) -> list[Threshold | None | Unknown | str]:
    """The optimum thresholds of the first windows at ``centres`` (:func:`extract_window`), those of one shape
    computed together (:func:`aerofid.detect.threshold.optimum_thresholds`: the numbers each window's own
    :func:`~aerofid.detect.threshold.optimum_threshold` gives, several times faster on a box's hundreds of 16 px
    windows); :data:`~aerofid.detect.hough.analysis.UNKNOWN` for a window outside the box (its analysis says
    why). Where a window's bright pixels at its threshold already refuse it
    (:func:`~aerofid.detect.hough.analysis.bright_refusal`: most of a notch dot's box is brighter than the
    threshold of its windows of dark film), the reason its analysis would give instead. The windows that lie
    wholly inside the box are gathered at once from a view of every window of the box
    (``numpy.lib.stride_tricks.sliding_window_view``: a failed search of a 640 px box visits some 3600 of them);
    the few that its edges clip, one by one. Their pixels are compared with their thresholds in the type in which
    their analysis compares them (:func:`_bright_counts`)."""
    out: list[Threshold | None | Unknown | str] = [UNKNOWN] * len(centres)
    h, w = image.shape
    c = np.asarray(centres, dtype=np.float64).reshape(-1, 2)
    x0 = np.floor(c[:, 0] - (size - 1) / 2.0 + 0.5).astype(np.int64)   # extract_window's origin, in float64 alike
    y0 = np.floor(c[:, 1] - (size - 1) / 2.0 + 0.5).astype(np.int64)
    whole = (x0 >= 0) & (y0 >= 0) & (x0 + size <= w) & (y0 + size <= h)
    groups: list[tuple[np.ndarray, np.ndarray]] = []
    if whole.any():
        at = np.flatnonzero(whole)
        groups.append((at, sliding_window_view(image, (size, size))[y0[at], x0[at]]))
    clipped: dict[tuple[int, ...], list[tuple[int, np.ndarray]]] = {}
    for i in np.flatnonzero(~whole).tolist():
        got = extract_window(image, float(c[i, 0]), float(c[i, 1]), size)
        if got is not None:
            clipped.setdefault(got[0].shape, []).append((i, got[0]))
    groups += [(np.array([i for i, _ in g]), np.stack([win for _, win in g])) for g in clipped.values()]
    for at, windows in groups:
        found = optimum_thresholds(windows.reshape(len(at), -1))
        values = [bright_value(v, params) if f else None for v, f in zip(found.value.tolist(), found.found.tolist(),
                                                                          strict=True)]
        counts = _bright_counts(windows, values).tolist()
        pixels = windows[0].size
        for j, i in enumerate(at.tolist()):
            out[i] = None if values[j] is None else bright_refusal(counts[j], pixels, params) or found.threshold(j)
    return out


def _bright_counts(windows: np.ndarray, thresholds: list[Any]) -> np.ndarray:
    """Per window of ``windows`` (n x rows x columns), its pixels above its threshold (None: none counted), compared
    as :func:`~aerofid.detect.hough.analysis.bright_pixels` compares one window with its threshold: in the type numpy
    gives a window and that threshold (a Python float is compared with a float32 window in float32, a numpy float64
    in float64; the thresholds are all one product's, of one type)."""
    known = next((v for v in thresholds if v is not None), None)
    if known is None:
        return np.zeros(len(thresholds), np.int64)
    compared = np.result_type(windows.dtype, known)
    limits = np.array([np.inf if v is None else v for v in thresholds], dtype=compared)
    return np.count_nonzero(windows > limits.reshape(-1, 1, 1), axis=(1, 2))


def window_sizes(params: HoughParams) -> list[int]:
    """First-stage window sizes to search: ``window_size``, else by ``mark`` (both for ``"auto"``)."""
    if params.window_size is not None:
        return [params.window_size]
    return {"external": [WINDOW_EXTERNAL], "panel": [WINDOW_PANEL]}.get(params.mark, [WINDOW_EXTERNAL, WINDOW_PANEL])


class _Search:
    """The state of one box search: every candidate, the refused ones, the best so far."""

    def __init__(self, image: np.ndarray, params: HoughParams, verify: Verifier | None):
        self.image, self.params, self.verify = image, params, verify
        self.candidates: list[Candidate] = []
        self.rejected: list[tuple[Candidate, str]] = []
        self.best: Candidate | None = None
        self.best_check: object = None
        self.seen: set[tuple[int, int, int]] = set()

    def refused_enough(self) -> bool:
        """Verification has refused ``max_rejections`` candidates: nothing more is fitted."""
        limit = self.params.max_rejections
        return self.verify is not None and limit is not None and len(self.rejected) >= limit

    def capped(self) -> bool:
        """... and the search ends (an exhaustive listing goes on)."""
        return self.refused_enough() and not self.params.exhaustive

    def admit(self, c: Candidate, size1: int) -> bool:
        """Make ``c`` the best if it beats the best so far and passes verification."""
        if self.best is not None and c.metric <= self.best.metric:
            return False
        conv = self.params.convergence
        if any(abs(r.x - c.x) + abs(r.y - c.y) < conv for r, _ in self.rejected):
            return False  # the same feature, already refused: do not fit it again
        if self.refused_enough():
            return False
        check = self.verify(c, size1) if self.verify is not None else None
        if isinstance(check, str):
            self.rejected.append((c, check))
            return False
        self.best, self.best_check = c, check
        return True

    def stage1(self, x: float, y: float, size: int, first: Threshold | None | Unknown = UNKNOWN) -> Candidate | None:
        """The first-stage candidate of the window at (x, y) (``first``: its optimum threshold, if known),
        recorded; None if none or already seen."""
        got = recursive_analysis(self.image, x, y, size, self.params, first)
        c1 = None if isinstance(got, str) else make_candidate(1, got, size, self.params)
        if c1 is None:
            return None
        key = (int(round(c1.x)), int(round(c1.y)), size)
        if key in self.seen:
            return None
        self.seen.add(key)
        self.candidates.append(c1)
        return c1

    def stage2(self, c1: Candidate, size: int) -> Candidate | None:
        """The second-stage candidate (window of half the size on ``c1``), or ``c1`` itself when that window
        cannot be analysed and ``stage2_fallback`` is on; None: drop the candidate (the seed)."""
        size2 = max(4, size // 2)
        got2 = recursive_analysis(self.image, c1.x, c1.y, size2, self.params)
        c2 = None if isinstance(got2, str) else make_candidate(2, got2, size2, self.params)
        if c2 is None:
            return c1 if self.params.stage2_fallback else None
        self.candidates.append(c2)
        return c2

    def visit(self, x: float, y: float, size: int, first: Threshold | None | Unknown = UNKNOWN) -> bool:
        """Both tiers at one spiral position (C ``fiducial``; ``first``: its window's optimum threshold, if
        known); True when a candidate was accepted at once."""
        p = self.params
        c1 = self.stage1(x, y, size, first)
        if c1 is None or c1.metric < p.stage2_enter:
            return False
        if c1.metric > p.stage1_accept:
            return self.admit(c1, size)
        c2 = self.stage2(c1, size)
        if c2 is None:
            return False
        return c2.metric > p.min_metric and self.admit(c2, size) and c2.metric > p.stage2_accept

    def spiral(self, size: int) -> bool:
        """Every spiral position of one window size; True when a candidate was accepted."""
        h, w = self.image.shape
        accepted = False
        centres = spiral_coordinates(h, w, size, self.params.overlap)
        least = SPIRAL_BATCHES[-1]
        for start, end in spiral_chunks(len(centres)):
            if self.capped():
                return accepted
            chunk = centres[start:end]
            known = (spiral_thresholds(self.image, chunk, size, self.params) if len(chunk) >= least
                     else [UNKNOWN] * len(chunk))
            for (x, y), first in zip(chunk.tolist(), known, strict=True):
                if first is None or isinstance(first, str):     # a homogeneous first window, or one its bright
                    continue                                    # pixels refuse: its analysis would say so
                if self.capped():                               # (only a visit's verification changes it)
                    return accepted
                if self.visit(x, y, size, first):
                    accepted = True
                    if not self.params.exhaustive:
                        return accepted
        return accepted

    def result(self) -> SearchResult:
        """The best candidate, or why there is none."""
        cands, rejected = tuple(self.candidates), tuple(self.rejected)
        if self.best is not None and self.best.metric > self.params.min_metric:
            return SearchResult(self.best, cands, "", self.best_check, rejected)
        if rejected:
            reason = "no mark identified: the best candidates failed verification (" + rejected[0][1] + ")"
            if self.refused_enough():
                reason += f"; search stopped after {len(rejected)} refused candidates"
        elif cands:
            reason = "no mark identified"
        else:
            reason = "no candidate: every window was homogeneous, too bright or lacked a pair of lines"
        return SearchResult(None, cands, reason, None, rejected)


def search_box(image: np.ndarray, params: HoughParams = DEFAULT, verify: Verifier | None = None) -> SearchResult:
    """The whole search of seed 001 over ``image`` (the operator's box), both tiers, every window size.

    With ``mark="auto"`` and no ``window_size``, the search runs with the external-fiducial window (40 px)
    and, if that finds nothing acceptable, with the panel window (16 px); the best candidate wins.

    ``verify(candidate, stage1_window_size)`` (beyond the seed) is called for every candidate that would be
    accepted or retained as the best; it returns a string (the reason) to reject it, anything else to keep
    it. A rejected candidate is recorded and the search goes on.
    """
    search = _Search(image, params, verify)
    h, w = image.shape
    for size in window_sizes(params):
        size = int(min(size, h, w))
        if size < 4:
            continue
        if search.spiral(size) and not params.exhaustive:
            break
        if search.capped():
            break
    return search.result()


__all__ = ["SPIRAL_BATCHES", "WINDOW_EXTERNAL", "WINDOW_PANEL", "Candidate", "SearchResult", "Verifier",
           "extract_window", "make_candidate", "recursive_analysis", "search_box", "spiral_coordinates",
           "spiral_chunks", "spiral_thresholds", "window_sizes"]
