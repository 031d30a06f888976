"""Sub-pixel centre of a '+' by least-squares fit of a blurred-cross model to the grey values.

Beyond the seeds (Hunt, Ryan & Gifford stop at one pixel): the grey values g(x, y) of a patch around the
Hough centre are modelled as

    g = b0 + bx (x - x0) + by (y - y0) + A * U(c1, c2),   U = c1 + c2 - c1 c2

where c_k is the coverage of bar k (length L_k, stroke width w, normal angle theta_k, through the centre
(xc, yc)) blurred by a Gaussian of standard deviation s; across and along the bar the blurred box profile
is Phi((u + a/2) / s) - Phi((u - a/2) / s). The 12 parameters (xc, yc, theta1, theta2, L1, L2, w, s, A,
b0, bx, by) are estimated by Levenberg-Marquardt (MINPACK, :mod:`aerofid.scipy_kernels`); the
covariance of the centre is sigma0^2 (J^T J)^-1 with sigma0^2 = v^T v / (n - u), so texture that the model
does not explain widens the reported sigma instead of hiding in it, and is widened by the residuals' correlation
(film grain, scanner blur, JPEG: :func:`~aerofid.detect.noise.correlated_covariance`), which the white-noise
formula takes for independent pixels.

The fit uses every pixel of the mark, including the crossing, and works for 7 px panels as for 40 px
external fiducials, for non-orthogonal arms and for arms of unequal length.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from aerofid.detect.noise import correlated_covariance
from aerofid.robust import percentile, robust_std
from aerofid.scipy_kernels import LMSolution, levenberg_marquardt, ndtr

PATCH_MARGIN = 3.0
"""The patch fitted reaches this many px beyond the arms' estimated ends."""
MAX_PATCH = 81
"""Largest patch side fitted (px); longer arms are fitted over their inner part."""
ANGLE_RANGE = np.deg2rad(35.0)
"""How far (rad) a bar's fitted angle may move from the Hough estimate before the fit is not trusted."""
MODEL_TOLERANCE = 0.03
"""The model's own imperfection (union of blurred bars, Gaussian blur) as a fraction of the amplitude: the
misfit is measured against the larger of the noise and this, so that a nearly noise-free scan is not
held to a perfection no model reaches."""
MAX_EVALUATIONS = 100
"""Most model evaluations per least-squares pass (most '+' converge in 10-30; a true Wild corner '+' of
bench_peers.py's scenes needed 63)."""
RETRY_SHIFT = 1.0
"""A pass that runs out of evaluations is retried with the bounded solver only when its centre stayed within this
many px of the pass's start (:func:`_least_squares`). Measured by ``benchmarks/bench_fits.py --marks 30`` with the
unconditional retry (at e5854bd), on ``hough``'s runs over bench_marks.py's scenes: the 7 '+' a retry rescued had
moved 0.00-0.61 px; of the 755 retries that found nothing, 440 had moved further than 1 px (up to 185 px). With
this limit the same 441 '+' are accepted and 315 retries are made; the refused fits' CPU time fell by a sixth."""
ROBUST_PASSES = 2
"""Reweighted refits after the first least-squares fit (Huber weights)."""
HUBER_K = 3.0
"""Residuals beyond this many robust standard deviations are down-weighted (Huber)."""



@dataclass(frozen=True)
class CrossFit:
    """Result of :func:`fit_cross`: centre and parameters in the window's pixels."""

    x: float
    y: float
    sigma_x: float
    sigma_y: float
    theta1: float         # degrees, normal angle of bar 1's centre line
    theta2: float
    length1: float        # px
    length2: float
    width: float          # stroke width, px
    blur: float           # Gaussian sigma, px
    amplitude: float      # grey levels above background
    sigma0: float         # RMS residual of the fit (grey levels)
    noise: float          # grey-level noise estimated from the patch's background
    arm_contrast: tuple[float, float, float, float]
    """Mean data minus fitted background along each of the four half-arms."""
    at_bound: str = ""
    """Name of a shape parameter that ended on its bound (the model did not find a '+'), or empty."""
    patch_half: float = float("inf")
    """Half-size (px) of the patch the fit saw: bar lengths beyond twice this are not determined."""
    misfit: float = 0.0
    """Robust spread of the residuals on the mark (model coverage > 0.5) over the noise of its
    surroundings (at least ``MODEL_TOLERANCE`` x the amplitude): about 1 when the model explains the
    mark, larger for a feature that only resembles it."""
    cov_xy: float = float("nan")
    """Covariance of the centre's x and y (px^2): with ``sigma_x``, ``sigma_y`` the centre's 2 x 2 block of
    sigma0^2 (J^T J)^+, widened by the residuals' correlation (:func:`_centre_covariance`)."""

    @property
    def arm_balance(self) -> float:
        """Weakest half-arm over strongest: near 1 for a '+', near 0 for an L, a T or a lone bar."""
        c = np.asarray(self.arm_contrast)
        return float(max(c.min(), 0.0) / c.max()) if c.max() > 0 else 0.0

    @property
    def arm_snr(self) -> float:
        """The weaker of the fitted amplitude and the weakest half-arm's contrast, over the larger of the
        background noise and the fit's RMS residual (so sparse impulse noise, which the robust background
        estimate ignores, still counts)."""
        return float(min(min(self.arm_contrast), self.amplitude) / max(self.noise, self.sigma0, 1e-9))

    @property
    def sigma(self) -> float:
        """Standard deviation of the centre per axis, sqrt((sx^2 + sy^2) / 2)."""
        return float(np.sqrt((self.sigma_x ** 2 + self.sigma_y ** 2) / 2.0))


SQRT_2PI = np.sqrt(2.0 * np.pi)


def _profile(u: np.ndarray, extent: np.ndarray, s: float,
             derivatives: bool = True) -> tuple[np.ndarray, ...]:
    """A box of width ``extent`` blurred by a Gaussian of std ``s`` at ``u``, and (``derivatives``) its derivatives
    by u, extent and s: P = Phi(alpha) - Phi(beta), alpha = (u + extent/2)/s, beta = (u - extent/2)/s. ``u`` may
    hold several profiles as rows, ``extent`` then a column of their widths (one call for all four of a cross). Both
    edges go through each function at once (alpha's rows above beta's): on a patch of a few hundred pixels the
    calls, not the arithmetic, are most of the time."""
    n = len(u)
    edges = np.concatenate([u + extent / 2.0, u - extent / 2.0])
    edges /= s
    phi = ndtr(edges)
    P = phi[:n] - phi[n:]
    if not derivatives:
        return (P,)
    with np.errstate(over="ignore", under="ignore"):  # far from the edges the Gaussian is 0
        density = np.exp(-0.5 * edges * edges) / SQRT_2PI
    (al, be), (pa, pb) = (edges[:n], edges[n:]), (density[:n], density[n:])
    return P, (pa - pb) / s, (pa + pb) / (2.0 * s), -(al * pa - be * pb) / s


def _sign(v: float) -> float:
    """The sign a length, the width or the blur gives its derivatives (the model takes their magnitude): 1 at 0."""
    return 1.0 if v >= 0 else -1.0 if v < 0 else math.nan


def cross_model(p: np.ndarray, px: np.ndarray, py: np.ndarray, x0: float, y0: float,
                jacobian: bool = False):
    """Grey values of the blurred-cross model with parameters ``p`` at the points (px, py), and with
    ``jacobian=True`` also d(model)/d(p) as an (n, 12) array. The four box profiles (across each bar, then along
    each) are evaluated together, as the rows (r1, r2, u1, u2) of one array."""
    xc, yc, t1, t2, l1, l2, w, s, a, b0, bx, by = p
    # lengths, width and blur enter by their magnitude, so an unconstrained solver cannot flip their sign
    signs = np.array([[_sign(l1)], [_sign(l2)], [_sign(w)], [_sign(s)]])
    l1, l2, w, s = abs(l1), abs(l2), abs(w), max(abs(s), 0.05)
    dx, dy = px - xc, py - yc
    angles = np.array([[t1], [t2]])
    cos, sin = np.cos(angles), np.sin(angles)
    # across each bar (along its normal), then along each bar
    ru = np.concatenate([dx * cos + dy * sin, -dx * sin + dy * cos])
    # P and (with the Jacobian) its derivatives by the coordinate, the extent and the blur
    profiles = _profile(ru, np.array([[w], [w], [l1], [l2]]), s, jacobian)
    P = profiles[0]
    across, along = P[:2], P[2:]
    coverage = across * along                             # each bar's: rows c1, c2
    c1, c2 = coverage
    union = c1 + c2 - c1 * c2
    model = b0 + bx * (px - x0) + by * (py - y0) + a * union
    if not jacobian:
        return model
    _, P_u, P_e, P_s = profiles
    # both bars at once, as rows k = 0, 1: d model / d c_k, and d c_k by the across (r) and along (u) coordinates;
    # a sum over the two rows is row 0 + row 1
    weight = a * (1.0 - coverage[::-1])
    r, u = ru[:2], ru[2:]
    dc_dr, dc_du = P_u[:2] * along, across * P_u[2:]
    J = np.empty((12, px.size))      # filled by rows, handed over as its (n, 12) transpose (Fortran order)
    d_xc = weight * (dc_dr * -cos + dc_du * sin)                # dr/dxc = -cos t, du/dxc = sin t
    d_yc = weight * (dc_dr * -sin + dc_du * -cos)               # dr/dyc = -sin t, du/dyc = -cos t
    J[0], J[1] = d_xc[0] + d_xc[1], d_yc[0] + d_yc[1]
    J[2:4] = weight * (dc_dr * u - dc_du * r)                   # dr/dt = u, du/dt = -r
    J[4:6] = weight * across * P_e[2:]                          # the lengths
    d_w = weight * P_e[:2] * along                              # the stroke width
    d_s = weight * (P_s[:2] * along + across * P_s[2:])         # the blur
    J[6], J[7] = d_w[0] + d_w[1], d_s[0] + d_s[1]
    J[4:8] *= signs
    J[8] = union
    J[9] = 1.0
    J[10] = px - x0
    J[11] = py - y0
    return model, J.T


EVALUATIONS_KEPT = 8
"""The model evaluations a patch keeps (:meth:`_Patch.evaluated`): the latest, by parameters."""


@dataclass(frozen=True, eq=False)
class _Patch:
    """The pixels fitted: coordinates, grey values, the start centre and the patch's half-size."""

    px: np.ndarray
    py: np.ndarray
    g: np.ndarray
    x: float
    y: float
    half: int
    kept: OrderedDict[bytes, tuple[np.ndarray, np.ndarray]] = field(default_factory=OrderedDict, init=False,
                                                                    repr=False, compare=False)

    def evaluated(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:func:`cross_model` at the parameters ``p`` on the patch's pixels with its Jacobian (its model is the
        model without it, to the bit), read-only, kept for the last :data:`EVALUATIONS_KEPT` parameters. The solver
        asks for the Jacobian at points whose residuals it computed; the reweighting, the covariance and the misfit
        ask for the model at the solution, which the solver evaluated shortly before: about a third of a fit's
        evaluations on bench_peers.py's crosses (11.8 instead of 18.9 a fit)."""
        key = np.asarray(p, np.float64).tobytes()
        got = self.kept.get(key)
        if got is None:
            got = self.kept[key] = cross_model(p, self.px, self.py, self.x, self.y, jacobian=True)
            for a in got:
                a.setflags(write=False)
            if len(self.kept) > EVALUATIONS_KEPT:
                self.kept.popitem(last=False)
        return got


def _patch(window: np.ndarray, x: float, y: float, thetas_deg: tuple[float, float], arm: float, width: float,
           margin: float, max_patch: int) -> _Patch | None:
    """The square patch around (x, y) reaching ``margin`` beyond the arms, reduced to the pixels near either
    arm when there are enough of them (far background only adds work); None when it is too small."""
    h, w = window.shape
    half = int(np.ceil(min(arm + margin, max_patch / 2)))
    c0, c1 = max(0, int(round(x)) - half), min(w, int(round(x)) + half + 1)
    r0, r1 = max(0, int(round(y)) - half), min(h, int(round(y)) + half + 1)
    if (c1 - c0) < 5 or (r1 - r0) < 5:
        return None
    patch = window[r0:r1, c0:c1].astype(np.float64)
    yy, xx = np.mgrid[r0:r1, c0:c1]
    px, py, g = xx.ravel().astype(np.float64), yy.ravel().astype(np.float64), patch.ravel()
    near = np.zeros(px.size, bool)
    for th in thetas_deg:
        t = np.deg2rad(th)
        r = (px - x) * np.cos(t) + (py - y) * np.sin(t)
        u = -(px - x) * np.sin(t) + (py - y) * np.cos(t)
        near |= (np.abs(r) <= width / 2.0 + margin + 1.0) & (np.abs(u) <= arm + margin)
    if near.sum() >= 40:
        px, py, g = px[near], py[near], g[near]
    return _Patch(px, py, g, x, y, half)


@dataclass(frozen=True, eq=False)
class CrossStart:
    """Where :func:`fit_cross` starts: the patch fitted, the start parameters and their plausible region."""

    patch: _Patch
    p0: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


def cross_start(window: np.ndarray, x: float, y: float, theta1_deg: float, theta2_deg: float, arm: float,
                width: float = 2.0, blur: float = 0.8, margin: float = PATCH_MARGIN,
                max_patch: int = MAX_PATCH) -> CrossStart | None:
    """The patch and start of :func:`fit_cross` (its parameters); None when the patch is too small."""
    thetas = (theta1_deg, theta2_deg)
    pt = _patch(window, x, y, thetas, arm, width, margin, max_patch)
    if pt is None:
        return None
    return CrossStart(pt, *_start(pt, thetas, arm, width, blur))


START_TURNS = (0.0, -10.0, 10.0, -20.0, 20.0, -30.0, 30.0)
"""Turns (degrees) of both bars of the start's '+' that :func:`start_share` tries, in turn: the fit may turn each bar
up to :data:`ANGLE_RANGE` from the Hough angles (a speck on the crossing or a faint '+' can put them 15-25 degrees
off), so that a '+' which the fit would find is seen at its own angles within 5 degrees."""


def start_share(start: CrossStart, enough: float = 1.0) -> tuple[float, float]:
    """Before the fit: how much of a bright '+' the patch holds at the start's centre. The model's shape there (the
    start's bars, arms, stroke and blur, unit amplitude: :func:`_shape`), turned by each of :data:`START_TURNS`, and a
    plane in the pixel coordinates are fitted to the patch's grey values by linear least squares
    (:func:`shape_share`). Returns the amplitude and share of the turn whose '+' explains most (a positive amplitude
    before any negative one), the turns tried until one with a positive amplitude explains ``enough``; nan where the
    grey values are not finite."""
    def rank(got: tuple[float, float]) -> tuple[bool, float]:
        return got[0] > 0.0, got[1] if got[0] > 0.0 else -got[1]

    pt, tried = start.patch, []
    dx, dy = pt.px - pt.x, pt.py - pt.y
    for turn in START_TURNS:
        p = start.p0.copy()
        p[2:4] += np.deg2rad(turn)
        got = shape_share(pt.g, _shape(p, pt), dx, dy)
        if not np.isfinite(got[1]):
            return got
        tried.append(got)
        if got[0] > 0.0 and got[1] >= enough:
            break
    return max(tried, key=rank)


def shape_share(g: np.ndarray, shape: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> tuple[float, float]:
    """The linear least squares of the values ``g`` on ``shape`` and a plane ``b0 + bx dx + by dy``: the coefficient of
    ``shape`` and the share of the variance of ``g`` about its own plane that ``shape`` explains (their squared
    partial correlation, the plane held out); (0, 0) where either has nothing left about the plane, and nan where the
    values are not finite (then no refusal rests on them)."""
    plane = np.column_stack([np.ones_like(shape), dx, dy])
    both = np.column_stack([g, shape])
    with np.errstate(all="ignore"):
        v = both - plane @ np.linalg.lstsq(plane, both, rcond=None)[0]   # the values and the shape, the plane held out
        gs, ss, gg = float(v[:, 0] @ v[:, 1]), float(v[:, 1] @ v[:, 1]), float(v[:, 0] @ v[:, 0])
    if not (np.isfinite(gs) and np.isfinite(ss) and np.isfinite(gg)):
        return float("nan"), float("nan")
    if ss <= 0.0 or gg <= 0.0:
        return 0.0, 0.0
    return gs / ss, gs * gs / (ss * gg)


def _shape(p: np.ndarray, pt: _Patch) -> np.ndarray:
    """The model's bars with parameters ``p`` at unit amplitude on a flat ground of 0, on the patch's pixels."""
    return cross_model(np.r_[p[:8], 1.0, 0.0, 0.0, 0.0], pt.px, pt.py, pt.x, pt.y)


def _start(pt: _Patch, thetas_deg: tuple[float, float], arm: float, width: float,
           blur: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start values and the plausible region (lower, upper) of the 12 parameters."""
    x, y = pt.x, pt.y
    b0 = percentile(pt.g, 25)
    a0 = max(percentile(pt.g, 99) - b0, 1e-3)
    length = 2.0 * arm
    t1, t2 = np.deg2rad(thetas_deg[0]), np.deg2rad(thetas_deg[1])
    p0 = np.array([x, y, t1, t2, length, length, max(width, 0.8), blur, a0, b0, 0.0, 0.0])
    inf = np.inf
    lo = np.array([x - 3, y - 3, t1 - ANGLE_RANGE, t2 - ANGLE_RANGE, 2.0, 2.0, 0.3, 0.25, 0.0, -inf, -inf, -inf])
    hi = np.array([x + 3, y + 3, t1 + ANGLE_RANGE, t2 + ANGLE_RANGE, 4.0 * arm + 8, 4.0 * arm + 8, 8.0, 4.0,
                   inf, inf, inf, inf])
    return np.clip(p0, lo + 1e-9, hi - 1e-9), lo, hi


def _least_squares(pt: _Patch, start: np.ndarray, weights: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                   retry: bool = True, evaluations: int = MAX_EVALUATIONS) -> LMSolution:
    """One weighted least-squares pass from ``start``, at most ``evaluations`` model evaluations: Levenberg-Marquardt
    (MINPACK,
    :func:`aerofid.scipy_kernels.levenberg_marquardt`) without bounds, several times faster than the bounded
    trust-region solver (a solution that leaves the plausible region is reported via ``at_bound``). When LM runs out
    of evaluations with the centre still within :data:`RETRY_SHIFT` of the start, it has wandered into a degenerate
    shape (a hair-thin, very bright stroke; an arm growing without end) while the '+' held, and when it ends on values
    that are not finite: the bounded trust-region solver (``scipy.optimize.least_squares``, imported then) runs once
    from the same start (unless not ``retry``)."""

    # the solvers ask for the Jacobian at nearly every point whose residuals they computed (MINPACK: after each
    # accepted step), and both come from the same bar profiles: compute them together (:meth:`_Patch.evaluated`)

    def residuals(p: np.ndarray) -> np.ndarray:
        return weights * (pt.evaluated(p)[0] - pt.g)

    def jac(p: np.ndarray) -> np.ndarray:
        return weights[:, None] * pt.evaluated(p)[1]

    with np.errstate(over="ignore", invalid="ignore", under="ignore"):  # wild trial steps
        sol = levenberg_marquardt(residuals, jac, start, evaluations)
        finite = bool(np.all(np.isfinite(sol.x)))
        ran_out = finite and not (sol.success or sol.status > 0)
        if retry and (not finite or (ran_out and np.hypot(sol.x[0] - start[0], sol.x[1] - start[1]) <= RETRY_SHIFT)):
            from scipy.optimize import least_squares  # rare: scipy.optimize's start-up (0.6-0.7 s) only then

            inside = np.array(start, float)
            inside[4:8] = np.abs(inside[4:8])  # lengths, width, blur enter by magnitude
            inside = np.clip(inside, lo + 1e-9, hi - 1e-9)
            bounded = least_squares(residuals, inside, jac=jac, method="trf", bounds=(lo, hi), x_scale="jac",
                                    max_nfev=evaluations)
            sol = LMSolution(np.asarray(bounded.x, float), int(bounded.status), int(bounded.nfev))
    return sol


def _robust_solve(pt: _Patch, p0: np.ndarray, lo: np.ndarray, hi: np.ndarray, max_shift: float = np.inf,
                  retry: bool = True, evaluations: int = MAX_EVALUATIONS) -> tuple[np.ndarray, np.ndarray] | None:
    """The least-squares solution, iteratively reweighted: pixels hit by dust, scratches or impulse noise
    (|v| > HUBER_K robust sigmas) get Huber weights, so that they neither pull the centre nor inflate the
    misfit. Returns (parameters, final weights) or None when a pass fails.

    Early exit: a first pass that ends with a shape parameter on its bound, or the centre beyond the plausible
    region (:func:`_at_bound`), or more than ``max_shift`` px from the start, found no '+' - reweighting does
    not bring it back (on 693 fits of the benchmark scenes, real RC20 marks and rejection scenes, the 68
    accepted '+' moved at most 0.61 px in their first pass and never ended on a bound; 271 of the 625 refused
    did either, with ``max_shift`` 3 px), so the refits are skipped and the caller refuses it."""
    weights = np.ones_like(pt.g)
    x: np.ndarray | None = None
    for k in range(1 + ROBUST_PASSES):
        try:
            sol = _least_squares(pt, p0 if x is None else x, weights, lo, hi, retry, evaluations)
        except (ValueError, np.linalg.LinAlgError):
            return None
        if not np.all(np.isfinite(sol.x)) or (not sol.success and sol.status <= 0):
            return None
        x = np.asarray(sol.x, np.float64)
        if k == 0 and (_at_bound(np.r_[x[:4], np.abs(x[4:8]), x[8:]], lo, hi)
                       or np.hypot(x[0] - pt.x, x[1] - pt.y) > max_shift):
            break
        v_raw = pt.evaluated(x)[0] - pt.g
        scale = max(robust_std(v_raw), 1e-6)
        a = np.abs(v_raw) / (HUBER_K * scale)
        new_weights = np.sqrt(np.where(a > 1.0, 1.0 / np.maximum(a, 1e-12), 1.0))
        if np.allclose(new_weights, weights):
            break
        weights = new_weights
    return (x, weights) if x is not None else None


def _centre_covariance(pt: _Patch, sol: np.ndarray, weights: np.ndarray) -> tuple[float, np.ndarray] | None:
    """sigma0 = sqrt(v'Pv / (n - u)) and the covariance sigma0^2 (J'J)^+ of the parameters (pseudo-inverse:
    when the arms run out of the patch their lengths are not determined, but the centre still is), the centre's
    block widened by the residuals' correlation (:func:`~aerofid.detect.noise.correlated_covariance`)."""
    model, jacobian = pt.evaluated(sol)
    v = model - pt.g
    J = weights[:, None] * jacobian
    sigma0 = float(np.sqrt((weights * v) @ (weights * v) / max(pt.g.size - sol.size, 1)))
    try:
        Q = np.linalg.pinv(J.T @ J, rcond=1e-12, hermitian=True)
    except np.linalg.LinAlgError:
        return None
    centre = Q[:2] @ J.T   # the centre's weights on the pixels' values
    cov = sigma0 ** 2 * Q
    cov[:2, :2] = correlated_covariance(pt.px, pt.py, weights * v, centre, cov[:2, :2])
    if not (np.isfinite(cov[0, 0]) and np.isfinite(cov[1, 1]) and cov[0, 0] >= 0 and cov[1, 1] >= 0):
        return None
    return sigma0, cov


def _noise_and_misfit(pt: _Patch, sol: np.ndarray, sigma0: float) -> tuple[float, float]:
    """Noise: residual spread of the pixels the model calls background (far from both bars); misfit: robust
    spread of the residuals on the bars over the larger of the noise and ``MODEL_TOLERANCE`` x amplitude."""
    v = pt.evaluated(sol)[0] - pt.g
    shape = _shape(sol, pt)
    # a thin, blurred stroke never reaches full coverage: "on the bars" is relative to the model's peak
    peak = float(shape.max())
    far, on = shape < 0.05 * peak, shape > 0.5 * peak
    noise = robust_std(v[far]) if far.sum() >= 8 else sigma0
    tolerance = max(noise, MODEL_TOLERANCE * abs(float(sol[8])), 1e-9)
    misfit = robust_std(v[on]) / tolerance if on.sum() >= 8 else float("inf")
    return float(noise), float(misfit)


def _arm_contrast(pt: _Patch, sol: np.ndarray) -> tuple[float, float, float, float]:
    """Mean data minus fitted background along the core of each of the four half-arms."""
    xc, yc, t1, t2, l1, l2, wd = sol[:7]
    b0, bx, by = sol[9:12]
    background = b0 + bx * (pt.px - pt.x) + by * (pt.py - pt.y)
    contrast = []
    for t, length in ((t1, l1), (t2, l2)):
        c, sn = np.cos(t), np.sin(t)
        r = (pt.px - xc) * c + (pt.py - yc) * sn
        along = -(pt.px - xc) * sn + (pt.py - yc) * c
        core = np.abs(r) <= max(wd / 2.0, 0.5)
        gap = max(wd / 2.0, 0.5) + 1.0
        for side in (1.0, -1.0):
            sel = core & (side * along >= gap) & (side * along <= length / 2.0)
            contrast.append(float((pt.g[sel] - background[sel]).mean()) if sel.any() else 0.0)
    return contrast[0], contrast[1], contrast[2], contrast[3]


def _at_bound(sol: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> str:
    """The first shape parameter that ended on its bound, or empty. Blur and a thin stroke may go to their
    lower limits (a sharp scan) and arms may be longer than the patch, but a stroke as wide as the upper bound
    is a blob and a bar shorter than 2 px is no arm."""
    names = ("centre x", "centre y", "angle 1", "angle 2", "length 1", "length 2", "stroke width")
    span = hi[:7] - lo[:7]
    on_bound = (sol[:7] - lo[:7] < 1e-3 * span) | (hi[:7] - sol[:7] < 1e-3 * span)
    on_bound[6] = hi[6] - sol[6] < 1e-3 * span[6]
    on_bound[4:6] = sol[4:6] - lo[4:6] < 1e-3 * span[4:6]   # arms running out of the patch are fine
    return next((nm for nm, b in zip(names, on_bound) if b), "")


def fit_cross(window: np.ndarray, x: float, y: float, theta1_deg: float, theta2_deg: float,
              arm: float, width: float = 2.0, blur: float = 0.8,
              margin: float = PATCH_MARGIN, max_patch: int = MAX_PATCH,
              max_shift: float = np.inf, retry: bool = True, evaluations: int = MAX_EVALUATIONS) -> CrossFit | None:
    """Fit the blurred-cross model around the start (x, y) with arms of half-length ``arm`` px.

    Parameters
    ----------
    window : ndarray
        Grey levels, the mark bright.
    x, y, theta1_deg, theta2_deg, arm : float
        Start: centre (window pixels), the two bars' normal angles (degrees) and their half-length (px).
    width, blur : float
        Start stroke width and Gaussian blur (px).
    margin, max_patch : float, int
        The patch reaches ``margin`` px beyond the arms, at most ``max_patch`` px wide.
    max_shift : float
        A first least-squares pass whose centre moves further than this (px) from the start is not refitted
        (:func:`_robust_solve`; the caller refuses a '+' that far off).
    retry : bool
        Whether a pass that ran out of evaluations gets the bounded solver's second try (:func:`_least_squares`).
    evaluations : int
        Most model evaluations of a least-squares pass (:data:`MAX_EVALUATIONS`); a pass that runs out of them
        without ``retry`` fails the fit.

    Returns
    -------
    CrossFit or None
        None when the patch is too small, the fit does not converge, or its normal matrix is singular.
    """
    start = cross_start(window, x, y, theta1_deg, theta2_deg, arm, width, blur, margin, max_patch)
    return None if start is None else fit_start(start, max_shift, retry, evaluations)


def fit_start(start: CrossStart, max_shift: float = np.inf, retry: bool = True,
              evaluations: int = MAX_EVALUATIONS) -> CrossFit | None:
    """:func:`fit_cross` from its patch and start (:func:`cross_start`)."""
    pt, p0, lo, hi = start.patch, start.p0, start.lo, start.hi
    solved = _robust_solve(pt, p0, lo, hi, max_shift, retry, evaluations)
    if solved is None:
        return None
    sol, weights = solved
    got = _centre_covariance(pt, sol, weights)
    if got is None:
        return None
    sigma0, cov = got
    sol = sol.copy()
    sol[4:8] = np.abs(sol[4:8])  # the model uses their magnitudes (cross_model)
    noise, misfit = _noise_and_misfit(pt, sol, sigma0)
    xc, yc, t1, t2, l1, l2, wd, s, a = (float(v) for v in sol[:9])
    return CrossFit(x=xc, y=yc, sigma_x=float(np.sqrt(cov[0, 0])), sigma_y=float(np.sqrt(cov[1, 1])),
                    cov_xy=float(0.5 * (cov[0, 1] + cov[1, 0])),
                    theta1=float(np.rad2deg(t1)), theta2=float(np.rad2deg(t2)), length1=l1, length2=l2,
                    width=wd, blur=s, amplitude=a, sigma0=sigma0, noise=noise,
                    arm_contrast=_arm_contrast(pt, sol), at_bound=_at_bound(sol, lo, hi), patch_half=float(pt.half),
                    misfit=misfit)
