"""Centre of any centrally symmetric mark by symmetry analysis (Cho & Kim, seed 002).

Cho, S.-I. and Kim, K.-O., "Automatic Identification of Fiducial Marks Based on Weak Constraints". The
method needs no model of the mark, only two weak assumptions (seed section 2.1): (1) the mark is symmetric
about its centre, (2) the *fiducial area* around it is roughly symmetric about an axis through that centre.
It runs in four stages (seed Fig. 3):

1. **Fiducial-area analysis** (seed 3.1, :func:`fiducial_area`): accumulated edge profiles, eq. (1),
   thresholded at their mean, give the upper and lower bounds L1, L2 and the horizontal extent of the area;
   the symmetry of the accumulated grey-level profile between them, eq. (2), gives the axis L3. For a corner
   area the window is first projected diagonally (rotated 45 degrees) so that the area's axis is upright
   (``diagonal``). The bounds also give the half-size of the mark, which sets the symmetry kernel (seed 3.2).
2. **Mark analysis** (seed 3.2, :func:`axis_peak`): a simplified Laplacian of Gaussian by box
   filtering, eq. (3); symmetry enhancement, eqs. (4)-(5); accumulation to a profile, eq. (6); high-pass
   filtering, eq. (7), whose peak is the centre of symmetry along one axis. Alternately along y and x, with an
   accumulation / smoothing interval that narrows each iteration, until the shift is at most one pixel; no
   convergence is a failure.
3. **Self-diagnosis** (seed 3.3, :func:`self_diagnosis`): mirror-added images, eqs. (8)-(9), their 90-degree
   rotations, eqs. (10)-(11), and the mean of four normalised cross-correlations, eqs. (12)-(13); ``R_self``
   below 0.5 is a failure.
4. **Sub-pixel location** (seed 3.4, :func:`subpixel_centre`): the neighbourhood of the unit-pixel centre is
   enlarged (bilinear), Gaussian-smoothed and analysed again in the same way; the centre is the weighted mean
   of the final high-pass profile, eq. (14), mapped back by eq. (15). A total shift that is too large, or a
   neighbourhood whose grey levels hardly vary (too faint), is a failure.

Beyond the seed, the centre of eq. (15) is refined by least squares on point symmetry itself
(:func:`point_symmetry_centre`, ``point_refine=True``): eq. (14) is biased on marks whose filter response is
uneven (rotated thin crosses: 0.1-0.3 px), the refinement is not; the two centres' disagreement enters
``sigma``. The final centre must be centrally symmetric by the shared measure
:func:`aerofid.detect.asymmetry.point_asymmetry` (``max_asymmetry``).

Every step works on absolute differences of a linear filter, so the method is blind to polarity: a bright
mark on dark ground and a dark mark on bright ground give the same centre.

The returned ``score`` is ``R_self`` (clipped to [0, 1]) evaluated at the final sub-pixel centre, so a found
mark has ``score >= rself_threshold`` (0.5). ``sigma_x``, ``sigma_y``, ``cov_xy`` are a propagated covariance
(see :func:`centre_covariance`) and ``sigma`` the mean of ``sigma_x`` and ``sigma_y``; the benchmark
``benchmarks/bench_symmetry.py`` checks it against observed errors.

Deviations from, and readings of, the paper are marked "Reading:" in the docs of :class:`SymmetryParams`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from aerofid.conventions import FOUND
from aerofid.detect.asymmetry import disc_mask, point_asymmetry
from aerofid.detect.noise import laplacian_noise_sigma
from aerofid.detect.params import MAX_PX, MAX_SIGMA_PX, MethodParams, check
from aerofid.detect.result import Detection, Refused
from aerofid.detect.spline import NEAR_REACH, SplinePart, cubic_coefficients, grid_differences, near, square_grid
from aerofid.robust import MAD_TO_SIGMA, median

if TYPE_CHECKING:
    from matplotlib.figure import Figure

METHOD = "symmetry"

DIAGONALS = (None, "main", "anti")
"""The fiducial area's symmetry axis: upright (None), along the main or the anti-diagonal (seed 2.2)."""


# --- parameters ---------------------------------------------------------------------------------------------

def _is_int(v: Any) -> bool:
    return isinstance(v, int | np.integer) and not isinstance(v, bool)


def _is_num(v: Any) -> bool:
    return isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool) and not math.isnan(v)


@dataclass(frozen=True)
class SymmetryParams(MethodParams):
    """Parameters of the symmetry detector (Cho & Kim, seed 002); the seed's values where it gives them.

    Examples
    --------
    >>> SymmetryParams().max_asymmetry
    0.1
    >>> SymmetryParams(radius=0)
    Traceback (most recent call last):
    ...
    ValueError: radius must be None or an integer in [1, 10000] (px), not 0
    """

    diagonal: str | None = None
    """``None`` for a side fiducial area whose symmetry axis L3 is upright (seed Fig. 2); ``"main"`` for a
    corner area whose axis runs along the main diagonal (top-left to bottom-right), ``"anti"`` along the
    anti-diagonal. The window is then "diagonally projected" (rotated by 45 degrees) before L1, L2, L3 are found
    (seed 2.2); the mark analysis itself is unchanged."""
    edge_step: int = 2
    """``d`` of eq. (1), the pixel separation of the edge profile; the profile is thresholded at its mean
    (seed 3.1)."""
    radius: int | None = None
    """Radius of the symmetry-enhancement kernel of eqs. (4)-(5), "as large as the half-size of the target
    object" (seed 3.2). ``None``: half the larger extent of the fiducial area (L1..L2 and the horizontal
    extent), never less than ``min_radius``."""
    min_radius: int = 3
    """Smallest kernel radius used when the bounds give a smaller one."""
    log_inner: int = 2
    """The simplified LoG of eq. (3), seed 3.2: "the inner radius of R1 as two, outer one as three, and outer
    one of R2 as four". Reading: R1 is the square of half-width ``log_inner`` (5 x 5), R2 the square frame
    between half-widths ``log_gap`` and ``log_outer`` (9 x 9 minus 7 x 7); I2 = mean(R2) - mean(R1), computed
    with box filters."""
    log_gap: int = 3
    """See ``log_inner`` (seed 3.2)."""
    log_outer: int = 4
    """See ``log_inner`` (seed 3.2)."""
    interval: int | None = None
    """``d`` of eqs. (6)-(7) at the first iteration; ``None`` = the kernel radius ("the half-size of the target
    object at first step", seed 3.2)."""
    interval_shrink: float = 0.5
    """Factor by which the interval narrows at each iteration (seed 3.2 says only "narrowing"; halving is our
    choice)."""
    min_interval: int = 1
    """The interval never narrows below this."""
    max_iter: int = 12
    """Iterations (each one vertical and one horizontal step) before the refinement is declared divergent."""
    converge_px: float = 1.0
    """The iteration stops when the shift of one iteration is at most this ("converges into one pixel", seed
    3.2); it diverges when the shift grows twice in a row or ``max_iter`` passes."""
    rself_threshold: float = 0.5
    """Threshold on ``R_self`` of eq. (13) ("adequate value of the threshold can be 0.5", seed 3.3)."""
    min_rotation_corr: float = 0.25
    """Our guard, not in the seed: each 90-degree term R13, R24 of eq. (13) must reach this too. Because R34
    equals R12 identically, a straight bar or band (mirror-symmetric, no centre along its length) scores exactly
    0.5 and would pass the seed's test half of the time."""
    max_asymmetry: float = 0.1
    """Our guard, not in the seed: the largest share of the structure within the kernel radius of the final
    centre (net of noise) that may differ from its 180-degree rotation about it
    (:func:`aerofid.detect.asymmetry.point_asymmetry`, the measure ``auto`` uses too). The mirror additions of
    eqs. (8)-(9) hide a one-sided part (a disc with a bump scores R_self ~ 0.8); assumption (1) of the seed is
    checked directly instead. Measured (docs/marks.md, ``benchmarks/bench_symmetry.py --n 100``): synthetic
    marks on film border stay below 0.01, a disc with a bump of a quarter of its area gives 0.19-0.25, a 'T'
    0.37-0.51. On textured (aerial) ground the texture inside the disc is itself asymmetric (0.05-0.9) and most
    marks are rejected: raise this (e.g. to 1.0) there, accepting that one-sided blobs may then pass. (The limit
    stayed 0.1 when this disc measure replaced the square sub-image measure used before issue 8: 0.08 took the
    same decisions in benchmarks/bench_symmetry.py but refused 3-9 of 30 occluded rings in
    benchmarks/bench_marks.py, which 0.1 keeps; docs/marks.md.)"""
    enlarge: int = 4
    """``R_e`` of eq. (15), the enlargement rate of the bilinear interpolation (not given in the seed; 4 gives
    steps of 1/4 px, refined further by the weighted mean of eq. 14); less for large kernels
    (:data:`ENLARGED_RADIUS`)."""
    smooth_sigma: float = 0.5
    """Standard deviation, in original pixels, of the Gaussian smoothing of the enlarged image (seed 3.4; value
    not given in the seed)."""
    max_total_shift: float = 1.5
    """The sub-pixel stage fails when its total shift from the unit-pixel centre exceeds this many original
    pixels (seed 3.4, "a given threshold")."""
    faint_snr: float = 1.0
    """The mark is "too faint" (seed 3.4) when the standard deviation of the grey levels within ``radius`` of the
    final centre, less the part the noise explains (``sqrt(std^2 - noise^2)``), is below
    ``max(min_std, faint_snr * noise)``; the noise is estimated from the window
    (:func:`aerofid.detect.noise.laplacian_noise_sigma`). The seed gives no values; the noise correction is ours
    (a plain std threshold rejects thin, high-contrast crosses)."""
    min_std: float = 0.005
    """See ``faint_snr`` (seed 3.4)."""
    area_smooth: int = 3
    """Side of a box filter applied to the window before the edge profiles of eq. (1) (not in the seed: it keeps
    the mean threshold from being crossed by noise rows when the mark is thin; 1 = off)."""
    sigma_inefficiency: float = 1.7
    """Calibration of the reported ``sigma`` (not in the seed): the Cramer-Rao-like bound
    ``noise / sqrt(sum of squared gradients)`` times this, ..."""
    sigma_floor: float = 0.005
    """... plus this many px in quadrature for the discretisation of eq. (14) (:func:`centre_sigma`)."""
    point_refine: bool = True
    """Beyond the seed: after eq. (15), the centre is refined by least squares on point symmetry itself
    (:func:`point_symmetry_centre`: the (x, y) about which the window best equals its 180-degree rotation,
    cubic-spline resampled, within the kernel radius). Eq. (14)'s weighted mean of a filtered, accumulated
    profile is biased on marks whose symmetry filters respond unevenly, e.g. 0.1-0.3 px (0.6 px under strong
    blur) on rotated thin crosses, where the refinement gives 0.02 (0.07) px (docs/benchmarks_marks.md).
    ``False``: the seed's centre as published."""
    max_refine_shift: float = 1.0
    """The refinement fails (not found) when it moves the centre further than this (px) from eq. (15)'s: the
    two definitions of the centre disagree. A smaller disagreement is added to ``sigma`` (per axis, in
    quadrature): on textured ground both centres are pulled, differently."""

    def validate(self) -> None:
        """One-line ``ValueError`` for a value no later step could use."""
        check(self.diagonal in DIAGONALS, f"diagonal must be one of {DIAGONALS}, not {self.diagonal!r}")
        for name, low in (("edge_step", 1), ("min_radius", 1), ("log_inner", 0), ("min_interval", 1),
                          ("max_iter", 1), ("enlarge", 1), ("area_smooth", 1)):
            v = getattr(self, name)
            check(_is_int(v) and low <= v <= MAX_PX, f"{name} must be an integer in [{low}, {MAX_PX}], not {v!r}")
        for name in ("radius", "interval"):
            v = getattr(self, name)
            check(v is None or (_is_int(v) and 1 <= v <= MAX_PX),
                  f"{name} must be None or an integer in [1, {MAX_PX}] (px), not {v!r}")
        check(_is_int(self.log_gap) and _is_int(self.log_outer) and self.log_inner < self.log_gap <= self.log_outer,
              f"log_inner < log_gap <= log_outer must hold (integers), not {self.log_inner}, {self.log_gap}, "
              f"{self.log_outer}")
        check(_is_num(self.interval_shrink) and 0 < self.interval_shrink <= 1,
              f"interval_shrink must be in (0, 1], not {self.interval_shrink!r}")
        for name in ("rself_threshold", "min_rotation_corr"):
            v = getattr(self, name)
            check(_is_num(v) and -1 <= v <= 1, f"{name} must be a correlation in [-1, 1], not {v!r}")
        for name in ("converge_px", "max_asymmetry", "smooth_sigma", "faint_snr", "min_std", "sigma_floor",
                     "max_refine_shift"):
            v = getattr(self, name)
            top = MAX_SIGMA_PX if name == "smooth_sigma" else MAX_PX
            check(_is_num(v) and (0 <= v <= top or (name == "max_asymmetry" and v == math.inf)),
                  f"{name} must be a number in [0, {top:g}], not {v!r}")
        for name in ("max_total_shift", "sigma_inefficiency"):
            v = getattr(self, name)
            check(_is_num(v) and 0 < v < math.inf, f"{name} must be a finite number > 0, not {v!r}")
        check(isinstance(self.point_refine, bool | np.bool_), f"point_refine must be True or False, not "
              f"{self.point_refine!r}")


DEFAULT = SymmetryParams()


# --- typed diagnostics --------------------------------------------------------------------------------------

def _diag(default: Any = None) -> Any:
    """A diagnostic field of a result: not compared (it may hold arrays), not in the repr."""
    return field(default=default, compare=False, repr=False)


@dataclass(frozen=True, eq=False)
class FiducialArea:
    """Seed 3.1: the fiducial area's bounds, in window pixels (with ``diagonal``, L1, L2, p1, p2 and the
    profiles are in the diagonally projected window; L3 and ``y_mid`` are mapped back)."""

    L1: int
    """Upper bound (row)."""
    L2: int
    """Lower bound (row)."""
    p1: int
    """Left end of the horizontal extent (column)."""
    p2: int
    """Right end of the horizontal extent (column)."""
    L3: float
    """Symmetry axis (column), eq. (2)."""
    y_mid: float
    """Middle row between L1 and L2."""
    half_height: float
    half_width: float
    edge_profile_v: np.ndarray = _diag()
    """Eq. (1) along the rows (vertical edges)."""
    edge_profile_h: np.ndarray = _diag()
    """Eq. (1) along the columns, below L1 (horizontal edges)."""
    area_profile: np.ndarray = _diag()
    """The grey levels accumulated over rows L1..L2."""
    symmetry_profile: np.ndarray = _diag()
    """Eq. (2) of ``area_profile``."""
    diagonal: str | None = None
    L3_rotated: float | None = None
    y_mid_rotated: float | None = None


@dataclass(frozen=True, eq=False)
class AxisProfile:
    """One step of the mark analysis along one axis: eq. (6) ``I4`` and eq. (7) ``I5`` at ``positions``."""

    positions: np.ndarray = _diag()
    I4: np.ndarray = _diag()
    I5: np.ndarray = _diag()


@dataclass(frozen=True)
class Profiles:
    """The last profiles of an iteration: along x (columns) and along y (rows)."""

    x: AxisProfile
    y: AxisProfile


@dataclass(frozen=True)
class SelfDiagnosis:
    """Eq. (12)-(13): the four normalised cross-correlations and their mean ``r_self``."""

    R12: float
    R34: float
    R13: float
    R24: float

    @property
    def r_self(self) -> float:
        """Eq. (13): the mean of the four correlations (the seed's ``R_self``)."""
        return float((self.R12 + self.R34 + self.R13 + self.R24) / 4.0)


@dataclass(frozen=True, eq=False)
class SubpixelStage:
    """Seed 3.4, on the enlarged neighbourhood: its LoG, the iterations (x', y', d') in enlarged px, the last
    profiles, the enlarged kernel radius and the enlargement rate."""

    enlarged_log: np.ndarray = _diag()
    iterations: tuple[tuple[int, int, int], ...] = ()
    profiles: Profiles | None = None
    kernel_radius: int = 0
    enlarge: int = 1


@dataclass(frozen=True)
class SymmetryResult(Detection):
    """The symmetry detector's answer with every stage's intermediate results (window pixels).

    A field stays at its default when the detector stopped before that stage.
    """

    noise_sigma: float = _diag(float("nan"))
    """The window's noise (:func:`aerofid.detect.noise.laplacian_noise_sigma`)."""
    bounds: FiducialArea | None = _diag()
    """Stage 1, seed 3.1."""
    radius: int | None = _diag()
    """The symmetry kernel's radius (px)."""
    log: np.ndarray | None = _diag()
    """Eq. (3) of the window."""
    aoi: tuple[int, int, int, int] | None = _diag()
    """The area of interest searched at unit-pixel accuracy (x_lo, y_lo, x_hi, y_hi), inclusive."""
    iterations: tuple[tuple[int, int, int], ...] = _diag(())
    """Stage 2: (x, y, interval) after each iteration, starting from (L3, y_mid)."""
    shifts: tuple[float, ...] = _diag(())
    """Stage 2: the shift of each iteration (px)."""
    profiles: Profiles | None = _diag()
    """Stage 2: the last iteration's profiles."""
    centre_pixel: tuple[int, int] | None = _diag()
    """The unit-pixel centre."""
    R_self_pixel: float = _diag(float("nan"))
    R_parts_pixel: SelfDiagnosis | None = _diag()
    """Stage 3 at the unit-pixel centre."""
    subpixel: SubpixelStage | None = _diag()
    """Stage 4."""
    centre_eq15: tuple[float, float] | None = _diag()
    """The centre of eq. (15), before the point-symmetry refinement."""
    R_self: float = _diag(float("nan"))
    R_parts: SelfDiagnosis | None = _diag()
    """Stage 3 at the final centre."""
    asymmetry: float = _diag(float("nan"))
    """:func:`aerofid.detect.asymmetry.point_asymmetry` at the final centre."""
    neighbourhood_std: float = _diag(float("nan"))
    signal_std: float = _diag(float("nan"))
    faint_limit: float = _diag(float("nan"))
    """Faintness test (seed 3.4): the grey-level std near the centre, net of noise, and its limit."""

    def plot(self, fig: Figure, window: np.ndarray) -> None:
        """The window with the fiducial area's bounds L1, L2 (rows), p1, p2 and the axis L3 (columns), the
        unit-pixel and final centres; beside it the last iteration's high-pass profiles ``I5`` (eq. 7)."""
        ax = fig.add_subplot(1, 2, 1)
        ax.imshow(window, cmap="gray", interpolation="nearest")
        b = self.bounds
        if b is not None and b.diagonal is None:
            for yv in (b.L1, b.L2):
                ax.axhline(yv, color="tab:cyan", lw=0.8)
            for xv in (b.p1, b.p2):
                ax.axvline(xv, color="tab:cyan", lw=0.5, ls=":")
            ax.axvline(b.L3, color="tab:green", lw=0.8)
        elif b is not None:
            ax.plot([b.L3], [b.y_mid], "x", color="tab:green", ms=10)
        if self.centre_pixel is not None:
            ax.plot([self.centre_pixel[0]], [self.centre_pixel[1]], "s", mfc="none", color="tab:blue", ms=8)
        if self.found:
            ax.plot([self.x - self.origin[0]], [self.y - self.origin[1]], "+", color="orange", ms=14, mew=2)
            ax.set_title(f"symmetry: ({self.x:.3f}, {self.y:.3f}) R_self {self.score:.2f}", fontsize=9)
        else:
            ax.set_title(f"symmetry: {self.reason}"[:60], fontsize=8)
        ax2 = fig.add_subplot(1, 2, 2)
        if self.profiles is not None:
            for name, prof in (("x", self.profiles.x), ("y", self.profiles.y)):
                ax2.plot(prof.positions, prof.I5, label=f"I5 along {name}")
            ax2.legend(fontsize=7)
        ax2.set_title("high-pass profiles, eq. (7)", fontsize=9)


@dataclass(eq=False)
class _Trace:
    """Internal: the intermediate results gathered so far (the diagnostic fields of :class:`SymmetryResult`)."""

    noise_sigma: float = float("nan")
    bounds: FiducialArea | None = None
    radius: int | None = None
    log: np.ndarray | None = None
    aoi: tuple[int, int, int, int] | None = None
    iterations: tuple[tuple[int, int, int], ...] = ()
    shifts: tuple[float, ...] = ()
    profiles: Profiles | None = None
    centre_pixel: tuple[int, int] | None = None
    R_self_pixel: float = float("nan")
    R_parts_pixel: SelfDiagnosis | None = None
    subpixel: SubpixelStage | None = None
    centre_eq15: tuple[float, float] | None = None
    R_self: float = float("nan")
    R_parts: SelfDiagnosis | None = None
    asymmetry: float = float("nan")
    neighbourhood_std: float = float("nan")
    signal_std: float = float("nan")
    faint_limit: float = float("nan")
    sigma_x: float = float("nan")
    sigma_y: float = float("nan")
    cov_xy: float = float("nan")

    def fields(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def detect(window: np.ndarray, params: SymmetryParams = DEFAULT) -> SymmetryResult:
    """Find the centre of a centrally symmetric mark in ``window`` (Cho & Kim, seed 002).

    Parameters
    ----------
    window : ndarray
        2-D grey-level image, float on [0, 1]. The mark may be brighter or darker than its ground (the method
        is polarity-blind: absolute differences of linear filters, eqs. 3-5, and normalised correlations,
        eq. 12).
    params : SymmetryParams
        The method's parameters (seed defaults).

    Returns
    -------
    SymmetryResult
        The centre in window pixels, ``score = R_self`` of eq. (13) at the final centre (clipped to [0, 1]),
        ``sigma_x``, ``sigma_y``, ``cov_xy`` (px, px^2), ``sigma`` = the mean of ``sigma_x`` and ``sigma_y``
        (not their RMS), and every stage's intermediate results as typed fields. A window without a centrally
        symmetric mark gives ``status="not_found"`` with the reason (never an exception).

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("ring_x_dot", 40, window=90, rng=np.random.default_rng(1))
    >>> d = detect(scene.image)
    >>> d.found, bool(np.hypot(d.x - scene.marks[0].x, d.y - scene.marks[0].y) < 0.05)
    (True, True)
    >>> detect(np.full((60, 60), 0.5, np.float32)).reason
    'homogeneous window: no grey-level variation at all'
    """
    return _answer(window, params, lambda img, t: _run(img, params, t))


def remeasure(window: np.ndarray, x: float, y: float, params: SymmetryParams = DEFAULT,
              final: Detection | None = None) -> SymmetryResult:
    """The centre of a mark this method measured before, at (x, y) (window pixels), on another window: how the
    centre moves with the window, which :meth:`aerofid.find.Measurer.window_term` adds to its uncertainty.

    The window changes the centre through stage 1 (the fiducial area gives the kernel radius) and the
    point-symmetry refinement at that radius; the searches of stages 2 and 4 only lead back to the known centre.
    So: stage 1 as :func:`detect`; the known pixel must lie inside the search range (else the mark is cut by this
    window's edge, as :func:`detect` refuses it); :func:`point_symmetry_centre` from (x, y), within
    ``p.max_refine_shift`` of it; the checks of the final centre (self-diagnosis, point symmetry, faintness). The
    answer equals :func:`detect`'s within 1e-3 px wherever both find it (the window-term windows of the
    synthetic frames of ``benchmarks/bench_frames.py`` and of the real RC20 marks), at a quarter of its cost; it
    has no sigma (``nan``). Without ``point_refine`` the centre is eq. (15)'s, which only the full stages give:
    :func:`detect` then.

    ``final``: this method's own answer at (x, y) (a :class:`SymmetryResult`, any window's coordinates; an ``auto``
    answer is not one, and the full refinement runs). Where stage 1 gives the kernel radius ``final`` was refined
    with, the disc about the centre holds the same pixels: the refinement would stop where it starts (within its
    convergence, 1e-4 px), so it does not run, nor do the final centre's checks (which ``final`` passed; here they
    would differ only through this window's own noise estimate), and the answer is (x, y) with ``final``'s score.
    The window's noise is estimated only where the refinement runs (else ``noise_sigma`` is ``nan``).

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("ring_x_dot", 40, window=90, rng=np.random.default_rng(1))
    >>> d = detect(scene.image)
    >>> again = remeasure(scene.image[2:-3, 4:], d.x - 4, d.y - 2)
    >>> again.found, bool(np.hypot(again.x + 4 - d.x, again.y + 2 - d.y) < 0.05)
    (True, True)
    """
    if not params.point_refine:
        return detect(window, params)
    return _answer(window, params, lambda img, t: _run_again(img, x, y, params, final, t))


def _answer(window: np.ndarray, p: SymmetryParams,
            stages: Callable[[np.ndarray, _Trace], tuple[float, float, float, float]]) -> SymmetryResult:
    """The result of ``stages`` (x, y, score, sigma) on a usable window (float32), the trace's fields with it;
    not found with the reason where the window is unusable or a stage refuses it."""
    img = np.asarray(window)
    problem = _window_problem(img, p)
    if problem is not None:
        return SymmetryResult.not_found(METHOD, problem)
    trace = _Trace()
    try:
        x, y, score, sigma = stages(img.astype(np.float32, copy=False), trace)
    except Refused as f:
        return SymmetryResult.not_found(METHOD, f.reason, **trace.fields())
    return SymmetryResult(status=FOUND, x=x, y=y, score=score, sigma=sigma, method=METHOD, **trace.fields())


def _run_again(img: np.ndarray, x: float, y: float, p: SymmetryParams, final: Detection | None,
               t: _Trace) -> tuple[float, float, float, float]:
    """:func:`remeasure`'s stages on a usable window; fills ``t``; returns (x, y, score, nan) or raises
    :class:`Refused`."""
    bounds, r = _area_stage(img, p, t)
    t.aoi = aoi = search_range(bounds, r, p, img.shape)
    t.centre_pixel = (int(round(x)), int(round(y)))
    _check_in_range(*t.centre_pixel, aoi)
    if isinstance(final, SymmetryResult) and final.found and final.radius == r:
        return float(x), float(y), final.score, float("nan")
    noise = _noise(img, t)
    xs, ys, spline = _refine(img, x, y, r, p, start="the known centre")
    square = spline.square(xs, ys, r)
    score = _verify_centre(img, xs, ys, r, noise, p, t, None if square is None else square.astype(np.float32))
    return float(xs), float(ys), float(np.clip(score, 0.0, 1.0)), float("nan")


def _window_problem(img: np.ndarray, p: SymmetryParams) -> str | None:
    """Why the method cannot run on ``img`` at all (the shape, NaN, no variation), or None."""
    if img.ndim != 2:
        return f"window must be a 2-D grey image, got shape {img.shape}"
    if not np.all(np.isfinite(img)):
        return "window contains NaN or infinite values"
    h, w = img.shape
    need = 2 * (p.log_outer + p.min_radius) + 3
    if h < need or w < need:
        return f"window {w}x{h} px is too small (needs at least {need}x{need})"
    if float(img.max() - img.min()) < 1e-6:
        return "homogeneous window: no grey-level variation at all"
    return None


def _run(img: np.ndarray, p: SymmetryParams, t: _Trace) -> tuple[float, float, float, float]:
    """The four stages on a usable window; fills ``t``; returns (x, y, score, sigma) or raises :class:`Refused`
    (sigma: the mean of ``sigma_x`` and ``sigma_y``)."""
    noise = _noise(img, t)
    bounds, r = _area_stage(img, p, t)
    t.log = i2 = simplified_log(img, p.log_inner, p.log_gap, p.log_outer)
    t.aoi = aoi = search_range(bounds, r, p, img.shape)
    x, y, d = _unit_pixel_centre(i2, bounds, r, aoi, p, t)
    t.centre_pixel = (x, y)
    diag = self_diagnosis(img[y - r:y + r + 1, x - r:x + r + 1])
    t.R_self_pixel, t.R_parts_pixel = diag.r_self, diag
    _check_self_diagnosis(diag, p, "unit-pixel", x, y)
    xs, ys = _subpixel_stage(img, x, y, r, d, p, t)
    x15, y15 = xs, ys
    grid = None
    if p.point_refine:
        t.centre_eq15 = (xs, ys)
        xs, ys, spline = _refine(img, xs, ys, r, p)
        grid = spline.square(xs, ys, r + 1)                   # the refinement's own coefficients, where they reach
    # the final centre's checks and covariance interpolate the same part of the window about the same centre:
    # one (2r + 3)-square of the spline, whose inner (2r + 1)-square is the checks' (the same taps and sums; the
    # same fractions too, to the last bit from r = spline.EDGE_PAD on, below it within 1e-14 of the grey levels)
    part, x0, y0 = near(img, xs, ys, r + 1 + NEAR_REACH)
    if grid is None:
        grid = square_grid(part, xs - x0, ys - y0, r + 1, 3, cubic_coefficients(part))
    score = _verify_centre(img, xs, ys, r, noise, p, t, grid[1:-1, 1:-1].astype(np.float32))
    cov = centre_covariance(part, xs - x0, ys - y0, r, noise, p.sigma_inefficiency, p.sigma_floor, grid)
    # the two centres' disagreement is part of the uncertainty (texture pulls them apart; 0 without point_refine)
    t.sigma_x = float(np.hypot(np.sqrt(cov[0, 0]), xs - x15))
    t.sigma_y = float(np.hypot(np.sqrt(cov[1, 1]), ys - y15))
    t.cov_xy = float(cov[0, 1])
    _check_determined(t.sigma_x, t.sigma_y, r)
    return float(xs), float(ys), float(np.clip(score, 0.0, 1.0)), float(0.5 * (t.sigma_x + t.sigma_y))


def _noise(img: np.ndarray, t: _Trace) -> float:
    """The window's noise (:func:`~aerofid.detect.noise.laplacian_noise_sigma`); fills ``t``."""
    t.noise_sigma = noise = laplacian_noise_sigma(img)
    return noise


def _area_stage(img: np.ndarray, p: SymmetryParams, t: _Trace) -> tuple[FiducialArea, int]:
    """Stage 1 (seed 3.1): the fiducial area and the kernel radius it gives; fills ``t``."""
    area_img = img if p.area_smooth <= 1 else cv2.blur(img, (p.area_smooth, p.area_smooth),
                                                        borderType=cv2.BORDER_REFLECT)
    t.bounds = bounds = fiducial_area(area_img, edge_step=p.edge_step, diagonal=p.diagonal)
    t.radius = r = kernel_radius(bounds, p, img.shape)
    return bounds, r


def kernel_radius(bounds: FiducialArea, p: SymmetryParams, shape: tuple[int, ...]) -> int:
    """The symmetry kernel's radius (seed 3.2): ``p.radius``, or half the larger extent of the fiducial area
    (at least ``p.min_radius``); it must leave room for the LoG inside the window."""
    h, w = shape
    r_max = (min(h, w) - 1) // 2 - p.log_outer - 1
    if p.radius is None:
        r = int(round(max(bounds.half_height, bounds.half_width)))
        return max(p.min_radius, min(r, r_max))
    if p.radius > r_max:
        raise Refused(f"kernel radius {p.radius} px does not fit in the {w}x{h} px window (max {r_max})")
    return int(p.radius)


def search_range(bounds: FiducialArea, r: int, p: SymmetryParams, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """The area of interest of the mark analysis (seed 3.2): the neighbourhood of L3 and the rows between L1 and
    L2 (a square of the kernel radius about the initial centre with ``diagonal``), within the positions where
    the kernel and the LoG fit; (x_lo, y_lo, x_hi, y_hi), inclusive."""
    h, w = shape
    lo_x, hi_x = p.log_outer + r, w - 1 - p.log_outer - r
    lo_y, hi_y = p.log_outer + r, h - 1 - p.log_outer - r
    if lo_x > hi_x or lo_y > hi_y:
        raise Refused(f"window {w}x{h} px leaves no room for a symmetry kernel of radius {r} px")
    if p.diagonal is None:
        ax0, ax1 = bounds.L3 - max(bounds.half_width, r), bounds.L3 + max(bounds.half_width, r)
        ay0, ay1 = min(bounds.L1, bounds.y_mid - r), max(bounds.L2, bounds.y_mid + r)
    else:
        ax0, ax1 = bounds.L3 - r, bounds.L3 + r
        ay0, ay1 = bounds.y_mid - r, bounds.y_mid + r
    lo_x, hi_x = max(lo_x, int(np.floor(ax0))), min(hi_x, int(np.ceil(ax1)))
    lo_y, hi_y = max(lo_y, int(np.floor(ay0))), min(hi_y, int(np.ceil(ay1)))
    if lo_x > hi_x or lo_y > hi_y:
        raise Refused("the area of interest around L3 and between L1 and L2 leaves no room for a symmetry "
                       f"kernel of radius {r} px inside the window")
    return lo_x, lo_y, hi_x, hi_y


def _unit_pixel_centre(i2: np.ndarray, bounds: FiducialArea, r: int, aoi: tuple[int, int, int, int],
                       p: SymmetryParams, t: _Trace) -> tuple[int, int, int]:
    """Stage 2 (seed 3.2): from (L3, y_mid), alternate vertical and horizontal steps (:func:`axis_peak`) with an
    interval that narrows by ``p.interval_shrink`` until a step moves the centre at most ``p.converge_px``;
    returns the unit-pixel centre (x, y) and the last interval. Divergence, or a centre at the limit of the
    search range (a mark cut by the window edge), is a failure."""
    lo_x, lo_y, hi_x, hi_y = aoi
    x = int(np.clip(round(bounds.L3), lo_x, hi_x))
    y = int(np.clip(round(bounds.y_mid), lo_y, hi_y))
    d = int(p.interval) if p.interval is not None else r
    history, shifts = [(x, y, d)], []
    converged = False
    dy, dx = mirror_differences(i2.T, r, lo_y, hi_y), mirror_differences(i2, r, lo_x, hi_x)
    for _ in range(p.max_iter):
        y_new, py = axis_peak(i2.T, x, r, d, lo_y, hi_y, dy)     # vertical step: L4 (centre row)
        x_new, px = axis_peak(i2, y_new, r, d, lo_x, hi_x, dx)   # horizontal step: centre column
        t.profiles = Profiles(x=px, y=py)
        shift = float(np.hypot(x_new - x, y_new - y))
        shifts.append(shift)
        x, y = x_new, y_new
        history.append((x, y, d))
        d_next = max(p.min_interval, int(np.floor(d * p.interval_shrink)))
        converged = _converged(shifts, p.converge_px, d_next == d)
        if converged or _diverging(shifts, p.converge_px):
            break
        d = d_next
    t.iterations, t.shifts = tuple(history), tuple(shifts)
    if not converged:
        raise Refused(f"symmetry centre diverged: shifts {', '.join(f'{s:.1f}' for s in shifts)} px "
                       f"in {len(shifts)} iterations")
    _check_in_range(x, y, aoi)
    return x, y, d


def _check_in_range(x: int, y: int, aoi: tuple[int, int, int, int]) -> None:
    """A unit-pixel centre at the limit of the search range ``aoi`` is a failure (a mark cut by the window edge)."""
    lo_x, lo_y, hi_x, hi_y = aoi
    for name, c, lo, hi in (("x", x, lo_x, hi_x), ("y", y, lo_y, hi_y)):
        if hi - lo >= 2 and (c <= lo or c >= hi):
            raise Refused(f"symmetry centre {name}={c} is at the limit of the search range [{lo}, {hi}]: "
                           "the mark is probably cut by the window edge or larger than the window")


def _converged(shifts: list[float], converge_px: float, interval_final: bool) -> bool:
    """The last step moved at most ``converge_px`` with the interval at its floor, or two steps in a row did."""
    if shifts[-1] > converge_px:
        return False
    return interval_final or (len(shifts) >= 2 and shifts[-2] <= converge_px)


def _diverging(shifts: list[float], converge_px: float) -> bool:
    """The shift grew twice in a row and is still above ``converge_px``."""
    return len(shifts) >= 3 and shifts[-1] > shifts[-2] > shifts[-3] and shifts[-1] > converge_px


def _check_self_diagnosis(diag: SelfDiagnosis, p: SymmetryParams, stage: str, x: float, y: float) -> None:
    """Seed 3.3: ``R_self >= p.rself_threshold``; and (ours, not the seed's) the 90-degree terms R13, R24 at
    least ``p.min_rotation_corr``: since R34 == R12, any pattern mirror-symmetric in x and y but with no structure
    across the other axis (a straight bar or band) scores R_self = (1 + 1 + 0 + 0) / 4 = 0.5 and passes the
    seed's threshold by the toss of the noise."""
    if not diag.r_self >= p.rself_threshold:
        if stage == "unit-pixel":
            raise Refused(f"self-diagnosis failed: R_self = {diag.r_self:.2f} < {p.rself_threshold} at pixel "
                           f"({x}, {y}); the window holds no centrally symmetric mark there")
        raise Refused(f"self-diagnosis failed at the sub-pixel centre: R_self = {diag.r_self:.2f} < "
                       f"{p.rself_threshold}")
    if not min(diag.R13, diag.R24) >= p.min_rotation_corr:
        raise Refused(f"self-diagnosis failed at the {stage} centre ({x:.1f}, {y:.1f}): the 90-degree "
                       f"correlations R13 = {diag.R13:.2f}, R24 = {diag.R24:.2f} are below {p.min_rotation_corr} "
                       "(a straight bar or band, or a pattern symmetric about one axis only)")


def _subpixel_stage(img: np.ndarray, x: int, y: int, r: int, d: int, p: SymmetryParams,
                    t: _Trace) -> tuple[float, float]:
    """Stage 4 (seed 3.4) with its failures: no room for the enlarged kernel, or a total shift above
    ``p.max_total_shift``."""
    got = subpixel_centre(img, x, y, r, d, p)
    if got is None:
        raise Refused("sub-pixel stage: no room for the enlarged kernel (the mark is too close to the window "
                       "edge); enlarge the box")
    xs, ys, t.subpixel = got
    total = float(np.hypot(xs - x, ys - y))
    if not np.isfinite(total) or total > p.max_total_shift:
        raise Refused(f"sub-pixel stage moved the centre by {total:.2f} px (> {p.max_total_shift} px) "
                       "from the unit-pixel centre")
    return xs, ys


def _refine(img: np.ndarray, xs: float, ys: float, r: int, p: SymmetryParams,
            start: str = "eq. (15)'s") -> tuple[float, float, SplinePart]:
    """Beyond the seed: :func:`point_symmetry_centre` from the ``start`` centre (xs, ys), eq. (15)'s; it must
    converge and stay within ``p.max_refine_shift`` of it. With the spline coefficients it ended on (which
    resample the window about the centre where they reach: :meth:`~aerofid.detect.spline.SplinePart.square`)."""
    got = _point_symmetry(img, xs, ys, r)
    if got is None:
        raise Refused("the point-symmetry refinement did not converge (a flat or one-sided pattern)")
    shift = float(np.hypot(got[0] - xs, got[1] - ys))
    if shift > p.max_refine_shift:
        raise Refused(f"the point-symmetry centre lies {shift:.2f} px from {start} (> {p.max_refine_shift} "
                       "px): the two disagree")
    return got


def _verify_centre(img: np.ndarray, xs: float, ys: float, r: int, noise: float, p: SymmetryParams,
                   t: _Trace, subs: np.ndarray | None = None) -> float:
    """The checks at the final centre: self-diagnosis (seed 3.3), point symmetry (``p.max_asymmetry``, ours)
    and faintness (seed 3.4); returns ``R_self`` there. ``subs``: the (2r + 1)-square about the centre
    (:func:`_resample`), if known."""
    if subs is None:
        subs = _resample(img, xs, ys, r)
    diag = self_diagnosis(subs)
    t.R_self, t.R_parts = diag.r_self, diag
    _check_self_diagnosis(diag, p, "sub-pixel", xs, ys)
    t.asymmetry = asym = point_asymmetry(img, xs, ys, r, noise)
    if not asym <= p.max_asymmetry:
        raise Refused(f"the pattern is not centrally symmetric about ({xs:.2f}, {ys:.2f}): the 180-degree "
                       f"residual holds {asym:.2f} of its structure (limit {p.max_asymmetry})")
    spread = float(subs[disc_mask(r, float(r))].std())
    t.neighbourhood_std, t.signal_std = spread, float(np.sqrt(max(spread * spread - noise * noise, 0.0)))
    t.faint_limit = max(p.min_std, p.faint_snr * noise)
    if t.signal_std < t.faint_limit:
        raise Refused(f"mark too faint: grey-level std {spread:.4f} near the centre, {t.signal_std:.4f} net of "
                       f"noise {noise:.4f}, is below {t.faint_limit:.4f}")
    return diag.r_self


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
        p[d:n - d] = moving_mean(p[d:n - d], d)
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
    a = np.asarray(a, np.float64)
    n = len(a)
    out = np.full(n, np.inf)
    if d < 1 or n < 3:
        return out
    # terms[u - 1, x] = |a(x + u) - a(x - u)| for u = 1..d where both exist, summed over u = 1..k(x)
    x = np.arange(n)
    k = np.minimum(np.minimum(x, n - 1 - x), d)
    u = np.arange(1, d + 1)[:, None]
    terms = np.abs(a[np.clip(x + u, 0, n - 1)] - a[np.clip(x - u, 0, n - 1)])
    sums = np.cumsum(terms, axis=0)
    ok = k >= max(1, d // 2)
    out[ok] = sums[k[ok] - 1, x[ok]] / k[ok]
    return out


def fiducial_area(img: np.ndarray, edge_step: int = 2, diagonal: str | None = None) -> FiducialArea:
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
    fill = float(median(img))
    rot = np.where(valid, rot, fill).astype(np.float32)
    b = _area_upright(rot, edge_step)
    inv = cv2.invertAffineTransform(m)
    x0 = inv[0, 0] * b.L3 + inv[0, 1] * b.y_mid + inv[0, 2]
    y0 = inv[1, 0] * b.L3 + inv[1, 1] * b.y_mid + inv[1, 2]
    return dataclasses.replace(b, diagonal=diagonal, L3_rotated=b.L3, y_mid_rotated=b.y_mid, L3=float(x0),
                               y_mid=float(y0), half_height=b.half_height / np.sqrt(2),
                               half_width=b.half_width / np.sqrt(2))


def _area_upright(img: np.ndarray, edge_step: int) -> FiducialArea:
    """:func:`fiducial_area` for an upright axis."""
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
    return FiducialArea(L1=int(l1), L2=int(l2), p1=int(p1), p2=int(p2), L3=l3, y_mid=0.5 * (l1 + l2),
                        half_height=0.5 * (l2 - l1), half_width=0.5 * (p2 - p1), edge_profile_v=iv,
                        edge_profile_h=ih, area_profile=ia, symmetry_profile=i_s)


# --- stage 2: mark analysis --------------------------------------------------------------------------------

def simplified_log(img: np.ndarray, inner: int = 2, gap: int = 3, outer: int = 4) -> np.ndarray:
    """Eq. (3): ``I2 = mean over R2 - mean over R1`` with R1 the ``(2 inner + 1)``-square and R2 the square
    frame between half-widths ``gap`` and ``outer``, by box filtering (McDonald 1981), float32."""
    f = img.astype(np.float32)

    def boxsum(k: int) -> np.ndarray:
        return cv2.boxFilter(f, -1, (2 * k + 1, 2 * k + 1), normalize=False, borderType=cv2.BORDER_REFLECT)

    n1 = (2 * inner + 1) ** 2
    n2 = (2 * outer + 1) ** 2 - (2 * gap - 1) ** 2
    out = boxsum(outer)
    if gap >= 1:
        out -= boxsum(gap - 1)
    out /= n2
    s_in = boxsum(inner)
    s_in /= n1
    out -= s_in
    return out


@dataclass(frozen=True, eq=False)
class MirrorDifferences:
    """``D(y, x) = sum_{u=1..r} |I2(x + u, y) - I2(x - u, y)|`` for every row ``y`` of ``I2`` and the columns
    ``x0 .. x0 + n - 1``: the part of eq. (4) that depends on neither the row of a step nor its interval, so the
    iterations of stages 2 and 4 compute it once per axis instead of at every step (:func:`mirror_differences`)."""

    values: np.ndarray
    """(rows of I2, n) float32."""
    x0: int


MIRROR_BUDGET = 1 << 20
"""Most differences (float32) :func:`mirror_differences` holds at once to sum them over ``u`` in one reduction (4 MB);
where the kernel radius times the image's side exceeds it, they are summed one ``u`` at a time."""


def mirror_differences(i2: np.ndarray, r: int, lo: int, hi: int) -> MirrorDifferences:
    """:class:`MirrorDifferences` of ``i2`` for the kernel radius ``r`` and the columns ``lo..hi`` (inclusive;
    columns ``lo - r .. hi + r`` must lie inside ``i2``). Taken along the rows of ``i2`` transposed (the array a
    transposed view, the vertical axis, views; else a contiguous copy), so that every slice is contiguous, in
    float32 like ``I2`` (:func:`simplified_log`): sums of at most a few hundred terms, to about 1e-6 of their size,
    2-3x faster than in float64. Where the differences of every ``u`` fit :data:`MIRROR_BUDGET` they are made in
    one pass over a stack of views (``(r, columns, rows)``) and summed over ``u`` by one reduction (2x faster on the
    windows of the marks than a pass per ``u``); else one ``u`` at a time in place. Both add the terms in the order
    ``u = 1 .. r``, so both give the same sums: numpy adds along an axis that is not the fastest in memory one slice
    after another (its pairwise summation is only along the fastest), which the stack's first axis is not unless the
    stack holds one difference per ``u`` (one row of one column: then one ``u`` at a time)."""
    src = np.asarray(i2.T if i2.T.flags.c_contiguous else np.ascontiguousarray(i2.T), np.float32)
    n = hi + 1 - lo
    if 1 < n * src.shape[1] and r * n * src.shape[1] <= MIRROR_BUDGET:
        # win[j] holds the rows lo - r + j .. hi - r + j: u's right terms are win[r + u], its left ones win[r - u]
        win = sliding_window_view(src[lo - r:hi + 1 + r], n, axis=0).transpose(0, 2, 1)
        step = np.subtract(win[r + 1:], win[r - 1::-1])
        out = np.add.reduce(np.abs(step, out=step), axis=0)
    else:
        out = np.zeros((n, src.shape[1]), np.float32)
        one = np.empty_like(out)
        for u in range(1, r + 1):
            cv2.absdiff(src[lo + u:hi + 1 + u], src[lo - u:hi + 1 - u], dst=one)   # |a - b| in one pass
            out += one
    return MirrorDifferences(np.ascontiguousarray(out.T), int(lo))


def symmetry_accumulation(i2: np.ndarray, row: int, r: int, d: int, xs: np.ndarray,
                          diffs: MirrorDifferences | None = None) -> np.ndarray:
    """Eqs. (4) and (6) together: for each column ``x`` in ``xs``,
    ``I4(x) = sum_{v=-d..d} I3(x, row + v)`` with ``I3(x, y) = sum_{u=1..r} sum_{v'=-r..r}
    |I2(x + u, y + v') - I2(x - u, y + v')|`` (the half-kernels T1/T2 of seed Fig. 6 are squares of radius
    ``r``). Row offsets ``v + v'`` are weighted by how often they occur; rows outside the image are skipped.
    Columns ``x - r .. x + r`` must lie inside ``i2``. ``diffs`` (:func:`mirror_differences` of ``i2`` and ``r``
    for columns including ``xs``) saves recomputing the sum over ``u``.
    """
    first = row - (d + r)                               # the rows of the offsets v + v', clipped to the image
    lo_row = min(max(first, 0), i2.shape[0])
    n_rows = max(min(row + d + r, i2.shape[0] - 1) + 1 - lo_row, 0)
    wts = _row_weights(r, d)[lo_row - first:lo_row - first + n_rows]
    if diffs is None:
        lo = int(np.min(xs))
        return wts @ mirror_differences(i2[lo_row:lo_row + n_rows], r, lo, int(np.max(xs))).values[:, xs - lo]
    return wts @ diffs.values[lo_row:lo_row + n_rows][:, xs - diffs.x0]


@functools.lru_cache(maxsize=256)
def _row_weights(r: int, d: int) -> np.ndarray:
    """How often each row offset ``v + v'`` (``-(d + r) .. d + r``) occurs in :func:`symmetry_accumulation`:
    the convolution of two boxcars of ``2d + 1`` and ``2r + 1`` ones (read-only, made once per r and d)."""
    w = np.convolve(np.ones(2 * d + 1), np.ones(2 * r + 1))
    w.setflags(write=False)
    return w


def high_pass(profile: np.ndarray, d: int) -> np.ndarray:
    """Eq. (7): ``I5(x) = mean_{u=-d..d} I4(x + u) - I4(x)`` (ends padded with the nearest value)."""
    return moving_mean(profile, d) - profile


def moving_mean(profile: np.ndarray, d: int) -> np.ndarray:
    """The mean of ``profile`` over ``2d + 1`` samples centred on each, its ends extended by their nearest value
    (``scipy.ndimage.uniform_filter1d(profile, 2 * d + 1, mode="nearest")``), in float64.

    Examples
    --------
    >>> moving_mean(np.array([0.0, 3.0, 0.0, 0.0]), 1).tolist()
    [1.0, 1.0, 1.0, 0.0]
    """
    a = np.asarray(profile, np.float64)
    c = np.empty(len(a) + 2 * d + 1)                     # 0, then the cumulative sums of the edge-extended profile
    c[0] = 0.0
    c[1:d + 1], c[d + 1:len(a) + d + 1], c[len(a) + d + 1:] = a[0], a, a[-1]
    np.cumsum(c[1:], out=c[1:])
    return (c[2 * d + 1:] - c[:-2 * d - 1]) / (2 * d + 1)


def axis_peak(i2: np.ndarray, row: int, r: int, d: int, lo: int, hi: int,
              diffs: MirrorDifferences | None = None) -> tuple[int, AxisProfile]:
    """One step along the columns of ``i2``: profile I4 (eq. 6) over ``lo..hi`` around ``row``, I5 (eq. 7), and
    the column of its peak (``diffs``: see :func:`symmetry_accumulation`)."""
    xs = np.arange(lo, hi + 1)
    i4 = symmetry_accumulation(i2, row, r, d, xs, diffs)
    i5 = high_pass(i4, d)
    return int(lo + int(np.argmax(i5))), AxisProfile(positions=xs, I4=i4, I5=i5)


# --- stage 3: self-diagnosis -------------------------------------------------------------------------------

def self_diagnosis(sub: np.ndarray) -> SelfDiagnosis:
    """Eqs. (8)-(13) on a square sub-image ``I6`` centred on the candidate centre.

    ``S1 = I6 + mirror_x(I6)``, ``S2 = I6 + mirror_y(I6)`` (eqs. 8-9), ``S3 = Rot90(S1)``, ``S4 = Rot90(S2)``
    (eqs. 10-11) and ``R_self = (R12 + R34 + R13 + R24) / 4`` (eq. 13). Rotating both images does not change
    their correlation, so ``R34 == R12`` (the seed's formula is kept as written, its term not computed twice);
    nor does it change an image's mean and norm, so each correlation is one sum of products of the two images
    less their means (eq. 12's values, within rounding).
    """
    s1 = (sub + sub[:, ::-1]).astype(np.float64)
    s2 = (sub + sub[::-1, :]).astype(np.float64)
    s1 -= s1.mean()
    s2 -= s2.mean()
    n1, n2 = float((s1 * s1).sum()), float((s2 * s2).sum())

    def r(a: np.ndarray, b: np.ndarray, den: float) -> float:
        return float((a * b).sum() / den) if den > 0 else 0.0

    r12 = r(s1, s2, math.sqrt(n1 * n2))
    return SelfDiagnosis(R12=r12, R34=r12, R13=r(s1, np.rot90(s1), n1), R24=r(s2, np.rot90(s2), n2))


# --- stage 4: sub-pixel location ---------------------------------------------------------------------------

def subpixel_centre(img: np.ndarray, x: int, y: int, r: int, d: int,
                    p: SymmetryParams = DEFAULT) -> tuple[float, float, SubpixelStage] | None:
    """Seed 3.4: enlarge the neighbourhood of pixel (x, y) by ``p.enlarge`` (bilinear), smooth it, run the mark
    analysis there with scaled kernels (:func:`_enlarged_iteration`) and take the weighted mean of eq. (14);
    return (x, y) by eq. (15) and the stage's intermediate results, or None when the enlarged kernel does not
    fit (the mark is too close to the window edge)."""
    re = enlargement(p.enlarge, r)
    hs = r + p.log_outer                                  # fits: candidates keep log_outer + r from the edges
    sub = img[y - hs:y + hs + 1, x - hs:x + hs + 1]
    n = 2 * hs + 1
    big = cv2.resize(sub, (n * re, n * re), interpolation=cv2.INTER_LINEAR)
    if p.smooth_sigma > 0:
        big = cv2.GaussianBlur(big, (0, 0), p.smooth_sigma * re, borderType=cv2.BORDER_REFLECT)
    i2 = simplified_log(big, p.log_inner * re, p.log_gap * re, p.log_outer * re)
    # enlarged pixel x' <-> sub-image coordinate (x' + 0.5) / re - 0.5 (cv2's half-pixel convention)
    c = int(round(re * (hs + 0.5) - 0.5))                # enlarged index nearest to the unit-pixel centre
    m = int(np.ceil((p.max_total_shift + 0.5) * re))      # search half-range, enlarged px
    margin = p.log_outer * re + int(np.ceil(3 * p.smooth_sigma * re)) + 1
    re_r = int(min(r * re, c - m - margin))
    if re_r < re:
        return None
    (cx, cy), hist, profiles = _enlarged_iteration(i2, c, m, re_r, max(1, int(d * re)), p)
    fx = _weighted_peak(profiles.x, cx)
    fy = _weighted_peak(profiles.y, cy)
    # eq. (15): x_t = x_f + x'_p + x''_s / R_e, with x_f the sub-image origin in the window
    xt = (x - hs) + (fx + 0.5) / re - 0.5
    yt = (y - hs) + (fy + 0.5) / re - 0.5
    return xt, yt, SubpixelStage(enlarged_log=i2, iterations=tuple(hist), profiles=profiles, kernel_radius=re_r,
                                 enlarge=re)


ENLARGED_RADIUS = 180
"""The enlarged kernel radius (px) beyond which the sub-pixel stage enlarges less than ``enlarge``, down to 2
(:func:`enlargement`): its cost grows with the cube of the enlarged radius, and a large mark's eq. (14) needs no
steps finer than half a pixel before the point-symmetry refinement. Where that refinement settles depends on its
start at the 0.01 px level, so large marks' centres move by that much (docs/benchmarks_frames.md: the 11000^2
frames, kernel radii 90-147 px, before and after)."""


def enlargement(enlarge: int, r: int) -> int:
    """``R_e`` of eq. (15) for a kernel of radius ``r``: ``enlarge``, less when ``r R_e`` would pass
    :data:`ENLARGED_RADIUS` (not below 2, nor above ``enlarge``).

    Examples
    --------
    >>> enlargement(4, 30), enlargement(4, 60), enlargement(4, 90), enlargement(1, 90)
    (4, 3, 2, 1)
    """
    return int(min(enlarge, max(2, ENLARGED_RADIUS // max(r, 1))))


def _enlarged_iteration(i2: np.ndarray, c: int, m: int, r: int, d: int, p: SymmetryParams
                        ) -> tuple[tuple[int, int], list[tuple[int, int, int]], Profiles]:
    """The iteration of stage 2 on the enlarged LoG ``i2`` from (c, c), searching ``c - m .. c + m``, until a
    step moves less than one enlarged pixel at the final interval; returns the centre, the history and the last
    profiles."""
    cx = cy = c
    hist = [(cx, cy, d)]
    profiles = None
    # the widest columns any step needs (the interval d only shrinks), for both axes of the square i2
    dy = mirror_differences(i2.T, r, max(r, c - m - d), min(i2.shape[0] - 1 - r, c + m + d))
    dx = mirror_differences(i2, r, max(r, c - m - d), min(i2.shape[1] - 1 - r, c + m + d))
    for _ in range(p.max_iter):
        cy_new, py = _axis_peak_local(i2.T, cx, r, d, c - m, c + m, dy)
        cx_new, px = _axis_peak_local(i2, cy_new, r, d, c - m, c + m, dx)
        profiles = Profiles(x=px, y=py)
        shift = max(abs(cx_new - cx), abs(cy_new - cy))
        cx, cy = cx_new, cy_new
        hist.append((cx, cy, d))
        d_next = max(1, int(np.floor(d * p.interval_shrink)))
        if shift < 1 and d_next == d:
            break
        d = d_next
    assert profiles is not None                           # max_iter >= 1
    return (cx, cy), hist, profiles


def _axis_peak_local(i2: np.ndarray, row: int, r: int, d: int, lo: int, hi: int,
                     diffs: MirrorDifferences) -> tuple[int, AxisProfile]:
    """Like :func:`axis_peak`, on ``lo..hi`` with I4 computed ``d`` further on each side so that the
    high-pass of eq. (7) is exact on the search range."""
    ext_lo = max(r, lo - d)
    ext_hi = min(i2.shape[1] - 1 - r, hi + d)
    xs = np.arange(ext_lo, ext_hi + 1)
    i4 = symmetry_accumulation(i2, row, r, d, xs, diffs)
    i5 = high_pass(i4, d)
    a, b = lo - ext_lo, hi - ext_lo
    p = a + int(np.argmax(i5[a:b + 1]))
    return int(ext_lo + p), AxisProfile(positions=xs, I4=i4, I5=i5)


def _weighted_peak(prof: AxisProfile, peak: int) -> float:
    """Eq. (14): weighted mean position of I5 over ``peak - dd .. peak + dd``, where ``dd`` is half the extent
    of the run of positive I5 around the peak (seed 3.4). Negative values inside the interval count as 0."""
    xs, i5 = prof.positions, prof.I5
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
    return square_grid(img, xc, yc, r, 3).astype(np.float32)


# --- noise and precision -----------------------------------------------------------------------------------

def _mirror_step(j: np.ndarray) -> np.ndarray:
    """One Gauss-Newton step (x, y) towards the mirror-symmetric centre of ``j``, a square resampled about a
    centre (float64): minimises sum (J - mirror(J))^2 over a shift of the centre."""
    gy, gx = _gradient(j, 0), _gradient(j, 1)
    out = []
    for dd, dg in ((j - j[:, ::-1], gx - gx[:, ::-1]), (j - j[::-1], gy - gy[::-1])):
        den = float((dg * dg).sum())
        out.append(-float((dd * dg).sum()) / den if den > 0 else 0.0)
    return np.array(out)


def _gradient(j: np.ndarray, axis: int) -> np.ndarray:
    """``np.gradient(j, axis=axis)`` (unit spacing: central differences, one-sided at the ends; the same
    operations, so the same values), without its generality's cost on a measuring window."""
    a = j if axis == 0 else j.T
    g = np.empty_like(a)
    g[1:-1] = (a[2:] - a[:-2]) / 2.0
    g[0] = a[1] - a[0]
    g[-1] = a[-1] - a[-2]
    return g if axis == 0 else g.T


HUBER_K = 1.5
"""Residuals beyond this many robust sigmas get Huber weights in :func:`point_symmetry_centre`."""
REFINE_ITERATIONS = 8
"""Iterations of :func:`point_symmetry_centre` at most (it stops at a step below 1e-4 px)."""
BROYDEN_PROGRESS = 0.9
""":func:`point_symmetry_centre` steps on Broyden's estimate only while each plain Gauss-Newton step is shorter than
this share of the one before (and turned by little: :data:`BROYDEN_ALIGN`); else it takes the plain step, afresh."""
BROYDEN_ALIGN = 0.95
"""Least cosine of the angle between two successive plain steps for :func:`point_symmetry_centre` to step on
Broyden's estimate."""
BROYDEN_MAX_GAIN = 5.0
"""Most times the plain step that a step on Broyden's estimate may be (the plain steps shrinking by 0.8 a step or
faster; else the plain step, afresh). Up to 50 times, the creeping refinements of a clean JPEG frame came nearer their
limit too (104 -> 94 steps, before :data:`BROYDEN_MAX_STEP`), but a real EarthExplorer block midside
(``hipp_nagap_ee/fiducial_templates/ee/block/B.jpg``) moved 0.22 px (0.005 px at 5), and without
:data:`BROYDEN_MIN_RADIUS` two notch dots of ``benchmarks/bench_marks.py`` that ``auto`` found were refused."""
BROYDEN_MAX_STEP = 0.02
"""Longest step (px) of :func:`point_symmetry_centre` on Broyden's estimate: it finishes the plain steps' creep, and
a long step from one secant pair left the basin of their limit (a faint, blurred JPEG dot: 0.22 px, to another
point 0.165 px away)."""
BROYDEN_MIN_RADIUS = 16
"""Least kernel radius (px) at which :func:`point_symmetry_centre` steps on Broyden's estimate. About a smaller disc
(a few hundred residuals, and fewer: ``auto``'s isolated blob, 6 px) the median's scale and the Huber weights change
by jumps from step to step, the plain steps wander rather than shrink, and Broyden's steps wandered further: a real
NAGAP midside (``hipp_nagap_ee/fiducial_templates/nagap/curve/T.jpg``) that the plain steps found was refused. Every
step saved on the frames of ``benchmarks/bench_frames.py`` and the real RC20 frame was at 16 px or more."""
REFINE_DRIFT = 4
"""The spline coefficients of :func:`point_symmetry_centre` are those of the window's part around its start,
with this much room for the centre to move before they are made again around it."""


@functools.lru_cache(maxsize=32)
def _half_disc(r: int) -> np.ndarray:
    """The half of the disc of radius ``r`` (:func:`~aerofid.detect.asymmetry.disc_mask`) that pairs with the other
    by a half turn: ``dy > 0``, or ``dy == 0 < dx`` (read-only, made once per radius)."""
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    m = ((yy > 0) | ((yy == 0) & (xx > 0))) & disc_mask(r, float(r))
    m.setflags(write=False)
    return m


def point_symmetry_centre(img: np.ndarray, xc: float, yc: float, r: int) -> tuple[float, float] | None:
    """The centre (x, y) about which the window best equals its 180-degree rotation, from (xc, yc): minimises
    ``sum_u (I(c + u) - I(c - u))^2`` over the offsets u in one half of the disc of radius ``r`` (cubic-spline
    resampling; derivatives by central differences of the spline), Huber-weighted (:func:`_gauss_newton_step`).
    None when the normal matrix is singular, the iteration leaves the window or does not settle.

    The centre is where the Huber-weighted Gauss-Newton step ``g(c)`` vanishes. The weights follow a robust scale
    from the median residual, which a mark's aliased edges (and a JPEG's blocks, and noise) exceed: much of what
    places the centre is in down-weighted residuals, and the plain steps ``c + g(c)`` converge linearly, on noisy and
    JPEG marks often not within :data:`REFINE_ITERATIONS`. So while the plain steps shrink steadily
    (:data:`BROYDEN_PROGRESS`, :data:`BROYDEN_ALIGN`) about a disc of :data:`BROYDEN_MIN_RADIUS` px or more, each
    step is ``H g``, ``H`` Broyden's estimate of ``-(dg/dc)^-1`` from the steps so far (``H = I`` first: the plain
    step; the "good" update of the inverse, Broyden 1965), at most :data:`BROYDEN_MAX_GAIN` plain steps and
    :data:`BROYDEN_MAX_STEP` px long; otherwise the plain step, and ``H`` afresh. The plain step alone stops the
    iteration (below 1e-4 px: then it is the step taken) and judges the answer (below 1e-2 px at the last iteration),
    as before. On the noisy frames of ``benchmarks/bench_frames.py`` and the real RC20 frame the refinements take
    a fifth to a third fewer steps and end nearer the plain steps' limit (on RC20 the plain ones stopped up to 0.011 px
    short of it).
    """
    got = _point_symmetry(img, xc, yc, r)
    return None if got is None else got[:2]


def _point_symmetry(img: np.ndarray, xc: float, yc: float, r: int) -> tuple[float, float, SplinePart] | None:
    """:func:`point_symmetry_centre`, with the spline coefficients of its last iteration."""
    h, w = img.shape
    if r < 2:
        return None
    half = _half_disc(r)
    step, start, spline = np.inf, (xc, yc), None
    c = np.array([xc, yc], float)
    inverse = np.eye(2)                             # H: minus the inverse Jacobian of the step g(c), estimated
    before: tuple[np.ndarray, np.ndarray] | None = None   # the centre and step of the iteration before
    for _ in range(REFINE_ITERATIONS):
        if not (r <= c[0] <= w - 1 - r and r <= c[1] <= h - 1 - r):
            return None
        if spline is None or max(abs(c[0] - start[0]), abs(c[1] - start[1])) > REFINE_DRIFT:
            # the coefficients of the part of the window the disc needs (made again when the centre moves away)
            start, spline = (float(c[0]), float(c[1])), SplinePart.about(img, c[0], c[1],
                                                                         r + NEAR_REACH + REFINE_DRIFT)
        g = _gauss_newton_step(spline, c, r, half)
        if g is None:
            return None
        step = float(np.hypot(*g))                  # the plain step: it stops the iteration and judges the answer
        d = g                                       # the step taken: the plain one, unless Broyden's estimate stands
        if step >= 1e-4 and before is not None and r >= BROYDEN_MIN_RADIUS and _steady(before[1], g):
            inverse = _broyden_update(inverse, c - before[0], g - before[1])
            d = inverse @ g
            if not np.isfinite(d).all() or np.hypot(*d) > min(BROYDEN_MAX_GAIN * step, BROYDEN_MAX_STEP):
                d = g
        if d is g:
            inverse = np.eye(2)
        before = (c, g)
        c = c + d
        if step < 1e-4:
            break
    return (float(c[0]), float(c[1]), spline) if step < 1e-2 and spline is not None else None


def _gauss_newton_step(spline: SplinePart, c: np.ndarray, r: int, half: np.ndarray) -> np.ndarray | None:
    """The Gauss-Newton step (dx, dy) of :func:`point_symmetry_centre` from the centre ``c``, each residual
    Huber-weighted (:data:`HUBER_K` robust sigmas, the sigma from their median: texture that is not point-symmetric,
    aerial ground around the mark, must not pull); None when its normal matrix is singular."""
    e, gx, gy = _mirror_terms(spline.coeffs, c[0] - spline.x0, c[1] - spline.y0, r, half)
    scale = max(MAD_TO_SIGMA * float(median(np.abs(e))), 1e-9)
    wgt = np.minimum(1.0, HUBER_K * scale / np.maximum(np.abs(e), 1e-12))
    A = np.column_stack([gx, gy]) * wgt[:, None]
    N = A.T @ A
    if not np.isfinite(N).all() or np.linalg.cond(N) > 1e8:
        return None
    return -np.linalg.solve(N, A.T @ (e * wgt))


def _steady(before: np.ndarray, g: np.ndarray) -> bool:
    """Whether the plain step ``g`` follows the plain step ``before`` steadily: shorter by :data:`BROYDEN_PROGRESS` and
    turned by little (:data:`BROYDEN_ALIGN`)."""
    n0, n1 = float(np.hypot(*before)), float(np.hypot(*g))
    return n1 < BROYDEN_PROGRESS * n0 and float(g @ before) > BROYDEN_ALIGN * n0 * n1


def _broyden_update(inverse: np.ndarray, dc: np.ndarray, dg: np.ndarray) -> np.ndarray:
    """Broyden's "good" update of ``H`` (minus the inverse Jacobian of the step ``g(c)``) from the change ``dc`` of
    the centre and ``dg`` of the step: the new ``H`` maps ``-dg`` onto ``dc`` and changes ``H`` least in the sense of
    Broyden (1965). ``H`` unchanged where the update is undefined."""
    h_dg = inverse @ dg
    den = float(dc @ h_dg)
    if not np.isfinite(den) or abs(den) < 1e-300:
        return inverse
    return inverse - np.outer(dc + h_dg, dc @ inverse) / den


def _mirror_terms(coeffs: np.ndarray, xc: float, yc: float, r: int, half: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the offsets ``u`` of ``half`` (a mask of the (2r+1)-square): ``I(c + u) - I(c - u)`` and its
    derivatives in x and y (central differences of the spline at +-0.5 px), the spline of ``coeffs`` (the
    window's, with 2 edge values around them) evaluated on whole grids
    (:func:`aerofid.detect.spline.grid_differences`). ``I(c - u)`` is the grid of ``I(c + u)`` turned by 180
    degrees."""
    n = 2 * r + 1
    got = grid_differences(coeffs, xc - r + 2, yc - r + 2, (n, n))
    assert got is not None
    g0, dx, dy = got
    return ((g0 - g0[::-1, ::-1])[half], (dx - dx[::-1, ::-1])[half], (dy - dy[::-1, ::-1])[half])


GAIN_REACH = 12
"""Half-size (px) of the impulse :func:`gradient_noise_gains` interpolates: the cubic spline's cardinal function
falls by 0.268 a pixel, to 1e-7 of the pixel's weight at this reach."""


@functools.lru_cache(maxsize=4096)
def _gains(fx: float, fy: float) -> tuple[float, float]:
    """:func:`gradient_noise_gains` at the fractional position (fx, fy) of the grid (rounded to 1e-3 px)."""
    n = 2 * GAIN_REACH + 1
    impulse = np.zeros((n, n))
    impulse[GAIN_REACH, GAIN_REACH] = 1.0
    gx, gy = _central_differences(square_grid(impulse, GAIN_REACH + fx, GAIN_REACH + fy, GAIN_REACH - 3, 3))
    return float((gx * gx).sum()), float((gy * gy).sum())


def _central_differences(sub: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The central differences (x, y) of a grid on its inner points (one point less on each side)."""
    return 0.5 * (sub[1:-1, 2:] - sub[1:-1, :-2]), 0.5 * (sub[2:, 1:-1] - sub[:-2, 1:-1])


def gradient_noise_gains(xc: float, yc: float) -> tuple[float, float]:
    """Variance of the central differences (x, y) of the cubic spline grid centred on (xc, yc), per unit of white
    pixel noise: the sum of the squares of one difference's weights on the pixels, which by the grid's shift
    invariance is that of an impulse's differences over the grid. 0.5 on whole pixels; interpolating between pixels
    averages the noise (0.33 at half a pixel in both axes). :func:`centre_covariance` takes it out of the squared
    gradients; 0.5 everywhere took out too much, and under noise a quarter of a real ring's contrast nothing was
    left (sigma 161 436 px)."""
    return _gains(round(xc - math.floor(xc), 3) % 1.0, round(yc - math.floor(yc), 3) % 1.0)


def _check_determined(sigma_x: float, sigma_y: float, r: int) -> None:
    """Refuse a centre whose sigma exceeds the kernel radius ``r``: the gradients within ``r`` px of it are no
    stronger than the noise's (:func:`centre_covariance` nets the noise out of them), so the window does not fix
    where the centre is. Under noise of a quarter of its contrast, a real Wild RC20 ring's centre was answered with
    a sigma of 161 436 px while the noise part was taken as 0.5 noise^2 a pixel (more than the spline grid holds,
    :func:`gradient_noise_gains`); with the grid's own gain it is 0.15 px, and this check is the guard that remains."""
    if not max(sigma_x, sigma_y) <= r:
        raise Refused(f"the centre's sigma ({sigma_x:.3g}, {sigma_y:.3g}) px exceeds the kernel radius {r} px: the "
                      f"gradients about it are no stronger than the noise")


def centre_sigma(img: np.ndarray, xc: float, yc: float, r: int, noise: float, inefficiency: float,
                 floor: float) -> tuple[float, float]:
    """Standard deviation of the centre per axis, (sigma_x, sigma_y): the square roots of the diagonal of
    :func:`centre_covariance`."""
    cov = centre_covariance(img, xc, yc, r, noise, inefficiency, floor)
    return float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))


def centre_covariance(img: np.ndarray, xc: float, yc: float, r: int, noise: float, inefficiency: float,
                      floor: float, grid: np.ndarray | None = None) -> np.ndarray:
    """Covariance of the centre (2 x 2, px^2): per axis the variances below, and between the axes the
    noise part's covariance.

    Noise: mirror symmetry about ``c`` pairs ``I(c + u)`` with ``I(c - u)``; a small shift ``dc`` changes each
    difference by ``2 I'(c + u) dc`` while the noise of a difference is ``sqrt(2) noise``; least squares over
    all pairs gives ``var(dc) = noise^2 / sum(I_x^2)`` over the (2r+1)-square (the squared gradients being
    corrected for their noise part, :func:`gradient_noise_gains`). Our estimator (absolute differences of a filtered
    image, accumulated, high-passed, weighted mean) is less efficient than that; ``inefficiency`` scales it.

    Sampling: a sharp, thin mark is aliased by the pixel grid, and no resampling of it is exactly symmetric
    about the true centre. The disagreement between the symmetric centres found with bilinear and with cubic
    resampling (one Gauss-Newton step each, :func:`_mirror_step`) measures that and is added in quadrature,
    with ``floor`` for the discretisation of eq. (14).

    Between the axes: the correlation of the noise part is that of the inverse of the normal matrix
    ``[[sum I_x^2, sum I_x I_y], [sum I_x I_y, sum I_y^2]]``, ``-sum(I_x I_y) / sqrt(sum I_x^2 sum I_y^2)``
    (white noise adds nothing to ``sum I_x I_y``); it scales the noise parts of the two standard deviations
    (the sampling and floor terms are independent per axis). A mark that is long along a diagonal (a '+'
    with one long arm at 45 degrees) has gradients across that arm, and its centre's x and y errors correlate.

    ``grid``: the (2r + 3)-square of ``img``'s cubic spline about the centre (float64, :func:`_resample`
    before its rounding to float32), if known (then ``img`` is already the part of the window around the centre
    that the resampling needs); else that part's.
    """
    if grid is None:
        part, x0, y0 = near(img, xc, yc, r + 1 + NEAR_REACH)
        img, xc, yc = part, xc - x0, yc - y0
        grid = square_grid(img, xc, yc, r + 1, 3)
    gx, gy = _central_differences(grid.astype(np.float32).astype(np.float64))
    gain_x, gain_y = gradient_noise_gains(xc, yc)
    ex = max(float((gx * gx).sum()) - gx.size * noise ** 2 * gain_x, 1e-12)
    ey = max(float((gy * gy).sum()) - gy.size * noise ** 2 * gain_y, 1e-12)
    rho = float(np.clip(-float((gx * gy).sum()) / np.sqrt(ex * ey), -1.0, 1.0))
    alias = np.abs(_mirror_step(square_grid(img, xc, yc, r, 1)) - _mirror_step(grid[1:-1, 1:-1]))
    vx, vy = (inefficiency * noise) ** 2 / ex, (inefficiency * noise) ** 2 / ey
    cxy = rho * float(np.sqrt(vx * vy))
    return np.array([[vx + alias[0] ** 2 + floor ** 2, cxy], [cxy, vy + alias[1] ** 2 + floor ** 2]])


__all__ = ["DEFAULT", "METHOD", "AxisProfile", "FiducialArea", "MirrorDifferences", "Profiles", "SelfDiagnosis",
           "SubpixelStage", "SymmetryParams", "SymmetryResult", "axis_peak", "centre_covariance", "centre_sigma",
           "detect", "enlargement", "fiducial_area", "gradient_noise_gains", "high_pass", "kernel_radius",
           "mirror_differences", "point_symmetry_centre", "remeasure", "search_range", "self_diagnosis",
           "simplified_log", "subpixel_centre", "symmetry_accumulation", "symmetry_profile"]
