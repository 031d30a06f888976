"""Transformations from scan pixels to film millimetres as objects, in the spirit of ``skimage.transform``.

Each transformation holds its 3x3 homogeneous matrix (pixel x = column, y = row -> film X, Y in mm) and
knows its published parameter vector:

* :class:`SimilarityTransform` (4 parameters a, b, c, f): ``X = a x - b y + c, Y = b x + a y + f``, or the
  reflected form ``X = a x + b y + c, Y = b x - a y + f`` (pixel y points down while film y usually points up).
* :class:`AffineTransform` (6 parameters, seed 004 table 3): ``X = a x + b y + c, Y = d x + e y + f``.
* :class:`ProjectiveTransform` (8 parameters):
  ``X = (a x + b y + c) / (g x + h y + 1), Y = (d x + e y + f) / (g x + h y + 1)``.

A transformation is called on points (``T(xy)``), has an :attr:`~ProjectiveTransform.inverse`, its local
:meth:`~ProjectiveTransform.jacobian`, and the :meth:`~ProjectiveTransform.residuals` of point pairs. The
parametrisation ``vec(H) = B p + b0`` (:meth:`~ProjectiveTransform.basis`) is what the least-squares
adjustment (:mod:`aerofid.orientation.adjustment`) estimates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from aerofid.errors import AerofidInputError


def as_matrix(H: ArrayLike) -> np.ndarray:
    """A 2x3 or 3x3 transformation as a 3x3 float matrix (a 2x3 one gets the row [0, 0, 1])."""
    H = np.asarray(H, dtype=float)
    if H.shape == (2, 3):
        H = np.vstack([H, [0.0, 0.0, 1.0]])
    if H.shape != (3, 3):
        raise ValueError(f"a transformation must be 2x3 or 3x3, not {H.shape}")
    return H


@dataclass(frozen=True, eq=False)
class ProjectiveTransform:
    """A plane projective transformation (8 parameters), the most general model.

    Parameters
    ----------
    matrix : array_like
        3x3 (or 2x3 affine) homogeneous matrix, pixel -> mm; stored read-only.

    Attributes
    ----------
    model : str
        The model's name: ``"projective"``, ``"affine"`` or ``"similarity"``.
    n_params : int
        Number of parameters u of the model.
    min_points : int
        Number of points that determine the model (zero redundancy).

    Examples
    --------
    >>> H = [[0.021, 0.0, -110.0], [0.0, -0.021, 120.0], [1e-6, 0.0, 1.0]]
    >>> T = ProjectiveTransform(H)
    >>> xy = np.array([[0.0, 0.0], [5000.0, 4000.0]])
    >>> bool(np.allclose(T.inverse(T(xy)), xy))
    True
    >>> T.params.shape
    (8,)
    """

    matrix: np.ndarray
    model: ClassVar[str] = "projective"
    n_params: ClassVar[int] = 8
    min_points: ClassVar[int] = 4
    #: Positions in the row-major vec(H) of the published parameters.
    param_index: ClassVar[tuple[int, ...]] = tuple(range(8))

    def __post_init__(self) -> None:
        H = np.array(as_matrix(self.matrix))
        H.setflags(write=False)
        object.__setattr__(self, "matrix", H)

    def __call__(self, xy: ArrayLike) -> np.ndarray:
        """Map points ``xy`` (n x 2, or one pair) and return them as an n x 2 array."""
        H = self.matrix
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        h = np.c_[xy, np.ones(len(xy))] @ H.T
        return h[:, :2] / h[:, 2:3]

    @cached_property
    def inverse(self) -> ProjectiveTransform:
        """The inverse transformation (same model), its matrix normalised so that ``[2, 2]`` is 1."""
        Hi = np.linalg.inv(self.matrix)
        return replace(self, matrix=Hi / Hi[2, 2])

    def jacobian(self, xy: Sequence[float]) -> np.ndarray:
        """2x2 Jacobian d(X, Y)/d(x, y) at the point ``xy`` (the linear part for the linear models)."""
        H = self.matrix
        x, y = float(xy[0]), float(xy[1])
        w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
        X = (H[0, 0] * x + H[0, 1] * y + H[0, 2]) / w
        Y = (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / w
        return np.array([[H[0, 0] - X * H[2, 0], H[0, 1] - X * H[2, 1]],
                         [H[1, 0] - Y * H[2, 0], H[1, 1] - Y * H[2, 1]]]) / w

    def residuals(self, src: ArrayLike, dst: ArrayLike) -> np.ndarray:
        """Euclidean distances between the mapped ``src`` points and ``dst`` (n,), in ``dst``'s unit."""
        d = self(src) - np.asarray(dst, dtype=float).reshape(-1, 2)
        return np.hypot(d[:, 0], d[:, 1])

    @property
    def params(self) -> np.ndarray:
        """The published parameter vector (a, b, c, d, e, f[, g, h]; similarity: a, b, c, f)."""
        h = self.matrix.reshape(-1)
        return h[list(self.param_index)] / h[8]

    @property
    def reflected(self) -> bool:
        """Whether the parametrisation is the reflected similarity form (False for the other models)."""
        return False

    @classmethod
    def basis(cls, reflected: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Matrix B (9 x u) and vector b0 (9,) with ``vec(H) = B p + b0`` (row-major 3x3)."""
        b0 = np.zeros(9)
        b0[8] = 1.0
        B = np.zeros((9, cls.n_params))
        B[:cls.n_params, :cls.n_params] = np.eye(cls.n_params)
        return B, b0

    @property
    def parametrisation(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`basis` of this transformation (for the similarity: of its form, proper or reflected)."""
        return self.basis(self.reflected)

    @classmethod
    def selection(cls) -> np.ndarray:
        """Matrix S (u x 9) that picks the published parameters out of vec(H)."""
        S = np.zeros((cls.n_params, 9))
        for i, j in enumerate(cls.param_index):
            S[i, j] = 1.0
        return S

    @classmethod
    def from_params(cls, params: ArrayLike, reflected: bool = False) -> ProjectiveTransform:
        """The transformation with the published parameter vector ``params``."""
        B, b0 = cls.basis(reflected)
        return cls._with_form((B @ np.asarray(params, dtype=float) + b0).reshape(3, 3), reflected)

    @classmethod
    def _with_form(cls, matrix: np.ndarray, reflected: bool) -> ProjectiveTransform:
        return cls(matrix)


@dataclass(frozen=True, eq=False)
class AffineTransform(ProjectiveTransform):
    """An affine transformation (6 parameters, seed 004 table 3): ``X = a x + b y + c, Y = d x + e y + f``.

    Examples
    --------
    >>> T = AffineTransform.from_params([0.021, 0.0001, -110.0, 0.0002, -0.021, 120.0])
    >>> T.matrix[:2].round(4).tolist()
    [[0.021, 0.0001, -110.0], [0.0002, -0.021, 120.0]]
    >>> px = np.array([[100.0, 200.0], [10000.0, 9000.0]])
    >>> bool(np.allclose(T.inverse(T(px)), px, atol=1e-9))
    True
    >>> T.residuals(px, T(px) + [0.003, 0.004]).round(6).tolist()
    [0.005, 0.005]
    """

    model: ClassVar[str] = "affine"
    n_params: ClassVar[int] = 6
    min_points: ClassVar[int] = 3
    param_index: ClassVar[tuple[int, ...]] = tuple(range(6))


@dataclass(frozen=True, eq=False)
class SimilarityTransform(AffineTransform):
    """A similarity (4 parameters a, b, c, f): scale, rotation and shift, possibly reflected.

    Parameters
    ----------
    matrix : array_like
        3x3 (or 2x3) matrix ``[[a, -b, c], [b, a, f]]``, or ``[[a, b, c], [b, -a, f]]`` when reflected.
    reflected : bool
        Whether the matrix has the reflected form (film y up while pixel y points down).

    Examples
    --------
    >>> T = SimilarityTransform.from_params([0.02, 0.0, -100.0, 100.0], reflected=True)
    >>> T([[0.0, 0.0], [1000.0, 1000.0]]).round(9).tolist()
    [[-100.0, 100.0], [-80.0, 80.0]]
    >>> T.inverse.reflected, T.params.tolist()
    (True, [0.02, 0.0, -100.0, 100.0])
    """

    reflected: bool = field(default=False)
    model: ClassVar[str] = "similarity"
    n_params: ClassVar[int] = 4
    min_points: ClassVar[int] = 2
    param_index: ClassVar[tuple[int, ...]] = (0, 3, 2, 5)

    @classmethod
    def basis(cls, reflected: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``vec(H) = B p + b0`` for p = (a, b, c, f): H = [[a, -b, c], [b, a, f]] or the reflected
        [[a, b, c], [b, -a, f]]."""
        b0 = np.zeros(9)
        b0[8] = 1.0
        B = np.zeros((9, 4))
        s = -1.0 if reflected else 1.0
        B[0, 0], B[4, 0] = 1.0, s
        B[1, 1], B[3, 1] = -s, 1.0
        B[2, 2] = 1.0
        B[5, 3] = 1.0
        return B, b0

    @classmethod
    def _with_form(cls, matrix: np.ndarray, reflected: bool) -> ProjectiveTransform:
        return cls(matrix, reflected)


#: The transformation of each model, by name.
TRANSFORMS: dict[str, type[ProjectiveTransform]] = {
    "similarity": SimilarityTransform, "affine": AffineTransform, "projective": ProjectiveTransform}
#: The model names, fewest parameters first.
MODELS = tuple(TRANSFORMS)


def transform_class(model: str) -> type[ProjectiveTransform]:
    """The transformation class of ``model``; an input error naming the models for an unknown name."""
    if model not in TRANSFORMS:
        raise AerofidInputError(f"unknown model {model!r}: choose one of {', '.join(MODELS)}")
    return TRANSFORMS[model]


__all__ = ["MODELS", "TRANSFORMS", "AffineTransform", "ProjectiveTransform", "SimilarityTransform", "as_matrix",
           "transform_class"]
