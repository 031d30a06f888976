"""Interior orientation of one scan: :func:`orient` and its result, :class:`InteriorOrientation`.

:func:`orient` names the measured points (as given, or by the film's arrangement in the scanner:
:mod:`aerofid.orientation.correspondence`), rejects blunders (:mod:`aerofid.orientation.blunders`), fits the
pixel -> mm transformation by least squares (:mod:`aerofid.orientation.adjustment`, seed 004 section 4) and
derives the residuals in mm and px and the scan geometry. No file is read here (see :mod:`aerofid.formats`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.orientation.adjustment import Adjustment, adjust
from aerofid.orientation.blunders import ALPHA_BLUNDER, MIN_BLUNDER_PX, reject_blunders
from aerofid.orientation.camera import Camera
from aerofid.orientation.correspondence import AmbiguousCorrespondenceError, Correspondence, match_fiducials
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.result import REJECTED, USED, FiducialResidual, InteriorOrientation
from aerofid.orientation.transform import ProjectiveTransform, transform_class

#: Warn when the RMS of the residual vectors exceeds this many pixels.
WARN_RMS_PX = 1.0
#: Warn when the smallest singular value of the centred fiducial layout is below this fraction of the largest.
COLLINEAR_RATIO = 0.1
#: Warn when the condition number of the (normalised) normal matrix exceeds this.
WARN_CONDITION = 1e8

def scan_geometry(transform: ProjectiveTransform, at: Sequence[float] = (0.0, 0.0)) -> dict[str, Any]:
    """Derived scan quantities from the linear part L of pixel -> mm at pixel ``at``.

    Pixel size x and y are the lengths of L's columns (the film distance of one pixel step along a row
    and along a column); the rotation is the angle of the pixel x axis in the film frame; the
    non-orthogonality is the angle between the two pixel axes in the film minus 90 degrees; the scale
    difference (sx - sy) / mean, in ppm, is the differential film deformation plus scanner affinity.
    ``det`` > 0 when the pixel axes keep their handedness on the film; for a certificate with y up a
    normal scan has det L < 0.
    """
    L = transform.jacobian(at)
    sx = float(np.hypot(L[0, 0], L[1, 0]))
    sy = float(np.hypot(L[0, 1], L[1, 1]))
    det = float(np.linalg.det(L))
    rot = math.degrees(math.atan2(L[1, 0], L[0, 0]))
    cosang = float(np.dot(L[:, 0], L[:, 1]) / (sx * sy))
    nonorth = math.degrees(math.acos(max(-1.0, min(1.0, cosang)))) - 90.0
    return {"pixel_size_um": (sx * 1000.0, sy * 1000.0), "rotation_deg": rot,
            "non_orthogonality_deg": nonorth, "scale_difference_ppm": (sx - sy) / ((sx + sy) / 2) * 1e6,
            "det": det}


def orient(camera: Camera, measurements: Measurements | Mapping | np.ndarray, model: str = "affine", *,
           correspondence: str | None = None, reject: bool = True, alpha: float = ALPHA_BLUNDER,
           min_blunder_px: float = MIN_BLUNDER_PX, image: str | None = None) -> InteriorOrientation:
    """Interior orientation of one scan from measured fiducial centres (seed 004, section 4).

    Parameters
    ----------
    camera : Camera
        The calibration certificate (:func:`aerofid.read_camera` reads a file).
    measurements : Measurements, mapping or array_like
        Measured fiducial centres (:func:`aerofid.read_measurements` reads a file), a mapping
        name -> (x, y), or an n x 2 array of unnamed points.
    model : str
        ``"similarity"``, ``"affine"`` (seed 004) or ``"projective"``.
    correspondence : str or None
        ``"names"`` (trust the point names), ``"auto"`` (assign by testing the 8 arrangements of the film
        in the scanner) or None (names when the points have names).
    reject : bool
        Detect and reject blunders by the leave-one-out outlier test.
    alpha, min_blunder_px : float
        See :func:`aerofid.orientation.blunders.reject_blunders`.
    image : str or None
        The scan's name in the result (default: the measurements' image).

    Returns
    -------
    InteriorOrientation

    Raises
    ------
    AerofidInputError
        Bad input, too few fiducials for the model, degenerate geometry.
    AmbiguousCorrespondenceError
        Auto correspondence found two equally good arrangements.

    Examples
    --------
    Four fiducials of a 212 mm frame, scanned at 21 um with film y up:

    >>> cam = Camera.from_dict({"name": "cam", "fiducials": {
    ...     "UL": [-106, 106], "UR": [106, 106], "LL": [-106, -106], "LR": [106, -106]}})
    >>> px = {"UL": [100.0, 100.0], "UR": [10196.0, 100.0], "LL": [100.0, 10196.0], "LR": [10196.0, 10196.0]}
    >>> res = orient(cam, px, "affine")
    >>> [round(s, 6) for s in res.pixel_size_um], res.redundancy, res.mirrored
    ([21.0, 21.0], 2, False)
    >>> res.to_mm([[5148.0, 5148.0]]).round(9).tolist()
    [[0.0, 0.0]]
    """
    if not isinstance(camera, Camera):
        raise AerofidInputError("camera must be a Camera: read a camera file with aerofid.read_camera(path)")
    meas = Measurements.from_any(measurements)
    cls = transform_class(model)
    if correspondence not in (None, "names", "auto"):
        raise AerofidInputError(f"correspondence must be 'names' or 'auto', not {correspondence!r}")
    corr: Correspondence | None = None
    warnings: list[str] = []
    if (correspondence or ("names" if meas.named else "auto")) == "names":
        names = _names_as_given(camera, meas)
    else:
        names, corr, warnings = _names_by_arrangement(camera, meas, model)
    px = meas.xy
    mm = np.array([[camera.fiducial(n).x_mm, camera.fiducial(n).y_mm] for n in names])
    if len(px) < cls.min_points:
        raise AerofidInputError(
            f"the {model} model needs at least {cls.min_points} fiducials, got {len(px)}: measure more fiducials "
            "or choose a model with fewer parameters")
    reasons: dict[int, str] = {}
    if reject:
        rejections, rejection_warnings = reject_blunders(px, mm, model, alpha=alpha, min_blunder_px=min_blunder_px,
                                                         names=names)
        reasons = {r.index: r.reason for r in rejections}
        warnings += rejection_warnings
    used = np.array([i not in reasons for i in range(len(px))])
    fit = adjust(px[used], mm[used], model)
    warnings += _fit_warnings(fit, px[used])
    fiducials = _fiducial_residuals(names, px, mm, fit, used, reasons)
    return _result(camera, meas, names, fit, fiducials, corr, warnings, image)


def _names_as_given(cam: Camera, meas: Measurements) -> list[str]:
    """The measured points' own names, checked against the camera's fiducials."""
    if meas.names is None:
        raise AerofidInputError("the measured points have no names: use correspondence 'auto'")
    unknown = [n for n in meas.names if n not in cam.names]
    if unknown:
        raise AerofidInputError(
            f"measured point(s) {', '.join(unknown)} are not fiducials of camera {cam.name!r} "
            f"(it has {', '.join(cam.names)})")
    return list(meas.names)


def _names_by_arrangement(cam: Camera, meas: Measurements,
                          model: str) -> tuple[list[str], Correspondence, list[str]]:
    """Names from the best film arrangement (:func:`match_fiducials`), the correspondence, and warnings."""
    corr = match_fiducials(meas.xy, cam.xy_mm, model, y_axis=cam.y_axis, fiducial_names=cam.names)
    if corr.status != "unique":
        raise AmbiguousCorrespondenceError(f"fiducial correspondence is ambiguous: {corr.reason}", corr)
    names = [cam.names[j] for j in corr.assignment]
    warnings = []
    if meas.names is not None and names != list(meas.names):
        warnings.append("the measured names disagree with the best arrangement: names were reassigned")
    return names, corr, warnings


def _fit_warnings(fit: Adjustment, px_used: np.ndarray) -> list[str]:
    """No redundancy, nearly collinear fiducials, ill-conditioned normal equations."""
    warnings = []
    if fit.redundancy == 0:
        warnings.append(f"no redundancy ({len(px_used)} fiducials, {fit.transform.n_params} parameters): residuals "
                        "are zero and the quality cannot be estimated")
    # smallest/largest singular value of the centred layout
    sv = np.linalg.svd(px_used - px_used.mean(axis=0), compute_uv=False)
    if sv[-1] < COLLINEAR_RATIO * sv[0]:
        warnings.append("the fiducials are nearly collinear: the transformation is poorly determined across them")
    if fit.condition > WARN_CONDITION:
        warnings.append(f"the normal equations are ill-conditioned (condition {fit.condition:.2g})")
    return warnings


def _fiducial_residuals(names: Sequence[str], px: np.ndarray, mm: np.ndarray, fit: Adjustment, used: np.ndarray,
                        reasons: Mapping[int, str]) -> tuple[FiducialResidual, ...]:
    """One row per measured point: adjusted position, residuals (calibrated minus adjusted) in mm and px,
    redundancy number (used points) or the reason of the rejection."""
    T = fit.transform
    adjusted = T(px)
    v = mm - adjusted                                       # calibrated minus adjusted (seed 004)
    qvv = iter(fit.qvv.reshape(-1, 2))
    rows = []
    for i, name in enumerate(names):
        vpx = T.inverse.jacobian(adjusted[i]) @ v[i]
        if used[i]:
            rn, status, reason = float(next(qvv).mean()), USED, ""
        else:
            rn, status, reason = math.nan, REJECTED, reasons[i]
        rows.append(FiducialResidual(name, float(px[i, 0]), float(px[i, 1]), float(mm[i, 0]), float(mm[i, 1]),
                                     float(adjusted[i, 0]), float(adjusted[i, 1]), float(v[i, 0]), float(v[i, 1]),
                                     float(vpx[0]), float(vpx[1]), rn, status, reason))
    return tuple(rows)


def _rms(v: np.ndarray) -> float:
    """sqrt(mean(vx^2 + vy^2)) of residual vectors (n x 2); per axis for an n-vector."""
    return math.sqrt(float(np.mean(np.sum(v ** 2, axis=1)))) if v.ndim == 2 else math.sqrt(float(np.mean(v ** 2)))


def _result(cam: Camera, meas: Measurements, names: Sequence[str], fit: Adjustment,
            fiducials: tuple[FiducialResidual, ...], corr: Correspondence | None, warnings: list[str],
            image: str | None) -> InteriorOrientation:
    """The statistics of the used fiducials and the scan geometry at the fiducial centre."""
    T = fit.transform
    used = [f for f in fiducials if f.status == USED]
    vu = np.array([[f.residual_x_mm, f.residual_y_mm] for f in used])
    rms_px = _rms(np.array([[f.residual_x_px, f.residual_y_px] for f in used]))
    if rms_px > WARN_RMS_PX:
        warnings = [*warnings, f"the RMS residual is {rms_px:.2f} px: check the measurements and the camera file"]
    fc_mm = cam.fiducial_centre_mm()
    fc_px = T.inverse([fc_mm])[0]
    pp_mm, pp_src = cam.principal_point_mm
    pp_px = T.inverse([pp_mm])[0]
    geo = scan_geometry(T, fc_px)
    nominal = None
    if cam.pixel_size_um:
        sx, sy = geo["pixel_size_um"]
        nominal = ((sx / cam.pixel_size_um - 1.0) * 1e6, (sy / cam.pixel_size_um - 1.0) * 1e6)
    mirrored = (geo["det"] > 0) if cam.y_axis == "up" else (geo["det"] < 0)
    return InteriorOrientation(
        model=T.model, camera=cam.name, image=image if image is not None else meas.image, transform=T,
        params_std=fit.params_std, matrix_std=fit.matrix_std, variance_of_unit_weight=fit.variance_of_unit_weight,
        redundancy=fit.redundancy, rms_mm=_rms(vu), rms_x_mm=_rms(vu[:, 0]), rms_y_mm=_rms(vu[:, 1]),
        rms_px=rms_px, fiducials=fiducials, missing=tuple(nm for nm in cam.names if nm not in names),
        pixel_size_um=geo["pixel_size_um"], rotation_deg=geo["rotation_deg"],
        non_orthogonality_deg=geo["non_orthogonality_deg"], scale_difference_ppm=geo["scale_difference_ppm"],
        scale_vs_nominal_ppm=nominal, mirrored=bool(mirrored),
        principal_point_px=(float(pp_px[0]), float(pp_px[1])), principal_point_source=pp_src,
        fiducial_centre_mm=fc_mm, fiducial_centre_px=(float(fc_px[0]), float(fc_px[1])),
        correspondence=corr, warnings=tuple(warnings))


__all__ = ["WARN_RMS_PX", "orient", "scan_geometry"]
