"""The ``hough`` method: Hunt, Ryan & Gifford's search (:mod:`.search`) over the window, each accepted candidate
refined to sub-pixel by the cross fit (:mod:`.cross_fit`) and verified as a '+' (beyond the seed)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aerofid.detect.hough.analysis import MARK_MODELS, METHOD, HoughParams, WindowAnalysis, analyse_window
from aerofid.detect.hough.cross_fit import CrossFit, fit_cross
from aerofid.detect.hough.search import SearchParams, extract_window, search_box
from aerofid.detect.result import FOUND, Detection, not_found

# --- sub-pixel refinement and verification (beyond the seed) ---------------------------------------------

MAX_REFINE_SHIFT = 2.0
"""A sub-pixel fit that moves the centre further than this (px) from the Hough centre is not trusted."""
REFINE_WINDOW_FACTOR = 1.5
"""When the arms reach the edge of the first-stage window, the sub-pixel fit looks at a window this many
times larger, so that it sees the arms' ends."""


def arm_half_length(analysis: WindowAnalysis, max_gap: int = 1) -> float:
    """Half-length of the arms: along each Hough line and on each side of the centre, the run of bright
    pixels (within 1.5 px of the line) that stays connected to the centre, allowing ``max_gap`` empty
    1-px steps; averaged over the four half-arms. Bright texture further along a line is not counted
    (a percentile of all bright pixels near the line overestimates a small panel's arms on aerial ground)."""
    ys, xs = np.nonzero(analysis.binary)
    out = []
    for th in (analysis.theta1, analysis.theta2):
        t = np.deg2rad(th)
        r = (xs - analysis.x) * np.cos(t) + (ys - analysis.y) * np.sin(t)
        along = -(xs - analysis.x) * np.sin(t) + (ys - analysis.y) * np.cos(t)
        near = np.abs(r) <= 1.5
        for side in (1.0, -1.0):
            steps = np.round(side * along[near]).astype(int)
            occupied = set(steps[steps >= 0].tolist())
            end, gap, k = 0, 0, 0
            while gap <= max_gap:
                k += 1
                if k in occupied:
                    end, gap = k, 0
                else:
                    gap += 1
            out.append(end + 0.5)
    return max(2.0, float(np.mean(out)))


MIN_ARM_BALANCE = 0.35
"""Verification (beyond the seed): the weakest of the four half-arms must carry at least this fraction of
the strongest's contrast, else the candidate is an L, a T, a bar or a corner of a roof, not a '+'."""
MIN_ARM_SNR = 3.0
"""Verification: the weakest half-arm's contrast must be at least this many times the grey-level noise."""
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


@dataclass(frozen=True)
class Verified:
    """A candidate that passed verification: its sub-pixel refinement in full-window pixels."""

    x: float
    y: float
    refinement: CrossFit


def verify_candidate(image: np.ndarray, cand, refine_size: int, params: HoughParams = HoughParams(),
                     min_arm_balance: float = MIN_ARM_BALANCE, min_arm_snr: float = MIN_ARM_SNR,
                     max_shift: float = MAX_REFINE_SHIFT) -> Verified | str:
    """Refine a search candidate to sub-pixel and check that it is a '+' (four balanced, visible arms,
    refined centre within ``max_shift`` of the Hough centre). Returns :class:`Verified` or the reason."""
    analysis, window, origin = cand.analysis, cand.window, cand.origin
    size = refine_size
    for _ in range(2):  # the first-stage window, enlarged once if the arms reach its edge
        got = extract_window(image, cand.x, cand.y, size)
        if got is None:
            break
        a = analyse_window(got[0], params)
        if isinstance(a, str) or np.hypot(a.x + got[1][0] - cand.x, a.y + got[1][1] - cand.y) > max_shift:
            break
        analysis, window, origin = a, got[0], got[1]
        if arm_half_length(a) + 2.0 < min(window.shape) / 2.0:
            break
        size = int(round(REFINE_WINDOW_FACTOR * refine_size))
    ref = fit_cross(window, analysis.x, analysis.y, analysis.theta1, analysis.theta2, arm_half_length(analysis))
    if ref is None:
        return "sub-pixel fit failed"
    x, y = ref.x + origin[0], ref.y + origin[1]
    if np.hypot(x - cand.x, y - cand.y) > max_shift:
        return f"sub-pixel fit moved more than {max_shift} px from the Hough centre"
    if ref.at_bound:
        return f"the '+' model does not fit (its {ref.at_bound} ended on a bound)"
    if ref.width > MAX_WIDTH_RATIO * min(ref.length1, ref.length2):
        return f"fitted shape is a blob, not a '+' (stroke {ref.width:.1f} px, bars {ref.length1:.1f}/{ref.length2:.1f} px)"
    if ref.width < MIN_RESOLVED_WIDTH and ref.blur > ref.width + 0.5:
        return (f"the stroke is not resolved (width {ref.width:.2f} px under a blur of {ref.blur:.2f} px): a "
                "blurred line in texture, not a '+'")
    protrusion = min(ref.length1, ref.length2) / 2.0 - (ref.width / 2.0 + 2.0 * ref.blur)
    if protrusion < MIN_ARM_PROTRUSION:
        return (f"the arms do not stick out of the blurred crossing ({protrusion:.1f} px beyond it): a blob, "
                "not a '+'")
    if ref.sigma > MAX_CENTRE_SIGMA:
        return (f"the centre is too uncertain (sigma {ref.sigma:.2f} px > {MAX_CENTRE_SIGMA} px): a faint or "
                "blurred '+', or texture")
    if ref.misfit > MAX_MISFIT:
        return f"the '+' model does not explain the grey values (misfit {ref.misfit:.1f} x noise)"
    if ref.arm_balance < min_arm_balance:
        return f"arms unbalanced ({ref.arm_balance:.2f} < {min_arm_balance}): not a '+'"
    if ref.arm_snr < min_arm_snr:
        return f"arms too faint (SNR {ref.arm_snr:.1f} < {min_arm_snr})"
    return Verified(x=float(x), y=float(y), refinement=ref)


def detect(window: np.ndarray, mark: str = "auto", **params) -> Detection:
    """Locate a '+' mark in ``window`` by the complete seed algorithm (spiral, two tiers, recursion,
    similarity metric; :func:`aerofid.detect.hough.search.search_box`), each accepted candidate refined to sub-pixel and
    verified (:func:`verify_candidate`).

    ``mark``: "external" (sharp-peak model), "panel" (raised-cosine model) or "auto" (the better of both).
    Keyword parameters: those of :class:`HoughParams` and :class:`aerofid.detect.hough.search.SearchParams`, and
    ``min_arm_balance``, ``min_arm_snr`` (verification; ``verify=False`` switches it off, as in the seed).
    """
    if mark not in MARK_MODELS:
        raise ValueError(f"mark must be one of {', '.join(MARK_MODELS)}")
    params = dict(params)
    do_verify = bool(params.pop("verify", True))
    checks = {k: params.pop(k) for k in ("min_arm_balance", "min_arm_snr") if k in params}
    hough_keys = set(HoughParams.__dataclass_fields__)
    search_keys = set(SearchParams.__dataclass_fields__)
    unknown = set(params) - hough_keys - search_keys
    if unknown:
        raise TypeError(f"unknown parameter(s) for method 'hough': {', '.join(sorted(unknown))}")
    hp = HoughParams(**{k: v for k, v in params.items() if k in hough_keys})
    sp = SearchParams(**{k: v for k, v in params.items() if k in search_keys})

    def verify(cand, stage1_size):
        return verify_candidate(window, cand, stage1_size, hp, **checks)

    result = search_box(window, mark, hp, sp, verify if do_verify else None)
    if result.best is None:
        return not_found(METHOD, result.reason, candidates=result.candidates)
    best = result.best
    diagnostics = {"candidates": result.candidates, "analysis": best.analysis, "window": best.window,
                   "window_origin": best.origin, "model": best.model, "model_name": best.model_name,
                   "stage": best.stage, "metric": best.metric}
    if isinstance(result.verified, Verified):
        v = result.verified
        diagnostics["refinement"] = v.refinement
        sigma = v.refinement.sigma
        x, y = v.x, v.y
    else:  # verification off: the Hough centre, quantised by the rho cells
        x, y, sigma = best.x, best.y, hp.rho_step / np.sqrt(12.0)
    return Detection(status=FOUND, x=float(x), y=float(y), score=float(np.clip(best.metric, 0.0, 1.0)),
                     sigma=float(sigma), method=METHOD, diagnostics=diagnostics)


__all__ = ["MIN_ARM_BALANCE", "MIN_ARM_SNR", "Verified", "arm_half_length", "detect", "verify_candidate"]
