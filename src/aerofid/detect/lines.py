"""Two crossing lines: local dynamic thresholding and the Hough transform (Sohn et al., seed 004).

The procedure of seed 004 (section 2, figure 2, and section 4) on one window:

1. **Binary image by local dynamic thresholding** -- a bimodal threshold per local 8 x 8 region
   (:func:`aerofid.detect.threshold.local_dynamic_threshold`), "two classes (foreground and background)".
2. **Hough transform of the foreground pixels** in the polar form ``rho = x cos(theta) + y sin(theta)``
   (seed eq. 3), ``0 <= theta < 180`` degrees (eq. 5) (:func:`hough_lines`).
3. **Two peaks**, one per direction of the mark: the strongest cell, and the strongest cell whose direction
   differs from it by at least ``min_angle`` ("with proper selection of theta, the noise element was able to be
   removed") -- "two peaks represented in accumulator array are mapped into two straight lines".
4. **Intersection of the lines** = the centre ("we calculated the intersection of the lines").

The seed stops at the Hough cell (its centres in Table 2 are on a half-pixel grid). To reach a fraction of a
pixel, each line is then refined (:func:`fit_line`) by a grey-value weighted least-squares fit of the pixels in
a band around it: the band is cut into 1 px slices across the line, the grey-weighted centroid of each slice
is an observation of the line's offset, and a straight line is fitted to the centroids by least squares;
pixels in the other line's band are left out. Band, background and fit are iterated. The intersection of the
two fitted lines is the centre, its covariance propagated from the two fitted offsets.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from aerofid.detect.asymmetry import point_asymmetry
from aerofid.detect.noise import difference_noise_sigma
from aerofid.detect.result import FOUND, Detection, not_found, unusable_window
from aerofid.detect.threshold import local_dynamic_threshold
from aerofid.robust import robust_std

METHOD = "lines"

REGION = 8
"""Local region (px) of the bimodal threshold (seed 004 section 4: "the size of local region to estimate
bimodal approximation was 8x8")."""

THETA_STEP = 0.5
"""Hough angle step in degrees over 0 <= theta < 180 (seed 004 eq. 5)."""

RHO_STEP = 1.0
"""Hough distance step in px (seed 004 eq. 4: 0 < rho < sqrt(M1^2 + M2^2), here signed)."""

MIN_ANGLE = 45.0
"""Smallest angle (degrees) between the two lines; the second peak is searched this far from the first.
Fiducial crosses cross at 60-90 degrees; a band (the frame under a blurred Zeiss notch) is centrally symmetric
about any point of its midline, and its edges with the notch's corners gave 36-degree crossings that passed
every other check (5 of 20 strongly blurred notch marks, 13-16 px off)."""

MIN_PEAK_RATIO = 0.3
"""The second Hough peak must hold at least this fraction of the first one's votes."""

BAND_MARGIN = 2.0
"""Half-width of the fitting band beyond the bar's half-width (px): the blurred flanks of the bar."""

MAX_ASYMMETRY = 0.1
"""Largest share of the structure about the intersection that may change under a half turn: half the limit
``auto`` applies to every answer (:data:`aerofid.detect.auto.MAX_ASYMMETRY`), as for ``symmetry``'s own check; at 0.2
a dot's chords still crossed 1-1.3 px off its centre."""

MIN_ARM = 3
"""Each line needs at least this many supported 1 px slices on each side of the intersection."""

MIN_ARM_RATIO = 0.25
"""... and its shorter side at least this fraction of its longer side (a mark cut by the window edge, or two
lines meeting in a 'T' or 'L', has one side missing)."""

ITERATIONS = 12
MIN_CONTRAST = 5.0
"""Each line's median slice weight must be this many times its noise standard deviation."""

MAX_SIDE_FOREGROUND = 0.4
"""A bar has ground beside it: at most this fraction of the strips beside a line's band may be foreground (the
ring of a Wild mark crossing them takes a little)."""

TAPER = 1.0
"""Standard deviation of the Gaussian taper across the line, in bar half-widths (0: a plain centroid)."""

OFFSET_FLOOR = 0.03
"""Model error (px) added in quadrature to each line's fitted offset: the grey-weighted centroid of a thin bar
whose edges were integrated over the pixel area (and not blurred before sampling) is aliased by up to a few
hundredths of a pixel (measured: 0.02-0.05 px RMS per axis on axis-aligned 1-3 px bars of aerofid.synth); the
fit's scatter cannot see it when every slice has the same sub-pixel phase. Applied to every line: on tilted
lines (where the phases average out) it makes sigma somewhat pessimistic, never optimistic."""
"""Band / background / fit iterations of the sub-pixel refinement."""


@dataclass(frozen=True)
class LineFit:
    """A refined line ``x cos(theta) + y sin(theta) = rho`` and the statistics of its fit."""

    theta: float                # radians, normal direction
    rho: float
    sigma_offset: float         # standard deviation of the line's offset at the intersection (px)
    sigma_slope: float          # of its direction (radians)
    rms: float                  # RMS of the slice centroids about the line (px)
    expected_rms: float         # RMS the noise alone would give (px)
    n_slices: int
    arms: tuple[int, int]       # supported slices before / after the intersection
    half_width: float           # estimated half-width of the bar (px)
    contrast: float             # median slice weight / its noise standard deviation
    side_foreground: float      # fraction of the strips beside the band that is foreground


def hough_lines(binary: np.ndarray, theta_step: float = THETA_STEP, rho_step: float = RHO_STEP):
    """Hough accumulator of the foreground pixels of ``binary`` (seed 004 eq. 3-5).

    Returns ``(acc, thetas, rhos)``: ``acc[i, j]`` counts pixels with ``x cos(thetas[i]) + y sin(thetas[i])``
    in the ``rho_step`` cell centred on ``rhos[j]``; thetas in radians on [0, pi)."""
    h, w = binary.shape
    ys, xs = np.nonzero(binary)
    thetas = np.deg2rad(np.arange(0.0, 180.0, theta_step))
    r_max = float(np.ceil(np.hypot(h, w) / rho_step) * rho_step)  # rho cells centred on multiples of rho_step
    n_rho = int(np.ceil(2 * r_max / rho_step)) + 1
    rhos = -r_max + rho_step * np.arange(n_rho)
    if xs.size == 0:
        return np.zeros((thetas.size, n_rho)), thetas, rhos
    rho = xs[:, None] * np.cos(thetas)[None, :] + ys[:, None] * np.sin(thetas)[None, :]
    j = np.rint((rho + r_max) / rho_step).astype(np.int64)
    idx = (np.arange(thetas.size)[None, :] * n_rho + j).ravel()
    acc = np.bincount(idx, minlength=thetas.size * n_rho).reshape(thetas.size, n_rho).astype(np.float64)
    return acc, thetas, rhos


def _angle_diff(a: np.ndarray | float, b: float) -> np.ndarray | float:
    """Smallest difference between line directions (radians, modulo pi)."""
    d = np.abs(np.asarray(a) - b) % np.pi
    return np.minimum(d, np.pi - d)


def two_peaks(acc: np.ndarray, thetas: np.ndarray, min_angle_deg: float = MIN_ANGLE):
    """The strongest Hough cell and the strongest cell at least ``min_angle_deg`` away in direction.

    The accumulator is smoothed with (1, 2, 1) / 4 over rho first (a bar 2 px wide, or a diagonal one, spreads over
    neighbouring cells).
    Returns ``((i1, j1, v1), (i2, j2, v2), smoothed)`` with i = theta index, j = rho index, v = smoothed votes.
    """
    a = acc.copy()
    # (1, 2, 1) / 4 along rho only: a diagonal bar's pixels alternate between neighbouring rho cells, and a
    # line concentrated in one cell still beats a slightly tilted one spread over three
    a[:, 1:-1] = 0.25 * acc[:, :-2] + 0.5 * acc[:, 1:-1] + 0.25 * acc[:, 2:]
    i1, j1 = np.unravel_index(int(np.argmax(a)), a.shape)
    far = _angle_diff(thetas, thetas[i1]) >= np.deg2rad(min_angle_deg)
    b = np.where(far[:, None], a, -1.0)
    i2, j2 = np.unravel_index(int(np.argmax(b)), b.shape)
    return (int(i1), int(j1), float(a[i1, j1])), (int(i2), int(j2), float(b[i2, j2])), a


def _bar_half_width(acc: np.ndarray, i: int, j: int, rho_step: float, reach: int = 10) -> float:
    """Half the width (px) of the ridge across rho at theta index ``i``: the run of cells around ``j`` above
    half-way between the peak and the local base (25th percentile of the cells within ``reach`` px), so the
    plateau a ring adds under the bar does not count as bar."""
    prof = acc[i]
    peak = prof[j]
    r = max(3, int(round(reach / rho_step)))
    near = prof[max(0, j - r):j + r + 1]
    base = float(np.percentile(near, 25))
    level = 0.5 * (peak + base)
    lo = j
    while lo > 0 and prof[lo - 1] >= level:
        lo -= 1
    hi = j
    while hi < prof.size - 1 and prof[hi + 1] >= level:
        hi += 1
    return 0.5 * (hi - lo + 1) * rho_step


def fit_line(window: np.ndarray, theta: float, rho: float, half_width: float, centre: np.ndarray,
             other: tuple[float, float, float] | None, noise: float, band_margin: float = BAND_MARGIN,
             exclude: np.ndarray | None = None, background_mask: np.ndarray | None = None,
             taper: float = TAPER) -> LineFit | None:
    """One refinement step of a line (seed 004's Hough line, refined to sub-pixel).

    Pixels within ``half_width + band_margin`` px of the line (and not in the ``other`` line's band
    ``(theta, rho, half_band)`` nor in ``exclude``) are weighted by their grey level minus the local
    background (median of the pixels just outside the band), grouped into 1 px slices along the line, and
    each slice's weighted centroid across the line is one observation ``v_b``; ``v_b = a + b (u_b - u_c)``
    is fitted by least squares (``u_c`` = the current intersection ``centre`` projected on the line), and
    ``a`` and ``b`` move and turn the line. The offset's standard deviation is the a-posteriori one of the
    fit, but never below what the window's ``noise`` alone gives the centroids.
    """
    h, w = window.shape
    n = np.array([np.cos(theta), np.sin(theta)])
    t = np.array([-np.sin(theta), np.cos(theta)])
    yy, xx = np.mgrid[0:h, 0:w]
    xs, ys = xx.ravel().astype(np.float64), yy.ravel().astype(np.float64)
    g = window.ravel().astype(np.float64)
    v = xs * n[0] + ys * n[1] - rho
    u = xs * t[0] + ys * t[1]
    band = half_width + band_margin
    in_band = np.abs(v) <= band
    outer = (np.abs(v) > band) & (np.abs(v) <= band + 3.0)
    keep = np.ones_like(in_band)
    if other is not None:
        th2, rho2, band2 = other
        v2 = xs * np.cos(th2) + ys * np.sin(th2) - rho2
        keep &= np.abs(v2) > band2
    if exclude is not None:
        keep &= ~exclude.ravel()
    ring = outer & keep
    side_fg = 0.0
    if background_mask is not None:
        bm = background_mask.ravel()
        side_fg = float(bm[ring].mean()) if ring.any() else 1.0
        ring &= ~bm
    if ring.sum() < 6:
        return None
    uc = float(centre @ t)
    # local background: a plane g = c0 + c1 v + c2 u fitted to the strips just outside the band, per 8 px
    # stretch of the line (a ramp of the film density across the band would otherwise move the centroids)
    seg = np.floor((u - uc) / 8.0).astype(np.int64)
    bg = _plane(g[ring], v[ring], u[ring] - uc, v, u - uc)
    for sgi in np.unique(seg[ring]):
        m = ring & (seg == sgi)
        if m.sum() >= 8 and np.ptp(v[m]) > band:   # both sides of the band
            on = seg == sgi
            bg[on] = _plane(g[m], v[m], u[m] - uc, v[on], u[on] - uc)
    sel = in_band & keep
    if sel.sum() < 10:
        return None
    us, vs = u[sel] - uc, v[sel]
    # Gaussian taper across the line (a matched filter): the slice centroid converges, over the iterations, to
    # the peak of the profile smoothed by the taper, and the noise of the pixels far from the bar is damped
    q = np.exp(-0.5 * (vs / max(taper * half_width, 0.5)) ** 2) if taper > 0 else np.ones_like(vs)
    wgt = (g[sel] - bg[sel]) * q
    k = np.rint(us).astype(np.int64)
    k0 = k.min()
    kk = k - k0
    nb = int(kk.max()) + 1
    W = np.bincount(kk, weights=wgt, minlength=nb)
    Wv = np.bincount(kk, weights=wgt * vs, minlength=nb)
    Wv2 = np.bincount(kk, weights=q * q * vs * vs, minlength=nb)
    Wv1 = np.bincount(kk, weights=q * q * vs, minlength=nb)
    Wq2 = np.bincount(kk, weights=q * q, minlength=nb)
    cnt = np.bincount(kk, minlength=nb)
    ub = np.arange(nb) + k0
    pos = W > 0
    if pos.sum() < 4:
        return None
    # slices of the bar itself: weight near the typical one (a ring crossing the band, or the centre dot,
    # makes a slice much heavier; the bar's end or a gap much lighter)
    ref = float(np.percentile(W[pos], 90))
    good = (W >= 0.3 * ref) & (cnt >= 2)
    if good.sum() < 4:
        return None
    med = float(np.median(W[good]))
    good &= (W >= 0.5 * med) & (W <= 1.6 * med)
    if good.sum() < 4:
        return None
    V = Wv[good] / W[good]
    U = ub[good].astype(np.float64)
    # noise-only variance of each centroid: noise^2 * sum_i q_i^2 (v_i - V)^2 / W^2
    var_noise = noise * noise * (Wv2[good] - 2 * V * Wv1[good] + Wq2[good] * V * V) / W[good] ** 2
    # one round of outlier rejection: residuals beyond 3.5 robust sigma (and 0.1 px) of a first fit
    # the bar must stand out of its sides: the slice weights against the noise of a weight
    w_noise = noise * float(np.sqrt(np.median(Wq2[good])))
    contrast = float(np.median(W[good])) / max(w_noise, 1e-9)
    X = np.column_stack([np.ones_like(U), U])
    c0, *_ = np.linalg.lstsq(X, V, rcond=None)
    r0 = V - X @ c0
    mad = robust_std(r0)
    inl = np.abs(r0) <= max(3.5 * mad, 0.1)
    if inl.sum() < 4:
        return None
    V, U, var_noise = V[inl], U[inl], var_noise[inl]
    X = np.column_stack([np.ones_like(U), U])
    XtX = X.T @ X
    try:
        Qx = np.linalg.inv(XtX)
    except np.linalg.LinAlgError:
        return None
    coef = Qx @ (X.T @ V)
    res = V - X @ coef
    dof = max(1, U.size - 2)
    s0 = float(np.sqrt(res @ res / dof))
    expected = float(np.sqrt(np.mean(var_noise)))
    s = max(s0, expected)
    a, b = float(coef[0]), float(coef[1])
    # move the line: points with v = a + b (u - uc) -> p.(n - b t) = rho + a - b uc
    nn = n - b * t
    norm = float(np.hypot(*nn))
    new_theta = float(np.arctan2(nn[1], nn[0]))
    new_rho = (rho + a - b * uc) / norm
    if new_theta < 0:
        new_theta += np.pi
        new_rho = -new_rho
    if new_theta >= np.pi:
        new_theta -= np.pi
        new_rho = -new_rho
    excl = half_width + band_margin
    arms = (int(((U < -excl)).sum()), int(((U > excl)).sum()))
    return LineFit(new_theta, float(new_rho), s * float(np.sqrt(Qx[0, 0])), s * float(np.sqrt(Qx[1, 1])),
                   s0, expected, int(U.size), arms, half_width, contrast, side_fg)


def _plane(g: np.ndarray, v: np.ndarray, u: np.ndarray, v_at: np.ndarray, u_at: np.ndarray) -> np.ndarray:
    """Least-squares plane ``g = c0 + c1 v + c2 u`` through the samples, evaluated at (v_at, u_at); the median
    when the samples do not determine a plane."""
    X = np.column_stack([np.ones_like(v), v, u])
    if g.size >= 4:
        coef, *_ = np.linalg.lstsq(X, g, rcond=None)
        if np.all(np.isfinite(coef)):
            return coef[0] + coef[1] * v_at + coef[2] * u_at
    return np.full(np.shape(v_at), float(np.median(g)) if g.size else 0.0)


def intersection(t1: float, r1: float, t2: float, r2: float) -> np.ndarray | None:
    """Intersection (x, y) of ``x cos t + y sin t = r`` for the two lines, None if (nearly) parallel."""
    A = np.array([[np.cos(t1), np.sin(t1)], [np.cos(t2), np.sin(t2)]])
    if abs(np.linalg.det(A)) < 1e-6:
        return None
    return np.linalg.solve(A, np.array([r1, r2]))


def detect(window: np.ndarray, *, region: int = REGION, theta_step: float = THETA_STEP,
           rho_step: float = RHO_STEP, min_angle: float = MIN_ANGLE, min_peak_ratio: float = MIN_PEAK_RATIO,
           band_margin: float = BAND_MARGIN, min_arm: int = MIN_ARM, min_arm_ratio: float = MIN_ARM_RATIO,
           iterations: int = ITERATIONS, taper: float = TAPER, offset_floor: float = OFFSET_FLOOR,
           min_contrast: float = MIN_CONTRAST, max_side_foreground: float = MAX_SIDE_FOREGROUND,
           max_asymmetry: float = MAX_ASYMMETRY) -> Detection:
    """Centre of a mark made of two crossing lines (Sohn et al., seed 004), in window pixels.

    Args:
        window: 2-D float32 grey levels on [0, 1], the mark brighter than its ground.
        region: local region of the dynamic threshold (seed: 8 x 8).
        theta_step, rho_step: Hough cell (degrees, px).
        min_angle: smallest angle (degrees) between the two lines.
        min_peak_ratio: the second peak's votes relative to the first.
        band_margin: fitting band beyond the bar's half-width (px).
        min_arm, min_arm_ratio: support each line needs on both sides of the intersection.
        iterations: refinement iterations (at most; they stop when the centre moves less than 0.001 px).
        taper: Gaussian taper across each line in bar half-widths, see :func:`fit_line`.
        max_side_foreground: largest foreground fraction of the strips beside each line (a bar has ground there).
        min_contrast: each line's slices must weigh this many noise standard deviations (a bar, not an edge).
        offset_floor: model error (px) of each line's offset added to its fitted standard deviation.
        max_asymmetry: beyond the seed: the largest share of the structure within the longest arm's reach (+2
            px, so that a blob's edge is inside) that may change under a half turn about the intersection (:func:`aerofid.detect.asymmetry.point_asymmetry`).
            A '+' is centrally symmetric about its crossing; chords through a dot or a bull's-eye cross off its
            centre (answers 1.5-4.5 px off in docs/benchmarks_marks.md before this check).

    Returns:
        Detection with ``method="lines"``: the intersection of the two refined lines; ``sigma`` = mean of its
        two standard deviations propagated from the lines' fitted offsets (each with ``offset_floor``); ``score`` = min(arm balance,
        angle, peak balance, fit quality); diagnostics ``binary``, ``thresholds``, ``accumulator``
        (with ``thetas``, ``rhos``), ``hough_lines`` [(theta, rho)], ``lines`` [LineFit], ``hough_centre``.
    """
    w = np.asarray(window, np.float32)
    bad = unusable_window(w)
    if bad is not None:
        return not_found(METHOD, bad)
    h, wd = w.shape
    binary, surface = local_dynamic_threshold(w, region, return_thresholds=True)
    diag: dict = {"binary": binary, "thresholds": surface}
    n_fg = int(binary.sum())
    if n_fg < 10:
        return not_found(METHOD, f"local dynamic thresholding found no mark ({n_fg} foreground pixels)", **diag)
    acc, thetas, rhos = hough_lines(binary, theta_step, rho_step)
    diag.update(accumulator=acc, thetas=thetas, rhos=rhos)
    (i1, j1, v1), (i2, j2, v2), acc_s = two_peaks(acc, thetas, min_angle)
    if v2 <= 0 or v2 < min_peak_ratio * v1:
        return not_found(METHOD, f"only one dominant direction in the Hough space (second peak {v2:.0f} votes "
                                 f"vs {v1:.0f})", **diag)
    lines0 = [(float(thetas[i1]), float(rhos[j1])), (float(thetas[i2]), float(rhos[j2]))]
    diag["hough_lines"] = lines0
    c = intersection(*lines0[0], *lines0[1])
    if c is None:
        return not_found(METHOD, "the two Hough lines are parallel", **diag)
    diag["hough_centre"] = tuple(float(q) for q in c)
    if not (-0.5 <= c[0] <= wd - 0.5 and -0.5 <= c[1] <= h - 0.5):
        return not_found(METHOD, "the Hough lines intersect outside the window", **diag)
    # bar half-widths from the smoothed ridges (a diagonal bar's raw rho profile alternates between cells)
    hw = [max(1.0, _bar_half_width(acc_s, i1, j1, rho_step)), max(1.0, _bar_half_width(acc_s, i2, j2, rho_step))]
    max_hw = max(3.0, 0.125 * min(h, wd))
    if max(hw) > max_hw:
        return not_found(METHOD, f"a Hough line is {2 * max(hw):.0f} px wide: an edge or a blob, not a bar",
                         **diag)
    noise = difference_noise_sigma(w)
    # foreground (dilated by 1 px) is kept out of the background estimate: the ring of a Wild mark crosses
    # the strips beside the lines
    fg_near = cv2.dilate(binary.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    cur = list(lines0)
    fits: list[LineFit | None] = [None, None]
    for _ in range(max(1, iterations)):
        new = []
        for k in (0, 1):
            o = 1 - k
            other = (cur[o][0], cur[o][1], hw[o] + band_margin)
            f = fit_line(w, cur[k][0], cur[k][1], hw[k], c, other, noise, band_margin,
                         background_mask=fg_near, taper=taper)
            if f is None:
                return not_found(METHOD, f"line {k + 1} has too little support for a least-squares fit", **diag)
            new.append(f)
        fits = new
        cur = [(f.theta, f.rho) for f in fits]
        c_new = intersection(*cur[0], *cur[1])
        if c_new is None:
            return not_found(METHOD, "the fitted lines are parallel", **diag)
        moved = float(np.hypot(*(c_new - c)))
        c = c_new
        if moved < 1e-3:
            break
    diag.update(lines=fits, fitted_lines=cur)
    x, y = float(c[0]), float(c[1])
    if not (0 <= x <= wd - 1 and 0 <= y <= h - 1):
        return not_found(METHOD, "the fitted lines intersect outside the window", **diag)
    if abs(x - diag["hough_centre"][0]) > 3 or abs(y - diag["hough_centre"][1]) > 3:
        return not_found(METHOD, "the least-squares lines moved more than 3 px from the Hough lines", **diag)
    angle = float(_angle_diff(cur[0][0], cur[1][0]))
    if angle < np.deg2rad(min_angle):
        return not_found(METHOD, f"the fitted lines cross at only {np.rad2deg(angle):.0f} degrees", **diag)
    for k, f in enumerate(fits):
        if f.side_foreground > max_side_foreground:
            return not_found(METHOD, f"line {k + 1} runs inside a bright area ({f.side_foreground:.0%} of its "
                                     f"sides are foreground): an edge or a blob, not a bar", **diag)
        if f.contrast < min_contrast:
            return not_found(METHOD, f"line {k + 1} hardly stands out of its sides ({f.contrast:.1f} noise "
                                     f"sigma): an edge, not a bar", **diag)
    for k, f in enumerate(fits):
        lo, hi = min(f.arms), max(f.arms)
        if lo < min_arm or lo < min_arm_ratio * hi:
            return not_found(METHOD, f"line {k + 1} is supported on one side of the intersection only "
                                     f"({f.arms[0]} / {f.arms[1]} px): a 'T' or 'L', or a mark cut by the "
                                     f"window edge", **diag)
    reach = min(max(max(f.arms) for f in fits) + 2.0, x, y, wd - 1 - x, h - 1 - y)
    asym = point_asymmetry(w, x, y, max(reach, 3.0), noise)
    diag["asymmetry"] = asym
    if not asym <= max_asymmetry:
        return not_found(METHOD, f"the window is not centrally symmetric about the intersection ({asym:.2f} of the "
                                 f"structure within {reach:.0f} px changes under a half turn; limit {max_asymmetry}): "
                                 "not the centre of a '+'", **diag)
    # covariance of the intersection from the two offsets (rotation about the intersection does not move it)
    N = np.array([[np.cos(cur[0][0]), np.sin(cur[0][0])], [np.cos(cur[1][0]), np.sin(cur[1][0])]])
    Ni = np.linalg.inv(N)
    cov = Ni @ np.diag([fits[0].sigma_offset ** 2 + offset_floor ** 2,
                        fits[1].sigma_offset ** 2 + offset_floor ** 2]) @ Ni.T
    sigma = 0.5 * (np.sqrt(cov[0, 0]) + np.sqrt(cov[1, 1]))
    # score
    s_arm = min(1.0, min(min(f.arms) / max(f.arms) for f in fits) / 0.5)
    s_angle = min(1.0, np.sin(angle) / np.sin(np.deg2rad(60.0)))
    s_peak = min(1.0, (v2 / v1) / 0.6)
    s_fit = min(1.0, min(2.0 * (f.expected_rms + 0.05) / max(f.rms, 1e-9) for f in fits))
    score = float(np.clip(min(s_arm, s_angle, s_peak, s_fit), 0.0, 1.0))
    diag.update(covariance=cov, score_parts={"arms": s_arm, "angle": s_angle, "peaks": s_peak, "fit": s_fit})
    return Detection(status=FOUND, x=x, y=y, score=score, sigma=float(sigma), method=METHOD, diagnostics=diag)
