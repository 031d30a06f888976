"""Centre of any centrally symmetric mark by symmetry analysis (Cho & Kim, seed 002).

Cho, S.-I. and Kim, K.-O., "Automatic Identification of Fiducial Marks Based on Weak Constraints". The
method needs no model of the mark, only two weak assumptions (seed section 2.1): (1) the mark is symmetric
about its centre, (2) the *fiducial area* around it is roughly symmetric about an axis through that centre.
It runs in four stages (seed Fig. 3):

1. **Fiducial-area analysis** (seed 3.1): accumulated edge profiles, eq. (1), thresholded at their mean,
   give the upper and lower bounds L1, L2 and the horizontal extent of the area; the symmetry of the
   accumulated grey-level profile between them, eq. (2), gives the axis L3. For a corner area the window is
   first projected diagonally (rotated 45 degrees) so that the area's axis is upright (``diagonal=``).
   The bounds also give the half-size of the mark, which sets the symmetry kernel (seed 3.2).
2. **Mark analysis** (seed 3.2): a simplified Laplacian of Gaussian by box filtering, eq. (3); symmetry
   enhancement, eqs. (4)-(5); accumulation to a profile, eq. (6); high-pass filtering, eq. (7), whose peak
   is the centre of symmetry along one axis. Alternately along y and x, with an accumulation / smoothing
   interval that narrows each iteration, until the shift is at most one pixel; no convergence is a failure.
3. **Self-diagnosis** (seed 3.3): mirror-added images, eqs. (8)-(9), their 90-degree rotations,
   eqs. (10)-(11), and the mean of four normalised cross-correlations, eqs. (12)-(13); ``R_self`` below 0.5
   is a failure.
4. **Sub-pixel location** (seed 3.4): the neighbourhood of the unit-pixel centre is enlarged (bilinear),
   Gaussian-smoothed and analysed again in the same way; the centre is the weighted mean of the final
   high-pass profile, eq. (14), mapped back by eq. (15). A total shift that is too large, or a neighbourhood
   whose grey levels hardly vary (too faint), is a failure.

Beyond the seed, the centre of eq. (15) is refined by least squares on point symmetry itself
(:func:`point_symmetry_centre`, ``point_refine=True``): eq. (14) is biased on marks whose filter response is
uneven (rotated thin crosses: 0.1-0.3 px), the refinement is not; the two centres' disagreement enters
``sigma``.

Every step works on absolute differences of a linear filter, so the method is blind to polarity: a bright
mark on dark ground and a dark mark on bright ground give the same centre.

The returned ``score`` is ``R_self`` (clipped to [0, 1]) evaluated at the final sub-pixel centre, so a found
mark has ``score >= rself_threshold`` (0.5). ``sigma`` is a propagated standard deviation (see
:func:`_centre_sigma`); the benchmark ``benchmarks/bench_symmetry.py`` checks it against observed errors.

Deviations from, and readings of, the paper are marked "Reading:" in the parameter docs of :func:`detect`.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from scipy import ndimage

from aerofid.detect.noise import laplacian_noise_sigma
from aerofid.detect.result import FOUND, Detection, not_found
from aerofid.robust import MAD_TO_SIGMA

METHOD = "symmetry"

_POLARITIES = ("bright", "dark", "either")
_DIAGONALS = (None, "main", "anti")


class _Failure(Exception):
    """Internal: a step could not go on; carries the reason for ``not_found``."""

    def __init__(self, reason: str, **diagnostics: Any):
        super().__init__(reason)
        self.reason = reason
        self.diagnostics = diagnostics


def detect(window: np.ndarray, *, polarity: str = "bright", diagonal: str | None = None,
           edge_step: int = 2, radius: int | None = None, min_radius: int = 3,
           log_inner: int = 2, log_gap: int = 3, log_outer: int = 4,
           interval: int | None = None, interval_shrink: float = 0.5, min_interval: int = 1,
           max_iter: int = 12, converge_px: float = 1.0,
           rself_threshold: float = 0.5, min_rotation_corr: float = 0.25, max_asymmetry: float = 0.1,
           enlarge: int = 4, smooth_sigma: float = 0.5, max_total_shift: float = 1.5,
           faint_snr: float = 1.0, min_std: float = 0.005, area_smooth: int = 3,
           sigma_inefficiency: float = 1.7, sigma_floor: float = 0.005,
           point_refine: bool = True, max_refine_shift: float = 1.0) -> Detection:
    """Find the centre of a centrally symmetric mark in ``window`` (Cho & Kim, seed 002).

    Args:
        window: 2-D grey-level image, float on [0, 1]. The mark may be brighter or darker than its ground.
        polarity: ``"bright"`` (default), ``"dark"`` or ``"either"``. Recorded only: the method uses
            absolute differences of linear filters (eqs. 3-5) and normalised correlations (eq. 12), so its
            answer is the same for a mark and its negative (seed section 2.1 assumes only symmetry).
        diagonal: ``None`` for a side fiducial area whose symmetry axis L3 is upright (seed Fig. 2);
            ``"main"`` for a corner area whose axis runs along the main diagonal (top-left to bottom-right),
            ``"anti"`` along the anti-diagonal. The window is then "diagonally projected" (rotated by 45
            degrees) before L1, L2, L3 are found (seed 2.2); the mark analysis itself is unchanged.
        edge_step: ``d`` of eq. (1), the pixel separation of the edge profile; the profile is thresholded
            at its mean (seed 3.1).
        radius: radius of the symmetry-enhancement kernel of eqs. (4)-(5), "as large as the half-size of
            the target object" (seed 3.2). ``None``: half the larger extent of the fiducial area (L1..L2
            and the horizontal extent), never less than ``min_radius``.
        min_radius: smallest kernel radius used when the bounds give a smaller one.
        log_inner, log_gap, log_outer: the simplified LoG of eq. (3), seed 3.2: "the inner radius of R1 as
            two, outer one as three, and outer one of R2 as four". Reading: R1 is the square of half-width
            ``log_inner`` (5 x 5), R2 the square frame between half-widths ``log_gap`` and ``log_outer``
            (9 x 9 minus 7 x 7); I2 = mean(R2) - mean(R1), computed with box filters.
        interval: ``d`` of eqs. (6)-(7) at the first iteration; ``None`` = the kernel radius ("the half-size
            of the target object at first step", seed 3.2).
        interval_shrink: factor by which the interval narrows at each iteration (seed 3.2 says only
            "narrowing"; halving is our choice).
        min_interval: the interval never narrows below this.
        max_iter: iterations (each one vertical and one horizontal step) before the refinement is declared
            divergent.
        converge_px: the iteration stops when the shift of one iteration is at most this ("converges into
            one pixel", seed 3.2); it diverges when the shift grows twice in a row or ``max_iter`` passes.
        rself_threshold: threshold on ``R_self`` of eq. (13) ("adequate value of the threshold can be 0.5").
        min_rotation_corr: our guard, not in the seed: each 90-degree term R13, R24 of eq. (13) must reach
            this too. Because R34 equals R12 identically, a straight bar or band (mirror-symmetric, no
            centre along its length) scores exactly 0.5 and would pass the seed's test half of the time.
        max_asymmetry: our guard, not in the seed: the largest share of the sub-image's structure (net of
            noise) that may differ from its 180-degree rotation about the final centre
            (:func:`point_asymmetry`). The mirror additions of eqs. (8)-(9) hide a one-sided part (a disc
            with a bump scores R_self ~ 0.8); assumption (1) of the seed is checked directly instead.
            Synthetic marks on film border stay below 0.02, a disc with a bump of a quarter of its area
            reaches 0.18. On textured (aerial) ground the texture inside the sub-image is itself asymmetric
            (0.1-0.9) and most marks are rejected: raise this (e.g. to 1.0) there, accepting that one-sided
            blobs may then pass.
        enlarge: ``R_e`` of eq. (15), the enlargement rate of the bilinear interpolation (not given in the
            seed; 4 gives steps of 1/4 px, refined further by the weighted mean of eq. 14).
        smooth_sigma: standard deviation, in original pixels, of the Gaussian smoothing of the enlarged image
            (seed 3.4; value not given in the seed).
        max_total_shift: the sub-pixel stage fails when its total shift from the unit-pixel centre exceeds
            this many original pixels (seed 3.4, "a given threshold").
        faint_snr, min_std: the mark is "too faint" (seed 3.4) when the standard deviation of the grey levels
            within ``radius`` of the final centre, less the part the noise explains
            (``sqrt(std^2 - noise^2)``), is below ``max(min_std, faint_snr * noise)``; the noise is estimated
            from the window (Immerkaer's Laplacian estimator, robust form). The seed gives no values; the
            noise correction is ours (a plain std threshold rejects thin, high-contrast crosses).
        area_smooth: side of a box filter applied to the window before the edge profiles of eq. (1) (not in
            the seed: it keeps the mean threshold from being crossed by noise rows when the mark is thin;
            1 = off).
        sigma_inefficiency, sigma_floor: calibration of the reported ``sigma`` (not in the seed): the
            Cramer-Rao-like bound ``noise / sqrt(sum of squared gradients)`` times ``sigma_inefficiency``,
            plus ``sigma_floor`` px in quadrature for the discretisation of eq. (14).
        point_refine: beyond the seed: after eq. (15), the centre is refined by least squares on point
            symmetry itself (:func:`point_symmetry_centre`: the (x, y) about which the window best equals its
            180-degree rotation, cubic-spline resampled, within the kernel radius). Eq. (14)'s weighted mean
            of a filtered, accumulated profile is biased on marks whose symmetry filters respond unevenly,
            e.g. 0.1-0.3 px (0.6 px under strong blur) on rotated thin crosses, where the refinement gives
            0.02 (0.07) px (docs/benchmarks_marks.md). ``False``: the seed's centre as published.
        max_refine_shift: the refinement fails (not found) when it moves the centre further than this (px)
            from eq. (15)'s: the two definitions of the centre disagree. A smaller disagreement is added to
            ``sigma`` (per axis, in quadrature): on textured ground both centres are pulled, differently.

    Returns:
        :class:`~aerofid.detect.result.Detection` with the centre in window pixels, ``score = R_self`` of eq.
        (13) at the final centre (clipped to [0, 1]), ``sigma`` in px, and ``diagnostics`` holding the LoG
        image, the symmetry profiles, the bounds and the iteration history. Failures return
        ``not_found("symmetry", reason)``.
    """
    if polarity not in _POLARITIES:
        raise ValueError(f"polarity must be one of {_POLARITIES}, not {polarity!r}")
    if diagonal not in _DIAGONALS:
        raise ValueError(f"diagonal must be one of {_DIAGONALS}, not {diagonal!r}")
    img = np.asarray(window)
    if img.ndim != 2:
        return not_found(METHOD, f"window must be a 2-D grey image, got shape {img.shape}")
    img = img.astype(np.float32, copy=False)
    if not np.all(np.isfinite(img)):
        return not_found(METHOD, "window contains NaN or infinite values")
    h, w = img.shape
    need = 2 * (log_outer + min_radius) + 3
    if h < need or w < need:
        return not_found(METHOD, f"window {w}x{h} px is too small (needs at least {need}x{need})")
    if float(img.max() - img.min()) < 1e-6:
        return not_found(METHOD, "homogeneous window: no grey-level variation at all")

    diag: dict[str, Any] = {"polarity": polarity}
    try:
        return _detect(img, diag, diagonal=diagonal, edge_step=edge_step, radius=radius,
                       min_radius=min_radius, log_inner=log_inner, log_gap=log_gap, log_outer=log_outer,
                       interval=interval, interval_shrink=interval_shrink, min_interval=min_interval,
                       max_iter=max_iter, converge_px=converge_px, rself_threshold=rself_threshold,
                       min_rotation_corr=min_rotation_corr, max_asymmetry=max_asymmetry, enlarge=enlarge, smooth_sigma=smooth_sigma, max_total_shift=max_total_shift,
                       faint_snr=faint_snr, min_std=min_std, area_smooth=area_smooth, sigma_inefficiency=sigma_inefficiency,
                       sigma_floor=sigma_floor, point_refine=point_refine, max_refine_shift=max_refine_shift)
    except _Failure as f:
        diag.update(f.diagnostics)
        return not_found(METHOD, f.reason, **diag)


def _detect(img, diag, *, diagonal, edge_step, radius, min_radius, log_inner, log_gap, log_outer, interval,
            interval_shrink, min_interval, max_iter, converge_px, rself_threshold, min_rotation_corr,
            max_asymmetry, enlarge, smooth_sigma,
            max_total_shift, faint_snr, min_std, area_smooth, sigma_inefficiency, sigma_floor, point_refine,
            max_refine_shift) -> Detection:
    h, w = img.shape
    noise = laplacian_noise_sigma(img)
    diag["noise_sigma"] = noise

    # --- 1. fiducial-area analysis: L1, L2, horizontal extent, L3 (eqs. 1-2) ---------------------------
    area_img = img if area_smooth <= 1 else cv2.blur(img, (int(area_smooth), int(area_smooth)),
                                                      borderType=cv2.BORDER_REFLECT)
    bounds = fiducial_area(area_img, edge_step=edge_step, diagonal=diagonal)
    diag["bounds"] = bounds
    r_max = (min(h, w) - 1) // 2 - log_outer - 1
    if radius is None:
        r = int(round(max(bounds["half_height"], bounds["half_width"])))
        r = max(min_radius, min(r, r_max))
    else:
        r = int(radius)
        if r > r_max:
            raise _Failure(f"kernel radius {r} px does not fit in the {w}x{h} px window (max {r_max})")
    diag["radius"] = r

    # --- 2. mark analysis at unit-pixel accuracy (eqs. 3-7), iterated with a narrowing interval -------
    i2 = simplified_log(img, log_inner, log_gap, log_outer)
    diag["log"] = i2
    lo_x, hi_x = log_outer + r, w - 1 - log_outer - r
    lo_y, hi_y = log_outer + r, h - 1 - log_outer - r
    if lo_x > hi_x or lo_y > hi_y:
        raise _Failure(f"window {w}x{h} px leaves no room for a symmetry kernel of radius {r} px")
    # area of interest (seed 3.2): the neighbourhood of L3 and the vertical limits L1, L2
    if diagonal is None:
        ax0, ax1 = bounds["L3"] - max(bounds["half_width"], r), bounds["L3"] + max(bounds["half_width"], r)
        ay0, ay1 = min(bounds["L1"], bounds["y_mid"] - r), max(bounds["L2"], bounds["y_mid"] + r)
    else:
        ax0, ax1 = bounds["L3"] - r, bounds["L3"] + r
        ay0, ay1 = bounds["y_mid"] - r, bounds["y_mid"] + r
    lo_x, hi_x = max(lo_x, int(np.floor(ax0))), min(hi_x, int(np.ceil(ax1)))
    lo_y, hi_y = max(lo_y, int(np.floor(ay0))), min(hi_y, int(np.ceil(ay1)))
    diag["aoi"] = (lo_x, lo_y, hi_x, hi_y)
    if lo_x > hi_x or lo_y > hi_y:
        raise _Failure("the area of interest around L3 and between L1 and L2 leaves no room for a symmetry "
                       f"kernel of radius {r} px inside the window")
    x = int(np.clip(round(bounds["L3"]), lo_x, hi_x))
    y = int(np.clip(round(bounds["y_mid"]), lo_y, hi_y))
    d = int(interval) if interval is not None else r
    history = [(x, y, d)]
    shifts: list[float] = []
    converged = False
    prof = {}
    for _ in range(max_iter):
        y_new, py = _axis_peak(i2.T, x, r, d, lo_y, hi_y)     # vertical step: L4 (centre row)
        x_new, px = _axis_peak(i2, y_new, r, d, lo_x, hi_x)   # horizontal step: centre column
        prof = {"x": px, "y": py}
        shift = float(np.hypot(x_new - x, y_new - y))
        shifts.append(shift)
        x, y = x_new, y_new
        history.append((x, y, d))
        d_next = max(min_interval, int(np.floor(d * interval_shrink)))
        if shift <= converge_px and d_next == d:
            converged = True
            break
        if shift <= converge_px and len(shifts) >= 2 and shifts[-2] <= converge_px:
            converged = True
            break
        if len(shifts) >= 3 and shifts[-1] > shifts[-2] > shifts[-3] and shift > converge_px:
            break
        d = d_next
    diag.update(iterations=history, shifts=shifts, profiles=prof)
    if not converged:
        raise _Failure(f"symmetry centre diverged: shifts {', '.join(f'{s:.1f}' for s in shifts)} px "
                       f"in {len(shifts)} iterations")
    for name, p, lo, hi in (("x", x, lo_x, hi_x), ("y", y, lo_y, hi_y)):
        if hi - lo >= 2 and (p <= lo or p >= hi):
            raise _Failure(f"symmetry centre {name}={p} is at the limit of the search range [{lo}, {hi}]: "
                           "the mark is probably cut by the window edge or larger than the window")

    # --- 3. self-diagnosis at the unit-pixel centre (eqs. 8-13) ----------------------------------------
    sub = img[y - r:y + r + 1, x - r:x + r + 1]
    r_self, parts = self_diagnosis(sub)
    diag.update(centre_pixel=(x, y), R_self_pixel=r_self, R_parts_pixel=parts)
    if not r_self >= rself_threshold:
        raise _Failure(f"self-diagnosis failed: R_self = {r_self:.2f} < {rself_threshold} at pixel "
                       f"({x}, {y}); the window holds no centrally symmetric mark there")
    _check_rotation(parts, min_rotation_corr, "unit-pixel", x, y)

    # --- 4. sub-pixel location on the enlarged, smoothed neighbourhood (eqs. 14-15) -------------------
    xs, ys, sp = _subpixel(img, x, y, r, d, log_inner, log_gap, log_outer, enlarge, smooth_sigma,
                           max_total_shift, interval_shrink, max_iter)
    diag["subpixel"] = sp
    if "reason" in sp:
        raise _Failure(f"sub-pixel stage: {sp['reason']} (the mark is too close to the window edge); "
                       "enlarge the box")
    total = float(np.hypot(xs - x, ys - y))
    if not np.isfinite(total) or total > max_total_shift:
        raise _Failure(f"sub-pixel stage moved the centre by {total:.2f} px (> {max_total_shift} px) "
                       "from the unit-pixel centre")

    x15, y15 = xs, ys
    if point_refine:
        got = point_symmetry_centre(img, xs, ys, r)
        diag["centre_eq15"] = (xs, ys)
        if got is None:
            raise _Failure("the point-symmetry refinement did not converge (a flat or one-sided pattern)")
        shift = float(np.hypot(got[0] - xs, got[1] - ys))
        if shift > max_refine_shift:
            raise _Failure(f"the point-symmetry centre lies {shift:.2f} px from eq. (15)'s (> {max_refine_shift} "
                           "px): the two disagree")
        xs, ys = got

    # final self-diagnosis and faintness at the sub-pixel centre
    subs = _resample(img, xs, ys, r)
    score, parts_s = self_diagnosis(subs)
    diag.update(R_self=score, R_parts=parts_s)
    if not score >= rself_threshold:
        raise _Failure(f"self-diagnosis failed at the sub-pixel centre: R_self = {score:.2f} < "
                       f"{rself_threshold}")
    _check_rotation(parts_s, min_rotation_corr, "sub-pixel", xs, ys)
    asym = point_asymmetry(subs, noise)
    diag["asymmetry"] = asym
    if not asym <= max_asymmetry:
        raise _Failure(f"the pattern is not centrally symmetric about ({xs:.2f}, {ys:.2f}): the 180-degree "
                       f"residual holds {asym:.2f} of its structure (limit {max_asymmetry})")
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = xx * xx + yy * yy <= r * r
    spread = float(subs[disc].std())
    signal = float(np.sqrt(max(spread * spread - noise * noise, 0.0)))
    faint_limit = max(min_std, faint_snr * noise)
    diag.update(neighbourhood_std=spread, signal_std=signal, faint_limit=faint_limit)
    if signal < faint_limit:
        raise _Failure(f"mark too faint: grey-level std {spread:.4f} near the centre, {signal:.4f} net of noise "
                       f"{noise:.4f}, is below {faint_limit:.4f}")

    sx, sy = _centre_sigma(img, xs, ys, r, noise, sigma_inefficiency, sigma_floor)
    # the two centres' disagreement is part of the uncertainty (texture pulls them apart; 0 without point_refine)
    sx, sy = float(np.hypot(sx, xs - x15)), float(np.hypot(sy, ys - y15))
    diag.update(sigma_x=sx, sigma_y=sy)
    return Detection(status=FOUND, x=float(xs), y=float(ys), score=float(np.clip(score, 0.0, 1.0)),
                     sigma=float(0.5 * (sx + sy)), method=METHOD, diagnostics=diag)


# --- stage 1: fiducial-area analysis ----------------------------------------------------------------------

def edge_profile(img: np.ndarray, d: int = 2) -> np.ndarray:
    """Eq. (1): ``I_v(y) = sum_x |IO(x, y - d) - IO(x, y + d)|`` for every row ``y`` (0 near the borders)."""
    out = np.zeros(img.shape[0], np.float64)
    if img.shape[0] > 2 * d:
        out[d:img.shape[0] - d] = np.abs(img[:-2 * d] - img[2 * d:]).sum(axis=1)
    return out


def _smoothed_edge_profile(img: np.ndarray, d: int) -> np.ndarray:
    """Eq. (1) averaged over ``2d + 1`` rows (an edge already spreads over ``2d`` rows; the average keeps
    single noisy rows from crossing the mean threshold). Not in the seed."""
    p = edge_profile(img, d)
    n = len(p)
    if n > 2 * d:
        p[d:n - d] = ndimage.uniform_filter1d(p[d:n - d], 2 * d + 1, mode="nearest")
    return p


def _crossings(profile: np.ndarray, valid: np.ndarray | None = None) -> tuple[int, int]:
    """First and last index where ``profile`` exceeds its mean (the seed's threshold, section 3.1)."""
    p = profile if valid is None else profile[valid]
    thr = float(p.mean())
    above = np.flatnonzero(profile > thr) if valid is None else np.flatnonzero((profile > thr) & valid)
    if above.size == 0:
        return 0, len(profile) - 1
    return int(above[0]), int(above[-1])


def symmetry_profile(a: np.ndarray, d: int) -> np.ndarray:
    """Eq. (2): ``I_s(x) = sum_{u=1..d} |I_a(x + u) - I_a(x - u)|``, averaged over the terms that exist
    (so it is comparable near the ends); ``inf`` where fewer than ``max(1, d // 2)`` terms exist."""
    n = len(a)
    out = np.full(n, np.inf)
    for x in range(n):
        k = min(d, x, n - 1 - x)
        if k < max(1, d // 2):
            continue
        u = np.arange(1, k + 1)
        out[x] = np.abs(a[x + u] - a[x - u]).mean()
    return out


def fiducial_area(img: np.ndarray, edge_step: int = 2, diagonal: str | None = None) -> dict:
    """Seed 3.1: bounds L1, L2 (rows), horizontal extent p1..p2 (columns) and symmetry axis L3 (column) of the
    fiducial area, and the mid-row between L1 and L2, all in window pixels.

    ``diagonal`` ("main" / "anti") first projects the window diagonally (a 45-degree rotation, seed 2.2) so that
    the area's axis is upright; the results are mapped back (L3 and the mid-row then give the initial centre).
    """
    if diagonal is None:
        return _area_upright(img, edge_step)
    h, w = img.shape
    ang = 45.0 if diagonal == "main" else -45.0
    c = ((w - 1) / 2.0, (h - 1) / 2.0)
    size = int(np.ceil((h + w) / np.sqrt(2))) + 2
    m = cv2.getRotationMatrix2D(c, ang, 1.0)
    m[0, 2] += (size - 1) / 2.0 - c[0]
    m[1, 2] += (size - 1) / 2.0 - c[1]
    rot = cv2.warpAffine(img, m, (size, size), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=float("nan"))
    valid = np.isfinite(rot)
    fill = float(np.median(img))
    rot = np.where(valid, rot, fill).astype(np.float32)
    b = _area_upright(rot, edge_step)
    inv = cv2.invertAffineTransform(m)
    x0 = inv[0, 0] * b["L3"] + inv[0, 1] * b["y_mid"] + inv[0, 2]
    y0 = inv[1, 0] * b["L3"] + inv[1, 1] * b["y_mid"] + inv[1, 2]
    b = dict(b, diagonal=diagonal, L3_rotated=b["L3"], y_mid_rotated=b["y_mid"], L3=float(x0), y_mid=float(y0),
             half_height=b["half_height"] / np.sqrt(2), half_width=b["half_width"] / np.sqrt(2))
    return b


def _area_upright(img: np.ndarray, edge_step: int) -> dict:
    h, w = img.shape
    d = edge_step
    # L1: first row where the accumulated vertical-edge profile (eq. 1, all columns) exceeds its mean
    iv = _smoothed_edge_profile(img, d)
    rows = np.zeros(h, bool)
    rows[d:h - d] = True
    l1, _ = _crossings(iv, rows)
    # horizontal extent: the same profile along rows (horizontal edges), accumulated below L1
    ih = _smoothed_edge_profile(img[l1:].T, d)
    cols = np.zeros(w, bool)
    cols[d:w - d] = True
    p1, p2 = _crossings(ih, cols)
    # L2: the vertical-edge profile accumulated within the horizontal extent, thresholded at its mean (over
    # all rows, like L1), last crossing below L1
    iv2 = _smoothed_edge_profile(img[:, p1:p2 + 1], d)
    thr2 = float(iv2[rows].mean())
    below = np.flatnonzero((iv2 > thr2) & rows)
    below = below[below >= l1]
    l2 = int(below[-1]) if below.size else h - 1 - d
    if l2 < l1:
        l2 = l1
    # L3: symmetry centre (eq. 2) of the grey-level profile accumulated over rows L1..L2
    ia = img[l1:l2 + 1].sum(axis=0).astype(np.float64)
    half_w = max(1, (p2 - p1) // 2)
    i_s = symmetry_profile(ia, half_w)
    seg = i_s[p1:p2 + 1]
    if np.all(~np.isfinite(seg)):
        l3 = 0.5 * (p1 + p2)
    else:
        l3 = float(p1 + int(np.argmin(seg)))
    return {"L1": int(l1), "L2": int(l2), "p1": int(p1), "p2": int(p2), "L3": l3, "y_mid": 0.5 * (l1 + l2),
            "half_height": 0.5 * (l2 - l1), "half_width": 0.5 * (p2 - p1),
            "edge_profile_v": iv, "edge_profile_h": ih, "area_profile": ia, "symmetry_profile": i_s}


# --- stage 2: mark analysis --------------------------------------------------------------------------------

def simplified_log(img: np.ndarray, inner: int = 2, gap: int = 3, outer: int = 4) -> np.ndarray:
    """Eq. (3): ``I2 = mean over R2 - mean over R1`` with R1 the ``(2 inner + 1)``-square and R2 the square
    frame between half-widths ``gap`` and ``outer``, by box filtering (McDonald 1981), float32."""
    f = img.astype(np.float32)

    def boxsum(k):
        return cv2.boxFilter(f, -1, (2 * k + 1, 2 * k + 1), normalize=False, borderType=cv2.BORDER_REFLECT)

    n1 = (2 * inner + 1) ** 2
    n2 = (2 * outer + 1) ** 2 - (2 * gap - 1) ** 2
    s_out = boxsum(outer)
    s_gap = boxsum(gap - 1) if gap >= 1 else np.zeros_like(f)
    return ((s_out - s_gap) / n2 - boxsum(inner) / n1).astype(np.float32)


def symmetry_accumulation(i2: np.ndarray, row: int, r: int, d: int, xs: np.ndarray) -> np.ndarray:
    """Eqs. (4) and (6) together: for each column ``x`` in ``xs``,
    ``I4(x) = sum_{v=-d..d} I3(x, row + v)`` with ``I3(x, y) = sum_{u=1..r} sum_{v'=-r..r}
    |I2(x + u, y + v') - I2(x - u, y + v')|`` (the half-kernels T1/T2 of seed Fig. 6 are squares of radius
    ``r``). Row offsets ``v + v'`` are weighted by how often they occur; rows outside the image are skipped.
    Columns ``x - r .. x + r`` must lie inside ``i2``.
    """
    k = np.arange(-(d + r), d + r + 1)
    wts = np.convolve(np.ones(2 * d + 1), np.ones(2 * r + 1))
    rows = row + k
    ok = (rows >= 0) & (rows < i2.shape[0])
    s = i2[rows[ok]]
    wts = wts[ok].astype(np.float32)
    out = np.zeros(len(xs), np.float64)
    for u in range(1, r + 1):
        out += wts @ np.abs(s[:, xs + u] - s[:, xs - u])
    return out


def high_pass(profile: np.ndarray, d: int) -> np.ndarray:
    """Eq. (7): ``I5(x) = mean_{u=-d..d} I4(x + u) - I4(x)`` (ends padded with the nearest value)."""
    return ndimage.uniform_filter1d(profile, 2 * d + 1, mode="nearest") - profile


def _axis_peak(i2: np.ndarray, row: int, r: int, d: int, lo: int, hi: int) -> tuple[int, dict]:
    """One step along the columns of ``i2``: profile I4 over ``lo..hi`` around ``row``, I5, and its peak."""
    xs = np.arange(lo, hi + 1)
    i4 = symmetry_accumulation(i2, row, r, d, xs)
    i5 = high_pass(i4, d)
    return int(lo + int(np.argmax(i5))), {"positions": xs, "I4": i4, "I5": i5}


# --- stage 3: self-diagnosis -------------------------------------------------------------------------------

def ncc(a: np.ndarray, b: np.ndarray) -> float:
    """Normalised cross-correlation ``R{a, b}`` of eq. (12) (0 when either image is constant)."""
    a = a.astype(np.float64) - a.mean()
    b = b.astype(np.float64) - b.mean()
    den = np.sqrt((a * a).sum() * (b * b).sum())
    return float((a * b).sum() / den) if den > 0 else 0.0


def self_diagnosis(sub: np.ndarray) -> tuple[float, dict]:
    """Eqs. (8)-(13) on a square sub-image ``I6`` centred on the candidate centre.

    ``S1 = I6 + mirror_x(I6)``, ``S2 = I6 + mirror_y(I6)`` (eqs. 8-9), ``S3 = Rot90(S1)``, ``S4 = Rot90(S2)``
    (eqs. 10-11) and ``R_self = (R12 + R34 + R13 + R24) / 4`` (eq. 13). Note that rotating both images does
    not change their correlation, so ``R34 == R12``; we keep the seed's formula as written.
    """
    s1 = sub + sub[:, ::-1]
    s2 = sub + sub[::-1, :]
    s3 = np.rot90(s1)
    s4 = np.rot90(s2)
    parts = {"R12": ncc(s1, s2), "R34": ncc(s3, s4), "R13": ncc(s1, s3), "R24": ncc(s2, s4)}
    return float(sum(parts.values()) / 4.0), parts


def _check_rotation(parts: dict, limit: float, stage: str, x, y) -> None:
    """Guard (ours, not the seed's): since R34 == R12, any pattern mirror-symmetric in x and y but with no
    structure across the other axis (a straight bar or band) scores R_self = (1 + 1 + 0 + 0) / 4 = 0.5 and
    passes the seed's threshold by the toss of the noise. Require the 90-degree terms R13, R24 too."""
    rot = min(parts["R13"], parts["R24"])
    if not rot >= limit:
        raise _Failure(f"self-diagnosis failed at the {stage} centre ({x:.1f}, {y:.1f}): the 90-degree "
                       f"correlations R13 = {parts['R13']:.2f}, R24 = {parts['R24']:.2f} are below {limit} "
                       "(a straight bar or band, or a pattern symmetric about one axis only)")


def point_asymmetry(sub: np.ndarray, noise: float) -> float:
    """Share of the structure of ``sub`` that is not symmetric about its centre, net of noise:
    ``(mean (J - Rot180 J)^2 - 2 noise^2) / (2 (var J - noise^2))``; 0 for a centrally symmetric pattern,
    about 1 for an unrelated one. Ours, not the seed's (see ``max_asymmetry``)."""
    j = sub.astype(np.float64)
    dd = j - j[::-1, ::-1]
    sig = float(j.var()) - noise * noise
    if sig <= 0:
        return float("inf")
    return float(((dd * dd).mean() - 2.0 * noise * noise) / (2.0 * sig))


# --- stage 4: sub-pixel location ---------------------------------------------------------------------------

def _subpixel(img, x, y, r, d, log_inner, log_gap, log_outer, enlarge, smooth_sigma, max_total_shift,
              interval_shrink, max_iter):
    """Seed 3.4: enlarge the neighbourhood of pixel (x, y) by ``enlarge`` (bilinear), smooth it, run the mark
    analysis there with scaled kernels, and take the weighted mean of eq. (14); return (x, y) by eq. (15)."""
    re = int(enlarge)
    hs = r + log_outer                                   # fits: candidates keep log_outer + r from the edges
    sub = img[y - hs:y + hs + 1, x - hs:x + hs + 1]
    n = 2 * hs + 1
    big = cv2.resize(sub, (n * re, n * re), interpolation=cv2.INTER_LINEAR)
    if smooth_sigma > 0:
        big = cv2.GaussianBlur(big, (0, 0), smooth_sigma * re, borderType=cv2.BORDER_REFLECT)
    i2 = simplified_log(big, log_inner * re, log_gap * re, log_outer * re)
    # enlarged pixel x' <-> sub-image coordinate (x' + 0.5) / re - 0.5 (cv2's half-pixel convention)
    c = int(round(re * (hs + 0.5) - 0.5))                # enlarged index nearest to the unit-pixel centre
    m = int(np.ceil((max_total_shift + 0.5) * re))        # search half-range, enlarged px
    margin = log_outer * re + int(np.ceil(3 * smooth_sigma * re)) + 1
    re_r = int(min(r * re, c - m - margin))
    if re_r < re:
        return float("nan"), float("nan"), {"reason": "no room for the enlarged kernel"}
    de = max(1, int(d * re))
    cx = cy = c
    hist = [(cx, cy, de)]
    profiles = {}
    for _ in range(max_iter):
        cy_new, py = _axis_peak_local(i2.T, cx, re_r, de, c - m, c + m)
        cx_new, px = _axis_peak_local(i2, cy_new, re_r, de, c - m, c + m)
        profiles = {"x": px, "y": py}
        shift = max(abs(cx_new - cx), abs(cy_new - cy))
        cx, cy = cx_new, cy_new
        hist.append((cx, cy, de))
        de_next = max(1, int(np.floor(de * interval_shrink)))
        if shift < 1 and de_next == de:
            break
        de = de_next
    fx = _weighted_peak(profiles["x"], cx)
    fy = _weighted_peak(profiles["y"], cy)
    # eq. (15): x_t = x_f + x'_p + x''_s / R_e, with x_f the sub-image origin in the window
    xt = (x - hs) + (fx + 0.5) / re - 0.5
    yt = (y - hs) + (fy + 0.5) / re - 0.5
    return xt, yt, {"enlarged_log": i2, "iterations": hist, "profiles": profiles, "kernel_radius": re_r,
                    "enlarge": re}


def _axis_peak_local(i2, row, r, d, lo, hi):
    """Like :func:`_axis_peak`, on ``lo..hi`` with I4 computed ``d`` further on each side so that the
    high-pass of eq. (7) is exact on the search range."""
    ext_lo = max(r, lo - d)
    ext_hi = min(i2.shape[1] - 1 - r, hi + d)
    xs = np.arange(ext_lo, ext_hi + 1)
    i4 = symmetry_accumulation(i2, row, r, d, xs)
    i5 = high_pass(i4, d)
    a, b = lo - ext_lo, hi - ext_lo
    p = a + int(np.argmax(i5[a:b + 1]))
    return int(ext_lo + p), {"positions": xs, "I4": i4, "I5": i5}


def _weighted_peak(prof: dict, peak: int) -> float:
    """Eq. (14): weighted mean position of I5 over ``peak - dd .. peak + dd``, where ``dd`` is half the extent
    of the run of positive I5 around the peak (seed 3.4). Negative values inside the interval count as 0."""
    xs, i5 = prof["positions"], prof["I5"]
    k = int(peak - xs[0])
    if not (0 <= k < len(i5)) or i5[k] <= 0:
        return float(peak)
    a = k
    while a > 0 and i5[a - 1] > 0:
        a -= 1
    b = k
    while b < len(i5) - 1 and i5[b + 1] > 0:
        b += 1
    dd = max(1, int(round((b - a + 1) / 2.0)))
    lo, hi = max(0, k - dd), min(len(i5) - 1, k + dd)
    wgt = np.clip(i5[lo:hi + 1], 0.0, None)
    if wgt.sum() <= 0:
        return float(peak)
    return float((xs[lo:hi + 1] * wgt).sum() / wgt.sum())


def _resample(img: np.ndarray, xc: float, yc: float, r: int) -> np.ndarray:
    """The ``(2r + 1)``-square sub-image centred on the sub-pixel point (xc, yc), by cubic interpolation."""
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
    return ndimage.map_coordinates(img, [yy + yc, xx + xc], order=3, mode="nearest").astype(np.float32)


# --- noise and precision -----------------------------------------------------------------------------------

def _mirror_step(img, xc, yc, r, order):
    """One Gauss-Newton step (x, y) towards the mirror-symmetric centre of the (2r+1)-square around (xc, yc),
    resampled with spline ``order``: minimises sum (J - mirror(J))^2 over a shift of the centre."""
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
    j = ndimage.map_coordinates(img.astype(np.float64), [yy + yc, xx + xc], order=order, mode="nearest")
    gy, gx = np.gradient(j)
    out = []
    for dd, dg in ((j - j[:, ::-1], gx - gx[:, ::-1]), (j - j[::-1], gy - gy[::-1])):
        den = float((dg * dg).sum())
        out.append(-float((dd * dg).sum()) / den if den > 0 else 0.0)
    return np.array(out)


HUBER_K = 1.5
"""Residuals beyond this many robust sigmas get Huber weights in :func:`point_symmetry_centre`."""
REFINE_ITERATIONS = 8
"""Gauss-Newton iterations of :func:`point_symmetry_centre` at most (it stops at a step below 1e-4 px)."""


def point_symmetry_centre(img: np.ndarray, xc: float, yc: float, r: int) -> tuple[float, float] | None:
    """The centre (x, y) about which the window best equals its 180-degree rotation, by Gauss-Newton from
    (xc, yc): minimises ``sum_u (I(c + u) - I(c - u))^2`` over the offsets u in one half of the disc of radius
    ``r`` (cubic-spline resampling; derivatives by central differences of the spline). None when the normal
    matrix is singular, the iteration leaves the window or does not settle."""
    h, w = img.shape
    if r < 2:
        return None
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
    half = ((yy > 0) | ((yy == 0) & (xx > 0))) & (xx * xx + yy * yy <= r * r)
    u, v = xx[half], yy[half]
    coeffs = ndimage.spline_filter(np.asarray(img, np.float64), order=3)

    def at(px, py):
        return ndimage.map_coordinates(coeffs, [py, px], order=3, mode="nearest", prefilter=False)

    step = np.inf
    for _ in range(REFINE_ITERATIONS):
        if not (r <= xc <= w - 1 - r and r <= yc <= h - 1 - r):
            return None
        e = at(xc + u, yc + v) - at(xc - u, yc - v)
        gx = (at(xc + u + 0.5, yc + v) - at(xc + u - 0.5, yc + v)) - (at(xc - u + 0.5, yc - v) - at(xc - u - 0.5, yc - v))
        gy = (at(xc + u, yc + v + 0.5) - at(xc + u, yc + v - 0.5)) - (at(xc - u, yc - v + 0.5) - at(xc - u, yc - v - 0.5))
        # Huber weights: texture that is not point-symmetric (aerial ground around the mark) must not pull
        scale = max(MAD_TO_SIGMA * float(np.median(np.abs(e))), 1e-9)
        wgt = np.minimum(1.0, HUBER_K * scale / np.maximum(np.abs(e), 1e-12))
        A = np.column_stack([gx, gy]) * wgt[:, None]
        N = A.T @ A
        if not np.isfinite(N).all() or np.linalg.cond(N) > 1e8:
            return None
        d = -np.linalg.solve(N, A.T @ (e * wgt))
        xc, yc = xc + float(d[0]), yc + float(d[1])
        step = float(np.hypot(*d))
        if step < 1e-4:
            break
    return (xc, yc) if step < 1e-2 else None


def _centre_sigma(img, xc, yc, r, noise, inefficiency, floor):
    """Standard deviation of the centre per axis, (sigma_x, sigma_y).

    Noise: mirror symmetry about ``c`` pairs ``I(c + u)`` with ``I(c - u)``; a small shift ``dc`` changes each
    difference by ``2 I'(c + u) dc`` while the noise of a difference is ``sqrt(2) noise``; least squares over
    all pairs gives ``var(dc) = noise^2 / sum(I_x^2)`` over the (2r+1)-square (the squared gradients being
    corrected for their noise part). Our estimator (absolute differences of a filtered image, accumulated,
    high-passed, weighted mean) is less efficient than that; ``inefficiency`` scales it.

    Sampling: a sharp, thin mark is aliased by the pixel grid, and no resampling of it is exactly symmetric
    about the true centre. The disagreement between the symmetric centres found with bilinear and with cubic
    resampling (one Gauss-Newton step each, :func:`_mirror_step`) measures that and is added in quadrature,
    with ``floor`` for the discretisation of eq. (14).
    """
    sub = _resample(img, xc, yc, r + 1).astype(np.float64)
    gx = 0.5 * (sub[1:-1, 2:] - sub[1:-1, :-2])
    gy = 0.5 * (sub[2:, 1:-1] - sub[:-2, 1:-1])
    nn = gx.size * noise ** 2 * 0.5
    ex = max(float((gx * gx).sum()) - nn, 1e-12)
    ey = max(float((gy * gy).sum()) - nn, 1e-12)
    alias = np.abs(_mirror_step(img, xc, yc, r, 1) - _mirror_step(img, xc, yc, r, 3))
    sx = float(np.sqrt((inefficiency * noise) ** 2 / ex + alias[0] ** 2 + floor ** 2))
    sy = float(np.sqrt((inefficiency * noise) ** 2 / ey + alias[1] ** 2 + floor ** 2))
    return sx, sy
