"""The least-squares adjustment pixel -> mm and its statistics (Sohn et al., seed 004, section 4, tables 3, 4).

The calibrated fiducial coordinates (mm) are the observations ``l``, the measured pixel centres are the
(error-free) arguments, and the parameters ``x`` of a transformation (:mod:`aerofid.orientation.transform`)
are estimated by least squares in the Gauss-Markov model::

    A  design matrix (2n x u), rows ordered X1, Y1, X2, Y2, ...
    P  weight matrix (identity: every calibrated coordinate equally precise)
    N  = A^T P A             normal matrix
    Q  = N^-1                cofactor matrix of the parameters
    x  = Q A^T P l           estimated parameters (seed 004, table 3)
    v  = A x - l             corrections (adjusted minus calibrated)
    r  = 2n - u              redundancy
    sigma0^2 = v^T P v / r   variance of unit weight, mm^2 (seed 004, table 4)
    s_x = sigma0 sqrt(diag Q) standard deviations of the parameters (seed 004, table 4)

Seed 004 tabulates *residuals* as calibrated minus adjusted, i.e. ``-v``; the interior orientation does the
same (:attr:`aerofid.orientation.interior.FiducialResidual.residual_x_mm`).

The similarity is fitted in its reflected and its proper form and the better-fitting one is kept; the
projective model is solved by Gauss-Newton iterations from the linear (DLT) solution.

Numerically the pixel coordinates are centred and scaled before the normal equations are formed; the
parameters and their cofactor matrix are then propagated back exactly (``Q_p = J Q_p' J^T``), so the numbers
are those of the textbook formulas without the loss of digits that ``x^2 ~ 10^8`` terms would cause.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from aerofid.errors import AerofidInputError
from aerofid.orientation.transform import ProjectiveTransform, transform_class

#: Largest condition number of the (normalised) normal matrix that still determines the model.
MAX_CONDITION = 1e12


@dataclass(frozen=True, eq=False)
class Adjustment:
    """Result of one least-squares fit pixel -> mm (see the module docstring for the symbols).

    Attributes
    ----------
    transform : ProjectiveTransform
        The fitted pixel -> mm transformation (its matrix has ``[2, 2] = 1``).
    Qxx : numpy.ndarray
        Cofactor matrix of ``transform.params`` (u x u).
    v : numpy.ndarray
        Corrections ``A x - l`` (2n,), mm, ordered X1, Y1, X2, ...
    qvv : numpy.ndarray
        Diagonal of the cofactor matrix of the corrections, ``Q_vv = P^-1 - A Q A^T``.
    redundancy : int
        r = 2n - u.
    variance_of_unit_weight : float
        sigma0^2 = v^T P v / r in mm^2 (NaN when r = 0).
    condition : float
        Condition number of the (normalised) normal matrix N.
    """

    transform: ProjectiveTransform
    Qxx: np.ndarray
    v: np.ndarray
    qvv: np.ndarray
    redundancy: int
    variance_of_unit_weight: float
    condition: float = 1.0

    @property
    def model(self) -> str:
        return self.transform.model

    @property
    def params(self) -> np.ndarray:
        """The published parameter vector (affine: a, b, c, d, e, f as seed 004 table 3)."""
        return self.transform.params

    @property
    def params_std(self) -> np.ndarray:
        """sigma0 * sqrt(diag Q_xx) (seed 004, table 4)."""
        return np.sqrt(self.variance_of_unit_weight * np.diag(self.Qxx))

    @property
    def matrix_std(self) -> np.ndarray:
        """Standard deviations of the entries of the matrix (3x3), propagated from Q_xx through vec(H) = B p + b0."""
        B, _ = self.transform.parametrisation
        cov = B @ self.Qxx @ B.T * self.variance_of_unit_weight
        return np.sqrt(np.clip(np.diag(cov), 0, None)).reshape(3, 3)

    def design_matrix(self, xy: np.ndarray) -> np.ndarray:
        """Design matrix A (2n x u) of the published parameters at the pixel points ``xy`` (n x 2)."""
        T = self.transform
        A, _ = design(type(T), T.reflected, self.params, xy)
        return A


def design(cls: type[ProjectiveTransform], reflected: bool, p: np.ndarray,
           xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Design matrix A (2n x u) = d(X1, Y1, ...)/dp at ``p`` and the values f(p) at the points ``xy``.

    For the similarity and affine models A does not depend on p (linear observation equations, e.g.
    seed 004's ``X = a x + b y + c, Y = d x + e y + f``); for the projective model it is the Jacobian.
    """
    B, b0 = cls.basis(reflected)
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


def adjust(px: ArrayLike, mm: ArrayLike, model: str = "affine", *, reflected: bool | None = None,
           max_iter: int = 50) -> Adjustment:
    """Least-squares pixel -> mm transformation with its statistics (seed 004, tables 3 and 4).

    Parameters
    ----------
    px : array_like
        Measured fiducial centres, n x 2 (x = column, y = row).
    mm : array_like
        Calibrated fiducial coordinates, n x 2 (the observations l).
    model : str
        ``"similarity"``, ``"affine"`` or ``"projective"``.
    reflected : bool or None
        Similarity only: force the reflected (True) or proper (False) form; None tries both.
    max_iter : int
        Most Gauss-Newton iterations of the projective model.

    Raises
    ------
    AerofidInputError
        Too few points for the model, or a degenerate (e.g. collinear) configuration.

    Examples
    --------
    >>> px = [[167.5, 212.5], [5215.0, 234.0], [148.5, 5259.5], [5194.5, 5279.5]]
    >>> mm = [[-106.0, 106.0], [105.996, 105.999], [-106.001, -106.004], [105.999, -105.999]]
    >>> fit = adjust(px, mm, "affine")
    >>> fit.params.round(5).tolist()[2], fit.redundancy
    (-113.08782, 2)
    """
    cls = transform_class(model)
    px, mm = _checked_points(px, mm, cls)
    if cls.model == "similarity" and reflected is None:
        fits = [adjust(px, mm, model, reflected=r) for r in (True, False)]
        return min(fits, key=lambda a: float(a.v @ a.v))
    return _fit(cls, bool(reflected), px, mm, max_iter)


def _checked_points(px: ArrayLike, mm: ArrayLike, cls: type[ProjectiveTransform]) -> tuple[np.ndarray, np.ndarray]:
    """``px`` and ``mm`` as n x 2 float arrays, or an input error (too few points, non-finite numbers)."""
    px = np.asarray(px, dtype=float).reshape(-1, 2)
    mm = np.asarray(mm, dtype=float).reshape(-1, 2)
    n = len(px)
    if n < cls.min_points:
        raise AerofidInputError(
            f"the {cls.model} model needs at least {cls.min_points} fiducials, got {n}"
            + (": measure more fiducials or choose a model with fewer parameters" if n else ""))
    if not (np.all(np.isfinite(px)) and np.all(np.isfinite(mm))):
        raise AerofidInputError("fiducial coordinates must be finite numbers")
    return px, mm


def _fit(cls: type[ProjectiveTransform], reflected: bool, px: np.ndarray, mm: np.ndarray,
         max_iter: int) -> Adjustment:
    """The adjustment in normalised pixel coordinates, its statistics, and the result in the original ones."""
    n = len(px)
    M = normaliser(px)
    xn = ProjectiveTransform(M)(px)
    l = mm.reshape(-1)                                      # observations X1, Y1, X2, ...
    P = np.eye(2 * n)                                       # equal weights
    p, cond = _solve(cls, reflected, xn, mm, P, max_iter)
    A, f = design(cls, reflected, p, xn)
    N = A.T @ P @ A
    Q = np.linalg.inv(N)
    v = f - l                                               # v = A x - l
    r = 2 * n - cls.n_params
    sigma0_sq = float(v @ P @ v / r) if r > 0 else float("nan")
    qvv = np.clip(np.diag(np.linalg.inv(P) - A @ Q @ A.T), 0, None)
    transform, Qxx = _in_original_pixels(cls, reflected, p, Q, M)
    return Adjustment(transform=transform, Qxx=Qxx, v=v, qvv=qvv, redundancy=r, variance_of_unit_weight=sigma0_sq,
                      condition=cond)


def _solve(cls: type[ProjectiveTransform], reflected: bool, xn: np.ndarray, mm: np.ndarray, P: np.ndarray,
           max_iter: int) -> tuple[np.ndarray, float]:
    """Parameters in normalised pixel coordinates (one step for the linear models, Gauss-Newton for the
    projective one from the DLT solution), and the condition number of the last normal matrix."""
    projective = cls.model == "projective"
    l = mm.reshape(-1)
    p = _dlt(xn, mm) if projective else np.zeros(cls.n_params)
    cond = 1.0
    for _ in range(max_iter if projective else 1):
        A, f = design(cls, reflected, p, xn)
        N = A.T @ P @ A
        cond = np.linalg.cond(N)
        if not np.isfinite(cond) or cond > MAX_CONDITION:
            raise AerofidInputError(
                f"the fiducials' geometry cannot determine the {cls.model} model (points coincide or are "
                "collinear): check the measurements")
        Q = np.linalg.inv(N)
        dp = Q @ A.T @ P @ (l - f)                          # linear models: x = Q A^T P l
        p = p + dp
        if not projective or np.max(np.abs(dp)) < 1e-13 * (1 + np.max(np.abs(p))):
            break
    return p, float(cond)


def _in_original_pixels(cls: type[ProjectiveTransform], reflected: bool, p: np.ndarray, Q: np.ndarray,
                        M: np.ndarray) -> tuple[ProjectiveTransform, np.ndarray]:
    """Back to the original pixel coordinates: H = H_n M, p_orig = g(p_n), Q_orig = J Q J^T."""
    B, b0 = cls.basis(reflected)
    K = np.stack([((B[:, k]).reshape(3, 3) @ M).reshape(-1) for k in range(cls.n_params)], axis=1)
    h = K @ p + (b0.reshape(3, 3) @ M).reshape(-1)
    params = h[list(cls.param_index)] / h[8]
    S = cls.selection()
    dp_dh = S / h[8] - np.outer(S @ h, np.eye(9)[8]) / h[8] ** 2
    J = dp_dh @ K
    return cls.from_params(params, reflected), J @ Q @ J.T


def normaliser(px: np.ndarray) -> np.ndarray:
    """3x3 matrix M that centres the pixel coordinates and scales them to unit RMS distance."""
    c = px.mean(axis=0)
    s = math.sqrt(float(np.mean(np.sum((px - c) ** 2, axis=1)))) or 1.0
    return np.array([[1 / s, 0, -c[0] / s], [0, 1 / s, -c[1] / s], [0, 0, 1.0]])


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


__all__ = ["Adjustment", "adjust", "design", "normaliser"]
