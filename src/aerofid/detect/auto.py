"""``method="auto"``: run the detectors that apply, cross-check them, and answer only when the answer is trusted.

A confident wrong centre is the worst outcome for a user (Cho & Kim, seed 002, report 1 erroneous answer in
284 marks; our goal is none), so :func:`detect_auto` prefers an explicit ``not_found`` to any centre it
cannot corroborate. The rule, applied deterministically to one grey window (mark brighter than its ground):

1. **Candidates.** ``circles`` (Seedahmed) and ``symmetry`` (Cho & Kim) run on the whole window (both are
   cheap). If neither found a mark, ``hough`` (Hunt, Ryan & Gifford) runs on the whole window too, when
   the user named the kind of mark (``mark="external"`` or ``"panel"``) or the ground is plain (film
   border: at least ``MIN_PLAIN`` of the box within 4 noise sigma of its median; with ``mark="auto"`` on
   textured ground a lone ``hough`` answer could not be accepted anyway, see below, and its search is slow
   there). With ``mark="panel"`` ``hough`` and ``symmetry`` run (a cloth panel is a '+'). ``lines`` (Sohn et al.) is
   never run on the whole window (it returns confident wrong centres on dots and bull's-eyes); it is a
   corroborator only (step 2). Each detector must first pass its own self-diagnosis (status found).
2. **Cross-check.** Found answers within ``max(0.5 px, 3 sqrt(s1^2 + s2^2))`` (capped at ``MAX_AGREE`` px) of
   each other form a group. A group with a single member is re-examined on a crop of the window centred on
   it (half-size = the mark's extent + ``CROP_MARGIN``): a '+' from ``hough`` by ``lines`` (not for cloth
   panels, whose thin low-contrast strips on textured ground ``lines`` does not resolve), any answer by
   ``symmetry`` and, for rings, ``circles``. Two or more independent methods agreeing is strong evidence
   (*corroborated*). A lone answer is kept only when its method applies to what the window shows (and it
   passes step 3): a ``hough`` answer (its verification has already checked four balanced arms of a '+';
   ``lines`` does not survive JPEG blocks, so its silence is no evidence), a ``circles`` answer
   (two concentric circles, each covered on 60 % of its circumference), or a ``symmetry`` answer whose
   centre holds a compact core that stands out of the ground (a dot: :func:`core_contrast`). Two found
   answers that disagree while both lie on the same mark (closer than its extent) mean that at least one is
   wrong: nothing is answered.
3. **Verification, independent of the methods** (:func:`verify_centre`), on the group's centre and the
   mark's extent R (from the detectors' own models: the cross fit's arm lengths, the circles' radii; else a
   radial profile of the grey levels):

   - *containment*: the disc of radius R + ``EDGE_MARGIN`` lies inside the window (half a mark cut by the
     box edge fails here);
   - *point symmetry*: the share of the structure in that disc that changes under a 180-degree rotation
     about the centre, net of noise, is at most ``MAX_ASYMMETRY`` (every supported mark style is
     centrally symmetric about its centre; a mark lying on the film border's edge, a wrong centre, a half
     mark fail here);
   - *uniqueness*: the disc is blanked out with the ground's grey level and the group's methods, and
     ``symmetry``, run again on the rest of the window; a second mark found there makes the box ambiguous.

4. **Compact dots with no method** (the Zeiss dot in a notch, whose frame edge spoils the whole-window
   methods): when nothing was found, the single strongest compact blob (difference of Gaussians, not an
   edge point) whose surroundings are flat (a moat of at least ``MIN_MOAT`` px) is isolated (everything
   beyond its moat, at most ``ISOLATE_FACTOR`` x its radius + 2 px, replaced by the ground level) and
   ``symmetry`` runs on it; its answer must agree with an intensity-weighted centroid of
   the blob and pass step 3.

**Score** (comparable across methods, in [0, 1]): with s_m the detectors' own scores, the group's evidence
is ``1 - prod(1 - s_m)`` over its members (independent methods), times ``LONE_FACTOR`` for a lone answer,
times the verification quality ``1 - asymmetry / (2 MAX_ASYMMETRY)``. The centre is that of the member with
the first in ``PRIORITY`` (its ``method`` is reported), the ``sigma`` that member's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import cv2
import numpy as np

from aerofid.detect import available_methods, detector
from aerofid.detect.asymmetry import patch as _patch
from aerofid.detect.asymmetry import point_asymmetry
from aerofid.detect.noise import laplacian_noise_sigma
from aerofid.detect.result import FOUND, Detection, not_found

METHOD = "auto"

MAX_AGREE = 1.0
"""Largest distance (px) at which two methods' centres count as agreeing, whatever their sigmas."""
MIN_AGREE = 0.5
"""Two centres within this distance (px) always agree."""
CROP_MARGIN = 8
"""A lone answer is re-examined on a crop of half-size extent + this many px."""
EDGE_MARGIN = 3.0
"""The mark's disc, this much beyond its extent (px), must lie inside the window."""
MAX_ASYMMETRY = 0.2
"""Largest share of the mark disc's structure that may change under a 180-degree rotation."""
LONE_FACTOR = 0.8
"""A lone (uncorroborated) answer's evidence is scaled by this."""
MIN_SCORE = {"hough": 0.2, "circles": 0.5, "symmetry": 0.5}
"""Detector score below which a lone answer is not accepted (``hough``: its own minimum metric, seed 001)."""
SECOND_RATIO = 0.5
"""Uniqueness: a second answer of a method counts when its score reaches this fraction of the mark's own
score by that method (any score when the method did not answer for the mark)."""
SECOND_SIZE = 2.0
"""... and when its extent is within this factor of the mark's (:func:`_similar_size`)."""
EXTENT_PERCENTILE = 75.0
"""The mark's extent from the radial profile (:func:`profile_extent`) uses this percentile over each circle."""
MIN_CORE_SNR = 8.0
"""A lone ``symmetry`` answer needs a core (radius ``max(1.5, R/4)``) this many noise sigma off the ground."""
ISOLATE_FACTOR = 2.0
"""Step 4 isolates a blob within this many times its radius (plus 2 px)."""
MIN_PLAIN = 0.5
"""Step 4 runs only on plain ground (film border): at least this fraction of the box within 4 noise sigma
of its median grey level (aerial ground, an image-area edge in the box: no isolated-dot search)."""
PLAIN_FLOOR = 0.02
"""... or within this many grey levels (of 1) of it: JPEG blocks make plain film exceed 4 noise sigma (the
noise estimate sees the smoothed blocks), while aerial ground stays below 25 % of the box within 0.02."""
EDGE_RATIO = (10.0 + 1.0) ** 2 / 10.0
"""Step 4: a blob's DoG Hessian must have trace^2 / det below this (Lowe 2004, principal-curvature ratio 10):
points on the frame's straight edges are not blobs."""
MIN_BLOB_SNR = 10.0
"""Step 4: a compact blob's peak must stand this many noise sigma above the ground."""
MIN_MOAT = 2.5
"""Step 4: flat ground must surround the blob from its radius out to at least this many px beyond it."""

PRIORITY = ("hough", "symmetry", "circles", "lines", "centroid")
"""Whose centre a corroborated group returns: the first of its members in this order (docs/benchmarks_marks.md:
the cross fit of ``hough`` is the most accurate on '+' marks, ``symmetry`` with its point-symmetry refinement on
rings, dots and bull's-eyes: RMS 0.012 px against 0.019 px for ``circles`` on 20 Wild corner marks, 0.014
against 0.047 px with a speck on the ring; ``circles`` is better only under heavy noise, 0.024 against 0.032 px.
Picking the member with the smallest sigma, or the sigma-weighted mean, did worse: 0.019 and 0.014 px)."""


def _hough_keys() -> frozenset[str]:
    from aerofid.detect.hough.analysis import HoughParams
    from aerofid.detect.hough.search import SearchParams

    return frozenset(HoughParams.__dataclass_fields__) | frozenset(SearchParams.__dataclass_fields__) | {
        "verify", "min_arm_balance", "min_arm_snr"}


@dataclass(frozen=True)
class Check:
    """Outcome of :func:`verify_centre`."""

    ok: bool
    reason: str
    asymmetry: float
    extent: float


Runner = Callable[..., Detection]
"""``run(method, window, **overrides) -> Detection``; ``overrides`` are that method's keyword parameters."""


def make_runner(mark: str = "auto", params: dict | None = None) -> Runner:
    """A function ``run(method, window, **overrides) -> Detection`` that passes ``mark`` and the user's
    parameters to ``hough`` (the only method whose parameters ``locate`` exposes today), and ``overrides``
    (auto's own settings for one call) to the method."""
    params = dict(params or {})

    def run(method: str, window: np.ndarray, **overrides) -> Detection:
        fn = detector(method)
        if method == "hough":
            return fn(window, mark=mark, **{**params, **overrides})
        return fn(window, **overrides)

    return run


# --- geometry helpers ------------------------------------------------------------------------------------

def ground_level(img: np.ndarray, x: float, y: float, r_in: float, r_out: float) -> float:
    """Median grey level in the annulus r_in..r_out around (x, y) (whole window when it is empty)."""
    h, w = img.shape
    yy, xx = np.mgrid[0:h, 0:w]
    d = np.hypot(xx - x, yy - y)
    sel = (d >= r_in) & (d <= r_out)
    return float(np.median(img[sel])) if sel.sum() >= 8 else float(np.median(img))


def profile_extent(img: np.ndarray, x: float, y: float, noise: float, r_max: float) -> float:
    """Radius (px) of the structure around (x, y): the last radius at which the ``EXTENT_PERCENTILE``-th
    percentile of the absolute deviation from the ground over the circle (smoothed by 1 px) exceeds
    max(0.25 x its largest value, 5 noise). A percentile, not the largest value: a thin line running through
    a dot (the real EarthExplorer block mark) or a '+' beyond a ring crosses every circle at a few points and
    would make the mark as large as the box."""
    k = int(np.ceil(r_max))
    p = cv2.GaussianBlur(_patch(img, x, y, k), (0, 0), 1.0)
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    rr = np.hypot(xx, yy)
    ring = (rr > k - 2) & (rr <= k)
    g = float(np.median(p[ring])) if ring.any() else float(np.median(p))
    dev = np.abs(p - g)
    ri = np.floor(rr).astype(int)
    inside = rr <= k
    prof = np.array([np.percentile(dev[inside & (ri == r)], EXTENT_PERCENTILE) if (inside & (ri == r)).any() else 0.0
                     for r in range(k + 1)])
    thr = max(0.25 * prof.max(), 5.0 * noise)
    above = np.flatnonzero(prof > thr)
    return float(above[-1] + 1) if above.size else 1.0


def detection_extent(det: Detection) -> float | None:
    """The mark's radius (px) from a detector's own model, or None."""
    d = det.diagnostics or {}
    if det.method == "hough" and "refinement" in d:
        f = d["refinement"]  # arms that run out of the fitted patch are as long as the patch shows them
        return float(min(max(f.length1, f.length2) / 2.0, f.patch_half) + f.width / 2.0 + f.blur)
    if det.method == "circles" and d.get("circles"):
        return float(max(r for _, _, r in d["circles"]) + 1.0)
    if det.method == "lines" and d.get("lines"):
        return float(max(max(f.arms) for f in d["lines"]) + 1.0)
    return None


def core_contrast(img: np.ndarray, x: float, y: float, extent: float, noise: float) -> float:
    """Mean grey level within max(1.5, extent/4) px of (x, y) minus the ground just outside the extent, in
    noise sigma (per-pixel noise over sqrt of the pixels averaged)."""
    k = int(np.ceil(extent + 4))
    p = _patch(img, x, y, k)
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    rr = np.hypot(xx, yy)
    core = rr <= max(1.5, extent / 4.0)
    ground = (rr > extent + 1) & (rr <= extent + 4)
    if not ground.any():
        return 0.0
    return float((p[core].mean() - np.median(p[ground])) / (max(noise, 1e-4) / np.sqrt(core.sum())))


def blank_disc(img: np.ndarray, x: float, y: float, radius: float, noise: float = 0.0,
               level: float | None = None) -> np.ndarray:
    """A copy of ``img`` with the disc of ``radius`` around (x, y) replaced by ``level`` (default: the ground
    level around it, :func:`ground_level`) plus white noise of std ``noise`` (a fixed seed: deterministic), so
    that the blank looks like plain ground."""
    h, w = img.shape
    yy, xx = np.mgrid[0:h, 0:w]
    d = np.hypot(xx - x, yy - y) <= radius
    out = img.copy()
    fill = np.random.default_rng(12345).normal(0.0, noise, int(d.sum())) if noise > 0 else 0.0
    if level is None:
        level = ground_level(img, x, y, radius, radius + 5)
    out[d] = (level + fill).astype(np.float32)
    return out


def verify_centre(img: np.ndarray, x: float, y: float, extent: float, noise: float) -> Check:
    """Containment and point symmetry (module docstring, step 3) of the mark of radius ``extent`` at (x, y)."""
    h, w = img.shape
    r = extent + EDGE_MARGIN
    room = min(x, y, w - 1 - x, h - 1 - y)
    if room < r:
        return Check(False, f"the mark (radius {extent:.1f} px) at ({x:.1f}, {y:.1f}) is cut by the box edge "
                            f"(only {room:.1f} px of room): enlarge or move the box", float("nan"), extent)
    asym = point_asymmetry(img, x, y, r, noise)
    if not asym <= MAX_ASYMMETRY:
        return Check(False, f"the mark at ({x:.1f}, {y:.1f}) is not centrally symmetric ({asym:.2f} of its "
                            f"disc's structure changes under a half turn; limit {MAX_ASYMMETRY}): partly hidden, on "
                            "an edge or a wrong centre", asym, extent)
    return Check(True, "", asym, extent)


# --- the automatic choice --------------------------------------------------------------------------------

def _agree(a: Detection, b: Detection) -> bool:
    d = float(np.hypot(a.x - b.x, a.y - b.y))
    sa = a.sigma if np.isfinite(a.sigma) else 0.1
    sb = b.sigma if np.isfinite(b.sigma) else 0.1
    return d <= min(MAX_AGREE, max(MIN_AGREE, 3.0 * np.hypot(sa, sb)))


def _shift(det: Detection, dx: float, dy: float) -> Detection:
    return Detection(status=det.status, x=det.x + dx, y=det.y + dy, score=det.score, sigma=det.sigma,
                     method=det.method, reason=det.reason, diagnostics=det.diagnostics)


def _crop(img: np.ndarray, x: float, y: float, half: int) -> tuple[np.ndarray, int, int]:
    h, w = img.shape
    cx, cy = int(round(x)), int(round(y))
    x0, y0 = max(0, cx - half), max(0, cy - half)
    x1, y1 = min(w, cx + half + 1), min(h, cy + half + 1)
    return img[y0:y1, x0:x1], x0, y0


def _extent(img, members: list[Detection], noise: float) -> float:
    ext = [e for e in (detection_extent(m) for m in members) if e is not None]
    if ext:
        return max(ext)
    h, w = img.shape
    m = members[0]
    r_max = max(4.0, min(m.x, m.y, w - 1 - m.x, h - 1 - m.y, 0.5 * min(h, w)))
    return profile_extent(img, m.x, m.y, noise, r_max)


def detect_auto(window: np.ndarray, mark: str = "auto", run: Runner | None = None,
                methods: list[str] | None = None) -> Detection:
    """The most reliable centre in ``window`` by the rule of the module docstring, or ``not_found``.

    ``run(method, window)`` runs one detector (default: :func:`make_runner` with ``mark``); ``methods``
    restricts the detectors used (default: every available one). The answer's ``method`` is the detector
    whose centre is returned; ``diagnostics`` hold ``answers`` (every detector's Detection, crops' in window
    pixels), ``groups``, ``check`` and ``rule`` (which step decided).
    """
    img = np.asarray(window, np.float32)
    run = run or make_runner(mark)
    have = [m for m in (methods or available_methods())]
    if img.ndim != 2 or min(img.shape) < 16:
        return not_found(METHOD, "window must be a 2-D array of at least 16 x 16 px")
    if not np.isfinite(img).all():
        return not_found(METHOD, "window holds NaN or infinite grey levels")
    if float(img.max() - img.min()) < 0.02:
        return not_found(METHOD, "homogeneous window (grey range below 0.02): no mark")
    noise = max(laplacian_noise_sigma(img), 1e-4)
    answers: dict[str, Detection] = {}

    def go(m: str) -> None:
        if m in have and m not in answers:
            answers[m] = run(m, img)

    first = ("hough", "symmetry") if mark == "panel" else ("circles", "symmetry")
    for m in first:
        go(m)
    flat = _plain_ground(img, noise)
    plain = float(flat.mean())
    if not any(d.found for d in answers.values()) and (mark != "auto" or plain >= MIN_PLAIN):
        go("hough")
    found = [d for d in answers.values() if d.found]
    diag: dict = {"answers": answers, "noise": noise, "plain_ground": plain,
                  "ground_level": float(np.median(img[flat])) if flat.any() else float(np.median(img))}

    # group the found answers
    groups: list[list[Detection]] = []
    for d in sorted(found, key=lambda d: d.sigma if np.isfinite(d.sigma) else 1e9):
        for g in groups:
            if _agree(g[0], d):
                g.append(d)
                break
        else:
            groups.append([d])
    # answers on the same mark that disagree: something is wrong
    for i, a in enumerate(groups):
        for b in groups[i + 1:]:
            dist = float(np.hypot(a[0].x - b[0].x, a[0].y - b[0].y))
            reach = max(_extent(img, a, noise), _extent(img, b, noise))
            if dist < reach:
                return not_found(METHOD, f"methods disagree: {a[0].method} at ({a[0].x:.2f}, {a[0].y:.2f}) and "
                                         f"{b[0].method} at ({b[0].x:.2f}, {b[0].y:.2f}), {dist:.2f} px apart on "
                                         "the same mark", **diag, groups=groups)
    if len(groups) > 1:
        return not_found(METHOD, f"{len(groups)} different marks answered in the box ("
                                 + "; ".join(f"{g[0].method} at ({g[0].x:.1f}, {g[0].y:.1f})" for g in groups)
                                 + "): ambiguous, draw a tighter box", **diag, groups=groups)
    diag["groups"] = groups
    if not groups:
        if mark == "panel":
            return not_found(METHOD, _reasons(answers), **diag)
        return _compact_dot(img, noise, run, have, answers, diag)

    group = groups[0]
    extent = _extent(img, group, noise)
    if len(group) == 1:
        # cross-check on a crop centred on the lone answer
        lone = group[0]
        crop, x0, y0 = _crop(img, lone.x, lone.y, int(np.ceil(extent + CROP_MARGIN)))
        extra = {"hough": ["symmetry"] if mark == "panel" else ["lines", "symmetry"],
                 "circles": ["symmetry", "hough"], "symmetry": ["circles", "hough"]}.get(lone.method, ["symmetry"])
        for m in extra:
            if m not in have or min(crop.shape) < 17:
                continue
            d = run(m, crop)
            if d.found:
                d = _shift(d, x0, y0)
                answers[f"{m}@crop"] = d
                if _agree(lone, d):
                    group.append(d)
                else:
                    dist = float(np.hypot(d.x - lone.x, d.y - lone.y))
                    return not_found(METHOD, f"methods disagree: {lone.method} at ({lone.x:.2f}, {lone.y:.2f}) and "
                                             f"{m} on a crop around it at ({d.x:.2f}, {d.y:.2f}), {dist:.2f} px "
                                             "apart", **diag)
    if len(group) == 1:
        lone = group[0]
        if lone.score < MIN_SCORE.get(lone.method, 0.5):
            return not_found(METHOD, f"lone {lone.method} answer with a low score ({lone.score:.2f})", **diag)
        if lone.method == "symmetry":
            c = core_contrast(img, lone.x, lone.y, extent, noise)
            diag["core_snr"] = c
            if not abs(c) >= MIN_CORE_SNR:
                return not_found(METHOD, f"a lone symmetry answer at ({lone.x:.1f}, {lone.y:.1f}) with no compact "
                                         f"core ({c:.1f} noise sigma): not corroborated", **diag)
        rule = f"lone {lone.method}"
    else:
        rule = "corroborated by " + ", ".join(d.method for d in group)
        extent = _extent(img, group, noise)
    return _finish(img, group, extent, noise, run, have, rule, diag, mark == "panel")


def _finish(img, group, extent, noise, run, have, rule, diag, panel=False, dot=None) -> Detection:
    """Steps 3 and the score; ``dot`` is the plain ground level around an isolated dot (step 4), which also
    fills its blank: the annulus just outside a dot in a small notch holds the notch's walls."""
    best = min(group, key=lambda d: PRIORITY.index(d.method) if d.method in PRIORITY else len(PRIORITY))
    chk = verify_centre(img, best.x, best.y, extent, noise)
    diag.update(check=chk, rule=rule, extent=extent)
    if not chk.ok:
        return not_found(METHOD, chk.reason, **diag)
    # uniqueness: blank the mark, look again
    blanked = blank_disc(img, best.x, best.y, extent + EDGE_MARGIN, noise, level=dot)
    again = []
    rest, blobs = structure_left(blanked, img, best.x, best.y, extent, noise, any_size=dot is not None)
    diag.update(structure_left=rest, mark_like=blobs)
    if blobs and not panel:
        x0, y0, x1, y1, area = blobs[0]
        return not_found(METHOD, f"a second mark-like feature ({area} px in ({x0}, {y0})-({x1}, {y1})) besides the "
                                 f"mark at ({best.x:.1f}, {best.y:.1f}): ambiguous, draw a tighter box", **diag)
    own = {d.method: d.score for d in group}
    for m in sorted(set(own) | {"symmetry", "circles"}) if rest else ():
        if m in ("lines", "centroid") or m not in have:
            continue
        # hough need not verify (fit) candidates too weak to count as a second mark
        floor = {"min_metric": max(MIN_SCORE["hough"], SECOND_RATIO * own.get(m, 0.0))} if m == "hough" else {}
        d = run(m, blanked, **floor)
        if d.found and np.hypot(d.x - best.x, d.y - best.y) > extent and d.score >= SECOND_RATIO * own.get(m, 0.0) \
                and _similar_size(detection_extent(d), extent):
            again.append(d)
    diag["second_marks"] = again
    if again:
        d = again[0]
        return not_found(METHOD, f"a second mark-like feature ({d.method}) at ({d.x:.1f}, {d.y:.1f}) besides the one "
                                 f"at ({best.x:.1f}, {best.y:.1f}): ambiguous, draw a tighter box", **diag)
    methods = {d.method for d in group}
    evidence = 1.0 - float(np.prod([1.0 - float(np.clip(d.score, 0, 1)) for d in group]))
    if len(methods) < 2:
        evidence *= LONE_FACTOR
    quality = 1.0 - chk.asymmetry / (2.0 * MAX_ASYMMETRY)
    score = float(np.clip(evidence * quality, 0.0, 1.0))
    return Detection(status=FOUND, x=best.x, y=best.y, score=score, sigma=best.sigma, method=best.method,
                     diagnostics=dict(diag, members=group))


def _similar_size(other: float | None, extent: float) -> bool:
    """Uniqueness: a second answer is another *mark* only when its size (from its detector's model) is within
    ``SECOND_SIZE`` times the mark's; a crossing of two field boundaries whose '+' arms run out of the box, or
    a broad blurred cross in aerial texture around a small cloth panel, is not."""
    return other is None or 1.0 / SECOND_SIZE <= other / max(extent, 1e-6) <= SECOND_SIZE


def _significance(img, x, y, extent, noise):
    """(smoothed image, ground level, threshold): a pixel of the image smoothed by 1 px is significant when it
    differs from the window's median by more than max(6 x its noise, a quarter of the mark's amplitude)."""
    g = float(np.median(img))
    sm = cv2.GaussianBlur(img, (0, 0), 1.0)
    k = int(np.ceil(extent))
    amp = float(np.abs(cv2.GaussianBlur(_patch(img, x, y, k), (0, 0), 1.0) - g).max())
    return sm, g, max(6.0 * noise * 0.28, 0.25 * amp)


def structure_left(blanked: np.ndarray, img: np.ndarray, x: float, y: float, extent: float,
                   noise: float, any_size: bool = False) -> tuple[int, list[tuple[int, int, int, int, int]]]:
    """What remains of the window once the mark is blanked out (:func:`blank_disc`): the number of significant
    pixels (:func:`_significance`) and the *mark-like* connected components among them, (x0, y0, x1, y1,
    area): at least a quarter of the mark's own significant area (and 6 px) and compact (bounding box at
    most 1.5 mark diameters across, not touching the box edge: an image-area edge or corner, or a frame
    running through the box, is not mark-like); with ``any_size`` (an isolated dot) any component up to half
    the box across counts: the 'dot' may be a piece of a larger mark, e.g. an arm's tip cut off by a speck). None left means the box holds nothing but the mark and plain ground."""
    sm0, g, thr = _significance(img, x, y, extent, noise)
    h, w = img.shape
    yy, xx = np.mgrid[0:h, 0:w]
    own = int(((np.abs(sm0 - g) > thr) & (np.hypot(xx - x, yy - y) <= extent + EDGE_MARGIN)).sum())
    sm = cv2.GaussianBlur(blanked, (0, 0), 1.0)
    sig = (np.abs(sm - g) > thr).astype(np.uint8)
    n, lab, stats, _ = cv2.connectedComponentsWithStats(sig, connectivity=8)
    marks = []
    for i in range(1, n):
        x0, y0, bw, bh, area = (int(v) for v in stats[i])
        inside = x0 > 0 and y0 > 0 and x0 + bw < w and y0 + bh < h
        compact = max(bw, bh) <= 1.5 * 2 * (extent + EDGE_MARGIN)
        if any_size:
            compact = max(bw, bh) <= 0.5 * max(h, w)
        if inside and area >= max(6, 0.25 * own) and compact:
            marks.append((x0, y0, x0 + bw, y0 + bh, area))
    return int(sig.sum()), marks


def _compact_dot(img, noise, run, have, answers, diag) -> Detection:
    """Step 4 of the module docstring."""
    if "symmetry" not in have:
        return not_found(METHOD, _reasons(answers), **diag)
    plain, ground = diag["plain_ground"], diag["ground_level"]
    if plain < MIN_PLAIN:
        return not_found(METHOD, _reasons(answers) + f"; the ground is not plain (only {plain:.0%} of the box is "
                                 "within 4 noise sigma of its median): no isolated dot is looked for", **diag)
    peaks = []
    for s in (1.0, 1.5, 2.0, 2.5):
        dog = (cv2.GaussianBlur(img, (0, 0), s) - cv2.GaussianBlur(img, (0, 0), 1.6 * s)) * s
        dil = cv2.dilate(dog, np.ones((5, 5), np.uint8))
        # Lowe's edge-response test on the DoG's Hessian: a blob curves both ways (det > 0, trace^2 / det
        # small), a point on a straight edge or frame line only across it
        dxx = cv2.Sobel(dog, cv2.CV_32F, 2, 0, ksize=3)
        dyy = cv2.Sobel(dog, cv2.CV_32F, 0, 2, ksize=3)
        dxy = cv2.Sobel(dog, cv2.CV_32F, 1, 1, ksize=3)
        det, tr = dxx * dyy - dxy * dxy, dxx + dyy
        blobby = (det > 0) & (tr < 0) & (tr * tr < EDGE_RATIO * det)
        ys, xs = np.nonzero((dog >= dil) & (dog > 0) & blobby)
        peaks += [(float(dog[y, x]), int(x), int(y)) for y, x in zip(ys, xs)]
    peaks.sort(key=lambda t: (-t[0], t[2], t[1]))
    seen: list[tuple[int, int]] = []
    blob = None
    why = "no compact blob with flat surroundings"
    for _, bx, by in peaks:
        if any(abs(bx - sx) <= 3 and abs(by - sy) <= 3 for sx, sy in seen):
            continue
        seen.append((bx, by))
        if len(seen) > 12:
            break
        got = _flat_blob(img, bx, by, noise, ground)
        if isinstance(got, str):
            why = got
            continue
        blob = (bx, by, got)
        break
    if blob is None:
        return not_found(METHOD, _reasons(answers) + f"; {why}", **diag)
    bx, by, (r_blob, iso) = blob
    cx, cy = float(bx), float(by)
    det = None
    for _ in range(2):
        half_w = max(24, int(np.ceil(iso + 12)))
        sub, x0, y0 = _crop(img, cx, cy, half_w)
        sy, sx = np.mgrid[0:sub.shape[0], 0:sub.shape[1]]
        gl = ground_level(sub, cx - x0, cy - y0, iso, iso + 3)
        fill = gl + np.random.default_rng(12345).normal(0.0, noise, sub.shape)
        iso_img = np.where(np.hypot(sx - (cx - x0), sy - (cy - y0)) <= iso, sub, fill).astype(np.float32)
        det = run("symmetry", iso_img)
        if not det.found:
            answers["symmetry@isolated"] = det
            return not_found(METHOD, _reasons(answers) + f"; isolated compact blob: {det.reason}", **diag)
        det = _shift(det, x0, y0)
        cx, cy = det.x, det.y
    answers["symmetry@isolated"] = det
    # corroboration: intensity-weighted centroid of the blob above the ground
    pc = _patch(img, cx, cy, int(np.ceil(iso)))
    yy, xx = np.mgrid[-int(np.ceil(iso)):int(np.ceil(iso)) + 1, -int(np.ceil(iso)):int(np.ceil(iso)) + 1]
    wgt = np.clip(pc - ground_level(img, cx, cy, iso, iso + 3), 0, None) * (np.hypot(xx, yy) <= r_blob + 2)
    if wgt.sum() <= 0:
        return not_found(METHOD, _reasons(answers), **diag)
    centroid = Detection(status=FOUND, x=cx + float((wgt * xx).sum() / wgt.sum()),
                         y=cy + float((wgt * yy).sum() / wgt.sum()), score=0.8,
                         sigma=max(det.sigma, 0.05), method="centroid")
    answers["centroid"] = centroid
    if not _agree(det, centroid):
        return not_found(METHOD, f"isolated dot: symmetry ({det.x:.2f}, {det.y:.2f}) and centroid "
                                 f"({centroid.x:.2f}, {centroid.y:.2f}) disagree", **diag)
    group = [det, centroid]
    diag["groups"] = [group]
    return _finish(img, group, r_blob + 1.0, noise, run, have, "isolated compact dot: symmetry + centroid", diag,
                   dot=ground)


def _flat_blob(img, bx, by, noise, ground) -> tuple[float, float] | str:
    """(radius, moat) of a compact bright blob at pixel (bx, by), or why it is not one. The radius is the
    half maximum of its radial profile above the plain ground level ``ground``; the moat is the radius out to
    which its surroundings are flat: every 1-px ring from radius + 1.5 px on, up to ``ISOLATE_FACTOR`` x the
    radius + 2 px, has at least 95 % of its pixels within 4 noise of the ground. A moat narrower than
    ``MIN_MOAT`` px means the blob is part of a larger structure (a small Zeiss notch is allowed to come
    closer than ``ISOLATE_FACTOR`` radii)."""
    h, w = img.shape
    k = int(min(20, bx, by, w - 1 - bx, h - 1 - by))
    if k < 5:
        return "a compact blob at the box edge"
    p = _patch(img, bx, by, k)
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    rr = np.hypot(xx, yy)
    prof = np.array([p[(rr >= r - 0.5) & (rr < r + 0.5)].mean() for r in range(k + 1)])
    if prof[0] - ground < MIN_BLOB_SNR * noise:
        return "the brightest compact blob is too faint"
    half = np.flatnonzero(prof - ground < 0.5 * (prof[0] - ground))
    if not half.size:
        return "a blob larger than 20 px"
    r_blob = max(1.0, float(half[0]))
    reach = ISOLATE_FACTOR * r_blob + 2.0
    if reach + 2 > k:
        return "a compact blob too close to the box edge"
    flat = np.abs(p - ground) <= 4.0 * noise
    moat = r_blob + 1.5
    while moat + 1.0 <= reach:
        ring = (rr > moat) & (rr <= moat + 1.0)
        if flat[ring].mean() < 0.95:
            break
        moat += 1.0
    if moat < r_blob + MIN_MOAT:
        return "the compact blob's surroundings are not flat"
    return r_blob, moat


def _plain_ground(img: np.ndarray, noise: float) -> np.ndarray:
    """The pixels within max(4 noise, ``PLAIN_FLOOR``) of the window's median grey level."""
    return np.abs(img - np.median(img)) <= max(4.0 * noise, PLAIN_FLOOR)


def _reasons(answers: dict[str, Detection]) -> str:
    return "no method found a mark: " + "; ".join(f"{m}: {d.reason}" for m, d in answers.items() if not d.found)


__all__ = ["Check", "detect_auto", "make_runner", "point_asymmetry", "verify_centre"]
