"""Interior orientation: least-squares transformation from scan pixels to film millimetres.

The adjustment follows Sohn et al. (seed 004, section 4, tables 3 and 4): the calibrated fiducial
coordinates (mm) are the observations ``l``, the measured pixel centres are the (error-free) arguments, and
the transformation parameters ``x`` are estimated by least squares in the Gauss-Markov model::

    A  design matrix (2n x u), rows ordered X1, Y1, X2, Y2, ...
    P  weight matrix (identity: every calibrated coordinate equally precise)
    N  = A^T P A             normal matrix
    Q  = N^-1                cofactor matrix of the parameters
    x  = Q A^T P l           estimated parameters (seed 004, table 3)
    v  = A x - l             corrections (adjusted minus calibrated)
    r  = 2n - u              redundancy
    sigma0^2 = v^T P v / r   variance of unit weight, mm^2 (seed 004, table 4)
    s_x = sigma0 sqrt(diag Q) standard deviations of the parameters (seed 004, table 4)

Seed 004 tabulates *residuals* as calibrated minus adjusted, i.e. ``-v``; the results here do the same
(:attr:`FiducialResidual.residual_x_mm`).

Models (pixel x = column, y = row; film X, Y in mm):

* ``similarity`` (4 parameters a, b, c, f). Pixel y points down while film y usually points up, so the
  reflected form ``X = a x + b y + c, Y = b x - a y + f`` is fitted as well as the proper one
  ``X = a x - b y + c, Y = b x + a y + f``; the better-fitting one is kept.
* ``affine`` (6 parameters, seed 004 table 3): ``X = a x + b y + c, Y = d x + e y + f``.
* ``projective`` (8 parameters): ``X = (a x + b y + c) / (g x + h y + 1)``, ``Y = (d x + e y + f) / (g x + h y + 1)``,
  solved by Gauss-Newton iterations from the linear (DLT) solution.

Numerically the pixel coordinates are centred and scaled before the normal equations are formed; the
parameters and their cofactor matrix are then propagated back exactly (``Q_p = J Q_p' J^T``), so the numbers
are those of the textbook formulas without the loss of digits that ``x^2 ~ 10^8`` terms would cause.

Everything here is a pure function on numpy arrays; reading and writing files lives in :mod:`aerofid.formats`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
from scipy import optimize, stats

from aerofid.errors import AerofidInputError
from aerofid.orientation.camera import Camera
from aerofid.orientation.measurements import Measurements

MODELS = ("similarity", "affine", "projective")
#: Minimum number of fiducials that determine each model (zero redundancy).
MIN_POINTS = {"similarity": 2, "affine": 3, "projective": 4}
#: Number of parameters u of each model.
N_PARAMS = {"similarity": 4, "affine": 6, "projective": 8}

#: Significance level of each leave-one-out outlier test. Baarda's classic alpha_0 = 0.001 misses 10 of 64
#: 5-px blunders planted in the real pjhartzell frames (residuals ~0.5 px); 0.01 rejects a second, good
#: fiducial in 8 of them; 0.005 finds all 64 with no false rejection (tests/test_orientation.py).
ALPHA_BLUNDER = 0.005
#: A fiducial is rejected only if its discrepancy from the fit of the others is at least this many pixels.
MIN_BLUNDER_PX = 1.0
#: Lower bound of the estimated standard deviation used in the outlier test, in pixels (guards noise-free data).
SIGMA_FLOOR_PX = 0.05
#: Warn when the RMS of the residual vectors exceeds this many pixels.
WARN_RMS_PX = 1.0
#: Significance level of the test that tells two fiducial arrangements apart.
ALPHA_ARRANGEMENT = 0.01


class AmbiguousCorrespondenceError(AerofidInputError):
    """Two arrangements of the fiducials fit the measurements equally well; names are needed."""

    def __init__(self, message: str, correspondence: "Correspondence"):
        super().__init__(message)
        self.correspondence = correspondence


# ---------------------------------------------------------------------------------------------------
# Transformations as 3x3 matrices
# ---------------------------------------------------------------------------------------------------

def apply_transform(H: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Apply a 3x3 (homogeneous) or 2x3 transformation to points ``xy`` (n x 2)."""
    H = _as3x3(H)
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    h = np.c_[xy, np.ones(len(xy))] @ H.T
    return h[:, :2] / h[:, 2:3]


def invert_transform(H: np.ndarray) -> np.ndarray:
    """Inverse of a 3x3 transformation, normalised so that its [2, 2] element is 1."""
    Hi = np.linalg.inv(_as3x3(H))
    return Hi / Hi[2, 2]


def local_jacobian(H: np.ndarray, xy: Sequence[float]) -> np.ndarray:
    """2x2 Jacobian d(X, Y)/d(x, y) of the transformation at ``xy`` (the affine part for linear models)."""
    H = _as3x3(H)
    x, y = float(xy[0]), float(xy[1])
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    X = (H[0, 0] * x + H[0, 1] * y + H[0, 2]) / w
    Y = (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / w
    return np.array([[H[0, 0] - X * H[2, 0], H[0, 1] - X * H[2, 1]],
                     [H[1, 0] - Y * H[2, 0], H[1, 1] - Y * H[2, 1]]]) / w


def _as3x3(H) -> np.ndarray:
    H = np.asarray(H, dtype=float)
    if H.shape == (2, 3):
        H = np.vstack([H, [0.0, 0.0, 1.0]])
    if H.shape != (3, 3):
        raise ValueError(f"a transformation must be 2x3 or 3x3, not {H.shape}")
    return H


# ---------------------------------------------------------------------------------------------------
# Parametrisation of the models: vec(H) = B p + b0 (row-major 3x3), and the published parameter vector
# ---------------------------------------------------------------------------------------------------

def _basis(model: str, reflected: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Matrix B (9 x u) and vector b0 (9,) with vec(H) = B p + b0."""
    b0 = np.zeros(9)
    b0[8] = 1.0
    if model == "affine":
        B = np.zeros((9, 6))
        B[:6, :6] = np.eye(6)
    elif model == "projective":
        B = np.zeros((9, 8))
        B[:8, :8] = np.eye(8)
    elif model == "similarity":
        # p = (a, b, c, f); H = [[a, -b, c], [b, a, f]] or reflected [[a, b, c], [b, -a, f]]
        B = np.zeros((9, 4))
        s = -1.0 if reflected else 1.0
        B[0, 0], B[4, 0] = 1.0, s
        B[1, 1], B[3, 1] = -s, 1.0
        B[2, 2] = 1.0
        B[5, 3] = 1.0
    else:
        raise AerofidInputError(f"unknown model {model!r}: choose one of {', '.join(MODELS)}")
    return B, b0


def _params_from_h(model: str, h: np.ndarray) -> np.ndarray:
    """Published parameter vector from vec(H) (H normalised so H[2, 2] = 1 for projective)."""
    if model == "affine":
        return h[:6] / h[8]
    if model == "projective":
        return h[:8] / h[8]
    return np.array([h[0], h[3], h[2], h[5]]) / h[8]


def _h_from_params(model: str, p: np.ndarray, reflected: bool = False) -> np.ndarray:
    B, b0 = _basis(model, reflected)
    return (B @ p + b0).reshape(3, 3)


def _normaliser(px: np.ndarray) -> np.ndarray:
    """3x3 matrix M that centres the pixel coordinates and scales them to unit RMS distance."""
    c = px.mean(axis=0)
    s = math.sqrt(float(np.mean(np.sum((px - c) ** 2, axis=1)))) or 1.0
    return np.array([[1 / s, 0, -c[0] / s], [0, 1 / s, -c[1] / s], [0, 0, 1.0]])


# ---------------------------------------------------------------------------------------------------
# The least-squares adjustment
# ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Adjustment:
    """Result of one least-squares fit pixel -> mm (arrays; see module docstring for the symbols).

    Attributes:
        model: ``"similarity"``, ``"affine"`` or ``"projective"``.
        H: 3x3 pixel -> mm transformation (H[2, 2] = 1).
        params: published parameter vector (affine: a, b, c, d, e, f as seed 004 table 3).
        Qxx: cofactor matrix of ``params`` (u x u).
        v: corrections ``A x - l`` (2n,), mm, ordered X1, Y1, X2, ...
        qvv: diagonal of the cofactor matrix of the corrections, ``Q_vv = P^-1 - A Q A^T``.
        redundancy: r = 2n - u.
        sigma0_sq: variance of unit weight v^T P v / r in mm^2 (NaN when r = 0).
        reflected: for the similarity model, whether the reflected form was fitted.
        condition: condition number of the (normalised) normal matrix N.
    """

    model: str
    H: np.ndarray
    params: np.ndarray
    Qxx: np.ndarray
    v: np.ndarray
    qvv: np.ndarray
    redundancy: int
    sigma0_sq: float
    reflected: bool = False
    condition: float = 1.0

    @property
    def param_std(self) -> np.ndarray:
        """sigma0 * sqrt(diag Q_xx) (seed 004, table 4)."""
        return np.sqrt(self.sigma0_sq * np.diag(self.Qxx))

    @property
    def matrix_std(self) -> np.ndarray:
        """Standard deviations of the entries of H (3x3), propagated from Q_xx through vec(H) = B p + b0."""
        B, _ = _basis(self.model, self.reflected)
        cov = B @ self.Qxx @ B.T * self.sigma0_sq
        return np.sqrt(np.clip(np.diag(cov), 0, None)).reshape(3, 3)


def _design(model: str, p: np.ndarray, xy: np.ndarray, reflected: bool) -> tuple[np.ndarray, np.ndarray]:
    """Design matrix A (2n x u) = d(X1, Y1, ...)/dp at ``p`` and the values f(p) at the points ``xy``.

    For the similarity and affine models A does not depend on p (linear observation equations, e.g.
    seed 004's ``X = a x + b y + c, Y = d x + e y + f``); for the projective model it is the Jacobian.
    """
    B, b0 = _basis(model, reflected)
    H = (B @ p + b0).reshape(3, 3)
    xh = np.c_[xy, np.ones(len(xy))]                       # n x 3
    w = xh @ H[2]                                         # denominators (1 for linear models)
    X = xh @ H[0] / w
    Y = xh @ H[1] / w
    Bk = B.T.reshape(-1, 3, 3)                             # u x 3 x 3: dH/dp_k
    dnum_x = np.einsum("ni,ki->nk", xh, Bk[:, 0, :])
    dnum_y = np.einsum("ni,ki->nk", xh, Bk[:, 1, :])
    dden = np.einsum("ni,ki->nk", xh, Bk[:, 2, :])
    A = np.empty((2 * len(xy), B.shape[1]))
    A[0::2] = (dnum_x - X[:, None] * dden) / w[:, None]
    A[1::2] = (dnum_y - Y[:, None] * dden) / w[:, None]
    f = np.empty(2 * len(xy))
    f[0::2], f[1::2] = X, Y
    return A, f


def adjust(px: np.ndarray, mm: np.ndarray, model: str = "affine", *, reflected: bool | None = None,
           max_iter: int = 50) -> Adjustment:
    """Least-squares pixel -> mm transformation with its statistics (seed 004, tables 3 and 4).

    Args:
        px: measured fiducial centres, n x 2 (x = column, y = row).
        mm: calibrated fiducial coordinates, n x 2 (the observations l).
        model: ``"similarity"``, ``"affine"`` or ``"projective"``.
        reflected: similarity only: force the reflected (True) or proper (False) form; None tries both.

    Raises:
        AerofidInputError: too few points for the model, or a degenerate (e.g. collinear) configuration.
    """
    px = np.asarray(px, dtype=float).reshape(-1, 2)
    mm = np.asarray(mm, dtype=float).reshape(-1, 2)
    if model not in MODELS:
        raise AerofidInputError(f"unknown model {model!r}: choose one of {', '.join(MODELS)}")
    n = len(px)
    if n < MIN_POINTS[model]:
        raise AerofidInputError(
            f"the {model} model needs at least {MIN_POINTS[model]} fiducials, got {n}"
            + (": measure more fiducials or choose a model with fewer parameters" if n else ""))
    if not (np.all(np.isfinite(px)) and np.all(np.isfinite(mm))):
        raise AerofidInputError("fiducial coordinates must be finite numbers")
    if model == "similarity" and reflected is None:
        fits = [adjust(px, mm, model, reflected=r) for r in (True, False)]
        return min(fits, key=lambda a: float(a.v @ a.v))
    reflected = bool(reflected)

    M = _normaliser(px)
    xn = apply_transform(M, px)
    l = mm.reshape(-1)                                      # observations X1, Y1, X2, ...
    P = np.eye(2 * n)                                       # equal weights
    u = N_PARAMS[model]

    if model == "projective":
        p = _dlt(xn, mm)
    else:
        p = np.zeros(u)
    for _ in range(max_iter if model == "projective" else 1):
        A, f = _design(model, p, xn, reflected)
        N = A.T @ P @ A
        cond = np.linalg.cond(N)
        if not np.isfinite(cond) or cond > 1e12:
            raise AerofidInputError(
                f"the fiducials' geometry cannot determine the {model} model (points coincide or are "
                "collinear): check the measurements")
        Q = np.linalg.inv(N)
        dp = Q @ A.T @ P @ (l - f)                          # linear models: x = Q A^T P l
        p = p + dp
        if model != "projective" or np.max(np.abs(dp)) < 1e-13 * (1 + np.max(np.abs(p))):
            break
    A, f = _design(model, p, xn, reflected)
    N = A.T @ P @ A
    Q = np.linalg.inv(N)
    v = f - l                                               # v = A x - l
    r = 2 * n - u
    sigma0_sq = float(v @ P @ v / r) if r > 0 else float("nan")
    qvv = np.clip(np.diag(np.linalg.inv(P) - A @ Q @ A.T), 0, None)

    # back to the original pixel coordinates: H = H_n M, p_orig = g(p_n), Q_orig = J Q J^T
    B, b0 = _basis(model, reflected)
    K = np.stack([((B[:, k]).reshape(3, 3) @ M).reshape(-1) for k in range(u)], axis=1)
    h = K @ p + (b0.reshape(3, 3) @ M).reshape(-1)
    params = _params_from_h(model, h)
    S = _selection(model)
    dp_dh = S / h[8] - np.outer(S @ h, np.eye(9)[8]) / h[8] ** 2
    J = dp_dh @ K
    Qxx = J @ Q @ J.T
    H = _h_from_params(model, params, reflected)
    return Adjustment(model=model, H=H, params=params, Qxx=Qxx, v=v, qvv=qvv, redundancy=r,
                      sigma0_sq=sigma0_sq, reflected=reflected, condition=float(cond))


def _selection(model: str) -> np.ndarray:
    S = np.zeros((N_PARAMS[model], 9))
    idx = {"affine": range(6), "projective": range(8), "similarity": (0, 3, 2, 5)}[model]
    for i, j in enumerate(idx):
        S[i, j] = 1.0
    return S


def _dlt(xn: np.ndarray, mm: np.ndarray) -> np.ndarray:
    """Linear start values for the projective model: X (g x + h y + 1) = a x + b y + c, ..."""
    n = len(xn)
    x, y = xn[:, 0], xn[:, 1]
    X, Y = mm[:, 0], mm[:, 1]
    A = np.zeros((2 * n, 8))
    A[0::2, 0], A[0::2, 1], A[0::2, 2] = x, y, 1
    A[0::2, 6], A[0::2, 7] = -X * x, -X * y
    A[1::2, 3], A[1::2, 4], A[1::2, 5] = x, y, 1
    A[1::2, 6], A[1::2, 7] = -Y * x, -Y * y
    return np.linalg.lstsq(A, mm.reshape(-1), rcond=None)[0]


# ---------------------------------------------------------------------------------------------------
# Blunder detection: leave-one-out (externally studentised) outlier test
# ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class OutlierTest:
    """Leave-one-out test of one fiducial.

    ``T = d^T C^-1 d / (2 s^2)`` where d is the calibrated minus predicted position from the fit without
    the fiducial, ``C = I + A_i Q_(i) A_i^T`` its cofactor, and ``s^2`` the variance of unit weight of
    that fit. Under the null hypothesis T ~ F(2, r - 2) (Pope's tau test generalised to a point).
    """

    index: int
    statistic: float
    critical: float
    discrepancy_mm: float
    discrepancy_px: float
    dof: int

    @property
    def significant(self) -> bool:
        return self.statistic > self.critical


def outlier_tests(px: np.ndarray, mm: np.ndarray, model: str, reflected: bool | None = None, *,
                  alpha: float = ALPHA_BLUNDER, sigma_floor_px: float = SIGMA_FLOOR_PX) -> list[OutlierTest]:
    """Leave-one-out outlier test for every point (empty when the redundancy is below 3)."""
    px = np.asarray(px, dtype=float)
    mm = np.asarray(mm, dtype=float)
    n = len(px)
    u = N_PARAMS[model]
    dof = 2 * (n - 1) - u
    if dof < 1 or n - 1 < MIN_POINTS[model]:
        return []
    out = []
    for i in range(n):
        keep = np.arange(n) != i
        try:
            fit = adjust(px[keep], mm[keep], model, reflected=reflected)
        except AerofidInputError:
            continue
        pred = apply_transform(fit.H, px[i:i + 1])[0]
        d = mm[i] - pred
        Jpx = local_jacobian(fit.H, px[i])                 # mm per px
        mm_per_px = math.sqrt(abs(np.linalg.det(Jpx)))
        Ai = _design_original(fit, px[i:i + 1])
        C = np.eye(2) + Ai @ fit.Qxx @ Ai.T
        s2 = max(fit.sigma0_sq, (sigma_floor_px * mm_per_px) ** 2)
        T = float(d @ np.linalg.solve(C, d) / (2 * s2))
        d_px = np.linalg.solve(Jpx, d)
        out.append(OutlierTest(index=i, statistic=T, critical=float(stats.f.ppf(1 - alpha, 2, dof)),
                               discrepancy_mm=float(np.hypot(*d)), discrepancy_px=float(np.hypot(*d_px)),
                               dof=dof))
    return out


def _design_original(fit: Adjustment, xy: np.ndarray) -> np.ndarray:
    """Design matrix in the published parametrisation (original pixel coordinates) at ``xy``."""
    if fit.model == "similarity":
        A, _ = _design("similarity", np.array([fit.params[0], fit.params[1], fit.params[2], fit.params[3]]),
                       xy, fit.reflected)
        return A
    A, _ = _design(fit.model, fit.params, xy, False)
    return A


@dataclass(frozen=True)
class Rejection:
    index: int
    reason: str


def reject_blunders(px: np.ndarray, mm: np.ndarray, model: str, *, alpha: float = ALPHA_BLUNDER,
                    min_blunder_px: float = MIN_BLUNDER_PX, sigma_floor_px: float = SIGMA_FLOOR_PX,
                    names: Sequence[str] | None = None) -> tuple[list[Rejection], list[str]]:
    """Iterative data snooping by leave-one-out: reject the worst significant fiducial, re-fit, repeat.

    A fiducial is rejected when its leave-one-out statistic exceeds the F(2, r - 2) quantile at
    ``1 - alpha`` *and* its discrepancy is at least ``min_blunder_px`` pixels. When the two largest
    statistics are about equal the blunder cannot be located (e.g. 4 fiducials with the affine model,
    where all residuals have the same size, as in seed 004 table 4), and nothing is rejected.

    Returns:
        (rejections with indices into the input, warnings)
    """
    px = np.asarray(px, dtype=float)
    mm = np.asarray(mm, dtype=float)
    names = list(names) if names is not None else [str(i) for i in range(len(px))]
    active = list(range(len(px)))
    rejected: list[Rejection] = []
    warnings: list[str] = []
    while True:
        tests = outlier_tests(px[active], mm[active], model, alpha=alpha, sigma_floor_px=sigma_floor_px)
        if not tests:
            if not rejected:
                need = (N_PARAMS[model] + 3) // 2 + 1
                warnings.append(f"blunder detection needs at least {need} fiducials for the {model} model; "
                                f"{len(active)} measured: a wrong mark would go unnoticed")
            break
        tests.sort(key=lambda t: -t.statistic)
        worst = tests[0]
        if not (worst.significant and worst.discrepancy_px >= min_blunder_px):
            break
        if len(tests) > 1 and tests[1].significant and tests[1].statistic > 0.9 * worst.statistic:
            who = ", ".join(names[active[t.index]] for t in tests[:2])
            warnings.append(f"a blunder is likely among {who} but cannot be located (their outlier tests are "
                            "about equal): check these marks")
            break
        i = active[worst.index]
        rejected.append(Rejection(i, (
            f"outlier: {worst.discrepancy_px:.2f} px ({worst.discrepancy_mm * 1000:.1f} um) from the fit of the "
            f"other fiducials; test F = {worst.statistic:.4g} > F(2, {worst.dof}; {1 - alpha:g}) = "
            f"{worst.critical:.3g}")))
        active.remove(i)
    return rejected, warnings


# ---------------------------------------------------------------------------------------------------
# Correspondence: the 8 arrangements of the film in the scanner
# ---------------------------------------------------------------------------------------------------

#: The 8 arrangements: rotation of the film image on the scan (degrees, counter-clockwise as seen on the
#: film's mm frame) and whether the scan is mirrored (film scanned from the other side).
ARRANGEMENTS = tuple((rot, mir) for mir in (False, True) for rot in (0, 90, 180, 270))


def arrangement_matrix(rotation_deg: int, mirrored: bool, y_axis: str = "up") -> np.ndarray:
    """Signed permutation G with pixel -> mm linear part ~ s * G for this arrangement.

    The nominal arrangement (0, False) maps pixel x (column) to film x and pixel y (row, down) to film
    y, reversed when the camera's y axis points up.
    """
    L0 = np.diag([1.0, -1.0]) if y_axis == "up" else np.eye(2)
    t = math.radians(rotation_deg)
    R = np.round(np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]))
    F = np.diag([1.0, -1.0]) if mirrored else np.eye(2)
    return R @ L0 @ F


@dataclass(frozen=True)
class ArrangementFit:
    rotation_deg: int
    mirrored: bool
    assignment: tuple[int, ...]          # for each measured point, the index of the calibrated fiducial
    sum_sq_mm2: float                    # v^T v of the fit with that assignment
    rms_mm: float
    redundancy: int

    def to_dict(self, fiducial_names: Sequence[str] | None = None) -> dict:
        a = [fiducial_names[j] for j in self.assignment] if fiducial_names is not None else list(self.assignment)
        return {"rotation_deg": self.rotation_deg, "mirrored": self.mirrored, "assignment": a,
                "rms_mm": self.rms_mm, "sum_sq_mm2": self.sum_sq_mm2, "redundancy": self.redundancy}


@dataclass(frozen=True)
class Correspondence:
    """Which calibrated fiducial each measured point is, found by testing the 8 arrangements.

    Attributes:
        status: ``"unique"`` or ``"ambiguous"``.
        best: the best-fitting arrangement.
        candidates: all arrangements tested, best first.
        reason: why it is ambiguous (empty when unique).
    """

    status: str
    best: ArrangementFit
    candidates: tuple[ArrangementFit, ...]
    reason: str = ""
    fiducial_names: tuple[str, ...] = ()

    @property
    def assignment(self) -> tuple[int, ...]:
        return self.best.assignment

    def to_dict(self) -> dict:
        names = self.fiducial_names or None
        return {"status": self.status, "rotation_deg": self.best.rotation_deg, "mirrored": self.best.mirrored,
                "assignment": self.best.to_dict(names)["assignment"], "reason": self.reason,
                "candidates": [c.to_dict(names) for c in self.candidates]}


def match_fiducials(px: np.ndarray, mm: np.ndarray, model: str = "affine", *, y_axis: str = "up",
                    fiducial_names: Sequence[str] | None = None, alpha: float = ALPHA_ARRANGEMENT,
                    max_rotation_deg: float = 45.0) -> Correspondence:
    """Assign unnamed measured points (m x 2 px) to calibrated fiducials (n x 2 mm), m <= n.

    For each of the 8 arrangements (4 rotations x 2 sides) every pair of measured points is matched to
    every pair of calibrated fiducials; the similarity they define (rotation within +-45 degrees of the
    arrangement, so each hypothesis belongs to one arrangement) maps all fiducials onto the scan and the
    measured points are assigned to them (Hungarian method). The best assignment of each arrangement is
    then fitted with ``model`` (similarity when the model has no redundancy) and the arrangements are ranked
    by ``v^T v``. The best is ``unique`` only if the runner-up is worse by the F test
    ``v2^T v2 / v1^T v1 > F(r, r; 1 - alpha)``; otherwise the answer is ``ambiguous``.
    """
    px = np.asarray(px, dtype=float).reshape(-1, 2)
    mm = np.asarray(mm, dtype=float).reshape(-1, 2)
    m, n = len(px), len(mm)
    if m > n:
        raise AerofidInputError(f"{m} measured points but the camera has only {n} fiducials")
    if m < 2:
        raise AerofidInputError("at least 2 measured points are needed to assign them to fiducials")
    rank_model = model if 2 * m - N_PARAMS[model] > 0 and m >= MIN_POINTS[model] else "similarity"
    fits: list[ArrangementFit] = []
    lim = math.radians(max_rotation_deg) + 1e-9
    for rot, mir in ARRANGEMENTS:
        G = arrangement_matrix(rot, mir, y_axis)
        Cp = mm @ np.linalg.inv(G).T                        # fiducials in the scan's orientation (px-like, scaled)
        best_cost, best_assign = np.inf, None
        for i1, i2 in itertools.combinations(range(m), 2):
            dm = px[i2] - px[i1]
            for j1, j2 in itertools.permutations(range(n), 2):
                dc = Cp[j2] - Cp[j1]
                nc = np.hypot(*dc)
                if nc == 0 or np.hypot(*dm) == 0:
                    continue
                ang = math.atan2(dm[1], dm[0]) - math.atan2(dc[1], dc[0])
                ang = (ang + math.pi) % (2 * math.pi) - math.pi
                if abs(ang) > lim:
                    continue
                k = np.hypot(*dm) / nc
                R = k * np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
                t = px[i1] - R @ Cp[j1]
                proj = Cp @ R.T + t                          # fiducials projected into the scan
                D = np.sum((px[:, None, :] - proj[None, :, :]) ** 2, axis=2)
                rows, cols = optimize.linear_sum_assignment(D)
                assign = tuple(int(c) for c in cols[np.argsort(rows)])
                cost = float(D[rows, cols].sum())
                if cost < best_cost:
                    best_cost, best_assign = cost, assign
        if best_assign is None:
            continue
        try:
            fit = adjust(px, mm[list(best_assign)], rank_model)
        except AerofidInputError:
            continue
        ss = float(fit.v @ fit.v)
        fits.append(ArrangementFit(rot, mir, best_assign, ss, math.sqrt(ss / m), fit.redundancy))
    if not fits:
        raise AerofidInputError("the measured points cannot be matched to the camera's fiducials")
    # one candidate per distinct assignment, best first
    fits.sort(key=lambda f: f.sum_sq_mm2)
    uniq: list[ArrangementFit] = []
    for f in fits:
        if all(f.assignment != g.assignment for g in uniq):
            uniq.append(f)
    best = uniq[0]
    names = tuple(fiducial_names) if fiducial_names is not None else ()
    if len(uniq) == 1:
        return Correspondence("unique", best, tuple(uniq), "", names)
    second = uniq[1]
    r = best.redundancy
    if r < 1:
        reason = "no redundancy to compare the arrangements: measure more fiducials or give names"
        return Correspondence("ambiguous", best, tuple(uniq), reason, names)
    crit = float(stats.f.ppf(1 - alpha, r, r))
    ratio = second.sum_sq_mm2 / max(best.sum_sq_mm2, 1e-30)
    if ratio > crit:
        return Correspondence("unique", best, tuple(uniq), "", names)
    reason = (f"arrangements rotation {best.rotation_deg} deg{' mirrored' if best.mirrored else ''} "
              f"(rms {best.rms_mm * 1000:.2f} um) and rotation {second.rotation_deg} deg"
              f"{' mirrored' if second.mirrored else ''} (rms {second.rms_mm * 1000:.2f} um) fit equally well "
              f"(ratio {ratio:.3g} <= F({r}, {r}; {1 - alpha:g}) = {crit:.3g}): name the measured points")
    return Correspondence("ambiguous", best, tuple(uniq), reason, names)


# ---------------------------------------------------------------------------------------------------
# The user-facing result and aerofid.orient()
# ---------------------------------------------------------------------------------------------------

USED = "used"
REJECTED = "rejected"


@dataclass(frozen=True)
class FiducialResidual:
    """One fiducial in the interior orientation (seed 004, table 4, one row).

    Residuals are calibrated minus adjusted (seed 004's sign); for a rejected fiducial they are taken
    against the fit of the used ones.
    """

    name: str
    x_px: float
    y_px: float
    x_mm: float
    y_mm: float
    adjusted_x_mm: float
    adjusted_y_mm: float
    residual_x_mm: float
    residual_y_mm: float
    residual_x_px: float
    residual_y_px: float
    redundancy_number: float
    status: str = USED
    reason: str = ""

    @property
    def residual_um(self) -> tuple[float, float]:
        return self.residual_x_mm * 1000.0, self.residual_y_mm * 1000.0

    def to_dict(self) -> dict:
        return {"name": self.name, "x_px": self.x_px, "y_px": self.y_px, "x_mm": self.x_mm, "y_mm": self.y_mm,
                "adjusted_x_mm": self.adjusted_x_mm, "adjusted_y_mm": self.adjusted_y_mm,
                "residual_x_mm": self.residual_x_mm, "residual_y_mm": self.residual_y_mm,
                "residual_x_um": self.residual_um[0], "residual_y_um": self.residual_um[1],
                "residual_x_px": self.residual_x_px, "residual_y_px": self.residual_y_px,
                "redundancy_number": _num(self.redundancy_number), "status": self.status, "reason": self.reason}


@dataclass(frozen=True)
class InteriorOrientation:
    """The interior orientation of one scan: pixel -> film mm with its statistics.

    Matrices are row-major nested lists in :meth:`to_dict`: ``pixel_to_mm`` = [[a, b, c], [d, e, f]]
    (X = a x + b y + c, Y = d x + e y + f) for the similarity and affine models, 3x3 for projective.
    """

    model: str
    camera: str
    image: str
    pixel_to_mm: np.ndarray = field(compare=False)           # 3x3
    mm_to_pixel: np.ndarray = field(compare=False)           # 3x3
    params: np.ndarray = field(compare=False)                # published parameter vector
    params_std: np.ndarray = field(compare=False)            # sigma0 sqrt(diag Q), same order
    matrix_std: np.ndarray = field(compare=False)            # 3x3, std of the entries of pixel_to_mm
    variance_of_unit_weight: float                           # mm^2
    redundancy: int
    rms_mm: float                                            # sqrt(mean(vx^2 + vy^2)) over used fiducials
    rms_x_mm: float
    rms_y_mm: float
    rms_px: float
    fiducials: tuple[FiducialResidual, ...]
    missing: tuple[str, ...]
    pixel_size_um: tuple[float, float]
    rotation_deg: float
    non_orthogonality_deg: float
    scale_difference_ppm: float
    scale_vs_nominal_ppm: tuple[float, float] | None
    mirrored: bool
    principal_point_px: tuple[float, float]
    principal_point_source: str
    fiducial_centre_mm: tuple[float, float]
    fiducial_centre_px: tuple[float, float]
    correspondence: "Correspondence | None" = None
    warnings: tuple[str, ...] = ()

    @property
    def sigma0_mm(self) -> float:
        return math.sqrt(self.variance_of_unit_weight) if math.isfinite(self.variance_of_unit_weight) else math.nan

    @property
    def used(self) -> tuple[FiducialResidual, ...]:
        return tuple(f for f in self.fiducials if f.status == USED)

    @property
    def rejected(self) -> tuple[FiducialResidual, ...]:
        return tuple(f for f in self.fiducials if f.status == REJECTED)

    def to_mm(self, xy) -> np.ndarray:
        """Pixel (x, y) -> film mm."""
        return apply_transform(self.pixel_to_mm, xy)

    def to_pixel(self, xy_mm) -> np.ndarray:
        """Film mm -> pixel (x, y)."""
        return apply_transform(self.mm_to_pixel, xy_mm)

    def _layout(self, H: np.ndarray) -> list:
        return _rows(H if self.model == "projective" else H[:2])

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "camera": self.camera,
            "image": self.image,
            "pixel_to_mm": self._layout(self.pixel_to_mm),
            "mm_to_pixel": self._layout(self.mm_to_pixel),
            "parameters": [float(p) for p in self.params],
            "parameters_std": [_num(s) for s in self.params_std],
            "parameter_std": [[_num(s) for s in row] for row in
                              (self.matrix_std if self.model == "projective" else self.matrix_std[:2])],
            "variance_of_unit_weight": _num(self.variance_of_unit_weight),
            "sigma0_mm": _num(self.sigma0_mm),
            "redundancy": self.redundancy,
            "rms_mm": _num(self.rms_mm),
            "rms_x_mm": _num(self.rms_x_mm),
            "rms_y_mm": _num(self.rms_y_mm),
            "rms_um": _num(self.rms_mm * 1000),
            "rms_px": _num(self.rms_px),
            "fiducials": [f.to_dict() for f in self.fiducials],
            "missing": list(self.missing),
            "pixel_size_um": [float(v) for v in self.pixel_size_um],
            "rotation_deg": float(self.rotation_deg),
            "non_orthogonality_deg": float(self.non_orthogonality_deg),
            "scale_difference_ppm": float(self.scale_difference_ppm),
            "scale_vs_nominal_ppm": None if self.scale_vs_nominal_ppm is None else list(self.scale_vs_nominal_ppm),
            "mirrored": self.mirrored,
            "principal_point_px": list(self.principal_point_px),
            "principal_point_source": self.principal_point_source,
            "fiducial_centre_mm": list(self.fiducial_centre_mm),
            "fiducial_centre_px": list(self.fiducial_centre_px),
            "correspondence": None if self.correspondence is None else self.correspondence.to_dict(),
            "warnings": list(self.warnings),
        }


def _rows(H: np.ndarray) -> list:
    return [[float(v) for v in row] for row in np.asarray(H)]


def _num(v: float) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def scan_geometry(H: np.ndarray, at: Sequence[float] = (0.0, 0.0)) -> dict[str, Any]:
    """Derived scan quantities from the linear part L of pixel -> mm at pixel ``at``.

    Pixel size x and y are the lengths of L's columns (the film distance of one pixel step along a row
    and along a column); the rotation is the angle of the pixel x axis in the film frame; the
    non-orthogonality is the angle between the two pixel axes in the film minus 90 degrees; the scale
    difference (sx - sy) / mean, in ppm, is the differential film deformation plus scanner affinity.
    ``mirrored`` tells whether the pixel axes keep their handedness on the film (det L > 0); for a
    certificate with y up a normal scan has det L < 0.
    """
    L = local_jacobian(H, at)
    sx = float(np.hypot(L[0, 0], L[1, 0]))
    sy = float(np.hypot(L[0, 1], L[1, 1]))
    det = float(np.linalg.det(L))
    rot = math.degrees(math.atan2(L[1, 0], L[0, 0]))
    cosang = float(np.dot(L[:, 0], L[:, 1]) / (sx * sy))
    nonorth = math.degrees(math.acos(max(-1.0, min(1.0, cosang)))) - 90.0
    return {"pixel_size_um": (sx * 1000.0, sy * 1000.0), "rotation_deg": rot,
            "non_orthogonality_deg": nonorth, "scale_difference_ppm": (sx - sy) / ((sx + sy) / 2) * 1e6,
            "det": det}


def orient(camera: Camera, measurements: Measurements | Mapping | np.ndarray, model: str = "affine", *, correspondence: str | None = None,
           reject: bool = True, alpha: float = ALPHA_BLUNDER, min_blunder_px: float = MIN_BLUNDER_PX,
           image: str | None = None) -> InteriorOrientation:
    """Interior orientation of one scan from measured fiducial centres (seed 004, section 4).

    Args:
        camera: a :class:`aerofid.orientation.camera.Camera` (:func:`aerofid.read_camera` reads a file).
        measurements: a :class:`aerofid.orientation.measurements.Measurements`
            (:func:`aerofid.read_measurements` reads a file), a mapping name -> (x, y) or an n x 2 array of
            unnamed points.
        model: ``"similarity"``, ``"affine"`` (seed 004) or ``"projective"``.
        correspondence: ``"names"`` (trust the point names), ``"auto"`` (assign by testing the 8
            arrangements of the film in the scanner) or None (names when the points have names).
        reject: detect and reject blunders by the leave-one-out outlier test.
        alpha, min_blunder_px: see :func:`reject_blunders`.

    Raises:
        AerofidInputError: bad input, too few fiducials for the model, degenerate geometry.
        AmbiguousCorrespondenceError: auto correspondence found two equally good arrangements.
    """
    if not isinstance(camera, Camera):
        raise AerofidInputError("camera must be a Camera: read a camera file with aerofid.read_camera(path)")
    cam = camera
    meas = Measurements.from_any(measurements)
    if model not in MODELS:
        raise AerofidInputError(f"unknown model {model!r}: choose one of {', '.join(MODELS)}")
    if correspondence not in (None, "names", "auto"):
        raise AerofidInputError(f"correspondence must be 'names' or 'auto', not {correspondence!r}")
    mode = correspondence or ("names" if meas.named else "auto")
    warnings: list[str] = []
    corr = None
    if mode == "names":
        if not meas.named:
            raise AerofidInputError("the measured points have no names: use correspondence 'auto'")
        unknown = [n for n in meas.names if n not in cam.names]
        if unknown:
            raise AerofidInputError(
                f"measured point(s) {', '.join(unknown)} are not fiducials of camera {cam.name!r} "
                f"(it has {', '.join(cam.names)})")
        names = list(meas.names)
    else:
        corr = match_fiducials(meas.xy, cam.xy_mm, model, y_axis=cam.y_axis, fiducial_names=cam.names)
        if corr.status != "unique":
            raise AmbiguousCorrespondenceError(f"fiducial correspondence is ambiguous: {corr.reason}", corr)
        names = [cam.names[j] for j in corr.assignment]
        if meas.named and names != list(meas.names):
            warnings.append("the measured names disagree with the best arrangement: names were reassigned")
    px = meas.xy
    mm = np.array([[cam.fiducial(n).x_mm, cam.fiducial(n).y_mm] for n in names])
    n = len(px)
    if n < MIN_POINTS[model]:
        raise AerofidInputError(
            f"the {model} model needs at least {MIN_POINTS[model]} fiducials, got {n}: measure more fiducials "
            "or choose a model with fewer parameters")

    reasons: dict[int, str] = {}
    if reject:
        rej, w = reject_blunders(px, mm, model, alpha=alpha, min_blunder_px=min_blunder_px, names=names)
        reasons = {r.index: r.reason for r in rej}
        warnings += w
    used = np.array([i not in reasons for i in range(n)])
    fit = adjust(px[used], mm[used], model)
    if fit.redundancy == 0:
        warnings.append(f"no redundancy ({int(used.sum())} fiducials, {N_PARAMS[model]} parameters): residuals are "
                        "zero and the quality cannot be estimated")
    # geometry: warn on nearly collinear fiducials (smallest/largest singular value of the centred layout)
    sv = np.linalg.svd(px[used] - px[used].mean(axis=0), compute_uv=False)
    if sv[-1] < 0.1 * sv[0]:
        warnings.append("the fiducials are nearly collinear: the transformation is poorly determined across them")
    if fit.condition > 1e8:
        warnings.append(f"the normal equations are ill-conditioned (condition {fit.condition:.2g})")

    H = fit.H
    Hi = invert_transform(H)
    adj_all = apply_transform(H, px)
    v_all = mm - adj_all                                      # calibrated minus adjusted (seed 004)
    qvv = fit.qvv.reshape(-1, 2)
    fids = []
    k = 0
    for i in range(n):
        Jinv = local_jacobian(Hi, adj_all[i])
        vpx = Jinv @ v_all[i]
        if used[i]:
            rn = float(qvv[k].mean())
            k += 1
            status, reason = USED, ""
        else:
            rn, status, reason = math.nan, REJECTED, reasons[i]
        fids.append(FiducialResidual(names[i], float(px[i, 0]), float(px[i, 1]), float(mm[i, 0]), float(mm[i, 1]),
                                     float(adj_all[i, 0]), float(adj_all[i, 1]), float(v_all[i, 0]),
                                     float(v_all[i, 1]), float(vpx[0]), float(vpx[1]), rn, status, reason))
    vu = v_all[used]
    vpx_u = np.array([[f.residual_x_px, f.residual_y_px] for f in fids if f.status == USED])
    rms_mm = math.sqrt(float(np.mean(np.sum(vu ** 2, axis=1))))
    rms_px = math.sqrt(float(np.mean(np.sum(vpx_u ** 2, axis=1))))
    if rms_px > WARN_RMS_PX:
        warnings.append(f"the RMS residual is {rms_px:.2f} px: check the measurements and the camera file")

    fc_mm = cam.fiducial_centre_mm()
    fc_px = apply_transform(Hi, [fc_mm])[0]
    pp_mm, pp_src = cam.principal_point_mm
    pp_px = apply_transform(Hi, [pp_mm])[0]
    geo = scan_geometry(H, fc_px)
    nominal = None
    if cam.pixel_size_um:
        nominal = tuple((s / cam.pixel_size_um - 1.0) * 1e6 for s in geo["pixel_size_um"])
    mirrored = (geo["det"] > 0) if cam.y_axis == "up" else (geo["det"] < 0)
    return InteriorOrientation(
        model=model, camera=cam.name, image=image if image is not None else meas.image,
        pixel_to_mm=H, mm_to_pixel=Hi, params=fit.params, params_std=fit.param_std, matrix_std=fit.matrix_std,
        variance_of_unit_weight=fit.sigma0_sq, redundancy=fit.redundancy, rms_mm=rms_mm,
        rms_x_mm=math.sqrt(float(np.mean(vu[:, 0] ** 2))), rms_y_mm=math.sqrt(float(np.mean(vu[:, 1] ** 2))),
        rms_px=rms_px, fiducials=tuple(fids), missing=tuple(nm for nm in cam.names if nm not in names),
        pixel_size_um=geo["pixel_size_um"], rotation_deg=geo["rotation_deg"],
        non_orthogonality_deg=geo["non_orthogonality_deg"], scale_difference_ppm=geo["scale_difference_ppm"],
        scale_vs_nominal_ppm=nominal, mirrored=bool(mirrored),
        principal_point_px=(float(pp_px[0]), float(pp_px[1])), principal_point_source=pp_src,
        fiducial_centre_mm=fc_mm, fiducial_centre_px=(float(fc_px[0]), float(fc_px[1])),
        correspondence=corr, warnings=tuple(warnings))
