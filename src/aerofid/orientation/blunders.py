"""Blunder detection: the leave-one-out (externally studentised) outlier test and iterative data snooping."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.orientation.adjustment import adjust
from aerofid.orientation.f_distribution import f_critical
from aerofid.orientation.transform import transform_class

#: Significance level of each leave-one-out outlier test. Baarda's classic alpha_0 = 0.001 misses 10 of 64
#: 5-px blunders planted in the real pjhartzell frames (residuals ~0.5 px); 0.01 rejects a second, good
#: fiducial in 8 of them; 0.005 finds all 64 with no false rejection (tests/test_orientation.py).
ALPHA_BLUNDER = 0.005
#: A fiducial is rejected only if its discrepancy from the fit of the others is at least this many pixels.
MIN_BLUNDER_PX = 1.0
#: Lower bound of the estimated standard deviation used in the outlier test, in pixels (guards noise-free data).
SIGMA_FLOOR_PX = 0.05


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
    cls = transform_class(model)
    dof = 2 * (n - 1) - cls.n_params
    if dof < 1 or n - 1 < cls.min_points:
        return []
    critical = f_critical(alpha, 2, dof)
    tests = (_leave_one_out(px, mm, i, model, reflected, sigma_floor_px, critical, dof) for i in range(n))
    return [t for t in tests if t is not None]


def _leave_one_out(px: np.ndarray, mm: np.ndarray, i: int, model: str, reflected: bool | None,
                   sigma_floor_px: float, critical: float, dof: int) -> OutlierTest | None:
    """The test of point ``i`` against the fit of the others (None when they cannot be fitted)."""
    keep = np.arange(len(px)) != i
    try:
        fit = adjust(px[keep], mm[keep], model, reflected=reflected)
    except AerofidInputError:
        return None
    T = fit.transform
    d = mm[i] - T(px[i:i + 1])[0]
    Jpx = T.jacobian(px[i])                                # mm per px
    mm_per_px = math.sqrt(abs(np.linalg.det(Jpx)))
    Ai = fit.design_matrix(px[i:i + 1])
    C = np.eye(2) + Ai @ fit.Qxx @ Ai.T
    s2 = max(fit.variance_of_unit_weight, (sigma_floor_px * mm_per_px) ** 2)
    statistic = float(d @ np.linalg.solve(C, d) / (2 * s2))
    d_px = np.linalg.solve(Jpx, d)
    return OutlierTest(index=i, statistic=statistic, critical=critical, discrepancy_mm=float(np.hypot(*d)),
                       discrepancy_px=float(np.hypot(*d_px)), dof=dof)


@dataclass(frozen=True)
class Rejection:
    """A rejected fiducial: its index into the measured points and why."""

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

    Returns
    -------
    rejections : list of Rejection
        With indices into the input.
    warnings : list of str
    """
    px = np.asarray(px, dtype=float)
    mm = np.asarray(mm, dtype=float)
    labels = list(names) if names is not None else [str(i) for i in range(len(px))]
    active = list(range(len(px)))
    rejected: list[Rejection] = []
    while True:
        tests = outlier_tests(px[active], mm[active], model, alpha=alpha, sigma_floor_px=sigma_floor_px)
        if not tests:
            return rejected, [] if rejected else [_too_few_warning(model, len(active))]
        tests.sort(key=lambda t: -t.statistic)
        worst = tests[0]
        if not (worst.significant and worst.discrepancy_px >= min_blunder_px):
            return rejected, []
        if len(tests) > 1 and tests[1].significant and tests[1].statistic > 0.9 * worst.statistic:
            who = ", ".join(labels[active[t.index]] for t in tests[:2])
            return rejected, [f"a blunder is likely among {who} but cannot be located (their outlier tests are "
                              "about equal): check these marks"]
        i = active[worst.index]
        rejected.append(Rejection(i, _reason(worst, alpha)))
        active.remove(i)


def _too_few_warning(model: str, n: int) -> str:
    need = (transform_class(model).n_params + 3) // 2 + 1
    return (f"blunder detection needs at least {need} fiducials for the {model} model; "
            f"{n} measured: a wrong mark would go unnoticed")


def _reason(test: OutlierTest, alpha: float) -> str:
    return (f"outlier: {test.discrepancy_px:.2f} px ({test.discrepancy_mm * 1000:.1f} um) from the fit of the "
            f"other fiducials; test F = {test.statistic:.4g} > F(2, {test.dof}; {1 - alpha:g}) = "
            f"{test.critical:.3g}")


__all__ = ["ALPHA_BLUNDER", "MIN_BLUNDER_PX", "SIGMA_FLOOR_PX", "OutlierTest", "Rejection", "outlier_tests",
           "reject_blunders"]
