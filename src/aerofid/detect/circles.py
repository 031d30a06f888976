"""Concentric circles: Hough transform and Gauss-Helmert adjustment (Seedahmed, seed 003).

The pipeline of seed 003, section 5 ("Algorithm"), on one window:

1. **Edges** -- Canny's operator over the window (:func:`edges`). Each edge pixel is then moved to the
   sub-pixel maximum of the gradient magnitude along the pixel axis closest to its gradient (Devernay's
   parabola, 1995), so that the adjustment gets edge *positions*, not pixel centres.
2. **Hough space of the circles with known radii** -- "for a circle with a known radius, the observations
   are the coordinates along the circumference and the parameters are the circle centroid" (section 3):
   each edge pixel votes for every centre on a circle of radius R around it (:func:`hough_circles`). The
   accumulators of the two radii are added (the circles are concentric) and their peak is the approximate
   centre ("peak detection ... for the identification and an approximate localization").
   With ``radii=None`` the radii are estimated from the mark (:func:`estimate_radii`): the centre from a
   radius-free vote of every edge pixel along its gradient line, the radii from the histogram of the edge
   distances to it.
3. **De-Houghing** -- "substituting the parameters of each circle in their corresponding" equation to
   trace the edge pixels that belong to each circle (:func:`de_hough`).
4. **Precise localisation** -- least-squares adjustment of the two concentric circles, seed eq. (2),
   ``(x_i - x0)^2 + (y_i - y0)^2 - R_1^2 = e_i`` and ``(x_j - x0)^2 + (y_j - y0)^2 - R_2^2 = e_j``, handled as
   "condition equations with parameters" (the Gauss-Helmert model, seed eq. (3), Schaffrin 1997):
   ``B e + A xi = w``, ``e ~ (0, sigma0^2 P^-1)`` (:func:`fit_concentric_circles`). The cofactor matrix of
   the parameters scaled by the a-posteriori ``sigma0^2`` gives the centre's standard deviation.

The result is rejected (``not_found`` with a reason) when fewer than two circles are supported on enough of
their circumference, when the circles are not concentric (each circle adjusted on its own, its edge points
re-selected about its own centre), when another circular structure competes with the chosen centre (the
rounded notch of the film border that encloses a Wild mark does not compete: :func:`_notch_rim`), or when the
edge points scatter about the circles more than the noise explains (the noise measured on the gradients
too: JPEG blocks hide from the grey-level estimate).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import cv2
import numpy as np

from aerofid.detect.noise import difference_noise_sigma
from aerofid.detect.result import FOUND, Detection, not_found, unusable_window

METHOD = "circles"

# --- parameters (seed 003 defaults where the seed gives them) -------------------------------------------

CANNY_SIGMA = 0.7
"""Gaussian smoothing (px) of Canny's operator before the gradient (seed 003 section 5: "Canny's edge
algorithm with its associated parameters"; the paper does not give them. 0.7 px keeps the two edges of a
thin (1 px) ring and the ends of the bars inside it apart on 20 px marks)."""

CANNY_HIGH = 6.0
"""Canny high hysteresis threshold, in standard deviations of the gradient noise (estimated from the
window); the low threshold is ``CANNY_LOW_RATIO`` of it."""

CANNY_LOW_RATIO = 0.4

N_CIRCLES = 2
"""The seed's model uses two concentric circles (eq. 2)."""

MIN_RADIUS = 2.5
"""Smallest circle radius (px) considered when the radii are estimated."""

DEHOUGH_TOL = 1.5
"""Edge points within this distance (px) of a circle, with a radial gradient, belong to it (de-Houghing)."""

RADIAL_COS = 0.9
"""|cos| of the angle between an edge point's gradient and the radial direction for it to lie on a circle."""

MIN_COVERAGE = 0.6
"""Each circle must have edge points in at least this fraction of its circumference (36 sectors); a mark cut
by the window edge fails here instead of returning a shifted centre."""

CONCENTRIC_TOL = 0.5
"""Largest distance (px, plus three standard deviations) between the centres of the circles fitted one by
one for them to count as concentric."""

ENCLOSE_MARGIN = 3.0
"""A competing circle that encloses the mark's circles with this many px to spare and is a step up from dark
to bright is the film border's rounded notch around the mark (Wild RC20 midsides and corners), not a
competitor (:func:`_notch_rim`)."""
COMPETITOR_RATIO = 0.5
"""Another centre peak (radius-free vote) of at least this fraction of the chosen one, away from it, makes the
window ambiguous (e.g. two non-concentric circles)."""

N_SECTORS = 36

EDGE_CORRELATION = 2.0
"""Edge points per independent observation: neighbouring Canny pixels share the smoothing and Sobel kernels
(about 2 px along the edge), so the adjustment's cofactors, which assume independent points, are scaled by
sqrt(EDGE_CORRELATION). Measured: with it the RMS error on synthetic marks is 0.7-1.4 times the sigma."""

MAX_RMS_RATIO = 5.0
"""Largest ratio of the adjustment's sigma0 (edge residual RMS) to the RMS the noise explains; measured on good
synthetic marks (noise 0.01-0.05, contrast 0.3-0.8): at most 1.9."""

SAME_POLARITY_GAP = 3.0
"""Free radii: two circles whose edges have the same polarity must be at least this many px apart."""

SINGLE_PASSES = 3
"""Concentricity: each circle is fitted on its own this many times, re-selecting its edge points about its own
adjusted centre each time ...
"""
SINGLE_BAND = 3.0
"""... within this many px of it (less when another circle is nearer than twice this)."""

RAYLEIGH_MEDIAN = float(np.sqrt(2.0 * np.log(2.0)))
"""Median of the magnitude of a 2-D gradient of white noise, in units of its per-axis sigma."""

RADIUS_TOL = 1.5
"""Given radii are searched over +/- this many px (0.5 px steps) in the Hough space and the radius histogram."""


# --- edges ----------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class EdgePoints:
    """Canny edge pixels with sub-pixel positions and unit gradient directions."""

    x: np.ndarray        # sub-pixel edge position (column)
    y: np.ndarray        # sub-pixel edge position (row)
    nx: np.ndarray       # unit gradient (points from dark to bright)
    ny: np.ndarray
    mag: np.ndarray      # gradient magnitude (grey levels per px)
    col: np.ndarray      # integer pixel of the edge
    row: np.ndarray
    edge_map: np.ndarray  # bool image of the Canny edges
    noise: float         # estimated grey-level noise of the window


def edges(window: np.ndarray, canny_sigma: float = CANNY_SIGMA, canny_high: float = CANNY_HIGH,
          canny_low_ratio: float = CANNY_LOW_RATIO, border: int = 2) -> EdgePoints:
    """Canny edges of ``window`` (seed 003 section 5) with sub-pixel positions.

    The window is smoothed with a Gaussian of ``canny_sigma`` px and differentiated with Sobel (scaled to grey
    levels per px); OpenCV's Canny does the non-maximum suppression and hysteresis on that gradient, with the
    high threshold at ``canny_high`` standard deviations of the gradient noise. Each edge pixel is moved to the
    vertex of a parabola through the gradient magnitude at it and its two neighbours along the pixel axis
    closest to the gradient (Devernay 1995). Pixels within ``border`` of the window edge are dropped.
    """
    w = np.asarray(window, np.float32)
    h, wd = w.shape
    noise = difference_noise_sigma(w)
    if canny_sigma > 0:
        k = int(2 * np.ceil(3 * canny_sigma) + 1)
        s = cv2.GaussianBlur(w, (k, k), canny_sigma, borderType=cv2.BORDER_REPLICATE)
    else:
        s = w
    gx = cv2.Sobel(s, cv2.CV_32F, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE) / 8.0
    gy = cv2.Sobel(s, cv2.CV_32F, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE) / 8.0
    mag = np.hypot(gx, gy)
    # gradient noise: Sobel/8 of white noise smoothed by a Gaussian of sigma s has std about
    # noise * sqrt(12/64) / (2 sqrt(pi) s) ** 0.5 ... use the empirical factor of a pure-noise field instead
    # ... but no less than the gradient noise measured directly: the median magnitude of a 2-D Gaussian
    # gradient is sqrt(2 ln 2) = 1.1774 sigma. JPEG blocks and correlated film grain hide from the grey-level
    # noise estimate (a real RC20 scan: 1 grey level) while their gradients made half the window Canny edges.
    # The edge-position noise of the adjustment (_expected_edge_rms) uses the same effective noise.
    gain = _gradient_noise_gain(canny_sigma)
    g_noise = max(noise * gain, float(np.median(mag)) / RAYLEIGH_MEDIAN)
    noise = g_noise / gain
    empty = np.zeros(0)
    if not np.isfinite(mag).all() or mag.max() <= 0:
        return EdgePoints(empty, empty, empty, empty, empty, empty.astype(int), empty.astype(int),
                          np.zeros_like(w, bool), noise)
    hi = max(canny_high * g_noise, 1e-6)
    lo = canny_low_ratio * hi
    scale = 16000.0 / max(float(np.abs(gx).max()), float(np.abs(gy).max()), hi)
    dx = np.clip(np.rint(gx * scale), -32767, 32767).astype(np.int16)
    dy = np.clip(np.rint(gy * scale), -32767, 32767).astype(np.int16)
    emap = cv2.Canny(dx, dy, lo * scale, hi * scale, L2gradient=True) > 0
    if border > 0:
        emap[:border], emap[-border:], emap[:, :border], emap[:, -border:] = False, False, False, False
    row, col = np.nonzero(emap)
    g = mag[row, col]
    ux, uy = gx[row, col] / g, gy[row, col] / g
    horiz = np.abs(ux) >= np.abs(uy)
    sx = np.where(horiz, 1, 0)
    sy = np.where(horiz, 0, 1)
    m_minus = mag[row - sy, col - sx]
    m_plus = mag[row + sy, col + sx]
    denom = m_minus - 2 * g + m_plus
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom < 0, 0.5 * (m_minus - m_plus) / denom, 0.0)
    t = np.clip(t, -0.5, 0.5)
    x = col + t * sx
    y = row + t * sy
    return EdgePoints(x.astype(np.float64), y.astype(np.float64), ux.astype(np.float64),
                      uy.astype(np.float64), g.astype(np.float64), col, row, emap, noise)


_GAIN_CACHE: dict[float, float] = {}


def _gradient_noise_gain(canny_sigma: float) -> float:
    """Std of one gradient component (Gaussian smoothing + Sobel/8) per unit white noise (computed once)."""
    key = round(float(canny_sigma), 3)
    if key not in _GAIN_CACHE:
        rng = np.random.default_rng(0)
        n = rng.normal(size=(128, 128)).astype(np.float32)
        if canny_sigma > 0:
            k = int(2 * np.ceil(3 * canny_sigma) + 1)
            n = cv2.GaussianBlur(n, (k, k), canny_sigma)
        gx = cv2.Sobel(n, cv2.CV_32F, 1, 0, ksize=3) / 8.0
        _GAIN_CACHE[key] = float(gx[8:-8, 8:-8].std())
    return _GAIN_CACHE[key]


# --- Hough transform ------------------------------------------------------------------------------------

def hough_circles(x: np.ndarray, y: np.ndarray, radius: float, shape: tuple[int, int]) -> np.ndarray:
    """Hough accumulator of circle centres for a known ``radius`` (seed 003 section 3): each edge point
    (x, y) votes for every pixel on the circle of that radius around it. Returns a float array of ``shape``
    (rows, columns) with the votes per centre pixel, divided by the number of angle samples (so a complete,
    one-pixel-thick circle scores about 1 per unit of edge-point density)."""
    h, w = shape
    n_phi = max(16, int(np.ceil(2 * np.pi * radius)))
    phi = np.arange(n_phi) * (2 * np.pi / n_phi)
    cx = np.rint(x[:, None] - radius * np.cos(phi)[None, :]).astype(np.int64).ravel()
    cy = np.rint(y[:, None] - radius * np.sin(phi)[None, :]).astype(np.int64).ravel()
    ok = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    acc = np.bincount(cy[ok] * w + cx[ok], minlength=h * w).astype(np.float64)
    return acc.reshape(h, w) * (2 * np.pi * radius / n_phi) / (2 * np.pi * radius)


def hough_centres(ep: EdgePoints, r_min: float, r_max: float, shape: tuple[int, int]) -> np.ndarray:
    """Radius-free centre vote: every edge point votes, weighted 1/distance, for the pixels on its gradient
    line at distances ``r_min`` to ``r_max`` on both sides (the centre of any circle through it lies there).
    Used to find the centre when the radii are not given, and to find competing circular structures."""
    h, w = shape
    if ep.x.size == 0 or r_max < r_min:
        return np.zeros(shape)
    d = np.arange(r_min, r_max + 0.5, 0.5)
    d = np.concatenate([-d[::-1], d])
    cx = np.rint(ep.x[:, None] + d[None, :] * ep.nx[:, None]).astype(np.int64).ravel()
    cy = np.rint(ep.y[:, None] + d[None, :] * ep.ny[:, None]).astype(np.int64).ravel()
    wt = np.broadcast_to(1.0 / np.abs(d)[None, :], (ep.x.size, d.size)).ravel()
    ok = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    acc = np.bincount(cy[ok] * w + cx[ok], weights=wt[ok], minlength=h * w)
    return acc.reshape(h, w) / (2 * np.pi)


def _smooth(acc: np.ndarray, sigma: float = 1.0) -> np.ndarray:
    return cv2.GaussianBlur(acc.astype(np.float32), (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)


def _peak(acc: np.ndarray) -> tuple[float, float, float]:
    """Integer peak (x, y) of an accumulator and its value."""
    i = int(np.argmax(acc))
    r, c = divmod(i, acc.shape[1])
    return float(c), float(r), float(acc[r, c])


def _radial(ep: EdgePoints, cx: float, cy: float) -> tuple[np.ndarray, np.ndarray]:
    """Distances of the edge points from (cx, cy) and the |cos| between their gradient and the radius."""
    dx, dy = ep.x - cx, ep.y - cy
    d = np.hypot(dx, dy)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.abs(dx * ep.nx + dy * ep.ny) / d
    return d, np.nan_to_num(cos)


def _coverage(ep_x: np.ndarray, ep_y: np.ndarray, cx: float, cy: float, n_sectors: int = N_SECTORS) -> float:
    """Fraction of ``n_sectors`` angular sectors around (cx, cy) holding at least one point."""
    if ep_x.size == 0:
        return 0.0
    a = np.arctan2(ep_y - cy, ep_x - cx)
    k = np.floor((a + np.pi) / (2 * np.pi) * n_sectors).astype(int) % n_sectors
    return float(np.unique(k).size / n_sectors)


def estimate_radii(ep: EdgePoints, cx: float, cy: float, r_min: float, r_max: float,
                   n_circles: int = N_CIRCLES, near: tuple[float, ...] | None = None,
                   radial_cos: float = RADIAL_COS, min_coverage: float = MIN_COVERAGE) -> list[tuple[float, float]]:
    """Radii of circles centred near (cx, cy): peaks of the histogram (0.5 px bins, smoothed) of the
    distances of the edge points whose gradient is radial, each scored by its angular coverage.

    Without ``near``, returns up to ``n_circles`` (radius, coverage) at least 1.5 px apart (``SAME_POLARITY_GAP``
    px when both are edges of the same polarity, i.e. both dark inside or both bright inside: a blurred edge
    seen from a centre a pixel off splits into two histogram peaks), the circles covered on ``min_coverage``
    of their circumference first, each group by edge-point count (largest circles first). With ``near`` (the given radii), returns
    for each the best peak within max(2, 0.15 R) px of it.
    """
    d, cos = _radial(ep, cx, cy)
    ok = (cos >= radial_cos) & (d >= r_min - 1) & (d <= r_max + 1)
    if not ok.any():
        return []
    bw = 0.5
    edges_ = np.arange(max(0.0, r_min - 1.0), r_max + 1.0 + bw, bw)
    hist, _ = np.histogram(d[ok], bins=edges_)
    hs = np.convolve(hist.astype(float), [0.25, 0.5, 0.25], mode="same")
    centres = 0.5 * (edges_[:-1] + edges_[1:])
    is_peak = (hs > 0) & (hs >= np.roll(hs, 1)) & (hs >= np.roll(hs, -1))
    peaks = np.nonzero(is_peak)[0]

    # polarity of each edge point: +1 when its gradient points away from the centre (dark inside)
    with np.errstate(divide="ignore", invalid="ignore"):
        outward = np.sign((ep.x - cx) * ep.nx + (ep.y - cy) * ep.ny)

    def refine(i: int) -> tuple[float, float]:
        sel = ok & (np.abs(d - centres[i]) <= 1.0)
        r = float(np.median(d[sel])) if sel.any() else float(centres[i])
        sel = ok & (np.abs(d - r) <= 1.0)
        return r, _coverage(ep.x[sel], ep.y[sel], cx, cy)

    def polarity(r: float) -> float:
        sel = ok & (np.abs(d - r) <= 1.0)
        return float(np.sign(outward[sel].sum())) if sel.any() else 0.0

    if near is not None:
        # each given radius takes its own histogram peak (within max(2, 0.15 R)), the set of peaks with the
        # least total distance to the given radii; a radius without a peak keeps its value, coverage 0
        cand = [i for i in peaks if hs[i] >= 0.2 * hs.max()
                and min(abs(centres[i] - r0) - max(2.0, 0.15 * r0) for r0 in near) <= 0]
        best, best_cost = None, np.inf
        for combo in itertools.permutations(cand + [None] * len(near), len(near)):
            cost = 0.0
            for r0, i in zip(near, combo):
                if i is None:
                    cost += 10.0
                elif abs(centres[i] - r0) > max(2.0, 0.15 * r0):
                    cost = np.inf
                    break
                else:
                    cost += abs(centres[i] - r0)
            if cost < best_cost:
                best, best_cost = combo, cost
        return [refine(i) if i is not None else (float(r0), 0.0) for r0, i in zip(near, best)]
    # circles covered on at least min_coverage of their circumference first, then by edge-point count
    scored = []
    for i in peaks:
        r, cov = refine(i)
        if r >= r_min and cov >= 0.25:
            scored.append((cov >= min_coverage, float(hs[i]), r, cov))
    scored.sort(key=lambda t: (not t[0], -t[1]))
    out: list[tuple[float, float]] = []
    signs: list[float] = []
    for _, _, r, cov in scored:
        sign = polarity(r)
        if any(abs(r - q) < (SAME_POLARITY_GAP if sign == t else 1.5) for (q, _), t in zip(out, signs)):
            continue
        out.append((r, cov))
        signs.append(sign)
        if len(out) >= n_circles:
            break
    return out


def de_hough(ep: EdgePoints, cx: float, cy: float, radii: list[float], tol: float = DEHOUGH_TOL,
             radial_cos: float = RADIAL_COS) -> np.ndarray:
    """De-Houghing (seed 003 section 5): the index of the circle each edge point belongs to, or -1.

    A point belongs to the circle whose radius is nearest to its distance from (cx, cy), if that is within
    ``tol`` px and its gradient is radial (|cos| >= ``radial_cos``) -- the bars of a cross crossing the
    circles have tangential gradients and are left out.
    """
    d, cos = _radial(ep, cx, cy)
    r = np.asarray(radii, float)
    diff = np.abs(d[:, None] - r[None, :])
    k = np.argmin(diff, axis=1)
    ok = (diff[np.arange(d.size), k] <= tol) & (cos >= radial_cos)
    return np.where(ok, k, -1)


# --- Gauss-Helmert adjustment ---------------------------------------------------------------------------

@dataclass(frozen=True)
class CircleFit:
    """Result of the concentric-circles adjustment."""

    x0: float
    y0: float
    radii: tuple[float, ...]
    cov: np.ndarray          # covariance (sigma0^2 Q) of (x0, y0, R_1 .. R_k free)
    sigma0: float            # a-posteriori standard deviation of unit weight (px)
    residuals: np.ndarray    # e: corrections to the observed points, shape (n, 2)
    redundancy: int
    iterations: int
    converged: bool

    @property
    def sigma_xy(self) -> tuple[float, float]:
        return float(np.sqrt(self.cov[0, 0])), float(np.sqrt(self.cov[1, 1]))


def fit_concentric_circles(x: np.ndarray, y: np.ndarray, label: np.ndarray, radii: tuple[float, ...] | None = None,
                           centre: tuple[float, float] | None = None, fix_radii: bool = False,
                           weights: np.ndarray | None = None, max_iter: int = 20, tol: float = 1e-10) -> CircleFit | None:
    """Least-squares adjustment of k concentric circles, seed 003 eq. (2)-(3), as a Gauss-Helmert model.

    Condition equations, one per point i on circle k(i) (``label``):
    ``f_i = (x_i - x0)^2 + (y_i - y0)^2 - R_k^2 = 0`` with the observed coordinates (x_i, y_i) in error.
    Linearised at the current parameters xi0 and corrected observations y + e0 (Pope's rigorous iteration):
    ``A dxi + B e + w = 0`` with ``A = df/dxi``, ``B = df/dy``, ``w = f(xi0, y + e0) - B e0``;
    with ``e ~ (0, sigma0^2 P^-1)`` (P = ``weights``, one per point, isotropic):
    ``M = B P^-1 B^T``, ``N = A^T M^-1 A``, ``dxi = -N^-1 A^T M^-1 w``, ``k = -M^-1 (A dxi + w)``,
    ``e = P^-1 B^T k``, ``sigma0^2 = e^T P e / (n - u)``, ``Cov(xi) = sigma0^2 N^-1``.

    Parameters are (x0, y0) and, unless ``fix_radii``, the radii (one per label 0 .. k-1). ``radii`` and
    ``centre`` are starting values (defaults: centroid and mean distances); with ``fix_radii`` the radii are the
    known ones of the seed's model. Returns None when the normal matrix is singular or there is no redundancy.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    label = np.asarray(label, int)
    n = x.size
    if n == 0:
        return None
    k_circ = int(label.max()) + 1
    p = np.ones(n) if weights is None else np.asarray(weights, float)
    if centre is None:
        centre = (float(x.mean()), float(y.mean()))
    x0, y0 = centre
    if radii is None:
        dd = np.hypot(x - x0, y - y0)
        radii = tuple(float(dd[label == j].mean()) if (label == j).any() else 1.0 for j in range(k_circ))
    R = np.asarray(radii, float).copy()
    u = 2 + (0 if fix_radii else k_circ)
    if n - u <= 0:
        return None
    ex = np.zeros(n)
    ey = np.zeros(n)
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        xa, ya = x + ex, y + ey                       # Taylor point of the observations
        dx, dy = xa - x0, ya - y0
        Rk = R[label]
        f = dx * dx + dy * dy - Rk * Rk
        bx, by = 2 * dx, 2 * dy                        # B (block diagonal: one row per point)
        w = f - (bx * ex + by * ey)                    # misclosure at the observations y
        m = (bx * bx + by * by) / p                    # M = B P^-1 B^T (diagonal)
        if np.any(m <= 0):
            return None
        A = np.zeros((n, u))
        A[:, 0], A[:, 1] = -bx, -by
        if not fix_radii:
            A[np.arange(n), 2 + label] = -2 * Rk
        Am = A / m[:, None]
        N = A.T @ Am
        try:
            dxi = -np.linalg.solve(N, Am.T @ w)
        except np.linalg.LinAlgError:
            return None
        kk = -(A @ dxi + w) / m
        ex_new, ey_new = bx * kk / p, by * kk / p
        x0 += dxi[0]
        y0 += dxi[1]
        if not fix_radii:
            R += dxi[2:]
        step = float(np.max(np.abs(dxi))) + float(np.max(np.abs(ex_new - ex)) + np.max(np.abs(ey_new - ey)))
        ex, ey = ex_new, ey_new
        if step < tol:
            converged = True
            break
    # final linearisation at the solution for the cofactor matrix
    dx, dy = x + ex - x0, y + ey - y0
    bx, by = 2 * dx, 2 * dy
    m = (bx * bx + by * by) / p
    A = np.zeros((n, u))
    A[:, 0], A[:, 1] = -bx, -by
    if not fix_radii:
        A[np.arange(n), 2 + label] = -2 * R[label]
    N = A.T @ (A / m[:, None])
    try:
        Q = np.linalg.inv(N)
    except np.linalg.LinAlgError:
        return None
    r = n - u
    vtpv = float(np.sum(p * (ex * ex + ey * ey)))
    s0 = float(np.sqrt(vtpv / r))
    return CircleFit(float(x0), float(y0), tuple(float(v) for v in R), s0 * s0 * Q, s0,
                     np.column_stack([ex, ey]), r, it, converged)


# --- the detector ---------------------------------------------------------------------------------------

def detect(window: np.ndarray, radii: tuple[float, float] | None = None, *, n_circles: int = N_CIRCLES,
           canny_sigma: float = CANNY_SIGMA, canny_high: float = CANNY_HIGH,
           canny_low_ratio: float = CANNY_LOW_RATIO, min_radius: float = MIN_RADIUS,
           max_radius: float | None = None, dehough_tol: float = DEHOUGH_TOL, radial_cos: float = RADIAL_COS,
           min_coverage: float = MIN_COVERAGE, concentric_tol: float = CONCENTRIC_TOL,
           competitor_ratio: float = COMPETITOR_RATIO, radius_tol: float = RADIUS_TOL,
           max_rms_ratio: float = MAX_RMS_RATIO,
           fix_radii: bool = False) -> Detection:
    """Centre of a mark made of concentric circles (Seedahmed, seed 003), in window pixels.

    Args:
        window: 2-D float32 grey levels on [0, 1], the mark brighter than its ground.
        radii: the circles' radii in px (``(R_1, R_2)``, seed eq. 2, e.g. the inner and outer edge of a Wild
            RC10 ring), or None to estimate them from the mark (the ``n_circles`` best-supported circles).
        n_circles: circles to adjust when estimating the radii (the seed's model has two).
        canny_sigma, canny_high, canny_low_ratio: Canny's operator, see :func:`edges`.
        min_radius, max_radius: radius search range when estimating (default max: half the window).
        dehough_tol, radial_cos: de-Houghing, see :func:`de_hough`.
        min_coverage: fraction of each circle's circumference that must carry edge points.
        concentric_tol: px (plus 3 sigma) by which the circles' separately fitted centres may differ.
        competitor_ratio: a second centre peak this strong relative to the chosen one makes it ambiguous.
        radius_tol: given radii are searched over +/- this many px.
        max_rms_ratio: largest edge residual RMS, in multiples of what the noise explains.
        fix_radii: adjust with the radii fixed to ``radii`` (the seed's "known radius" model) instead of free.
            Free is the default because scanned radii differ from the nominal ones by the scan scale and
            the edge operator's blur.

    Returns:
        Detection with ``method="circles"``: the adjusted common centre, ``sigma`` = mean of its two standard
        deviations from the adjustment (times sqrt(``EDGE_CORRELATION``)), and ``score`` = min(circumference support / 0.9, fit quality,
        concentricity); diagnostics ``edges``, ``accumulator``, ``centre_votes``, ``circles``
        [(x0, y0, R)], ``points``, ``labels``, ``fit``.
    """
    w = np.asarray(window, np.float32)
    bad = unusable_window(w)
    if bad is not None:
        return not_found(METHOD, bad)
    h, wd = w.shape
    ep = edges(w, canny_sigma, canny_high, canny_low_ratio)
    diag: dict = {"edges": ep.edge_map, "noise": ep.noise}
    if ep.x.size < 12:
        return not_found(METHOD, f"too few edge pixels ({ep.x.size}) for circles", **diag)
    r_max = float(max_radius) if max_radius is not None else 0.5 * min(h, wd)
    if radii is not None:
        radii = tuple(float(r) for r in radii)
        if len(radii) < 2 or min(radii) <= 0:
            return not_found(METHOD, "radii must be two or more positive numbers (px)", **diag)
        # the Hough space of each known radius, over radius_tol px around it (scan scale, the edge operator's
        # blur moves the edges of a thin ring apart); the concentric circles' spaces are added
        per_acc = [sum(hough_circles(ep.x, ep.y, q, (h, wd))
                       for q in np.arange(max(1.0, r - radius_tol), r + radius_tol + 0.01, 0.5)) for r in radii]
        acc = sum(per_acc)
        cx, cy, _ = _peak(_smooth(acc))
        # separate peaks of each radius: concentric circles share the centre
        per = [_peak(_smooth(a)) for a in per_acc]
        diag["peaks"] = per
        diag["accumulator"] = acc
        vote_range = (max(1.5, min(radii) - 2.0), max(radii) + 2.0)
    else:
        vote_range = (min_radius, r_max)
    votes = _smooth(hough_centres(ep, vote_range[0], vote_range[1], (h, wd)))
    diag["centre_votes"] = votes
    if radii is None:
        cx, cy, _ = _peak(votes)
        diag["accumulator"] = votes
        found = estimate_radii(ep, cx, cy, min_radius, r_max, n_circles, radial_cos=radial_cos,
                               min_coverage=min_coverage)
        if len(found) < 2:
            return not_found(METHOD, f"fewer than two circles centred at the Hough peak ({cx:.0f}, {cy:.0f})",
                             **diag)
        use_radii = [r for r, _ in found]
    else:
        spread = max(np.hypot(px - cx, py - cy) for px, py, _ in per)
        if spread > max(4.0, 0.2 * min(radii)):
            return not_found(METHOD, f"the circles of radii {radii} peak {spread:.1f} px apart: not concentric",
                             **diag)
        found = estimate_radii(ep, cx, cy, 1.0, max(radii) + 3, near=radii, radial_cos=radial_cos)
        use_radii = [r for r, _ in found]

    # de-Houghing and adjustment, twice (the second time with the adjusted centre and radii)
    fit = None
    for tol_i in (dehough_tol, min(dehough_tol, 1.0)):
        lab = de_hough(ep, cx, cy, use_radii, tol_i, radial_cos)
        sel = lab >= 0
        if any((lab == j).sum() < 5 for j in range(len(use_radii))):
            return not_found(METHOD, "a circle has fewer than 5 edge points after de-Houghing", **diag)
        fit = fit_concentric_circles(ep.x[sel], ep.y[sel], lab[sel], tuple(radii) if fix_radii else tuple(use_radii),
                                     (cx, cy), fix_radii=fix_radii)
        if fit is None or not np.isfinite([fit.x0, fit.y0]).all():
            return not_found(METHOD, "the concentric-circles adjustment did not converge", **diag)
        cx, cy = fit.x0, fit.y0
        use_radii = list(fit.radii)
    lab = de_hough(ep, cx, cy, use_radii, min(dehough_tol, 1.0), radial_cos)
    sel = lab >= 0
    diag.update(points=np.column_stack([ep.x[sel], ep.y[sel]]), labels=lab[sel], fit=fit,
                circles=[(fit.x0, fit.y0, r) for r in fit.radii])
    if not (0 <= fit.x0 <= wd - 1 and 0 <= fit.y0 <= h - 1):
        return not_found(METHOD, "the adjusted centre lies outside the window", **diag)
    if max(fit.radii) > 0.5 * max(h, wd) * 1.5:
        return not_found(METHOD, "the adjusted circles are larger than the window", **diag)

    # support on the circumference (also catches circles cut by the window edge)
    cover = [_coverage(ep.x[lab == j], ep.y[lab == j], cx, cy) for j in range(len(use_radii))]
    diag["coverage"] = cover
    if min(cover) < min_coverage:
        j = int(np.argmin(cover))
        return not_found(METHOD, f"circle of radius {use_radii[j]:.1f} px has edges on only {cover[j]:.0%} of "
                                 f"its circumference (cut by the window edge, or not a circle)", **diag)
    # concentricity: each circle fitted on its own
    # (each circle's edge points are taken in a band of up to SINGLE_BAND px about it, short of the other
    # circles, and selected again about its own adjusted centre, SINGLE_PASSES times: a thin ring offset by a
    # pixel or two, whose edges the narrow de-Houghing about the common centre only half selects, moves to
    # its own centre)
    singles = []
    for j in range(len(use_radii)):
        gap = min((abs(use_radii[j] - r) for k, r in enumerate(use_radii) if k != j), default=2 * SINGLE_BAND)
        band = max(min(dehough_tol, 1.0), min(SINGLE_BAND, 0.5 * gap - 0.25))
        m = lab == j
        fj = None
        for _ in range(SINGLE_PASSES):
            fj = fit_concentric_circles(ep.x[m], ep.y[m], np.zeros(int(m.sum()), int),
                                        (use_radii[j] if fj is None else fj.radii[0],),
                                        (cx, cy) if fj is None else (fj.x0, fj.y0))
            if fj is None or not np.isfinite([fj.x0, fj.y0]).all():
                return not_found(METHOD, f"circle {j} could not be adjusted on its own", **diag)
            m = de_hough(ep, fj.x0, fj.y0, [fj.radii[0]], band, radial_cos) == 0
            if m.sum() < 5:
                return not_found(METHOD, f"circle {j} could not be adjusted on its own", **diag)
        singles.append(fj)
    sep = max(np.hypot(a.x0 - b.x0, a.y0 - b.y0) for i, a in enumerate(singles) for b in singles[i + 1:])
    s_sep = max(np.sqrt(a.cov[0, 0] + a.cov[1, 1] + b.cov[0, 0] + b.cov[1, 1])
                for i, a in enumerate(singles) for b in singles[i + 1:])
    diag["concentricity"] = (sep, s_sep)
    if sep > concentric_tol + 3 * s_sep:
        return not_found(METHOD, f"the circles' centres differ by {sep:.2f} px: not concentric", **diag)
    # every other well-supported circle around the centre must share it (a pair of rings offset by a pixel
    # or two passes the Hough and coverage tests)
    rest_idx = np.nonzero(lab < 0)[0]
    if rest_idx.size >= 8:
        rest = EdgePoints(ep.x[rest_idx], ep.y[rest_idx], ep.nx[rest_idx], ep.ny[rest_idx], ep.mag[rest_idx],
                          ep.col[rest_idx], ep.row[rest_idx], ep.edge_map, ep.noise)
        for r_o, cov_o in estimate_radii(rest, cx, cy, min_radius, r_max, 3, radial_cos=radial_cos,
                                         min_coverage=min_coverage):
            if cov_o < min_coverage:
                continue
            lo = de_hough(rest, cx, cy, [r_o], dehough_tol, radial_cos) == 0
            fo = fit_concentric_circles(rest.x[lo], rest.y[lo], np.zeros(int(lo.sum()), int), (r_o,), (cx, cy))
            if fo is None:
                continue
            d_o = float(np.hypot(fo.x0 - cx, fo.y0 - cy))
            s_o = float(np.sqrt(fo.cov[0, 0] + fo.cov[1, 1] + fit.cov[0, 0] + fit.cov[1, 1]))
            if d_o > concentric_tol + 3 * s_o:
                return not_found(METHOD, f"another circle (radius {fo.radii[0]:.1f} px) is centred {d_o:.2f} px "
                                         f"away: circles not concentric", **diag)
    # competing circular structure elsewhere in the window: a strong centre peak away from ours around which
    # edge points that are not on our circles form a well-supported circle (e.g. two non-concentric rings)
    comp = _competitor(w, ep, votes, cx, cy, use_radii, lab, min_radius, r_max, competitor_ratio, min_coverage,
                       radial_cos)
    diag["competitor"] = comp
    if comp is not None:
        ox, oy, rr, cov_o = comp
        return not_found(METHOD, f"another circle (radius {rr:.1f} px, {cov_o:.0%} of it) centred at ({ox:.1f}, "
                                 f"{oy:.1f}) competes with ({cx:.1f}, {cy:.1f}): circles not concentric or more "
                                 f"than one mark", **diag)

    expected = _expected_edge_rms(ep, lab, canny_sigma)
    if fit.sigma0 > max_rms_ratio * expected:
        return not_found(METHOD, f"the edge points scatter {fit.sigma0:.2f} px about the adjusted circles, "
                                 f"{fit.sigma0 / expected:.1f} times what the noise explains: not a clean pair of "
                                 f"concentric circles", **diag)
    sx, sy = fit.sigma_xy
    sigma = 0.5 * (sx + sy) * np.sqrt(EDGE_CORRELATION)
    # score: circumference support, fit quality (edge residual RMS vs what the noise explains), concentricity
    s_cover = min(1.0, min(cover) / 0.9)
    s_fit = float(min(1.0, 2.0 * expected / max(fit.sigma0, 1e-9)))
    s_conc = float(np.exp(-0.5 * (sep / (concentric_tol / 2 + 3 * s_sep)) ** 2))
    score = float(np.clip(min(s_cover, s_fit, s_conc), 0.0, 1.0))
    diag.update(score_parts={"coverage": s_cover, "fit": s_fit, "concentric": s_conc}, expected_rms=expected)
    return Detection(status=FOUND, x=float(cx), y=float(cy), score=score, sigma=float(sigma), method=METHOD,
                     diagnostics=diag)


def _competitor(window: np.ndarray, ep: EdgePoints, votes: np.ndarray, cx: float, cy: float, radii: list[float],
                lab: np.ndarray, r_min: float, r_max: float, ratio: float, min_coverage: float, radial_cos: float,
                max_peaks: int = 4):
    """The strongest competing circle (x, y, radius, coverage) or None: local maxima of the centre votes at least
    ``ratio`` of ours and more than max(3, R_min / 4) px from (cx, cy), around which the edge points *not* on
    our circles hold a circle covered on ``min_coverage`` of its circumference, unless that circle is the
    rim of a dark notch around the mark (:func:`_notch_rim`)."""
    h, w = votes.shape
    main = float(votes[int(round(np.clip(cy, 0, h - 1))), int(round(np.clip(cx, 0, w - 1)))])
    if main <= 0:
        return None
    vc = votes.copy()
    yy, xx = np.mgrid[0:h, 0:w]
    vc[np.hypot(xx - cx, yy - cy) <= max(3.0, 0.25 * min(radii))] = 0
    dil = cv2.dilate(vc, np.ones((5, 5), np.uint8))
    pk = np.nonzero((vc >= dil) & (vc >= ratio * main))
    if pk[0].size == 0:
        return None
    order = np.argsort(-vc[pk])[:max_peaks]
    others = lab < 0
    if others.sum() < 8:
        return None
    rest = EdgePoints(ep.x[others], ep.y[others], ep.nx[others], ep.ny[others], ep.mag[others],
                      ep.col[others], ep.row[others], ep.edge_map, ep.noise)
    for i in order:
        oy, ox = float(pk[0][i]), float(pk[1][i])
        found = estimate_radii(rest, ox, oy, r_min, r_max, 1, radial_cos=radial_cos)
        if found and found[0][1] >= min_coverage:
            if _notch_rim(window, ep.noise, cx, cy, radii, ox, oy, found[0][0]):
                continue
            return ox, oy, found[0][0], found[0][1]
    return None


def _notch_rim(window: np.ndarray, noise: float, cx: float, cy: float, radii: list[float], ox: float, oy: float,
               r: float) -> bool:
    """Whether the circle (ox, oy, r) is the rim of a dark notch holding the mark (the film border's rounded
    notch around Wild RC20 marks): it encloses the mark's circles with ``ENCLOSE_MARGIN`` px to spare and is a
    step up, not a ring: 2-6 px outside it the grey level stays at least max(6 noise, 0.05) above the level
    2-6 px inside it (a bright ring's edge falls back to the dark ground within its width)."""
    if np.hypot(ox - cx, oy - cy) + max(radii) + ENCLOSE_MARGIN > r:
        return False
    h, w = window.shape
    yy, xx = np.mgrid[0:h, 0:w]
    d = np.hypot(xx - ox, yy - oy)
    inside, outside = window[(d >= r - 6) & (d <= r - 2)], window[(d >= r + 2) & (d <= r + 6)]
    if inside.size < 20 or outside.size < 20:
        return False
    return float(np.median(outside) - np.median(inside)) >= max(6.0 * noise, 0.05)


def _expected_edge_rms(ep: EdgePoints, lab: np.ndarray, canny_sigma: float) -> float:
    """Edge position scatter the noise alone explains, plus the Devernay/pixel-grid quantisation floor:
    sqrt((gradient noise / (|gradient| / (edge width)))^2 + 0.05^2), using the median gradient on the
    circles and an edge width of sqrt(1 + canny_sigma^2) px."""
    g = float(np.median(ep.mag[lab >= 0])) if (lab >= 0).any() else 1.0
    g_noise = ep.noise * _gradient_noise_gain(canny_sigma)
    width = np.sqrt(1.0 + canny_sigma ** 2)
    return float(np.hypot(g_noise / max(g, 1e-9) * width, 0.05))
