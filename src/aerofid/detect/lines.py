"""Two crossing lines: local dynamic thresholding and the Hough transform (Sohn et al., seed 004).

The procedure of seed 004 (section 2, figure 2, and section 4) on one window:

1. **Binary image by local dynamic thresholding** -- a bimodal threshold per local 8 x 8 region
   (:func:`aerofid.detect.threshold.local_dynamic_threshold`), "two classes (foreground and background)".
2. **Hough transform of the foreground pixels** in the polar form ``rho = x cos(theta) + y sin(theta)``
   (seed eq. 3), ``0 <= theta < 180`` degrees (eq. 5) (:func:`hough_transform`, the package's one accumulator
   :func:`aerofid.detect.hough_lines.accumulate`).
3. **Two peaks**, one per direction of the mark: the strongest cell, and the strongest cell whose direction
   differs from it by at least ``min_angle`` ("with proper selection of theta, the noise element was able to be
   removed") -- "two peaks represented in accumulator array are mapped into two straight lines".
4. **Intersection of the lines** = the centre ("we calculated the intersection of the lines";
   :func:`aerofid.detect.hough_lines.intersection`).

The seed stops at the Hough cell (its centres in Table 2 are on a half-pixel grid). To reach a fraction of a
pixel, each line is then refined (:func:`fit_line`) by a grey-value weighted least-squares fit of the pixels in
a band around it: the band is cut into 1 px slices across the line, the grey-weighted centroid of each slice
is an observation of the line's offset, and a straight line is fitted to the centroids by least squares;
pixels in the other line's band are left out. Band, background and fit are iterated. The intersection of the
two fitted lines is the centre, its covariance propagated from the two fitted offsets.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from aerofid.conventions import FOUND
from aerofid.detect.asymmetry import point_asymmetry
from aerofid.detect.hough_lines import accumulate, intersection, theta_grid
from aerofid.detect.lines_params import LinesParams
from aerofid.detect.result import Detection, Refused, unusable_window
from aerofid.detect.threshold import local_dynamic_threshold
from aerofid.robust import difference_noise_sigma, median, percentile, robust_std

if TYPE_CHECKING:
    from matplotlib.figure import Figure

METHOD = "lines"

MIN_FOREGROUND = 10
"""Fewest foreground pixels of the binary image for a Hough transform."""
MAX_HOUGH_SHIFT = 3.0
"""The least-squares lines may move the intersection at most this far (px, per axis) from the Hough lines'."""
SLICE_LENGTH = 8.0
"""Length (px) along the line of each stretch whose background plane is fitted separately."""

DEFAULT = LinesParams()


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


@dataclass(frozen=True)
class ScoreParts:
    """The parts of the score (each in [0, 1]; the score is the smallest)."""

    arms: float
    angle: float
    peaks: float
    fit: float


@dataclass(frozen=True, eq=False)
class HoughPeaks:
    """The Hough transform of the binary image and its two peaks (seed 004, figure 5)."""

    accumulator: np.ndarray = field(repr=False)
    smoothed: np.ndarray = field(repr=False)
    thetas: np.ndarray = field(repr=False)   # radians
    rhos: np.ndarray = field(repr=False)     # cell centres, px
    first: tuple[int, int, float]            # (theta index, rho index, smoothed votes)
    second: tuple[int, int, float]

    @property
    def lines(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The two peaks as lines (theta in radians, rho in px)."""
        (i1, j1, _), (i2, j2, _) = self.first, self.second
        return ((float(self.thetas[i1]), float(self.rhos[j1])), (float(self.thetas[i2]), float(self.rhos[j2])))


@dataclass(frozen=True)
class LinesResult(Detection):
    """The answer of the ``lines`` method with its intermediate results (window pixels).

    Attributes
    ----------
    binary, thresholds : ndarray or None
        The binary image of local dynamic thresholding and its per-pixel threshold surface.
    peaks : HoughPeaks or None
        The Hough accumulator of the binary image with its two peaks.
    hough_centre : tuple of float or None
        The intersection of the two Hough lines (the seed's answer, to a Hough cell).
    lines : tuple of LineFit
        The two refined lines (empty before the refinement).
    asymmetry : float
        Share of the structure about the intersection that changes under a half turn (NaN if not measured).
    covariance : ndarray
        2 x 2 covariance of the centre (px^2), from ``sigma_x``, ``sigma_y``, ``cov_xy`` (NaN when not found).
    score_parts : ScoreParts or None
        The parts of the score.
    """

    binary: np.ndarray | None = field(default=None, compare=False, repr=False)
    thresholds: np.ndarray | None = field(default=None, compare=False, repr=False)
    peaks: HoughPeaks | None = field(default=None, compare=False, repr=False)
    hough_centre: tuple[float, float] | None = None
    lines: tuple[LineFit, ...] = field(default=(), compare=False, repr=False)
    asymmetry: float = float("nan")
    score_parts: ScoreParts | None = None

    @property
    def fitted_lines(self) -> tuple[tuple[float, float], ...]:
        """The refined lines as (theta in radians, rho in px)."""
        return tuple((f.theta, f.rho) for f in self.lines)

    @property
    def extent(self) -> float | None:
        """The mark's radius (px): the longest supported arm of the refined lines plus 1 px; None without them."""
        if not self.lines:
            return None
        return float(max(max(f.arms) for f in self.lines) + 1.0)

    def plot(self, fig: Figure, window: np.ndarray) -> None:
        """The binary image of local dynamic thresholding with the Hough lines (dashed), the refined lines and
        the centre; without a binary image, ``window`` with the reason (:meth:`Detection.plot`)."""
        if self.binary is None:
            super().plot(fig, window)
            return
        ax = fig.add_subplot(1, 1, 1)
        h, w = self.binary.shape
        ax.imshow(self.binary, cmap="gray", interpolation="nearest")
        hough = self.peaks.lines if self.peaks is not None else ()
        for lines, style in ((hough, "--"), (self.fitted_lines, "-")):
            for theta, rho in lines:
                _draw_line(ax, theta, rho, w, h, style)
        if self.found:
            ax.plot([self.x - self.origin[0]], [self.y - self.origin[1]], "+", color="orange", ms=14, mew=2)
            title = f"lines: ({self.x:.3f}, {self.y:.3f}) sigma {self.sigma:.3f} px"
        else:
            title = f"lines: not found: {self.reason}"
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
        ax.set_title(title[:90], fontsize=9)


def _draw_line(ax: Any, theta: float, rho: float, w: int, h: int, style: str) -> None:
    """Draw x cos(theta) + y sin(theta) = rho across a w x h image."""
    c, s = np.cos(theta), np.sin(theta)
    p0 = np.array([c * rho, s * rho])
    d = np.array([-s, c]) * float(np.hypot(w, h))
    ax.plot([p0[0] - d[0], p0[0] + d[0]], [p0[1] - d[1], p0[1] + d[1]], style, color="deepskyblue", lw=1)


# --- the seed's steps: binary image, Hough transform, two peaks ------------------------------------------

def hough_transform(binary: np.ndarray, theta_step: float = 0.5,
                    rho_step: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hough accumulator of the foreground pixels of ``binary`` (seed 004 eq. 3-5;
    :func:`aerofid.detect.hough_lines.accumulate`).

    Returns ``(acc, thetas, rhos)``: ``acc[i, j]`` counts pixels with ``x cos(thetas[i]) + y sin(thetas[i])``
    in the ``rho_step`` cell centred on ``rhos[j]``; thetas in radians on [0, pi)."""
    h, w = binary.shape
    ys, xs = np.nonzero(binary)
    thetas = np.deg2rad(theta_grid(theta_step))
    r_max = float(np.ceil(np.hypot(h, w) / rho_step) * rho_step)  # rho cells centred on multiples of rho_step
    n_rho = int(np.ceil(2 * r_max / rho_step)) + 1
    rhos = -r_max + rho_step * np.arange(n_rho)
    acc = accumulate(xs, ys, thetas, -r_max - rho_step / 2.0, rho_step, n_rho)
    return acc, thetas, rhos


def _angle_diff(a: np.ndarray | float, b: float) -> np.ndarray:
    """Smallest difference between line directions (radians, modulo pi)."""
    d = np.abs(np.asarray(a) - b) % np.pi
    return np.minimum(d, np.pi - d)


def two_peaks(acc: np.ndarray, thetas: np.ndarray,
              min_angle_deg: float = 45.0) -> tuple[tuple[int, int, float], tuple[int, int, float], np.ndarray]:
    """The strongest Hough cell and the strongest cell at least ``min_angle_deg`` away in direction.

    The accumulator is smoothed with (1, 2, 1) / 4 over rho first (a bar 2 px wide, or a diagonal one, spreads
    over neighbouring cells).
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


def hough_peaks(binary: np.ndarray, params: LinesParams = DEFAULT) -> HoughPeaks:
    """Steps 2 and 3 of seed 004: the Hough transform of ``binary`` and its two peaks."""
    acc, thetas, rhos = hough_transform(binary, params.theta_step, params.rho_step)
    first, second, smoothed = two_peaks(acc, thetas, params.min_angle)
    return HoughPeaks(acc, smoothed, thetas, rhos, first, second)


def bar_half_width(acc: np.ndarray, i: int, j: int, rho_step: float, reach: int = 10) -> float:
    """Half the width (px) of the ridge across rho at theta index ``i``: the run of cells around ``j`` above
    half-way between the peak and the local base (25th percentile of the cells within ``reach`` px), so the
    plateau a ring adds under the bar does not count as bar."""
    prof = acc[i]
    peak = prof[j]
    r = max(3, int(round(reach / rho_step)))
    near = prof[max(0, j - r):j + r + 1]
    base = percentile(near, 25)
    level = 0.5 * (peak + base)
    lo = j
    while lo > 0 and prof[lo - 1] >= level:
        lo -= 1
    hi = j
    while hi < prof.size - 1 and prof[hi + 1] >= level:
        hi += 1
    return 0.5 * (hi - lo + 1) * rho_step


# --- beyond the seed: each line refined to sub-pixel -----------------------------------------------------

RING_WIDTH = 3.0
"""Width (px) of the strips beside a line's band whose pixels measure its local background (:func:`_ground_ring`)."""


@dataclass(frozen=True, eq=False)
class _Frame:
    """The window's pixels near a line (``near``: a mask of the window's pixels, row by row) in the line's frame:
    grey value, offset v across and position u along it, column and row."""

    g: np.ndarray
    v: np.ndarray
    u: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    near: np.ndarray


def _frame(window: np.ndarray, theta: float, rho: float, reach: float) -> _Frame:
    """The window's pixels within ``reach`` px of the line ``x cos(theta) + y sin(theta) = rho`` in its frame, in
    the window's order: a line's fit reads no pixel beyond its band and the strips beside it (on bench_peers.py's
    200 px boxes 6-13 % of the pixels, on ``auto``'s cross-check windows of about 50 px a third). Each pixel's
    values are those of the whole window's arrays, to the bit (elementwise arithmetic), and every sum over them adds
    the same terms in the same order."""
    n = np.array([np.cos(theta), np.sin(theta)])
    t = np.array([-np.sin(theta), np.cos(theta)])
    xs, ys = _pixel_coordinates(window.shape)
    v = xs * n[0] + ys * n[1] - rho
    near = np.abs(v) <= reach
    xs, ys = xs[near], ys[near]
    return _Frame(window.ravel()[near].astype(np.float64), v[near], xs * t[0] + ys * t[1], n, t, xs, ys, near)


@functools.lru_cache(maxsize=8)
def _pixel_coordinates(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Every pixel's column and row (float64, row by row) of a window of ``shape``: made once per shape (a fit
    refines each line a dozen times on the same window); read-only."""
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    xs, ys = xx.ravel().astype(np.float64), yy.ravel().astype(np.float64)
    xs.setflags(write=False)
    ys.setflags(write=False)
    return xs, ys


def _ground_ring(fr: _Frame, band: float, other: tuple[float, float, float] | None,
                 background_mask: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, float]:
    """The pixels to use: ``keep`` (not in the ``other`` line's band), and the ``ring`` of strips
    :data:`RING_WIDTH` px wide beside the band that measures the local background (without ``background_mask``
    pixels), with the fraction of that ring the mask covers."""
    keep = np.ones(fr.v.shape, bool)
    if other is not None:
        th2, rho2, band2 = other
        keep &= np.abs(fr.xs * np.cos(th2) + fr.ys * np.sin(th2) - rho2) > band2
    ring = (np.abs(fr.v) > band) & (np.abs(fr.v) <= band + RING_WIDTH) & keep
    side_fg = 0.0
    if background_mask is not None:
        bm = background_mask.ravel()[fr.near]
        side_fg = float(bm[ring].mean()) if ring.any() else 1.0
        ring &= ~bm
    return keep, ring, side_fg


def _local_background(fr: _Frame, ring: np.ndarray, uc: float, band: float, at: np.ndarray) -> np.ndarray:
    """Local background at the pixels ``at`` (a mask): a plane g = c0 + c1 v + c2 u fitted to the strips just
    outside the band, per ``SLICE_LENGTH`` px stretch of the line (a ramp of the film density across the band would
    otherwise move the centroids); one plane for the whole ring where a stretch does not have both sides. The
    stretches' planes are solved together (:func:`_stretch_planes`); the whole ring's plane only where needed."""
    u = fr.u - uc
    key = np.floor(u / SLICE_LENGTH).astype(np.int64)
    key -= key.min()
    g, v, ur, kr = fr.g[ring], fr.v[ring], u[ring], key[ring]
    v_at, u_at, k_at = fr.v[at], u[at], key[at]
    planes = _stretch_planes(kr, g, v, ur, band, int(key.max()) + 1)
    bg = np.empty(v_at.shape)
    on = planes.fitted[k_at]
    k = k_at[on]
    bg[on] = planes.c0[k] + planes.c1[k] * (v_at[on] - planes.v0[k]) + planes.c2[k] * (u_at[on] - planes.u0[k])
    rest = ~on
    for k in planes.solo:   # a stretch whose plane is ill-conditioned: least squares on its own
        m, on = kr == k, k_at == k
        bg[on] = _plane(g[m], v[m], ur[m], v_at[on], u_at[on])
        rest &= ~on
    if rest.any():
        bg[rest] = _plane(g, v, ur, v_at[rest], u_at[rest])
    return bg


@dataclass(frozen=True, eq=False)
class _StretchPlanes:
    """Planes ``g = c0 + c1 (v - v0) + c2 (u - u0)`` per stretch (index = stretch number), ``fitted`` where one
    was solved here; ``solo``: stretches to fit on their own."""

    fitted: np.ndarray
    c0: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    v0: np.ndarray
    u0: np.ndarray
    solo: tuple[int, ...]


ILL_CONDITIONED = 1e-10
"""A stretch's centred normal matrix whose determinant is below this fraction of the product of its diagonal
(nearly collinear samples) is solved by least squares on its own (:func:`_plane`)."""


MIN_SPREAD = 1e-6
"""... and so is one whose samples, once v is accounted for, spread along the line by less than this (px^2 per
sample)."""


def _stretch_planes(key: np.ndarray, g: np.ndarray, v: np.ndarray, u: np.ndarray, band: float,
                    n: int) -> _StretchPlanes:
    """Least-squares planes of the ring samples (g, v, u) per stretch ``key`` (0..n-1), for every stretch with at
    least 8 samples whose v spans more than ``band`` (both sides of the band, for a ring of strips narrower than
    the band): normal equations of the samples centred on their stretch's means (so the slopes decouple from the
    mean), all stretches at once."""
    count = np.bincount(key, minlength=n).astype(np.float64)
    vmin, vmax = np.full(n, np.inf), np.full(n, -np.inf)
    np.minimum.at(vmin, key, v)
    np.maximum.at(vmax, key, v)
    fit = (count >= 8) & (vmax - vmin > band)
    safe = np.maximum(count, 1.0)
    v0, u0, c0 = (np.bincount(key, weights=x, minlength=n) / safe for x in (v, u, g))
    dv, du, dg = v - v0[key], u - u0[key], g - c0[key]
    svv, suu, svu, sgv, sgu = (np.bincount(key, weights=x, minlength=n)
                               for x in (dv * dv, du * du, dv * du, dg * dv, dg * du))
    det = svv * suu - svu * svu
    # the spread of u left once v explains what it can (det / svv per sample) must also be real: samples on one
    # pixel line at a bar angle a rounding error off an axis leave a relative test satisfied
    good = (det > ILL_CONDITIONED * svv * suu) & (det > MIN_SPREAD * svv * safe)
    inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
    c1, c2 = (suu * sgv - svu * sgu) * inv, (svv * sgu - svu * sgv) * inv
    solo = tuple(np.flatnonzero(fit & ~good).tolist())
    return _StretchPlanes(fit & good, c0, c1, c2, v0, u0, solo)


def _columns(*columns: np.ndarray) -> np.ndarray:
    """The design matrix ``np.column_stack([np.ones_like(c), *columns])`` of float64 columns (the same array, built
    without column_stack's generality: the refinement asks for three per step)."""
    X = np.empty((columns[0].size, 1 + len(columns)))
    X[:, 0] = 1.0
    for k, c in enumerate(columns, 1):
        X[:, k] = c
    return X


def _plane(g: np.ndarray, v: np.ndarray, u: np.ndarray, v_at: np.ndarray, u_at: np.ndarray) -> np.ndarray:
    """Least-squares plane ``g = c0 + c1 v + c2 u`` through the samples, evaluated at (v_at, u_at); the median
    when the samples do not determine a plane."""
    X = _columns(v, u)
    if g.size >= 4:
        coef, *_ = np.linalg.lstsq(X, g, rcond=None)
        if np.all(np.isfinite(coef)):
            return coef[0] + coef[1] * v_at + coef[2] * u_at
    return np.full(np.shape(v_at), float(median(g)) if g.size else 0.0)


@dataclass(frozen=True, eq=False)
class _Slices:
    """The 1 px slices across the line kept as bar: centroid offsets V at positions U (relative to the
    intersection), the noise-only variance of each centroid, and the bar's contrast over the noise."""

    U: np.ndarray
    V: np.ndarray
    var_noise: np.ndarray
    contrast: float


def _slice_centroids(us: np.ndarray, vs: np.ndarray, wgt: np.ndarray, q: np.ndarray,
                     noise: float) -> _Slices | None:
    """Group the band's pixels into 1 px slices along the line; each slice of the bar itself (weight near the
    typical one: a ring crossing the band, or the centre dot, makes a slice much heavier; the bar's end or a gap
    much lighter) gives its weighted centroid across the line. None with fewer than 4 such slices."""
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
    pos = W > 0
    if pos.sum() < 4:
        return None
    good = (W >= 0.3 * percentile(W[pos], 90)) & (cnt >= 2)
    if good.sum() < 4:
        return None
    med = float(median(W[good]))
    good &= (W >= 0.5 * med) & (W <= 1.6 * med)
    if good.sum() < 4:
        return None
    V = Wv[good] / W[good]
    # noise-only variance of each centroid: noise^2 * sum_i q_i^2 (v_i - V)^2 / W^2
    var_noise = noise * noise * (Wv2[good] - 2 * V * Wv1[good] + Wq2[good] * V * V) / W[good] ** 2
    # the bar must stand out of its sides: the slice weights against the noise of a weight
    w_noise = noise * float(np.sqrt(median(Wq2[good])))
    contrast = float(median(W[good])) / max(w_noise, 1e-9)
    U = (np.arange(nb) + k0)[good].astype(np.float64)
    return _Slices(U, V, var_noise, contrast)


def _fit_offsets(sl: _Slices) -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray] | None:
    """Least-squares line V = a + b U through the centroids after one round of outlier rejection (residuals
    beyond 3.5 robust sigma, and 0.1 px, of a first fit). Returns (coef, Qx, rms, expected rms, U inliers)."""
    X = _columns(sl.U)
    c0, *_ = np.linalg.lstsq(X, sl.V, rcond=None)
    r0 = sl.V - X @ c0
    inl = np.abs(r0) <= max(3.5 * robust_std(r0), 0.1)
    if inl.sum() < 4:
        return None
    V, U, var_noise = sl.V[inl], sl.U[inl], sl.var_noise[inl]
    X = _columns(U)
    try:
        Qx = np.linalg.inv(X.T @ X)
    except np.linalg.LinAlgError:
        return None
    coef = Qx @ (X.T @ V)
    res = V - X @ coef
    s0 = float(np.sqrt(res @ res / max(1, U.size - 2)))
    return coef, Qx, s0, math.sqrt(float(var_noise.mean())), U


def _moved_line(fr: _Frame, rho: float, a: float, b: float, uc: float) -> tuple[float, float]:
    """The line through the points v = a + b (u - uc): p.(n - b t) = rho + a - b uc, normalised, theta on
    [0, pi)."""
    nn = fr.normal - b * fr.tangent
    norm = float(np.hypot(*nn))
    new_theta = float(np.arctan2(nn[1], nn[0]))
    new_rho = (rho + a - b * uc) / norm
    if new_theta < 0:
        new_theta += np.pi
        new_rho = -new_rho
    if new_theta >= np.pi:
        new_theta -= np.pi
        new_rho = -new_rho
    return new_theta, float(new_rho)


def fit_line(window: np.ndarray, theta: float, rho: float, half_width: float, centre: np.ndarray,
             other: tuple[float, float, float] | None, noise: float, band_margin: float = 2.0,
             background_mask: np.ndarray | None = None, taper: float = 1.0) -> LineFit | None:
    """One refinement step of a line (seed 004's Hough line, refined to sub-pixel).

    Pixels within ``half_width + band_margin`` px of the line (and not in the ``other`` line's band
    ``(theta, rho, half_band)``) are weighted by their grey level minus the local background
    (:func:`_local_background`), tapered across the line by a Gaussian of ``taper`` half-widths, grouped into
    1 px slices along the line, and each slice's weighted centroid across the line is one observation ``v_b``
    (:func:`_slice_centroids`); ``v_b = a + b (u_b - u_c)`` is fitted by least squares (``u_c`` = the current
    intersection ``centre`` projected on the line), and ``a`` and ``b`` move and turn the line. The offset's
    standard deviation is the a-posteriori one of the fit, but never below what the window's ``noise`` alone
    gives the centroids. None when the line has too little support.
    """
    band = half_width + band_margin
    fr = _frame(window, theta, rho, band + RING_WIDTH)
    keep, ring, side_fg = _ground_ring(fr, band, other, background_mask)
    if ring.sum() < 6:
        return None
    uc = float(centre @ fr.tangent)
    sel = (np.abs(fr.v) <= band) & keep
    if sel.sum() < 10:
        return None
    bg = _local_background(fr, ring, uc, band, sel)
    us, vs = fr.u[sel] - uc, fr.v[sel]
    # Gaussian taper across the line (a matched filter): the slice centroid converges, over the iterations, to
    # the peak of the profile smoothed by the taper, and the noise of the pixels far from the bar is damped
    q = np.exp(-0.5 * (vs / max(taper * half_width, 0.5)) ** 2) if taper > 0 else np.ones_like(vs)
    slices = _slice_centroids(us, vs, (fr.g[sel] - bg) * q, q, noise)
    fit = None if slices is None else _fit_offsets(slices)
    if slices is None or fit is None:
        return None
    coef, Qx, s0, expected, U = fit
    s = max(s0, expected)
    new_theta, new_rho = _moved_line(fr, rho, float(coef[0]), float(coef[1]), uc)
    arms = (int((U < -band).sum()), int((U > band).sum()))
    return LineFit(new_theta, new_rho, s * float(np.sqrt(Qx[0, 0])), s * float(np.sqrt(Qx[1, 1])), s0, expected,
                   int(U.size), arms, half_width, slices.contrast, side_fg)


# --- the pipeline ----------------------------------------------------------------------------------------

def _seed_lines(binary: np.ndarray, params: LinesParams, fields: dict[str, Any]) -> tuple[HoughPeaks, np.ndarray]:
    """Seed 004's answer: the two Hough peaks (:func:`hough_peaks`) and their intersection, checked (two
    directions, not parallel, inside the window)."""
    n_fg = int(binary.sum())
    if n_fg < MIN_FOREGROUND:
        raise Refused(f"local dynamic thresholding found no mark ({n_fg} foreground pixels)")
    peaks = hough_peaks(binary, params)
    fields["peaks"] = peaks
    v1, v2 = peaks.first[2], peaks.second[2]
    if v2 <= 0 or v2 < params.min_peak_ratio * v1:
        raise Refused(f"only one dominant direction in the Hough space (second peak {v2:.0f} votes vs {v1:.0f})")
    (t1, r1), (t2, r2) = peaks.lines
    c = intersection(t1, r1, t2, r2)
    if c is None:
        raise Refused("the two Hough lines are parallel")
    fields["hough_centre"] = c
    h, w = binary.shape
    if not (-0.5 <= c[0] <= w - 0.5 and -0.5 <= c[1] <= h - 0.5):
        raise Refused("the Hough lines intersect outside the window")
    return peaks, np.array(c)


def _half_widths(peaks: HoughPeaks, shape: tuple[int, ...], rho_step: float) -> list[float]:
    """Bar half-widths from the smoothed ridges of the two peaks (a diagonal bar's raw rho profile alternates
    between cells); a line wider than 1/4 of the window (at least 6 px) is an edge or a blob."""
    hw = [max(1.0, bar_half_width(peaks.smoothed, i, j, rho_step)) for i, j, _ in (peaks.first, peaks.second)]
    if max(hw) > max(3.0, 0.125 * min(shape)):
        raise Refused(f"a Hough line is {2 * max(hw):.0f} px wide: an edge or a blob, not a bar")
    return hw


def refine_lines(w: np.ndarray, binary: np.ndarray, peaks: HoughPeaks, centre: np.ndarray, hw: list[float],
                 noise: float, params: LinesParams = DEFAULT) -> tuple[list[LineFit], np.ndarray]:
    """Refine both Hough lines (:func:`fit_line`), each with the other's band left out, until the intersection
    moves less than ``converged`` or ``iterations`` are done (``noise``: the window's grey-level noise).
    Returns the fits and their intersection."""
    # foreground (dilated by 1 px) is kept out of the background estimate: the ring of a Wild mark crosses
    # the strips beside the lines
    fg_near = cv2.dilate(binary.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    cur = list(peaks.lines)
    c = centre
    fits: list[LineFit] = []
    for _ in range(params.iterations):
        fits = []
        for k in (0, 1):
            o = 1 - k
            other = (cur[o][0], cur[o][1], hw[o] + params.band_margin)
            f = fit_line(w, cur[k][0], cur[k][1], hw[k], c, other, noise, params.band_margin,
                         background_mask=fg_near, taper=params.taper)
            if f is None:
                raise Refused(f"line {k + 1} has too little support for a least-squares fit")
            fits.append(f)
        cur = [(f.theta, f.rho) for f in fits]
        c_new = intersection(*cur[0], *cur[1])
        if c_new is None:
            raise Refused("the fitted lines are parallel")
        moved = float(np.hypot(*(np.array(c_new) - c)))
        c = np.array(c_new)
        if moved < params.converged:
            break
    return fits, c


def line_refusal(fits: list[LineFit], params: LinesParams = DEFAULT) -> str | None:
    """Why the refined lines are not the bars of a '+' (an edge or a blob beside a line, a line hardly
    standing out of its sides, a line supported on one side of the intersection only), or None."""
    for k, f in enumerate(fits):
        if f.side_foreground > params.max_side_foreground:
            return (f"line {k + 1} runs inside a bright area ({f.side_foreground:.0%} of its sides are "
                    "foreground): an edge or a blob, not a bar")
        if f.contrast < params.min_contrast:
            return f"line {k + 1} hardly stands out of its sides ({f.contrast:.1f} noise sigma): an edge, not a bar"
    for k, f in enumerate(fits):
        lo, hi = min(f.arms), max(f.arms)
        if lo < params.min_arm or lo < params.min_arm_ratio * hi:
            return (f"line {k + 1} is supported on one side of the intersection only ({f.arms[0]} / {f.arms[1]} "
                    "px): a 'T' or 'L', or a mark cut by the window edge")
    return None


def _check_geometry(fits: list[LineFit], c: np.ndarray, shape: tuple[int, ...], hough_centre: tuple[float, float],
                    params: LinesParams) -> float:
    """The refined intersection lies in the window, near the Hough one, at an angle of at least ``min_angle``;
    returns that angle (radians)."""
    h, wd = shape
    x, y = float(c[0]), float(c[1])
    if not (0 <= x <= wd - 1 and 0 <= y <= h - 1):
        raise Refused("the fitted lines intersect outside the window")
    if abs(x - hough_centre[0]) > MAX_HOUGH_SHIFT or abs(y - hough_centre[1]) > MAX_HOUGH_SHIFT:
        raise Refused(f"the least-squares lines moved more than {MAX_HOUGH_SHIFT:g} px from the Hough lines")
    angle = float(_angle_diff(fits[0].theta, fits[1].theta))
    if angle < np.deg2rad(params.min_angle):
        raise Refused(f"the fitted lines cross at only {np.rad2deg(angle):.0f} degrees")
    return angle


def _half_turn_asymmetry(w: np.ndarray, fits: list[LineFit], c: np.ndarray, noise: float, params: LinesParams,
                         fields: dict[str, Any]) -> None:
    """Beyond the seed: the window must be centrally symmetric about the intersection (``max_asymmetry``)."""
    h, wd = w.shape
    x, y = float(c[0]), float(c[1])
    reach = min(max(max(f.arms) for f in fits) + 2.0, x, y, wd - 1 - x, h - 1 - y)
    asym = point_asymmetry(w, x, y, max(reach, 3.0), noise)
    fields["asymmetry"] = asym
    if not asym <= params.max_asymmetry:
        raise Refused(f"the window is not centrally symmetric about the intersection ({asym:.2f} of the "
                       f"structure within {reach:.0f} px changes under a half turn; limit {params.max_asymmetry}): "
                       "not the centre of a '+'")


def centre_covariance(fits: list[LineFit], offset_floor: float = 0.03) -> np.ndarray:
    """Covariance of the intersection from the two lines' offsets, each with ``offset_floor`` added in
    quadrature (rotation about the intersection does not move it)."""
    N = np.array([[np.cos(f.theta), np.sin(f.theta)] for f in fits])
    Ni = np.linalg.inv(N)
    return Ni @ np.diag([f.sigma_offset ** 2 + offset_floor ** 2 for f in fits]) @ Ni.T


def score_parts(fits: list[LineFit], angle: float, peaks: HoughPeaks) -> ScoreParts:
    """Arm balance, angle, peak balance and fit quality, each scaled to [0, 1]."""
    v1, v2 = peaks.first[2], peaks.second[2]
    return ScoreParts(arms=min(1.0, min(min(f.arms) / max(f.arms) for f in fits) / 0.5),
                      angle=float(min(1.0, np.sin(angle) / np.sin(np.deg2rad(60.0)))),
                      peaks=min(1.0, (v2 / v1) / 0.6),
                      fit=min(1.0, min(2.0 * (f.expected_rms + 0.05) / max(f.rms, 1e-9) for f in fits)))


def _locate(w: np.ndarray, params: LinesParams, fields: dict[str, Any]) -> LinesResult:
    """The whole pipeline on a usable window; every intermediate result goes into ``fields``; a step that finds
    no mark raises :class:`Refused`."""
    binary, surface = local_dynamic_threshold(w, params.region, return_thresholds=True)
    fields.update(binary=binary, thresholds=surface)
    peaks, c = _seed_lines(binary, params, fields)
    hw = _half_widths(peaks, w.shape, params.rho_step)
    noise = difference_noise_sigma(w)
    fits, c = refine_lines(w, binary, peaks, c, hw, noise, params)
    fields["lines"] = tuple(fits)
    angle = _check_geometry(fits, c, w.shape, fields["hough_centre"], params)
    reason = line_refusal(fits, params)
    if reason is not None:
        raise Refused(reason)
    _half_turn_asymmetry(w, fits, c, noise, params, fields)
    cov = centre_covariance(fits, params.offset_floor)
    parts = score_parts(fits, angle, peaks)
    score = float(np.clip(min(parts.arms, parts.angle, parts.peaks, parts.fit), 0.0, 1.0))
    return LinesResult(status=FOUND, x=float(c[0]), y=float(c[1]), score=score,
                       sigma=float(0.5 * (np.sqrt(cov[0, 0]) + np.sqrt(cov[1, 1]))), method=METHOD,
                       sigma_x=float(np.sqrt(cov[0, 0])), sigma_y=float(np.sqrt(cov[1, 1])),
                       cov_xy=float(cov[0, 1]), score_parts=parts, **fields)


def detect(window: np.ndarray, params: LinesParams = DEFAULT) -> LinesResult:
    """Centre of a mark made of two crossing lines (Sohn et al., seed 004), in window pixels.

    The seed's steps (local dynamic thresholding, Hough transform, two peaks, their intersection), then each
    line refined to sub-pixel (:func:`refine_lines`) and the answer checked (:func:`line_refusal`, the angle,
    the half-turn symmetry about the intersection).

    Parameters
    ----------
    window : ndarray
        2-D grey levels on [0, 1], the mark brighter than its ground.
    params : LinesParams
        Every parameter of the method.

    Returns
    -------
    LinesResult
        The intersection of the two refined lines; ``sigma_x``, ``sigma_y``, ``cov_xy`` its covariance
        propagated from the lines' fitted offsets (each with ``offset_floor``), ``sigma`` = the mean of
        ``sigma_x`` and ``sigma_y`` (not their RMS); ``score`` = min(arm balance, angle, peak
        balance, fit quality); the binary image, the Hough peaks and the refined lines as typed fields.

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("ring_cross", 40, width=2.0, window=72, rng=np.random.default_rng(4))
    >>> r = detect(scene.image)
    >>> r.found, bool(np.hypot(r.x - scene.marks[0].x, r.y - scene.marks[0].y) < 0.1)
    (True, True)
    """
    w = np.asarray(window, np.float32)
    bad = unusable_window(w)
    if bad is not None:
        return LinesResult.not_found(METHOD, bad)
    fields: dict[str, Any] = {}
    try:
        return _locate(w, params, fields)
    except Refused as refused:
        return LinesResult.not_found(METHOD, str(refused), **fields)


__all__ = ["METHOD", "HoughPeaks", "LineFit", "LinesParams", "LinesResult", "ScoreParts", "bar_half_width",
           "centre_covariance", "detect", "fit_line", "hough_peaks", "hough_transform", "line_refusal",
           "refine_lines", "score_parts", "two_peaks"]
