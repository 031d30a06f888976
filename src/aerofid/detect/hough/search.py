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

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from aerofid.detect.hough.analysis import HoughParams, WindowAnalysis, analyse_window, similarity

WINDOW_EXTERNAL = 40
"""First-stage window for external fiducials, px (Appendix C: ``WNDSZ1 = 40`` for ``alg_flag == 1``)."""
WINDOW_PANEL = 16
"""First-stage window for cloth panels, px: the first setting of seed 001's Table 1 (16; the C code's
``WNDSZ1 = 12`` is the second, and Table 5.2 shows 16-24 scoring higher for an 8 px panel)."""
OVERLAP = 0.30
"""Overlap of neighbouring first-stage windows (seed 001: "overlap, e.g., 30 percent"; C: step 0.7 W)."""
STAGE1_ACCEPT = 0.6
"""A first-stage metric above this is accepted at once (Appendix C ``pthl``)."""
STAGE2_ENTER = 0.3
"""A first-stage metric below this moves on to the next window (Appendix C ``pm``)."""
STAGE2_ACCEPT = 0.4
"""A second-stage metric above this is accepted at once (Appendix C ``pth``)."""
MIN_METRIC = 0.2
"""The best metric must exceed this, else "no mark identified" (Appendix C ``pmin``)."""
MAX_RECURSION = 5
"""Re-centrings of one window before its answer is taken as it is (Appendix C: ``loop > 5``)."""
CONVERGENCE = 1.0
"""The recursion has converged when the centre moves by less than this (L1 distance, px). The C code's
integer test ``error < 3`` allows up to 2 px; sub-pixel answers allow a tighter test."""

MAX_REJECTIONS = 8
"""Candidates refused by the verification before the search gives up. Measured (hough on 15 marks per style
and condition, tests and benchmarks/bench_marks.py scenes): a true '+' or panel was always the first candidate
verified, while windows without a '+' (JPEG bull's-eyes and dots) had 13-37 refused candidates and took 1.0-1.2 s."""


@dataclass(frozen=True)
class SearchParams:
    """Parameters of the box search, with the seed's values as defaults."""

    window_size: int | None = None
    overlap: float = OVERLAP
    stage1_accept: float = STAGE1_ACCEPT
    stage2_enter: float = STAGE2_ENTER
    stage2_accept: float = STAGE2_ACCEPT
    min_metric: float = MIN_METRIC
    max_recursion: int = MAX_RECURSION
    convergence: float = CONVERGENCE
    exhaustive: bool = False
    """Analyse every spiral position even after a mark is accepted (to list every candidate, table 5.1)."""
    max_rejections: int | None = MAX_REJECTIONS
    """Beyond the seed: once this many candidates have failed verification, no further candidate is verified
    and the search ends (``None``: no limit). See :data:`MAX_REJECTIONS`."""
    stage2_fallback: bool = True
    """When the second-stage window cannot be analysed at all (too small for the mark: more than 30 %
    bright, or no pair of lines), let the first-stage candidate compete with its first-stage metric. The
    seed drops such a candidate; with marks wider than the seed's 1 px strokes the half-size window is
    often more than 30 % bright. ``False`` reproduces the seed."""

    def __post_init__(self):
        if self.window_size is not None and not (4 <= self.window_size <= 4096):
            raise ValueError("window_size must be between 4 and 4096 px")
        if not (0 <= self.overlap < 1):
            raise ValueError("overlap must be a fraction in [0, 1)")


@dataclass(frozen=True)
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

    def to_dict(self) -> dict:
        return {"stage": self.stage, "x": self.x, "y": self.y, "metric": self.metric,
                "model": self.model_name, "window_size": self.window_size}


@dataclass(frozen=True)
class SearchResult:
    """The best candidate (None: "no mark identified"), every candidate seen, and, when a verifier was
    given, what it returned for the best one."""

    best: Candidate | None
    candidates: tuple[Candidate, ...]
    reason: str = ""
    verified: Any = None
    rejected: tuple[tuple[Candidate, str], ...] = ()


def spiral_coordinates(height: int, width: int, window_size: int, overlap: float = OVERLAP) -> np.ndarray:
    """Window centres (x, y) in an outward square spiral from the box centre, ``(1 - overlap) * window``
    apart, keeping those whose windows cover the box (C ``estcoor``: steps of .7 * blk_sz1, directions
    alternating)."""
    step = max(1.0, (1.0 - overlap) * window_size)
    x, y = (width - 1) / 2.0, (height - 1) / 2.0
    dim = int(np.ceil(max(height, width) / step)) + 2
    pts = [(x, y)]
    for i in range(dim):
        sign = 1.0 if i % 2 == 0 else -1.0
        for dx, dy in ((0.0, sign), (sign, 0.0)):
            for _ in range(i + 1):
                x, y = x + dx * step, y + dy * step
                pts.append((x, y))
    p = np.array(pts)
    # keep every centre whose window's central square (side ``step``) reaches into the box, so the windows
    # cover the box to its edges
    m = step / 2.0
    inside = (p[:, 0] > -0.5 - m) & (p[:, 0] < width - 0.5 + m) & (p[:, 1] > -0.5 - m) & (p[:, 1] < height - 0.5 + m)
    return p[inside]


def extract_window(image: np.ndarray, x: float, y: float, size: int) -> tuple[np.ndarray, tuple[int, int]] | None:
    """The ``size`` x ``size`` window centred on (x, y), clipped to the image; (window, (x0, y0)).

    None when less than half the window lies inside the image."""
    h, w = image.shape
    x0 = int(np.floor(x - (size - 1) / 2.0 + 0.5))
    y0 = int(np.floor(y - (size - 1) / 2.0 + 0.5))
    xa, ya, xb, yb = max(0, x0), max(0, y0), min(w, x0 + size), min(h, y0 + size)
    if (xb - xa) < size / 2 or (yb - ya) < size / 2:
        return None
    return image[ya:yb, xa:xb], (xa, ya)


def recursive_analysis(image: np.ndarray, x: float, y: float, size: int, hp: HoughParams,
                       sp: SearchParams) -> tuple[WindowAnalysis, np.ndarray, tuple[int, int]] | str:
    """Analyse the window at (x, y) and re-centre it on the answer until the answer stops changing
    (seed 001, Recursion; C ``fid``). Returns (analysis, window, origin) or the reason for failure."""
    for loop in range(sp.max_recursion + 1):
        got = extract_window(image, x, y, size)
        if got is None:
            return "window outside the box"
        window, (x0, y0) = got
        a = analyse_window(window, hp)
        if isinstance(a, str):
            return a
        nx, ny = a.x + x0, a.y + y0
        if not (-0.5 <= nx < image.shape[1] - 0.5 and -0.5 <= ny < image.shape[0] - 0.5):
            return "decoded centre outside the box"
        if abs(nx - x) + abs(ny - y) < sp.convergence or loop == sp.max_recursion:
            return a, window, (x0, y0)
        x, y = nx, ny
    raise AssertionError("unreachable")


def _candidate(stage, got, size, mark, hp) -> Candidate | None:
    a, window, origin = got
    metric, model_name, model = similarity(a.projection, a.thetas, a.theta1, mark, hp.pair_separation)
    if metric is None:
        return None
    return Candidate(stage=stage, x=a.x + origin[0], y=a.y + origin[1], metric=metric, model_name=model_name,
                     window_size=size, origin=origin, analysis=a, window=window, model=model)


def search_box(image: np.ndarray, mark: str = "auto", hp: HoughParams = HoughParams(),
               sp: SearchParams = SearchParams(),
               verify: Callable[[Candidate, int], Any] | None = None) -> SearchResult:
    """The whole search of seed 001 over ``image`` (the operator's box), both tiers, every window size.

    With ``mark="auto"`` and no ``window_size``, the search runs with the external-fiducial window (40 px)
    and, if that finds nothing acceptable, with the panel window (16 px); the best candidate wins.

    ``verify(candidate, stage1_window_size)`` (beyond the seed) is called for every candidate that would be
    accepted or retained as the best; it returns a string (the reason) to reject it, anything else to keep
    it. A rejected candidate is recorded and the search goes on.
    """
    if sp.window_size is not None:
        sizes = [sp.window_size]
    else:
        sizes = {"external": [WINDOW_EXTERNAL], "panel": [WINDOW_PANEL]}.get(mark, [WINDOW_EXTERNAL, WINDOW_PANEL])
    h, w = image.shape
    candidates: list[Candidate] = []
    rejected: list[tuple[Candidate, str]] = []
    best: Candidate | None = None
    best_check: Any = None
    seen: set[tuple[int, int, int]] = set()

    def refused_enough() -> bool:
        """Verification has refused ``max_rejections`` candidates: nothing more is fitted."""
        return verify is not None and sp.max_rejections is not None and len(rejected) >= sp.max_rejections

    def capped() -> bool:
        """... and the search ends (an exhaustive listing goes on)."""
        return refused_enough() and not sp.exhaustive

    def admit(c: Candidate, size1: int) -> bool:
        """Make ``c`` the best if it beats the best so far and passes verification."""
        nonlocal best, best_check
        if best is not None and c.metric <= best.metric:
            return False
        near = next((r for r in rejected if abs(r[0].x - c.x) + abs(r[0].y - c.y) < sp.convergence), None)
        if near is not None:  # the same feature, already refused: do not fit it again
            return False
        if refused_enough():
            return False
        check = verify(c, size1) if verify is not None else None
        if isinstance(check, str):
            rejected.append((c, check))
            return False
        best, best_check = c, check
        return True

    for size in sizes:
        size = int(min(size, h, w))
        if size < 4:
            continue
        accepted = False
        for x, y in spiral_coordinates(h, w, size, sp.overlap):
            if capped():
                break
            got = recursive_analysis(image, x, y, size, hp, sp)
            if isinstance(got, str):
                continue
            c1 = _candidate(1, got, size, mark, hp)
            if c1 is None:
                continue
            key = (int(round(c1.x)), int(round(c1.y)), size)
            if key in seen:
                continue
            seen.add(key)
            candidates.append(c1)
            if c1.metric < sp.stage2_enter:
                continue
            if c1.metric > sp.stage1_accept:
                if admit(c1, size):
                    accepted = True
                    if not sp.exhaustive:
                        break
                continue
            size2 = max(4, size // 2)
            got2 = recursive_analysis(image, c1.x, c1.y, size2, hp, sp)
            c2 = None if isinstance(got2, str) else _candidate(2, got2, size2, mark, hp)
            if c2 is None:
                if not sp.stage2_fallback:
                    continue
                c2 = c1
            else:
                candidates.append(c2)
            if c2.metric > sp.min_metric and admit(c2, size) and c2.metric > sp.stage2_accept:
                accepted = True
                if not sp.exhaustive:
                    break
        if accepted and not sp.exhaustive:
            break
        if capped():
            break
    if best is None or best.metric <= sp.min_metric:
        if rejected:
            reason = "no mark identified: the best candidates failed verification (" + rejected[0][1] + ")"
            if refused_enough():
                reason += f"; search stopped after {len(rejected)} refused candidates"
        elif candidates:
            reason = "no mark identified"
        else:
            reason = "no candidate: every window was homogeneous, too bright or lacked a pair of lines"
        return SearchResult(None, tuple(candidates), reason, None, tuple(rejected))
    return SearchResult(best, tuple(candidates), "", best_check, tuple(rejected))
