"""The ``hough`` method: Hunt, Ryan & Gifford's search (:mod:`.search`) over the window, each accepted candidate
refined to sub-pixel by the cross fit (:mod:`.cross_fit`) and verified as a '+' (beyond the seed)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

import aerofid.detect.hough.cross_fit as cross_fit
from aerofid.conventions import FOUND
from aerofid.detect.hough.analysis import METHOD, WindowAnalysis, analyse_window
from aerofid.detect.hough.cross_fit import CrossFit, cross_start, fit_cross, fit_start, start_share
from aerofid.detect.hough.params import DEFAULT, HoughParams
from aerofid.detect.hough.search import Candidate, extract_window, search_box
from aerofid.detect.result import Detection, unusable_window
from aerofid.kept import Kept, digest

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# --- sub-pixel refinement and verification (beyond the seed) ---------------------------------------------

MAX_REFINE_SHIFT = 2.0
"""A sub-pixel fit that moves the centre further than this (px) from the Hough centre is not trusted."""
EARLY_EXIT_SHIFT = 1.5 * MAX_REFINE_SHIFT
"""A first least-squares pass that moves the centre further than this (px) from the fit's start is refused
without its Huber refits: 5 times the largest first-pass move of an accepted '+' (0.61 px on 693 fits of the
benchmark, rejection and RC20 scenes), and with the start within ``MAX_REFINE_SHIFT`` of the Hough centre."""
REFINE_WINDOW_FACTOR = 1.5
"""When the arms reach the edge of the first-stage window, the sub-pixel fit looks at a window this many
times larger, so that it sees the arms' ends."""


def half_arm_steps(analysis: WindowAnalysis) -> list[set[int]]:
    """For each of the four half-arms (along each Hough line, on each side of the centre), the 1-px steps from the
    centre (distances along the line, rounded) at which the thresholded window holds a bright pixel within 1.5 px of
    the line."""
    ys, xs = np.nonzero(analysis.binary)
    out = []
    for th in (analysis.theta1, analysis.theta2):
        t = np.deg2rad(th)
        r = (xs - analysis.x) * np.cos(t) + (ys - analysis.y) * np.sin(t)
        along = -(xs - analysis.x) * np.sin(t) + (ys - analysis.y) * np.cos(t)
        near = np.abs(r) <= 1.5
        for side in (1.0, -1.0):
            steps = np.round(side * along[near]).astype(int)
            out.append(set(steps[steps >= 0].tolist()))
    return out


def half_arm_runs(steps: list[set[int]], max_gap: int = 1) -> list[float]:
    """Each half-arm's run (px): its bright steps (:func:`half_arm_steps`) that stay connected to the centre, allowing
    ``max_gap`` empty steps, to the far side of the last one (its step + 0.5; 0.5 where the first ``max_gap + 1`` steps
    are empty). Bright texture further along a line is not counted (a percentile of all bright pixels near the line
    overestimates a small panel's arms on aerial ground)."""
    out = []
    for occupied in steps:
        end, gap, k = 0, 0, 0
        while gap <= max_gap:
            k += 1
            if k in occupied:
                end, gap = k, 0
            else:
                gap += 1
        out.append(end + 0.5)
    return out


def arm_half_length(analysis: WindowAnalysis, max_gap: int = 1) -> float:
    """Half-length of the arms: the four half-arms' runs (:func:`half_arm_runs`) averaged, at least 2 px."""
    return max(2.0, float(np.mean(half_arm_runs(half_arm_steps(analysis), max_gap))))


MAX_MISFIT = 1.8
"""Verification: the robust spread of the fit's residuals on the mark must stay within this factor of the
grey-level noise of its surroundings (measured: synthetic crosses up to 1.36, panels on real aerial
texture up to 1.56, the real NAGAP arc marks 0.88-1.39; a faint arc read as a '+' on the real NAGAP crop
2.0)."""
MAX_CENTRE_SIGMA = 0.15
"""Verification: the fit's standard deviation of the centre (per axis) must not exceed this (px). Measured
(129 true '+' in every benchmark condition: at most 0.12 px; '+'-like crossings in aerial texture: median
0.14 px; the two answers 0.5 px or more off the truth: 0.16 and 0.31 px)."""
MIN_ARM_PROTRUSION = 0.5
"""Verification: the shorter fitted half-arm must reach this far (px) beyond the blurred crossing, i.e. beyond
half the stroke width plus twice the blur (a compact bright blob in JPEG blocks fitted as a '+' of 4 px bars:
-0.7 px; 7 px cloth panels at blur 0.6: 1.7 px and more)."""
MIN_RESOLVED_WIDTH = 0.5
"""Verification: a stroke fitted narrower than this (px) under a blur more than 0.5 px wider is not resolved:
width and amplitude trade off (a hair-thin, very bright stroke), the fit has found a blurred line."""
MAX_WIDTH_RATIO = 0.35
"""Verification: the fitted stroke width must be at most this fraction of the shorter bar's length (a '+'
of strokes, not a blob or a square)."""

MIN_START_SHARE = 0.04
"""Verification, before the fit: the share of the patch's grey values (about their plane) that the '+' the fit
starts from explains, turned as the fit may turn it (:func:`aerofid.detect.hough.cross_fit.start_share`), must reach
this, and its amplitude must be positive, else the candidate is refused without the fit. Measured
(``benchmarks/bench_fits.py --n 8``, seeds 7 and 23, scratch wrappers: 593 accepted '+' of every condition and
rejection scene, 5203 refused candidates): the least share of an accepted '+' 0.19 (a ring and '+' half hidden), this
a fifth of it; no accepted '+' had a negative amplitude; it refuses 2275 of the refused candidates, 37 % of their fits'
time (such fits run to 100 evaluations). '+' fitted from Hough angles 0-30 degrees off (60 crosses per angle, a
review's scratch script): the least share of an accepted one 0.26. With the start's angles alone (no turns) and a
threshold of 0.013, a review found a '+' refused (its Hough angles 13-23 degrees off). The turns move both bars
together: a second review, fitting from each bar's angle off by 0-35 degrees independently (700 starts, 248 accepted),
found one accepted '+' refused here (share 0.025: a big ring round a '+' 24 degrees from square), on a scene that the
detectors answer alike with and without this screen."""


@dataclass(frozen=True)
class Verified:
    """A candidate that passed verification: its sub-pixel refinement in full-window pixels."""

    x: float
    y: float
    refinement: CrossFit


def crossing_gap(analysis: WindowAnalysis, limit: float) -> float:
    """Distance (px) from the Hough centre to the nearest bright pixel of the thresholded window, exact when it is at
    most ``limit``; above ``limit`` (inf when no pixel near the centre is bright) otherwise. Only the pixels that
    near are looked at: a pixel within d of the centre lies within d + 0.5 of its rounded position on each axis.

    Examples
    --------
    >>> from aerofid import synth
    >>> a = analyse_window(synth.mark_scene("cross", 30, width=2.0, window=60, rng=np.random.default_rng(2)).image)
    >>> crossing_gap(a, 1.0) <= 1.0
    True
    """
    reach = int(limit + 0.5)
    cx, cy = int(round(analysis.x)), int(round(analysis.y))
    x0, y0 = max(0, cx - reach), max(0, cy - reach)
    ys, xs = np.nonzero(analysis.binary[y0:max(y0, cy + reach + 1), x0:max(x0, cx + reach + 1)])
    if not xs.size:
        return float("inf")
    return float(np.hypot(xs + x0 - analysis.x, ys + y0 - analysis.y).min())


def refine_window(image: np.ndarray, cand: Candidate, refine_size: int,
                  params: HoughParams = DEFAULT) -> tuple[WindowAnalysis, np.ndarray, tuple[int, int]]:
    """The window the sub-pixel fit sees: the first-stage window re-centred on the candidate, enlarged once
    (x ``REFINE_WINDOW_FACTOR``) if the arms reach its edge; the candidate's own window when the re-centred
    one cannot be analysed or moves the centre more than ``MAX_REFINE_SHIFT``. (analysis, window, origin)."""
    analysis, window, origin = cand.analysis, cand.window, cand.origin
    size = refine_size
    for _ in range(2):
        got = extract_window(image, cand.x, cand.y, size)
        if got is None:
            break
        a = analyse_window(got[0], params)
        if isinstance(a, str) or np.hypot(a.x + got[1][0] - cand.x, a.y + got[1][1] - cand.y) > MAX_REFINE_SHIFT:
            break
        analysis, window, origin = a, got[0], got[1]
        if arm_half_length(a) + 2.0 < min(window.shape) / 2.0:
            break
        size = int(round(REFINE_WINDOW_FACTOR * refine_size))
    return analysis, window, origin


def shape_refusal(ref: CrossFit) -> str | None:
    """Why the fitted shape is no '+' (a bound reached, a blob, an unresolved stroke, arms that do not stick
    out of the blurred crossing), or None."""
    if ref.at_bound:
        return f"the '+' model does not fit (its {ref.at_bound} ended on a bound)"
    if ref.width > MAX_WIDTH_RATIO * min(ref.length1, ref.length2):
        return (f"fitted shape is a blob, not a '+' (stroke {ref.width:.1f} px, bars {ref.length1:.1f}/"
                f"{ref.length2:.1f} px)")
    if ref.width < MIN_RESOLVED_WIDTH and ref.blur > ref.width + 0.5:
        return (f"the stroke is not resolved (width {ref.width:.2f} px under a blur of {ref.blur:.2f} px): a "
                "blurred line in texture, not a '+'")
    protrusion = min(ref.length1, ref.length2) / 2.0 - (ref.width / 2.0 + 2.0 * ref.blur)
    if protrusion < MIN_ARM_PROTRUSION:
        return (f"the arms do not stick out of the blurred crossing ({protrusion:.1f} px beyond it): a blob, "
                "not a '+'")
    return None


def quality_refusal(ref: CrossFit, params: HoughParams = DEFAULT, slack: float = 1.0) -> str | None:
    """Why the fitted '+' is not trusted (uncertain centre, misfit, unbalanced or faint arms), or None; ``slack``
    widens the limits of the centre's sigma and of the misfit (a second '+' sought to refuse a box need not be one
    whose centre could be trusted)."""
    if ref.sigma > slack * MAX_CENTRE_SIGMA:
        return (f"the centre is too uncertain (sigma {ref.sigma:.2f} px > {slack * MAX_CENTRE_SIGMA:g} px): a faint "
                "or blurred '+', or texture")
    if ref.misfit > slack * MAX_MISFIT:
        return f"the '+' model does not explain the grey values (misfit {ref.misfit:.1f} x noise)"
    if ref.arm_balance < params.min_arm_balance:
        return f"arms unbalanced ({ref.arm_balance:.2f} < {params.min_arm_balance}): not a '+'"
    if ref.arm_snr < params.min_arm_snr:
        return f"arms too faint (SNR {ref.arm_snr:.1f} < {params.min_arm_snr})"
    return None


def verify_candidate(image: np.ndarray, cand: Candidate, refine_size: int,
                     params: HoughParams = DEFAULT) -> Verified | str:
    """Refine a search candidate to sub-pixel (:func:`refine_window`, :func:`fit_cross`) and check that it is a
    '+': before the fit, with ``params.max_crossing_gap``, a stroke at the Hough centre (:func:`crossing_gap`), and a
    '+' at its start that explains at least :data:`MIN_START_SHARE` of the grey values, brighter than its ground; after
    it, :func:`shape_refusal`, :func:`quality_refusal`, within ``MAX_REFINE_SHIFT`` of the Hough centre. Returns
    :class:`Verified` or the reason.

    The fit, or the refusal before it, is kept (:data:`FITS_KEPT`) by what it reads (:func:`_fit_key`): a search that
    meets the same candidate in the same pixels again - the windows of one box overlap, and a box's search measures
    many of them - reuses it, placed at the candidate's window (the same numbers)."""
    key = _fit_key(image, cand, refine_size, params)
    kept = _FITS.get(key[0]) if key is not None else None
    if key is not None and kept is not None:
        fitted = _moved(kept, key[1], 1)
    else:
        fitted = _fitted(image, cand, refine_size, params)
        if key is not None:
            _FITS.put(key[0], _moved(fitted, key[1], -1))
    if isinstance(fitted, str):
        return fitted
    return _verdict(fitted[0], fitted[1], (cand.x, cand.y), "the Hough centre", params)


Fitted = str | tuple[CrossFit | None, tuple[int, int]]
"""A verification's refusal before the fit, or its fit (None: failed) and the origin of the window fitted."""


def _moved(fitted: Fitted, origin: tuple[int, int], sign: int) -> Fitted:
    """``fitted`` with its window's origin moved by ``sign`` times ``origin`` (kept relative to the first refine
    window's origin, given at the candidate's)."""
    if isinstance(fitted, str):
        return fitted
    return fitted[0], (fitted[1][0] + sign * origin[0], fitted[1][1] + sign * origin[1])


def _fitted(image: np.ndarray, cand: Candidate, refine_size: int, params: HoughParams) -> Fitted:
    """:func:`verify_candidate`'s :data:`Fitted`. A cloth panel's fit (``mark="panel"``) gets no bounded retry
    (:func:`aerofid.detect.hough.cross_fit.fit_cross`'s ``retry``): on 3 700 scratch boxes with one or two panels
    (session 39's review scenes) it ran 1 290 times and verified a '+' 3 times, twice a second panel that made a box
    with two answer as found; on bench_marks.py's and bench_peers.py's panels 211 times, never verified; without it
    ``locate`` on a panel's 200 px box took 0.83 of the time, with the same answers (12 boxes)."""
    analysis, window, origin = refine_window(image, cand, refine_size, params)
    limit = params.max_crossing_gap
    if limit is not None and crossing_gap(analysis, limit) > limit:
        return (f"no stroke at the Hough centre (no bright pixel within {limit:g} px of it): the two lines do not "
                "cross as a '+' there")
    fitted_at = (int(origin[0]), int(origin[1]))
    start = cross_start(window, analysis.x, analysis.y, analysis.theta1, analysis.theta2, arm_half_length(analysis))
    if start is None:
        return None, fitted_at
    refusal = start_refusal(*start_share(start, MIN_START_SHARE))
    if refusal is not None:
        return refusal
    # the fit starts within MAX_REFINE_SHIFT of the candidate (refine_window); a first pass that moves more
    # than EARLY_EXIT_SHIFT from there will be refused: no refits (cross_fit._robust_solve)
    return fit_start(start, max_shift=EARLY_EXIT_SHIFT, retry=params.mark != "panel"), fitted_at


def start_refusal(amplitude: float, share: float) -> str | None:
    """Why the '+' at a fit's start (:func:`aerofid.detect.hough.cross_fit.start_share`: its amplitude and share of
    the grey values) refuses the candidate before the fit, or None (also where they are not numbers)."""
    if amplitude <= 0.0:
        return "no '+' at the Hough centre: turned either way, it is no brighter along its bars than beside them"
    if share < MIN_START_SHARE:
        return (f"no '+' at the Hough centre: turned either way, a '+' there explains {share:.2%} of the grey values "
                f"(< {MIN_START_SHARE:.2%})")
    return None


FITS_KEPT = 512
"""The verifications :func:`verify_candidate` keeps, the latest (a fit is a few hundred bytes)."""


_FITS: Kept[Fitted] = Kept(FITS_KEPT)


def _fit_key(image: np.ndarray, cand: Candidate, refine_size: int,
             params: HoughParams) -> tuple[tuple[bytes, HoughParams], tuple[int, int]] | None:
    """Everything :func:`_fitted` reads, as a digest with the parameters, and the origin of the candidate's first
    refine window (:func:`refine_window`), to which the digest's positions are relative; None where there is no such
    window. Read: the pixels of both refine windows, the candidate's own window, where it lies and its analysis's
    centre, lines and thresholded pixels (its fallback), the candidate's centre, the sizes."""
    first = extract_window(image, cand.x, cand.y, refine_size)
    if first is None:
        return None
    larger = extract_window(image, cand.x, cand.y, int(round(REFINE_WINDOW_FACTOR * refine_size)))
    (x0, y0), a = first[1], cand.analysis
    where = (refine_size, image.dtype.str, cand.x - x0, cand.y - y0, first[0].shape,
             None if larger is None else (larger[0].shape, larger[1][0] - x0, larger[1][1] - y0),
             cand.window.shape, cand.window.dtype.str, cand.origin[0] - x0, cand.origin[1] - y0,
             a.x, a.y, a.theta1, a.theta2, a.binary.shape,
             # the settings it reads, so that a run that changes them (bench_fits.py's limit) is not served old fits
             MIN_START_SHARE, MAX_REFINE_SHIFT, REFINE_WINDOW_FACTOR, EARLY_EXIT_SHIFT, cross_fit.MAX_EVALUATIONS)
    pixels = (first[0], None if larger is None else larger[0], cand.window, a.binary)
    key = digest(repr(where).encode(), *(np.ascontiguousarray(p).tobytes() for p in pixels if p is not None))
    return (key, params), (x0, y0)


def _verdict(ref: CrossFit | None, origin: tuple[float, float], start: tuple[float, float], named: str,
             params: HoughParams, slack: float = 1.0) -> Verified | str:
    """The checks of a fitted '+' (in a window at ``origin``): a fit, within ``MAX_REFINE_SHIFT`` of ``start``
    (called ``named`` in the reason), no :func:`shape_refusal` or :func:`quality_refusal` (with ``slack``)."""
    if ref is None:
        return "sub-pixel fit failed"
    x, y = ref.x + origin[0], ref.y + origin[1]
    if np.hypot(x - start[0], y - start[1]) > MAX_REFINE_SHIFT:
        return f"sub-pixel fit moved more than {MAX_REFINE_SHIFT} px from {named}"
    reason = shape_refusal(ref) or quality_refusal(ref, params, slack)
    return reason if reason is not None else Verified(x=float(x), y=float(y), refinement=ref)


LIKE_EVALUATIONS = 50
"""Most model evaluations of a least-squares pass of :func:`verify_like`, whose start is the '+' sought, turned as it
lies: the fit of a second cloth panel took 6-30 a pass (813 second panels found in 1 220 boxes with two panels:
plain, noisy, strongly blurred, JPEG q=40, the second panel of another contrast or size; scratch, session 39),
while 28 of the 60 fits on aerial clutter of bench_peers.py's single-panel boxes ran out of the 100 of a search's fit
(:data:`~aerofid.detect.hough.cross_fit.MAX_EVALUATIONS`) and failed, the others refused in 11-68. A review's 3 700
boxes of harder kinds (1 237 second panels found, at most 26 a pass) answered the same but for two lone panels, which
a clutter '+' fitted in 72 had refused."""


def verify_like(image: np.ndarray, x: float, y: float, model: CrossFit, turn: float,
                params: HoughParams = DEFAULT, slack: float = 1.0) -> Verified | str:
    """Beyond the seed: is there a '+' like ``model`` (a fitted '+', its parameters in any window) turned by ``turn``
    degrees, at (x, y) of ``image``? The blurred-cross fit starts there with ``model``'s bars turned (normal angles
    minus ``turn``: OpenCV's counter-clockwise turn of an image with y down), arms, stroke and blur (without the
    bounded solver's second try: from a start that close, no '+' of 35 such twins needed it, while it took 60 % of
    the time of the fits that found none, in scratch boxes with one and two panels; at most :data:`LIKE_EVALUATIONS`
    evaluations a pass), and what it
    finds must pass the same checks as a candidate of the search (:func:`shape_refusal`, :func:`quality_refusal` with
    ``slack``, within ``MAX_REFINE_SHIFT`` of (x, y)). Returns :class:`Verified` or the reason.

    Examples
    --------
    >>> from aerofid import synth
    >>> img = synth.panel_scene(np.random.default_rng(4), centre=(25.3, 30.6), size=9.0, angle_deg=12.0,
    ...                         contrast=0.4, ground=np.full((60, 100), 0.3, np.float32)).image
    >>> img = synth.panel_scene(np.random.default_rng(5), centre=(74.7, 29.2), size=9.0, angle_deg=12.0,
    ...                         contrast=0.4, ground=img).image
    >>> first = detect(img[:, :50], HoughParams(mark="panel"))
    >>> got = verify_like(img, 75.0, 29.0, first.refinement, 0.0)
    >>> round(got.x, 1), round(got.y, 1)
    (74.7, 29.2)
    >>> verify_like(img, 50.0, 10.0, first.refinement, 0.0)
    'sub-pixel fit moved more than 2.0 px from the start'
    """
    ref = fit_cross(image, x, y, model.theta1 - turn, model.theta2 - turn, 0.5 * max(model.length1, model.length2),
                    width=model.width, blur=model.blur, max_shift=EARLY_EXIT_SHIFT, retry=False,
                    evaluations=LIKE_EVALUATIONS)
    return _verdict(ref, (0.0, 0.0), (x, y), "the start", params, slack)


@dataclass(frozen=True)
class HoughResult(Detection):
    """The answer of the ``hough`` method with its intermediate results (window pixels of the window searched).

    Attributes
    ----------
    candidates : tuple of Candidate
        Every candidate of the search, both stages, in the order seen.
    rejected : tuple of (Candidate, str)
        Candidates refused by the verification, with the reason.
    analysis : WindowAnalysis or None
        The best candidate's window analysis (thresholded window, accumulators, projection); None when
        nothing was found.
    window_origin : tuple of int
        Where that window lies in the window searched.
    model, model_name, metric : ndarray or None, str, float
        The similarity model the projection was compared with, its name and the similarity metric.
    stage : int
        The search stage (1 or 2) of the best candidate; 0 when nothing was found.
    refinement : CrossFit or None
        The sub-pixel cross fit (None with ``verify=False``, or when nothing was found).
    """

    candidates: tuple[Candidate, ...] = field(default=(), compare=False, repr=False)
    rejected: tuple[tuple[Candidate, str], ...] = field(default=(), compare=False, repr=False)
    analysis: WindowAnalysis | None = field(default=None, compare=False, repr=False)
    window_origin: tuple[int, int] = (0, 0)
    model: np.ndarray | None = field(default=None, compare=False, repr=False)
    model_name: str = ""
    stage: int = 0
    metric: float = float("nan")
    refinement: CrossFit | None = field(default=None, compare=False, repr=False)

    @property
    def extent(self) -> float | None:
        """The mark's radius (px) by the fitted cross: half the longer bar (at most the half-size of the patch
        fitted: arms running out of it are as long as the patch shows them) plus half the stroke and the blur;
        None without a refinement."""
        f = self.refinement
        if f is None:
            return None
        return float(min(max(f.length1, f.length2) / 2.0, f.patch_half) + f.width / 2.0 + f.blur)

    def plot(self, fig: Figure, window: np.ndarray) -> None:
        """Thesis figures 5.2-5.5 of the best candidate's window: the optimally thresholded window, the Hough
        accumulator before and after thresholding, the theta projection with the similarity model; without
        an analysis, ``window`` with the reason (:meth:`Detection.plot`)."""
        a = self.analysis
        if a is None:
            super().plot(fig, window)
            return
        axes = [fig.add_subplot(2, 2, k) for k in (1, 2, 3, 4)]
        ox, oy = self.window_origin
        axes[0].imshow(a.binary, cmap="gray", interpolation="nearest")
        axes[0].plot([a.x], [a.y], "+", color="orange", ms=14, mew=2)
        axes[0].set_title(f"Optimally thresholded window (stage {self.stage}, origin {ox},{oy} in box)", fontsize=9)
        for ax, acc, title in ((axes[1], a.accumulator, "Hough accumulator"),
                               (axes[2], a.accumulator_thresholded, "Thresholded accumulator")):
            theta_step = 180.0 / len(a.thetas)
            ax.imshow(acc, aspect="auto", cmap="magma", interpolation="nearest", origin="lower",
                      extent=(a.rho_min, a.rho_min + acc.shape[1] * a.rho_step, 0.0, 180.0))
            ax.set_ylim(0.0, 180.0 - theta_step)
            ax.set_xlabel("rho (px)")
            ax.set_ylabel("theta (deg)")
            ax.set_title(title, fontsize=9)
        proj = a.projection / (a.projection.max() or 1.0)
        model = np.asarray(self.model if self.model is not None else np.zeros_like(a.thetas), float)
        model = model / (model.max() or 1.0)
        axes[3].plot(a.thetas, proj, "o-", label="projection (eq. 5)")
        axes[3].plot(a.thetas, model, "--", label=f"{self.model_name} model")
        axes[3].set_xlabel("theta (deg)")
        axes[3].set_title(f"Theta projection, similarity {self.metric:.2f}", fontsize=9)
        axes[3].legend(fontsize=8)
        fig.suptitle(f"{self.status}: x={self.x:.3f} y={self.y:.3f} sigma={self.sigma:.3f} px", fontsize=10)
        fig.tight_layout()


def detect(window: np.ndarray, params: HoughParams = DEFAULT) -> HoughResult:
    """Locate a '+' mark in ``window`` by the complete seed algorithm, each accepted candidate refined to
    sub-pixel and verified (beyond the seed).

    The search (:func:`aerofid.detect.hough.search.search_box`: spiral, two tiers, recursion, similarity
    metric) proposes candidates; with ``params.verify`` each one that would be accepted is refined by the
    blurred-cross fit and must pass :func:`verify_candidate`, else the search goes on.

    Parameters
    ----------
    window : ndarray
        2-D grey levels on [0, 1], the mark brighter than its ground.
    params : HoughParams
        Every parameter of the method, including ``mark`` (the similarity model).

    Returns
    -------
    HoughResult
        Centre in window pixels; ``score`` = the similarity metric (clipped to [0, 1]); ``sigma_x``,
        ``sigma_y``, ``cov_xy`` = the cross fit's covariance of the centre, or the rho cell's
        rho_step / sqrt(12) per axis (``cov_xy`` 0) with ``verify=False``; ``sigma`` = their RMS,
        sqrt((sigma_x^2 + sigma_y^2) / 2).

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("cross", 30, width=2.0, window=60, rng=np.random.default_rng(2))
    >>> r = detect(scene.image, HoughParams(mark="external"))
    >>> r.found, bool(np.hypot(r.x - scene.marks[0].x, r.y - scene.marks[0].y) < 0.1), r.refinement is not None
    (True, True, True)
    """
    image = np.asarray(window)
    bad = unusable_window(image, min_side=4)
    if bad is not None:
        return HoughResult.not_found(METHOD, bad)

    def verify(cand: Candidate, stage1_size: int) -> Verified | str:
        return verify_candidate(image, cand, stage1_size, params)

    result = search_box(image, params, verify if params.verify else None)
    best = result.best
    if best is None:
        return HoughResult.not_found(METHOD, result.reason, candidates=result.candidates, rejected=result.rejected)
    if isinstance(result.verified, Verified):
        v = result.verified
        x, y, refinement = v.x, v.y, v.refinement
        sx, sy, cxy = refinement.sigma_x, refinement.sigma_y, refinement.cov_xy
    else:  # verification off: the Hough centre, quantised by the rho cells
        x, y, refinement = best.x, best.y, None
        sx = sy = params.rho_step / np.sqrt(12.0)
        cxy = 0.0
    return HoughResult(status=FOUND, x=float(x), y=float(y), score=float(np.clip(best.metric, 0.0, 1.0)),
                       sigma=float(np.sqrt((sx * sx + sy * sy) / 2.0)), sigma_x=float(sx), sigma_y=float(sy),
                       cov_xy=float(cxy), method=METHOD, candidates=result.candidates, rejected=result.rejected,
                       analysis=best.analysis, window_origin=best.origin, model=best.model,
                       model_name=best.model_name, stage=best.stage, metric=float(best.metric),
                       refinement=refinement)


__all__ = ["LIKE_EVALUATIONS", "HoughResult", "Verified", "arm_half_length", "crossing_gap", "detect", "half_arm_runs",
           "half_arm_steps", "quality_refusal", "refine_window", "verify_like", "shape_refusal", "verify_candidate"]
