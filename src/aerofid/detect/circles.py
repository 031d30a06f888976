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
   the parameters scaled by the a-posteriori ``sigma0^2`` gives the centre's standard deviation, widened by the
   edge points' correlation (:func:`centre_covariance`; the seed takes them as independent).

The result is rejected (``not_found`` with a reason) when fewer than two circles are supported on enough of
their circumference, when the circles are not concentric (each circle adjusted on its own, its edge points
re-selected about its own centre), when another circular structure competes with the chosen centre (the
rounded notch of the film border that encloses a Wild mark does not compete: :func:`_notch_rim`), or when the
edge points scatter about the circles more than the noise explains (the noise measured on the gradients
too: JPEG blocks hide from the grey-level estimate).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, Literal

import cv2
import numpy as np

from aerofid.conventions import FOUND
from aerofid.detect.asymmetry import distances, in_disc
from aerofid.detect.noise import CORRELATION_LAG, correlated_covariance
from aerofid.detect.params import MAX_PX, MAX_SIGMA_PX, MethodParams, check
from aerofid.detect.result import Detection, Refused, unusable_window
from aerofid.robust import difference_noise_sigma, median

if TYPE_CHECKING:
    from matplotlib.figure import Figure

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

NOISY_CANNY_SIGMAS = (1.4, 2.8)
"""Wider Gaussian smoothings (px) of Canny's operator, tried in turn on a noisy window (:data:`NOISY_CONTRAST`) where
the circles were refused for want of edges (:class:`Unseen`). At ``CANNY_SIGMA`` the high threshold lies above a
faint ring's gradient: under white noise of a quarter of a real Wild RC20 ring's contrast, Canny found no edge on
it. Smoothing lowers the gradients' noise faster than a blurred edge's gradient (by 2.5 and 9 times against 1.4 and
2.4 times for an edge blurred by 1 px)."""

NOISY_CONTRAST = 10.0
"""A window whose brightest point, smoothed by the first of :data:`NOISY_CANNY_SIGMAS`, stands less than this many
sigmas of its pixel noise (:func:`~aerofid.robust.difference_noise_sigma`) above its median is noisy:
:data:`NOISY_CANNY_SIGMAS` are tried there. Clean windows refuse at once, as before: a '+' of contrast 0.8 under noise
0.05 stands 11-13 sigmas out, synthetic marks on aerial ground under noise 0.02 13-22, the real RC20 ring 56-108 in
the red channel, 10-11 with white noise of 10 grey levels added to each channel, 4-5 with 25. Two first forms
measured too many windows again: the window's 99th percentile (a thin '+' covers less than 1 % of a 200 px box), and
:func:`edges`' effective noise, which counts texture (aerial ground: 3-9 sigmas, and two thirds of ``circles``' runs
in a region search there were the wider ones)."""

N_CIRCLES = 2
"""The seed's model uses two concentric circles (eq. 2)."""

MIN_RADIUS = 2.5
"""Smallest circle radius (px) considered when the radii are estimated."""

MIN_RADIUS_FLOOR = 0.5
"""Smallest circle radius (px) sought: below half a pixel the centre vote's weights overflow (min_radius=1e-300)."""
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


class Unseen(Refused):
    """The circles were refused for want of evidence (too few edge points, too little of a circumference): in a
    noisy window, wider smoothing may show them (:data:`NOISY_CANNY_SIGMAS`). Other refusals (two marks, circles
    not concentric, scatter) stand at any smoothing."""


# --- edges ----------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
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
          canny_low_ratio: float = CANNY_LOW_RATIO, border: int = 2,
          pixel_noise: float | None = None) -> EdgePoints:
    """Canny edges of ``window`` (seed 003 section 5) with sub-pixel positions.

    The window is smoothed with a Gaussian of ``canny_sigma`` px and differentiated with Sobel (scaled to grey
    levels per px); OpenCV's Canny does the non-maximum suppression and hysteresis on that gradient, with the
    high threshold at ``canny_high`` standard deviations of the gradient noise. Each edge pixel is moved to the
    vertex of a parabola through the gradient magnitude at it and its two neighbours along the pixel axis
    closest to the gradient (Devernay 1995). Pixels within ``border`` of the window edge are dropped.
    ``pixel_noise``: the window's :func:`~aerofid.robust.difference_noise_sigma`, where it is known already.
    """
    w = np.asarray(window, np.float32)
    h, wd = w.shape
    noise = difference_noise_sigma(w) if pixel_noise is None else pixel_noise
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
    g_noise = max(noise * gain, float(median(mag)) / RAYLEIGH_MEDIAN)
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
        n: np.ndarray = rng.normal(size=(128, 128)).astype(np.float32)
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


VOTES_PER_CHUNK = 1_000_000
"""Votes cast at once by :func:`hough_centres` (their indices and weights: 16 MB)."""
VOTES_PER_BLOCK = 1 << 16
"""Votes whose pixel :func:`hough_centres` computes at once (its float temporaries stay in the processor's cache)."""


def hough_centres(ep: EdgePoints, r_min: float, r_max: float, shape: tuple[int, int]) -> np.ndarray:
    """Radius-free centre vote: every edge point votes, weighted 1/distance, for the pixels on its gradient
    line at distances ``r_min`` to ``r_max`` on both sides (the centre of any circle through it lies there).
    Used to find the centre when the radii are not given, and to find competing circular structures."""
    h, w = shape
    if ep.x.size == 0 or r_max < r_min:
        return np.zeros(shape)
    d = np.arange(r_min, r_max + 0.5, 0.5)
    d = np.concatenate([-d[::-1], d])
    # the accumulator has a border of one pixel: a vote that falls outside the window is clipped onto the border
    # and dropped with it (cheaper than selecting the votes inside; each pixel's sum is the same)
    acc = np.zeros((h + 2) * (w + 2))
    step = max(1, VOTES_PER_CHUNK // d.size)  # bounded memory: the votes of a few thousand edge points at a time
    chunk = min(step, ep.x.size)
    weights = np.tile(1.0 / np.abs(d), chunk)       # a chunk's votes' weights, point after point
    index = np.empty((chunk, d.size), np.int64)
    block = max(1, VOTES_PER_BLOCK // d.size)
    row, col = np.empty((block, d.size)), np.empty((block, d.size))
    for i in range(0, ep.x.size, step):
        n = min(step, ep.x.size - i)
        for j in range(0, n, block):
            sl, m = slice(i + j, i + min(j + block, n)), min(block, n - j)
            # the index in the bordered accumulator, (row + 1) (w + 2) + column + 1, in floating point (exact for
            # these integers) and in place
            y = _rounded_votes(ep.y[sl], ep.ny[sl], d, h, row[:m])
            x = _rounded_votes(ep.x[sl], ep.nx[sl], d, w, col[:m])
            y += 1.0
            y *= w + 2
            y += x
            y += 1.0
            index[j:j + m] = y
        acc += np.bincount(index[:n].ravel(), weights=weights[:n * d.size], minlength=acc.size)
    return acc.reshape(h + 2, w + 2)[1:-1, 1:-1] / (2 * np.pi)


def _rounded_votes(c: np.ndarray, n: np.ndarray, d: np.ndarray, size: int, out: np.ndarray) -> np.ndarray:
    """The pixel coordinate (rounded, clipped to -1 .. ``size``) of the points ``c + d n``, a row per point, in
    ``out``."""
    np.multiply.outer(n, d, out=out)
    out += c[:, None]
    np.rint(out, out=out)
    return np.clip(out, -1, size, out=out)


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
    seen = np.bincount(_sectors(ep_x, ep_y, cx, cy, n_sectors), minlength=n_sectors)
    return float(np.count_nonzero(seen) / n_sectors)


def _sectors(ep_x: np.ndarray, ep_y: np.ndarray, cx: float, cy: float, n_sectors: int = N_SECTORS) -> np.ndarray:
    """The angular sector (0 .. ``n_sectors`` - 1) of each point around (cx, cy)."""
    a = np.arctan2(ep_y - cy, ep_x - cx)
    return np.floor((a + np.pi) / (2 * np.pi) * n_sectors).astype(int) % n_sectors


@dataclass(frozen=True, eq=False)
class _Shells:
    """The edge points :func:`estimate_radii` weighs, sorted by their distance ``d`` from its centre, with the sums
    of their polarities over the first j points (``outward[j]``) and, per angular sector, how many of the first j
    points lie in it (``seen[s, j]``): the points within 1 px of a radius are one run of them."""

    d: np.ndarray
    outward: np.ndarray
    seen: np.ndarray

    @classmethod
    def about(cls, d: np.ndarray, sector: np.ndarray, outward: np.ndarray) -> _Shells:
        """The shells of points at distances ``d`` (ascending) in angular sectors ``sector``, of polarities
        ``outward`` (+1, -1 or 0: their sums are exact)."""
        seen = np.zeros((N_SECTORS, d.size + 1), np.int32)
        np.cumsum(sector[None, :] == np.arange(N_SECTORS)[:, None], axis=1, out=seen[:, 1:])
        return cls(d, np.concatenate([[0.0], np.cumsum(outward)]), seen)

    def runs(self, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The runs [lo, hi) of the points with ``|d - r| <= 1``, for each radius of ``r``, exactly as that test
        reads: ``d - r`` rounds to a non-decreasing sequence, so they are the points from the first whose
        ``d - r`` is not below -1 up to the first whose ``d - r`` is above 1."""
        return (self._first(r, lambda t: t >= -1.0, r - 1.0, "left"),
                self._first(r, lambda t: t > 1.0, r + 1.0, "right"))

    def _first(self, r: np.ndarray, holds: Callable[[np.ndarray], np.ndarray], guess: np.ndarray,
               side: Literal["left", "right"]) -> np.ndarray:
        """For each of ``r``, the index of the first point for which ``holds(d - r)`` (a test that, once true, stays
        true along ``d``): the bisection for ``guess`` moved over the few points rounding puts on its other side."""
        d, n = self.d, self.d.size
        i = np.searchsorted(d, guess, side)
        if n == 0:
            return i
        while (back := (i > 0) & holds(d[np.maximum(i - 1, 0)] - r)).any():
            i = i - back
        while (ahead := (i < n) & ~holds(d[np.minimum(i, n - 1)] - r)).any():
            i = i + ahead
        return i

    def radii(self, r0: np.ndarray) -> np.ndarray:
        """For each of ``r0``, the median distance of the points within 1 px of it (itself without any):
        :func:`aerofid.robust.median` of the run, its middle value or the mean of its two middle values."""
        lo, hi = self.runs(r0)
        n = hi - lo
        upper = self.d[np.minimum(lo + n // 2, self.d.size - 1)] if self.d.size else r0
        lower = self.d[np.maximum(lo + n // 2 - 1, 0)] if self.d.size else r0
        middle = np.where(n % 2 == 1, upper, (lower + upper) / 2.0)
        return np.where(n > 0, middle, r0)

    def coverage(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """:func:`_coverage` of the points of each run [lo, hi)."""
        return np.count_nonzero(self.seen[:, hi] > self.seen[:, lo], axis=0) / N_SECTORS

    def polarity(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """The sign of the summed polarities of the points of each run [lo, hi) (0 for none)."""
        return np.sign(self.outward[hi] - self.outward[lo])


def _histogram(ascending: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """``np.histogram(ascending, bins=edges)[0]`` of values already sorted (numpy sorts them again): the counts
    between the edges, each bin's left edge in it, the last bin's right edge too."""
    cum = np.concatenate([np.searchsorted(ascending, edges[:-1], "left"),
                          np.searchsorted(ascending, edges[-1:], "right")])
    return np.diff(cum)


def estimate_radii(ep: EdgePoints, cx: float, cy: float, r_min: float, r_max: float,
                   n_circles: int = N_CIRCLES, near: tuple[float, ...] | None = None,
                   radial_cos: float = RADIAL_COS, min_coverage: float = MIN_COVERAGE) -> list[tuple[float, float]]:
    """Radii of circles centred near (cx, cy): peaks of the histogram (0.5 px bins, smoothed) of the
    distances of the edge points whose gradient is radial, each scored by its angular coverage.

    Without ``near``, returns up to ``n_circles`` (radius, coverage) at least 1.5 px apart (``SAME_POLARITY_GAP``
    px when both are edges of the same polarity, i.e. both dark inside or both bright inside: a blurred edge
    seen from a centre a pixel off splits into two histogram peaks), the circles covered on ``min_coverage``
    of their circumference first, each group by edge-point count (largest circles first). With ``near`` (the
    given radii), returns for each the best peak within max(2, 0.15 R) px of it (:func:`_match_radii`).
    """
    d, cos = _radial(ep, cx, cy)
    ok = (cos >= radial_cos) & (d >= r_min - 1) & (d <= r_max + 1)
    if not ok.any():
        return []
    order = np.argsort(d[ok], kind="stable")
    ds = d[ok][order]
    bw = 0.5
    edges_ = np.arange(max(0.0, r_min - 1.0), r_max + 1.0 + bw, bw)
    hist = _histogram(ds, edges_)
    hs = np.convolve(hist.astype(float), [0.25, 0.5, 0.25], mode="same")
    centres = 0.5 * (edges_[:-1] + edges_[1:])
    is_peak = (hs > 0) & (hs >= np.roll(hs, 1)) & (hs >= np.roll(hs, -1))
    peaks = np.nonzero(is_peak)[0]

    # polarity of each edge point: +1 when its gradient points away from the centre (dark inside)
    x, y, nx, ny = (v[ok][order] for v in (ep.x, ep.y, ep.nx, ep.ny))
    with np.errstate(divide="ignore", invalid="ignore"):
        outward = np.sign((x - cx) * nx + (y - cy) * ny)
    shells = _Shells.about(ds, _sectors(x, y, cx, cy), outward)

    def refine(i: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Radius, coverage and polarity of the histogram peaks ``i``: the median distance of the points within 1 px
        of the peak, the coverage and summed polarity of the points within 1 px of that."""
        r = shells.radii(centres[i])
        run = shells.runs(r)
        return r, shells.coverage(*run), shells.polarity(*run)

    if near is not None:
        # each given radius takes its own histogram peak (within max(2, 0.15 R)), the set of peaks with the
        # least total distance to the given radii; a radius without a peak keeps its value, coverage 0
        best = _match_radii(peaks, hs, centres, near)
        r, cov, _ = refine(np.array([i for i in best if i is not None], dtype=np.intp))
        given = zip(r.tolist(), cov.tolist(), strict=True)
        return [next(given) if i is not None else (float(r0), 0.0) for r0, i in zip(near, best)]
    # circles covered on at least min_coverage of their circumference first, then by edge-point count
    r, cov, sign = refine(peaks)
    keep = (r >= r_min) & (cov >= 0.25)
    ranked = sorted(np.nonzero(keep)[0].tolist(), key=lambda j: (not cov[j] >= min_coverage, -float(hs[peaks[j]])))
    return _apart([(float(r[j]), float(cov[j])) for j in ranked], [float(sign[j]) for j in ranked], n_circles)


def _apart(circles: list[tuple[float, float]], polarity: list[float], n_circles: int) -> list[tuple[float, float]]:
    """The first ``n_circles`` of ``circles`` (radius, coverage) at least 1.5 px from every one taken before,
    :data:`SAME_POLARITY_GAP` px when both edges have the same ``polarity`` (one sign per circle)."""
    out: list[tuple[float, float]] = []
    signs: list[float] = []
    for (r, cov), sign in zip(circles, polarity, strict=True):
        if any(abs(r - q) < (SAME_POLARITY_GAP if sign == t else 1.5) for (q, _), t in zip(out, signs)):
            continue
        out.append((r, cov))
        signs.append(sign)
        if len(out) >= n_circles:
            break
    return out


def _match_radii(peaks: np.ndarray, hs: np.ndarray, centres: np.ndarray,
                 near: tuple[float, ...]) -> tuple[int | None, ...]:
    """For each given radius in ``near``, the index of its histogram peak (or None): the assignment of peaks
    (at least 0.2 of the highest, within max(2, 0.15 R) px of a given radius) with the least total distance to
    the given radii, a radius without a peak costing 10 px."""
    cand: list[int | None] = [int(i) for i in peaks if hs[i] >= 0.2 * hs.max()
                              and min(abs(centres[i] - r0) - max(2.0, 0.15 * r0) for r0 in near) <= 0]
    best: tuple[int | None, ...] = (None,) * len(near)
    best_cost = np.inf
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
    return best


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

@dataclass(frozen=True, eq=False)
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


def _start_radii(x: np.ndarray, y: np.ndarray, label: np.ndarray, x0: float, y0: float, k: int) -> np.ndarray:
    """Starting radii: each circle's mean distance of its points from (x0, y0) (1 for a circle without any)."""
    dd = np.hypot(x - x0, y - y0)
    return np.array([float(dd[label == j].mean()) if (label == j).any() else 1.0 for j in range(k)])


def _gauss_helmert_design(xa: np.ndarray, ya: np.ndarray, x0: float, y0: float, R: np.ndarray, label: np.ndarray,
                          p: np.ndarray, u: int, fix_radii: bool
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The condition equations of :func:`fit_concentric_circles` linearised at the observations (xa, ya) and the
    parameters (x0, y0, R): ``A`` (n x u), ``B`` as its two columns (bx, by) (block diagonal, one row per
    point), ``M = B P^-1 B^T`` (diagonal) and ``f``."""
    n = xa.size
    dx, dy = xa - x0, ya - y0
    Rk = R[label]
    f = dx * dx + dy * dy - Rk * Rk
    bx, by = 2 * dx, 2 * dy
    m = (bx * bx + by * by) / p
    A = np.zeros((n, u))
    A[:, 0], A[:, 1] = -bx, -by
    if not fix_radii:
        A[np.arange(n), 2 + label] = -2 * Rk
    return A, bx, by, m, f


def fit_concentric_circles(x: np.ndarray, y: np.ndarray, label: np.ndarray,
                           radii: tuple[float, ...] | None = None, centre: tuple[float, float] | None = None,
                           fix_radii: bool = False, weights: np.ndarray | None = None, max_iter: int = 20,
                           tol: float = 1e-10) -> CircleFit | None:
    """Least-squares adjustment of k concentric circles, seed 003 eq. (2)-(3), as a Gauss-Helmert model.

    Condition equations, one per point i on circle k(i) (``label``):
    ``f_i = (x_i - x0)^2 + (y_i - y0)^2 - R_k^2 = 0`` with the observed coordinates (x_i, y_i) in error,
    ``e ~ (0, sigma0^2 P^-1)`` (P = ``weights``, one per point, isotropic). The estimate minimises ``e^T P e`` with
    every corrected point on its circle; with isotropic weights each point's correction is then its orthogonal
    projection onto the circle, so the estimate is the weighted orthogonal-distance fit, which this function solves
    by Gauss-Newton on the distances ``d_i = |(x_i, y_i) - (x0, y0)| - R_k`` (Jacobian: minus the unit vector from
    the centre, and -1 for the point's own radius) until the step is below ``tol`` px. Pope's rigorous iteration of
    the linearised model (:func:`_gauss_helmert_design`) reaches the same solution, but its corrections converge
    linearly: 5-20 iterations (mostly 6-8) against 1-9 (mostly 4-5) here on 257 adjustments of bench_peers.py's
    ring and bull's-eye boxes and the real RC20 marks, 6 of them not converged in 20, and centres within 3.1e-10 px
    of these.

    At the solution the corrections are ``e_i = -d_i u_i`` (u_i the unit vector from the centre) and the adjustment
    is the Gauss-Helmert model's, linearised there (:func:`_gauss_helmert_result`): ``A = df/dxi``,
    ``B = df/dy``, ``M = B P^-1 B^T``, ``N = A^T M^-1 A``, ``sigma0^2 = e^T P e / (n - u)``,
    ``Cov(xi) = sigma0^2 N^-1``.

    Parameters are (x0, y0) and, unless ``fix_radii``, the radii (one per label 0 .. k-1). ``radii`` and
    ``centre`` are starting values (defaults: centroid and mean distances); with ``fix_radii`` the radii are the
    known ones of the seed's model. Returns None when the normal matrix is singular, a point lies on the centre or
    there is no redundancy.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    label = np.asarray(label, int)
    n = x.size
    if n == 0:
        return None
    k_circ = int(label.max()) + 1
    p = np.ones(n) if weights is None else np.asarray(weights, float)
    x0, y0 = centre if centre is not None else (float(x.mean()), float(y.mean()))
    R = _start_radii(x, y, label, x0, y0, k_circ) if radii is None else np.asarray(radii, float).copy()
    u = 2 + (0 if fix_radii else k_circ)
    if n - u <= 0 or np.any(p <= 0):
        return None
    root_p = None if weights is None else np.sqrt(p)    # unit weights: J and the residuals as they are
    J = np.zeros((n, u))
    if not fix_radii:
        J[np.arange(n), 2 + label] = -1.0                  # the radii's columns do not change
    converged = False
    it = 0
    for it in range(1, max_iter + 1):              # noqa: B007 (``it`` is reported)
        dx, dy = x - x0, y - y0
        d = np.hypot(dx, dy)
        if np.any(d <= 0):
            return None
        np.divide(-dx, d, out=J[:, 0])
        np.divide(-dy, d, out=J[:, 1])
        res = d - R[label]
        Jw = J if root_p is None else J * root_p[:, None]
        try:
            step = np.linalg.solve(Jw.T @ Jw, -(Jw.T @ (res if root_p is None else res * root_p)))
        except np.linalg.LinAlgError:
            return None
        s = step.tolist()
        if not all(map(math.isfinite, s)):
            return None
        x0 += s[0]
        y0 += s[1]
        if not fix_radii:
            R += step[2:]
        if max(map(abs, s)) < tol:
            converged = True
            break
    dx, dy = x - x0, y - y0
    d = np.hypot(dx, dy)
    if np.any(d <= 0):
        return None
    off = (d - R[label]) / d                       # e = -(d - R) u: each point moved onto its circle
    return _gauss_helmert_result(x, y, -off * dx, -off * dy, x0, y0, R, label, p, u, fix_radii, it, converged)


def _gauss_helmert_result(x: np.ndarray, y: np.ndarray, ex: np.ndarray, ey: np.ndarray, x0: float, y0: float,
                          R: np.ndarray, label: np.ndarray, p: np.ndarray, u: int, fix_radii: bool, it: int,
                          converged: bool) -> CircleFit | None:
    """The :class:`CircleFit` at the solution: the cofactor matrix from the final linearisation, scaled by the
    a-posteriori ``sigma0^2 = e^T P e / (n - u)`` (None when the normal matrix is singular)."""
    A, _, _, m, _ = _gauss_helmert_design(x + ex, y + ey, x0, y0, R, label, p, u, fix_radii)
    try:
        Q = np.linalg.inv(A.T @ (A / m[:, None]))
    except np.linalg.LinAlgError:
        return None
    r = x.size - u
    s0 = float(np.sqrt(float(np.sum(p * (ex * ex + ey * ey))) / r))
    return CircleFit(float(x0), float(y0), tuple(float(v) for v in R), s0 * s0 * Q, s0,
                     np.column_stack([ex, ey]), r, it, converged)


# --- parameters and result ------------------------------------------------------------------------------

def _is_num(v: Any) -> bool:
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool) and not math.isnan(v)


def _finite(v: Any) -> bool:
    return _is_num(v) and math.isfinite(v)


@dataclass(frozen=True)
class CirclesParams(MethodParams):
    """Parameters of the concentric-circles detector (Seedahmed, seed 003).

    The seed gives the model (two concentric circles, eq. 2) and the steps (section 5), not the tuning values:
    the defaults are ours, documented with the module constants they come from.

    Examples
    --------
    >>> CirclesParams(radii=[9, 10]).radii
    (9.0, 10.0)
    >>> CirclesParams(radii=(5.0,))
    Traceback (most recent call last):
    ...
    ValueError: radii must be None or two or more positive numbers (px), not (5.0,)
    """

    radii: tuple[float, ...] | None = None
    """The circles' radii in px (``(R_1, R_2)``, seed eq. 2, e.g. the inner and outer edge of a Wild RC10
    ring), or None to estimate them from the mark (the ``n_circles`` best-supported circles)."""
    n_circles: int = N_CIRCLES
    """Circles to adjust when estimating the radii (the seed's model, eq. 2, has two)."""
    canny_sigma: float = CANNY_SIGMA
    """Canny's operator (seed 5), see :data:`CANNY_SIGMA` and :func:`edges`."""
    canny_high: float = CANNY_HIGH
    """See :data:`CANNY_HIGH`."""
    canny_low_ratio: float = CANNY_LOW_RATIO
    """Canny's low hysteresis threshold as a fraction of the high one."""
    min_radius: float = MIN_RADIUS
    """Smallest radius (px) when estimating the radii (:data:`MIN_RADIUS`)."""
    max_radius: float | None = None
    """Largest radius (px) when estimating the radii; None: half the window's smaller side."""
    dehough_tol: float = DEHOUGH_TOL
    """De-Houghing (seed 5), see :data:`DEHOUGH_TOL` and :func:`de_hough`."""
    radial_cos: float = RADIAL_COS
    """See :data:`RADIAL_COS`."""
    min_coverage: float = MIN_COVERAGE
    """Fraction of each circle's circumference that must carry edge points (:data:`MIN_COVERAGE`)."""
    concentric_tol: float = CONCENTRIC_TOL
    """Px (plus 3 sigma) by which the circles' separately fitted centres may differ (:data:`CONCENTRIC_TOL`)."""
    competitor_ratio: float = COMPETITOR_RATIO
    """A second centre peak this strong relative to the chosen one makes it ambiguous (:data:`COMPETITOR_RATIO`)."""
    radius_tol: float = RADIUS_TOL
    """Given radii are searched over +/- this many px (:data:`RADIUS_TOL`)."""
    max_rms_ratio: float = MAX_RMS_RATIO
    """Largest edge residual RMS, in multiples of what the noise explains (:data:`MAX_RMS_RATIO`)."""
    fix_radii: bool = False
    """Adjust with the radii fixed to ``radii`` (the seed's "known radius" model, section 3) instead of free.
    Free is the default because scanned radii differ from the nominal ones by the scan scale and the edge
    operator's blur."""

    def __post_init__(self) -> None:
        if self.radii is not None and isinstance(self.radii, list | tuple | np.ndarray):
            object.__setattr__(self, "radii", tuple(float(r) for r in self.radii))
        super().__post_init__()

    def validate(self) -> None:
        """One-line ``ValueError`` for a value no later step could use."""
        r = self.radii
        check(r is None or (isinstance(r, tuple) and len(r) >= 2 and all(_finite(v) and v > 0 for v in r)),
              f"radii must be None or two or more positive numbers (px), not {r!r}")
        check(isinstance(self.n_circles, int | np.integer) and not isinstance(self.n_circles, bool)
              and self.n_circles >= 2, f"n_circles must be an integer >= 2, not {self.n_circles!r}")
        for name in ("canny_sigma", "radius_tol", "concentric_tol"):
            v = getattr(self, name)
            top = MAX_SIGMA_PX if name == "canny_sigma" else MAX_PX
            check(_finite(v) and 0 <= v <= top, f"{name} must be a number in [0, {top:g}], not {v!r}")
        for name in ("canny_high", "dehough_tol", "competitor_ratio", "max_rms_ratio"):
            v = getattr(self, name)
            check(_finite(v) and 0 < v <= MAX_PX, f"{name} must be a number in (0, {MAX_PX}], not {v!r}")
        check(_finite(self.min_radius) and MIN_RADIUS_FLOOR <= self.min_radius <= MAX_PX,
              f"min_radius must be a number in [{MIN_RADIUS_FLOOR}, {MAX_PX}] px, not {self.min_radius!r}")
        for name in ("canny_low_ratio", "radial_cos", "min_coverage"):
            v = getattr(self, name)
            check(_finite(v) and 0 <= v <= 1, f"{name} must be in [0, 1], not {v!r}")
        check(self.max_radius is None or (_finite(self.max_radius) and self.min_radius < self.max_radius <= MAX_PX),
              f"max_radius must be None or a number in (min_radius ({self.min_radius}), {MAX_PX}], "
              f"not {self.max_radius!r}")
        check(isinstance(self.fix_radii, bool | np.bool_), f"fix_radii must be True or False, not {self.fix_radii!r}")
        check(not self.fix_radii or r is not None, "fix_radii=True needs the radii")


DEFAULT = CirclesParams()


def _diag(default: Any = None) -> Any:
    """A diagnostic field of a result: not compared (it may hold arrays), not in the repr."""
    return field(default=default, compare=False, repr=False)


@dataclass(frozen=True)
class CirclesResult(Detection):
    """The circles detector's answer with its intermediate results (window pixels); a field stays at its
    default when the detector stopped before that step."""

    noise: float = _diag(float("nan"))
    """The window's effective grey-level noise (:func:`edges`)."""
    edge_points: EdgePoints | None = _diag()
    """Canny's edges with sub-pixel positions (step 1)."""
    accumulator: np.ndarray | None = _diag()
    """The Hough space of the given radii, added (step 2), or the radius-free centre votes."""
    centre_votes: np.ndarray | None = _diag()
    """The radius-free centre votes (:func:`hough_centres`), smoothed."""
    peaks: tuple[tuple[float, float, float], ...] = _diag(())
    """Given radii: each radius's Hough peak (x, y, votes)."""
    circles: tuple[tuple[float, float, float], ...] = _diag(())
    """The adjusted circles (x0, y0, R) (step 4)."""
    points: np.ndarray | None = _diag()
    """The de-Houghed edge points (n, 2) as (x, y) (step 3) ..."""
    labels: np.ndarray | None = _diag()
    """... and the circle each belongs to."""
    fit: CircleFit | None = _diag()
    """The Gauss-Helmert adjustment of the concentric circles (step 4)."""
    coverage: tuple[float, ...] = _diag(())
    """Fraction of each circle's circumference holding edge points."""
    concentricity: tuple[float, float] | None = _diag()
    """Largest distance between the circles' separately fitted centres, and its standard deviation."""
    competitor: tuple[float, float, float, float] | None = _diag()
    """A competing circle (x, y, R, coverage), if any."""
    expected_rms: float = _diag(float("nan"))
    """The edge scatter the noise explains (:func:`_expected_edge_rms`)."""
    score_parts: Mapping[str, float] | None = _diag()
    """The score's parts: ``coverage``, ``fit``, ``concentric``."""
    canny_sigma: float = _diag(CANNY_SIGMA)
    """The smoothing (px) of Canny's operator the answer was measured with: the parameter's, or in a noisy window
    one of :data:`NOISY_CANNY_SIGMAS`."""

    @property
    def extent(self) -> float | None:
        """The mark's radius: the largest adjusted circle's, plus one pixel."""
        return float(max(r for _, _, r in self.circles) + 1.0) if self.circles else None

    def plot(self, fig: Figure, window: np.ndarray) -> None:
        """The window with the edge points (those on the circles coloured by circle), the adjusted circles and
        the centre."""
        ax = fig.add_subplot(1, 1, 1)
        ax.imshow(window, cmap="gray", interpolation="nearest")
        if self.edge_points is not None:
            ax.plot(self.edge_points.x, self.edge_points.y, ",", color="tab:blue")
        if self.points is not None and self.labels is not None:
            ax.scatter(self.points[:, 0], self.points[:, 1], s=2, c=self.labels, cmap="autumn")
        t = np.linspace(0, 2 * np.pi, 181)
        for x0, y0, r in self.circles:
            ax.plot(x0 + r * np.cos(t), y0 + r * np.sin(t), color="tab:green", lw=0.8)
        if self.found:
            ax.plot([self.x - self.origin[0]], [self.y - self.origin[1]], "+", color="orange", ms=14, mew=2)
            ax.set_title(f"circles: ({self.x:.3f}, {self.y:.3f}) sigma {self.sigma:.3f} px", fontsize=9)
        else:
            ax.set_title(f"circles: {self.reason}"[:90], fontsize=8)


@dataclass(eq=False)
class _Trace:
    """Internal: the intermediate results gathered so far (the diagnostic fields of :class:`CirclesResult`)."""

    noise: float = float("nan")
    edge_points: EdgePoints | None = None
    accumulator: np.ndarray | None = None
    centre_votes: np.ndarray | None = None
    peaks: tuple[tuple[float, float, float], ...] = ()
    circles: tuple[tuple[float, float, float], ...] = ()
    points: np.ndarray | None = None
    labels: np.ndarray | None = None
    fit: CircleFit | None = None
    coverage: tuple[float, ...] = ()
    concentricity: tuple[float, float] | None = None
    competitor: tuple[float, float, float, float] | None = None
    expected_rms: float = float("nan")
    score_parts: Mapping[str, float] | None = None
    canny_sigma: float = CANNY_SIGMA
    sigma_x: float = float("nan")
    sigma_y: float = float("nan")
    cov_xy: float = float("nan")

    def fields(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


# --- the detector ---------------------------------------------------------------------------------------

def detect(window: np.ndarray, params: CirclesParams = DEFAULT) -> CirclesResult:
    """Centre of a mark made of concentric circles (Seedahmed, seed 003), in window pixels.

    Parameters
    ----------
    window : ndarray
        2-D float32 grey levels on [0, 1], the mark brighter than its ground.
    params : CirclesParams
        The method's parameters.

    Returns
    -------
    CirclesResult
        The adjusted common centre; ``sigma_x``, ``sigma_y``, ``cov_xy`` = its covariance from the adjustment
        with the edge points' correlation (:func:`centre_covariance`), ``sigma`` = the mean of ``sigma_x`` and
        ``sigma_y`` (not their RMS);
        ``score`` = min(circumference support / 0.9, fit quality, concentricity), and the intermediate results
        as typed fields; ``extent`` is the largest circle's radius + 1 px. A window without two concentric
        circles gives ``status="not_found"`` with the reason.

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("bullseye", 30, window=60, rng=np.random.default_rng(1))
    >>> d = detect(scene.image)
    >>> d.found, bool(np.hypot(d.x - scene.marks[0].x, d.y - scene.marks[0].y) < 0.05), len(d.circles)
    (True, True, 2)
    """
    p = params
    w = np.asarray(window, np.float32)
    bad = unusable_window(w)
    if bad is not None:
        return CirclesResult.not_found(METHOD, bad)
    t = _Trace(canny_sigma=p.canny_sigma)
    pixel_noise = difference_noise_sigma(w)
    try:
        cx, cy, sigma, score = _run(w, p, t, pixel_noise=pixel_noise)
    except Refused as f:
        retry = _retry_from_centre_votes(w, p, t) or (
            _retry_smoother(w, p, pixel_noise) if isinstance(f, Unseen) else None)
        if retry is None:
            return CirclesResult.not_found(METHOD, f.reason, **t.fields())
        t, (cx, cy, sigma, score) = retry
    return CirclesResult(status=FOUND, x=cx, y=cy, score=score, sigma=sigma, method=METHOD, **t.fields())


def _retry_smoother(w: np.ndarray, p: CirclesParams,
                    pixel_noise: float) -> tuple[_Trace, tuple[float, float, float, float]] | None:
    """In a noisy window (:data:`NOISY_CONTRAST`; ``pixel_noise``: its
    :func:`~aerofid.robust.difference_noise_sigma`), the whole pipeline again with each wider smoothing of
    :data:`NOISY_CANNY_SIGMAS` in turn, until the circles are found or refused for another reason than want of edges;
    None if none finds them."""
    peak = float(cv2.GaussianBlur(w, (0, 0), NOISY_CANNY_SIGMAS[0], borderType=cv2.BORDER_REPLICATE).max())
    if not peak - float(median(w)) < NOISY_CONTRAST * pixel_noise:
        return None
    for sigma in (s for s in NOISY_CANNY_SIGMAS if s > p.canny_sigma):
        t = _Trace(canny_sigma=sigma)
        try:
            return t, _run(w, dataclasses.replace(p, canny_sigma=sigma), t, pixel_noise=pixel_noise)
        except Unseen:
            continue
        except Refused:
            return None
    return None


def _retry_from_centre_votes(w: np.ndarray, p: CirclesParams,
                             first: _Trace) -> tuple[_Trace, tuple[float, float, float, float]] | None:
    """Given radii only: the whole pipeline again, started at the peak of the radius-free centre votes instead of
    the peak of the given radii's Hough spaces, when they differ (None when they do not, or it fails too).

    The circles' Hough spaces searched over ``radius_tol`` about the given radii also collect the votes of the
    mark's *other* concentric edges at distance ``a``, on a ring of radius ``|R - a|`` about the centre: on small
    bull's-eyes (20 px: rings 1 px wide, edges 1-2 px apart) that ring outscores the centre, the peak lies
    1-1.5 px off and the adjustment settles on a mixture of rings that the checks refuse (3 of 12 000 marks,
    docs/marks.md). Every edge's gradient line passes through the common centre, so the centre votes peak
    there."""
    if p.radii is None or first.centre_votes is None or first.accumulator is None:
        return None
    vx, vy, _ = _peak(first.centre_votes)
    ax, ay, _ = _peak(_smooth(first.accumulator))
    if np.hypot(vx - ax, vy - ay) < 1.0:
        return None
    t = _Trace()
    try:
        return t, _run(w, p, t, start=(vx, vy))
    except Refused:
        return None


def _run(w: np.ndarray, p: CirclesParams, t: _Trace, start: tuple[float, float] | None = None,
         pixel_noise: float | None = None) -> tuple[float, float, float, float]:
    """The steps of seed 003 section 5 and the checks; fills ``t``; returns (x, y, sigma, score). ``start``
    replaces the Hough peak as the approximate centre (:func:`_retry_from_centre_votes`); ``pixel_noise``: as
    :func:`edges` takes it."""
    h, wd = w.shape
    ep = edges(w, p.canny_sigma, p.canny_high, p.canny_low_ratio, pixel_noise=pixel_noise)
    t.edge_points, t.noise = ep, ep.noise
    if ep.x.size < 12:
        raise Unseen(f"too few edge pixels ({ep.x.size}) for circles")
    r_max = float(p.max_radius) if p.max_radius is not None else 0.5 * min(h, wd)
    cx, cy, radii, votes = _hough_start(ep, p, r_max, (h, wd), t, start)
    fit, lab, fitted = _adjust(ep, cx, cy, radii, p, t)
    if not (0 <= fit.x0 <= wd - 1 and 0 <= fit.y0 <= h - 1):
        raise Refused("the adjusted centre lies outside the window")
    if max(fit.radii) > 0.5 * max(h, wd) * 1.5:
        raise Refused("the adjusted circles are larger than the window")
    cx, cy, radii = fit.x0, fit.y0, list(fit.radii)
    cover = _check_coverage(ep, lab, cx, cy, radii, p, t)
    sep, s_sep = _check_concentric(ep, lab, cx, cy, radii, p, t)
    _check_other_circles(ep, lab, fit, r_max, p)
    t.competitor = comp = _competitor(w, ep, votes, cx, cy, radii, lab, p.min_radius, r_max, p.competitor_ratio,
                                      p.min_coverage, p.radial_cos)
    if comp is not None:
        ox, oy, rr, cov_o = comp
        raise Refused(f"another circle (radius {rr:.1f} px, {cov_o:.0%} of it) centred at ({ox:.1f}, {oy:.1f}) "
                       f"competes with ({cx:.1f}, {cy:.1f}): circles not concentric or more than one mark")
    t.expected_rms = expected = _expected_edge_rms(ep, lab, p.canny_sigma)
    if fit.sigma0 > p.max_rms_ratio * expected:
        raise Refused(f"the edge points scatter {fit.sigma0:.2f} px about the adjusted circles, "
                       f"{fit.sigma0 / expected:.1f} times what the noise explains: not a clean pair of "
                       f"concentric circles")
    cov = centre_covariance(ep, *fitted, fit, p.fix_radii, p.canny_sigma)
    sx, sy = float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))
    t.sigma_x, t.sigma_y, t.cov_xy = sx, sy, float(cov[0, 1])
    # score: circumference support, fit quality (edge residual RMS vs what the noise explains), concentricity
    t.score_parts = parts = {"coverage": min(1.0, min(cover) / 0.9),
                             "fit": float(min(1.0, 2.0 * expected / max(fit.sigma0, 1e-9))),
                             "concentric": float(np.exp(-0.5 * (sep / (p.concentric_tol / 2 + 3 * s_sep)) ** 2))}
    score = float(np.clip(min(parts.values()), 0.0, 1.0))
    return float(cx), float(cy), float(0.5 * (sx + sy)), score


def _hough_start(ep: EdgePoints, p: CirclesParams, r_max: float, shape: tuple[int, int], t: _Trace,
                 start: tuple[float, float] | None = None) -> tuple[float, float, list[float], np.ndarray]:
    """Step 2: the approximate centre and radii. Given radii: the peak of their Hough spaces added
    (:func:`hough_circles`, each over +/- ``p.radius_tol``), which must agree with each radius's own peak
    (concentric circles share the centre); else the peak of the radius-free votes (:func:`hough_centres`) and
    the radii from the edge distances to it (:func:`estimate_radii`). Returns (x, y, radii, smoothed votes)."""
    h, wd = shape
    if p.radii is not None:
        radii = p.radii
        # the Hough space of each known radius, over radius_tol px around it (scan scale, the edge operator's
        # blur moves the edges of a thin ring apart); the concentric circles' spaces are added
        per_acc = [np.sum([hough_circles(ep.x, ep.y, q, (h, wd))
                           for q in np.arange(max(1.0, r - p.radius_tol), r + p.radius_tol + 0.01, 0.5)], axis=0)
                   for r in radii]
        t.accumulator = acc = np.sum(per_acc, axis=0)
        cx, cy = start if start is not None else _peak(_smooth(acc))[:2]
        t.peaks = per = tuple(_peak(_smooth(a)) for a in per_acc)
        vote_range = (max(1.5, min(radii) - 2.0), max(radii) + 2.0)
    else:
        vote_range = (p.min_radius, r_max)
    t.centre_votes = votes = _smooth(hough_centres(ep, vote_range[0], vote_range[1], (h, wd)))
    if p.radii is None:
        cx, cy, _ = _peak(votes)
        t.accumulator = votes
        found = estimate_radii(ep, cx, cy, p.min_radius, r_max, p.n_circles, radial_cos=p.radial_cos,
                               min_coverage=p.min_coverage)
        if len(found) < 2:
            raise Unseen(f"fewer than two circles centred at the Hough peak ({cx:.0f}, {cy:.0f})")
    else:
        spread = max(np.hypot(px - cx, py - cy) for px, py, _ in per)
        if spread > max(4.0, 0.2 * min(radii)):
            raise Refused(f"the circles of radii {radii} peak {spread:.1f} px apart: not concentric")
        found = estimate_radii(ep, cx, cy, 1.0, max(radii) + 3, near=radii, radial_cos=p.radial_cos)
    return cx, cy, [r for r, _ in found], votes


def _adjust(ep: EdgePoints, cx: float, cy: float, radii: list[float], p: CirclesParams,
            t: _Trace) -> tuple[CircleFit, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Steps 3-4: de-Houghing (:func:`de_hough`) and the Gauss-Helmert adjustment
    (:func:`fit_concentric_circles`), twice (the second time about the adjusted centre and radii, with a
    tolerance of at most 1 px, unless that selects the same edge points on the same circles: then the adjustment
    would end where it did, within its tolerance); returns the fit, the circle of each edge point about its
    centre (-1: none), and the points the fit was given (their indices and circles)."""
    fit, lab, used = None, None, (np.zeros(0, np.intp), np.zeros(0, np.intp))
    for tol_i in (p.dehough_tol, min(p.dehough_tol, 1.0)):
        again = de_hough(ep, cx, cy, radii, tol_i, p.radial_cos)
        if lab is not None and np.array_equal(again, lab):
            break  # the same points on the same circles: the adjustment would end where it did
        lab = again
        sel = lab >= 0
        if any((lab == j).sum() < 5 for j in range(len(radii))):
            raise Unseen("a circle has fewer than 5 edge points after de-Houghing")
        start = tuple(p.radii) if p.fix_radii and p.radii is not None else tuple(radii)
        fit = fit_concentric_circles(ep.x[sel], ep.y[sel], lab[sel], start, (cx, cy), fix_radii=p.fix_radii)
        if fit is None or not np.isfinite([fit.x0, fit.y0]).all():
            raise Refused("the concentric-circles adjustment did not converge")
        used = np.flatnonzero(sel), lab[sel]
        cx, cy = fit.x0, fit.y0
        radii = list(fit.radii)
    assert fit is not None
    lab = de_hough(ep, cx, cy, radii, min(p.dehough_tol, 1.0), p.radial_cos)
    sel = lab >= 0
    t.points, t.labels, t.fit = np.column_stack([ep.x[sel], ep.y[sel]]), lab[sel], fit
    t.circles = tuple((fit.x0, fit.y0, r) for r in fit.radii)
    return fit, lab, used


def centre_covariance(ep: EdgePoints, used: np.ndarray, label: np.ndarray, fit: CircleFit, fix_radii: bool,
                      canny_sigma: float = CANNY_SIGMA) -> np.ndarray:
    """The 2 x 2 covariance of the adjusted centre with the edge points' correlation: the adjustment's
    ``sigma0^2 N^-1`` takes the points as independent, but neighbouring Canny pixels share the smoothing and the
    Sobel kernels, and film grain, scanner blur and JPEG move neighbouring edge points together. The centre is
    linear in the points' distances from their circles, ``(J'J)^-1 J' d`` (J: the distances' Jacobian at the
    solution, minus the unit vector from the centre and -1 for the point's radius), so its covariance follows from
    the distances' correlation between edge pixels up to :data:`~aerofid.detect.noise.CORRELATION_LAG` px apart
    (:func:`~aerofid.detect.noise.correlated_covariance`), or 3 ``canny_sigma`` where the smoothing correlates them
    further (:data:`NOISY_CANNY_SIGMAS`). ``used``, ``label``: the indices of ``ep``'s points the adjustment was
    given, in its order, and their circles."""
    x, y = ep.x[used], ep.y[used]
    dx, dy = x - fit.x0, y - fit.y0
    d = np.hypot(dx, dy)
    ux, uy = dx / d, dy / d
    ex, ey = fit.residuals.T
    J = np.column_stack([-ux, -uy])
    if not fix_radii:
        J = np.column_stack([J, -(label[:, None] == np.arange(len(fit.radii))[None, :]).astype(float)])
    rows = (np.linalg.pinv(J.T @ J) @ J.T)[:2]
    return correlated_covariance(ep.col[used].astype(float), ep.row[used].astype(float), -(ex * ux + ey * uy), rows,
                                 fit.cov[:2, :2], max(CORRELATION_LAG, math.ceil(3 * canny_sigma)))


def _check_coverage(ep: EdgePoints, lab: np.ndarray, cx: float, cy: float, radii: list[float], p: CirclesParams,
                    t: _Trace) -> list[float]:
    """Support on the circumference: each circle must hold edge points in ``p.min_coverage`` of its
    :data:`N_SECTORS` sectors (this also catches circles cut by the window edge)."""
    cover = [_coverage(ep.x[lab == j], ep.y[lab == j], cx, cy) for j in range(len(radii))]
    t.coverage = tuple(cover)
    if min(cover) < p.min_coverage:
        j = int(np.argmin(cover))
        raise Unseen(f"circle of radius {radii[j]:.1f} px has edges on only {cover[j]:.0%} of "
                     f"its circumference (cut by the window edge, or not a circle)")
    return cover


def _check_concentric(ep: EdgePoints, lab: np.ndarray, cx: float, cy: float, radii: list[float],
                      p: CirclesParams, t: _Trace) -> tuple[float, float]:
    """Concentricity: each circle adjusted on its own (:func:`fit_single_circle`); their centres may differ by
    at most ``p.concentric_tol`` px plus three standard deviations. Returns (largest distance, its sigma)."""
    singles = [fit_single_circle(ep, lab == j, cx, cy, j, radii, p) for j in range(len(radii))]
    pairs = [(a, b) for i, a in enumerate(singles) for b in singles[i + 1:]]
    sep = max(float(np.hypot(a.x0 - b.x0, a.y0 - b.y0)) for a, b in pairs)
    s_sep = max(float(np.sqrt(a.cov[0, 0] + a.cov[1, 1] + b.cov[0, 0] + b.cov[1, 1])) for a, b in pairs)
    t.concentricity = (sep, s_sep)
    if sep > p.concentric_tol + 3 * s_sep:
        raise Refused(f"the circles' centres differ by {sep:.2f} px: not concentric")
    return sep, s_sep


def fit_single_circle(ep: EdgePoints, members: np.ndarray, cx: float, cy: float, j: int, radii: list[float],
                      p: CirclesParams = DEFAULT) -> CircleFit:
    """Circle ``j`` of ``radii`` adjusted on its own, from its de-Houghed edge points ``members`` about the
    common centre (cx, cy): its edge points are selected again about its own adjusted centre
    :data:`SINGLE_PASSES` times, in a band of up to :data:`SINGLE_BAND` px about it, short of the other circles
    (a thin ring offset by a pixel or two, whose edges the narrow de-Houghing about the common centre only half
    selects, moves to its own centre)."""
    gap = min((abs(radii[j] - r) for k, r in enumerate(radii) if k != j), default=2 * SINGLE_BAND)
    band = max(min(p.dehough_tol, 1.0), min(SINGLE_BAND, 0.5 * gap - 0.25))
    m = members
    fj = None
    for _ in range(SINGLE_PASSES):
        fj = fit_concentric_circles(ep.x[m], ep.y[m], np.zeros(int(m.sum()), int),
                                    (radii[j] if fj is None else fj.radii[0],),
                                    (cx, cy) if fj is None else (fj.x0, fj.y0))
        if fj is None or not np.isfinite([fj.x0, fj.y0]).all():
            raise Refused(f"circle {j} could not be adjusted on its own")
        again = de_hough(ep, fj.x0, fj.y0, [fj.radii[0]], band, p.radial_cos) == 0
        if again.sum() < 5:
            raise Refused(f"circle {j} could not be adjusted on its own")
        if np.array_equal(again, m):
            break  # the same points again: the next pass would end where this one did
        m = again
    assert fj is not None
    return fj


def _subset(ep: EdgePoints, sel: np.ndarray) -> EdgePoints:
    """The edge points ``sel`` (the edge map and noise of all)."""
    return EdgePoints(ep.x[sel], ep.y[sel], ep.nx[sel], ep.ny[sel], ep.mag[sel], ep.col[sel], ep.row[sel],
                      ep.edge_map, ep.noise)


def _check_other_circles(ep: EdgePoints, lab: np.ndarray, fit: CircleFit, r_max: float, p: CirclesParams) -> None:
    """Every other well-supported circle around the centre, among the edge points on none of ours, must share
    it (a pair of rings offset by a pixel or two passes the Hough and coverage tests)."""
    rest_idx = np.nonzero(lab < 0)[0]
    if rest_idx.size < 8:
        return
    cx, cy = fit.x0, fit.y0
    rest = _subset(ep, rest_idx)
    for r_o, cov_o in estimate_radii(rest, cx, cy, p.min_radius, r_max, 3, radial_cos=p.radial_cos,
                                     min_coverage=p.min_coverage):
        if cov_o < p.min_coverage:
            continue
        lo = de_hough(rest, cx, cy, [r_o], p.dehough_tol, p.radial_cos) == 0
        fo = fit_concentric_circles(rest.x[lo], rest.y[lo], np.zeros(int(lo.sum()), int), (r_o,), (cx, cy))
        if fo is None:
            continue
        d_o = float(np.hypot(fo.x0 - cx, fo.y0 - cy))
        s_o = float(np.sqrt(fo.cov[0, 0] + fo.cov[1, 1] + fit.cov[0, 0] + fit.cov[1, 1]))
        if d_o > p.concentric_tol + 3 * s_o:
            raise Refused(f"another circle (radius {fo.radii[0]:.1f} px) is centred {d_o:.2f} px "
                           f"away: circles not concentric")


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
    block, centre = in_disc(cx, cy, max(3.0, 0.25 * min(radii)), votes.shape)
    vc[block][centre] = 0
    dil = cv2.dilate(vc, np.ones((5, 5), np.uint8))
    pk = np.nonzero((vc >= dil) & (vc >= ratio * main))
    if pk[0].size == 0:
        return None
    order = np.argsort(-vc[pk])[:max_peaks]
    others = lab < 0
    if others.sum() < 8:
        return None
    rest = _subset(ep, others)
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
    d = distances(ox, oy, window.shape)
    inside, outside = window[(d >= r - 6) & (d <= r - 2)], window[(d >= r + 2) & (d <= r + 6)]
    if inside.size < 20 or outside.size < 20:
        return False
    return float(median(outside) - median(inside)) >= max(6.0 * noise, 0.05)


def _expected_edge_rms(ep: EdgePoints, lab: np.ndarray, canny_sigma: float) -> float:
    """Edge position scatter the noise alone explains, plus the Devernay/pixel-grid quantisation floor:
    sqrt((gradient noise / (|gradient| / (edge width)))^2 + 0.05^2), using the median gradient on the
    circles and an edge width of sqrt(1 + canny_sigma^2) px."""
    g = float(median(ep.mag[lab >= 0])) if (lab >= 0).any() else 1.0
    g_noise = ep.noise * _gradient_noise_gain(canny_sigma)
    width = np.sqrt(1.0 + canny_sigma ** 2)
    return float(np.hypot(g_noise / max(g, 1e-9) * width, 0.05))
