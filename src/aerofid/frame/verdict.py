"""The adjustment of a frame's found marks and the verdict: per fiducial found / rejected / not found, per frame
ok / doubtful / failed with the reasons (seed 002's self-diagnosis, carried to the whole frame)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.find import Located
from aerofid.frame.layout import LayoutMatch
from aerofid.frame.result import (
    DOUBTFUL,
    FAILED,
    FOUND_MARK,
    LIE_ASSUMED,
    LIE_GIVEN,
    LIE_TOLD,
    MISSING_MARK,
    OK,
    REJECTED_MARK,
    FiducialFinding,
    FrameOrientation,
)
from aerofid.orientation.camera import Camera
from aerofid.orientation.correspondence import (
    AmbiguousCorrespondenceError,
    ArrangementFit,
    Correspondence,
    match_fiducials,
)
from aerofid.orientation.interior import orient
from aerofid.orientation.result import REJECTED, InteriorOrientation
from aerofid.orientation.transform import transform_class

MAX_RMS_PX = 1.0
"""Largest RMS residual (px) of an orientation called ok: measured marks (0.01-0.1 px) and a film's deformation
beyond an affinity (a few um) explain a few tenths of a pixel (the real RC20 frame: 0.32 px at 42 um)."""
SCALE_AGREEMENT = 0.02
"""Largest relative difference between the adjusted pixel size and the one the scan or camera file declared."""
MIN_REDUNDANCY = 2
"""Fewest redundant observations for the marks to check each other (affine: 4 marks)."""


def verdict(cam: Camera, layout: LayoutMatch, located: Sequence[tuple[Located | None, str]], model: str,
            head: dict[str, Any], size: float | None, size_source: str,
            lie: tuple[int, bool] | None = None) -> FrameOrientation:
    """Step 4 of :func:`aerofid.orient_frame`: adjust the found marks, name them, judge the frame."""
    found = [k for k, (m, _) in enumerate(located) if m is not None]
    common = dict(head, pixel_size_mm=size, pixel_size_source=size_source)
    need = transform_class(model).min_points
    if len(found) < need:
        return FrameOrientation(**common, status=FAILED, reasons=(
            f"only {len(found)} of the camera's {len(located)} fiducials found: the {model} model needs {need}",),
            fiducials=_by_layout(cam, layout, located), orientation=None, rotation_deg=None, mirrored=None)
    px = np.array([[located[k][0].x, located[k][0].y] for k in found])  # type: ignore[union-attr]
    reasons: list[str] = []
    try:
        io, lie_fit, lie_source = _adjust(cam, px, model, str(head["image"]), lie, reasons)
    except AerofidInputError as e:
        return FrameOrientation(**common, status=FAILED, reasons=(f"adjustment: {e}",),
                                fiducials=_by_layout(cam, layout, located), orientation=None, rotation_deg=None,
                                mirrored=None)
    findings = _by_orientation(cam, layout, located, found, io)
    reasons += _doubts(io, findings, size, size_source)
    if size_source == "estimated":
        common["pixel_size_mm"] = adjusted_pixel_mm(io)
    return FrameOrientation(**common, status=DOUBTFUL if reasons else OK, reasons=tuple(reasons),
                            fiducials=findings, orientation=io, rotation_deg=lie_fit.rotation_deg,
                            mirrored=lie_fit.mirrored, lie_source=lie_source)


LIE_UNTOLD = "the film's lie cannot be told from the fiducials"
"""How the reason of a frame whose marks fit several lies equally (a symmetric layout) begins."""
NOMINAL_LIE = (0, False)
"""The lie assumed when the fiducials cannot tell (a symmetric layout): the film as the camera file draws it."""


def _adjust(cam: Camera, px: np.ndarray, model: str, image: str, lie: tuple[int, bool] | None,
            reasons: list[str]) -> tuple[InteriorOrientation, ArrangementFit, str]:
    """The adjustment with the film's lie decided by the arrangements' F test, and how it was decided
    (``FrameOrientation.lie_source``). When several lies fit equally (a symmetric layout), the given ``lie`` is taken
    if it is among them, else the nominal one (then the frame is doubtful: the reason says so); a given lie that fits
    worse than another is a reason too."""
    try:
        io = orient(cam, px, model, correspondence="auto", image=image)
        assert io.correspondence is not None
        best = io.correspondence.best
        if lie is not None and (best.rotation_deg, best.mirrored) != tuple(lie):
            reasons.append(f"the marks fit the lie rotation {best.rotation_deg} deg{_m(best.mirrored)} "
                           f"significantly better than the given rotation {lie[0]} deg{_m(lie[1])}")
        return io, best, LIE_TOLD
    except AmbiguousCorrespondenceError as e:
        corr = e.correspondence
    if lie is None and (cleared := _lie_without_a_blunder(cam, px, model, image, corr)) is not None:
        return (*cleared, LIE_TOLD)
    want = lie if lie is not None else NOMINAL_LIE
    chosen = next((f for f in corr.tied if (f.rotation_deg, f.mirrored) == tuple(want)), None)
    if chosen is None or lie is None:
        chosen = chosen or corr.best
        lies = ", ".join(f"rotation {f.rotation_deg} deg{_m(f.mirrored)}" for f in corr.tied)
        reasons.append(f"{LIE_UNTOLD} ({lies} fit equally well): assumed "
                       f"rotation {chosen.rotation_deg} deg{_m(chosen.mirrored)}; give the lie (--lie) if it is "
                       "not")
        return _oriented_as(cam, px, model, image, chosen), chosen, LIE_ASSUMED
    return _oriented_as(cam, px, model, image, chosen), chosen, LIE_GIVEN


def _oriented_as(cam: Camera, px: np.ndarray, model: str, image: str, fit: ArrangementFit) -> InteriorOrientation:
    """The adjustment of the marks ``px`` named as the arrangement ``fit`` assigns them."""
    names = [cam.names[j] for j in fit.assignment]
    return orient(cam, dict(zip(names, px.tolist(), strict=True)), model, correspondence="names", image=image)


LEAVE_ONE_OUT = 6
"""Fewest marks from which one is left out to tell the lie (:func:`_lie_without_a_blunder`): five then remain, two
more than an affine transformation needs."""


def _lie_without_a_blunder(cam: Camera, px: np.ndarray, model: str, image: str, corr: Correspondence
                           ) -> tuple[InteriorOrientation, ArrangementFit] | None:
    """The lie the marks tell once one blunder is left out, with the adjustment of all of them under it; None when
    no single mark hides the lie so. The arrangements' F test compares residuals of a few hundredths of a mm (the
    certificate's departures from a symmetric layout), so one mark measured a few px off (a mark half hidden by a
    blot, which the adjustment then rejects) makes every lie fit equally. Left out in turn (at least
    :data:`LEAVE_ONE_OUT` marks), the marks whose absence makes one lie significantly the best must all point to the
    same lie, and the adjustment of every mark under it must reject each of them as a blunder."""
    if len(px) < LEAVE_ONE_OUT:
        return None
    told: dict[tuple[int, bool], list[int]] = {}
    for i in range(len(px)):
        try:
            c = match_fiducials(np.delete(px, i, axis=0), cam.xy_mm, model, y_axis=cam.y_axis, fiducial_names=cam.names)
        except AerofidInputError:
            continue
        if c.status == "unique":
            told.setdefault((c.best.rotation_deg, c.best.mirrored), []).append(i)
    if len(told) != 1:
        return None
    (lie, left_out), = told.items()
    fit = next((f for f in corr.candidates if (f.rotation_deg, f.mirrored) == lie), None)
    if fit is None:
        return None
    try:
        io = _oriented_as(cam, px, model, image, fit)
    except AerofidInputError:
        return None
    used = {f.name for f in io.used}
    return (io, fit) if all(cam.names[fit.assignment[i]] not in used for i in left_out) else None


def _m(mirrored: bool) -> str:
    return " mirrored" if mirrored else ""


def _doubts(io: InteriorOrientation, findings: Sequence[FiducialFinding], size: float | None,
            size_source: str) -> list[str]:
    """Why an adjusted frame is doubtful (none: ok)."""
    out = []
    n_found = sum(f.status != MISSING_MARK for f in findings)
    if io.redundancy < MIN_REDUNDANCY:
        out.append(f"{len(io.used)} marks used: too few for them to check each other (redundancy {io.redundancy})")
    if 2 * n_found < len(findings):
        out.append(f"only {n_found} of the camera's {len(findings)} fiducials found")
    if math.isfinite(io.rms_px) and io.rms_px > MAX_RMS_PX:
        out.append(f"residual RMS {io.rms_px:.2f} px is more than the marks and the film explain (<= {MAX_RMS_PX} px)")
    if size is not None and size_source != "estimated":
        fitted = adjusted_pixel_mm(io)
        if abs(fitted / size - 1) > SCALE_AGREEMENT:
            whose = SIZE_SOURCES.get(size_source, size_source)
            out.append(f"the adjusted pixel size {fitted:.5f} mm differs from {whose} {size:.5f} mm")
    return out


SIZE_SOURCES = {"given": "the given", "tags": "the resolution tags'", "camera": "the camera file's",
                "profile": "the roll profile's"}
"""Where a declared pixel size came from, as a reason names it."""


def adjusted_pixel_mm(io: InteriorOrientation) -> float:
    """The adjustment's mean pixel size (mm): the geometric mean of its x and y pixel sizes."""
    return math.sqrt(io.pixel_size_um[0] * io.pixel_size_um[1]) / 1000.0


def _by_orientation(cam: Camera, layout: LayoutMatch, located: Sequence[tuple[Located | None, str]],
                    found: Sequence[int], io: InteriorOrientation) -> tuple[FiducialFinding, ...]:
    """A finding per camera fiducial, named by the adjustment: its position predicted by the orientation, and its
    measured point (used or rejected with the residual) or, if none, why no mark was found there."""
    by_name = {r.name: (k, r) for k, r in zip(found, io.fiducials, strict=True)}  # one row per point, in order
    out = []
    for fid in cam.fiducials:
        p = io.to_pixel([[fid.x_mm, fid.y_mm]])[0]
        if fid.name not in by_name:
            k = int(np.argmin(np.hypot(*(layout.predicted - p).T)))
            out.append(FiducialFinding(fid.name, MISSING_MARK, None, None, None, None, float(p[0]), float(p[1]),
                                       reason=located[k][1] or "not found"))
            continue
        k, r = by_name[fid.name]
        m = located[k][0]
        assert m is not None
        d = m.detection
        out.append(FiducialFinding(
            fid.name, REJECTED_MARK if r.status == REJECTED else FOUND_MARK, m.x, m.y, d.sigma_x, d.sigma_y,
            float(p[0]), float(p[1]),
            residual_px=float(math.hypot(r.residual_x_px, r.residual_y_px)),
            reason=r.reason or (UNCHECKED if io.redundancy == 0 else ""), method=d.method, located=m))
    return tuple(out)


UNCHECKED = ("not checked: the marks used fit the model exactly (redundancy 0), so neither this mark nor its name "
             "is confirmed")
"""The reason of a mark found in a frame whose adjustment has no redundancy: its residual is 0 whatever it is (the
real RC20 frame blurred by 6 px without its pixel size: 3 marks "found", two of them 500 px from any mark; a helper's
audit)."""


def _by_layout(cam: Camera, layout: LayoutMatch, located: Sequence[tuple[Located | None, str]]
               ) -> tuple[FiducialFinding, ...]:
    """Findings named by the layout's hypothesis alone (no adjustment: the lie is not decided)."""
    out = []
    for k, fid in enumerate(cam.fiducials):
        m, why = located[k]
        px, py = (float(v) for v in layout.predicted[k])
        if m is None:
            out.append(FiducialFinding(fid.name, MISSING_MARK, None, None, None, None, px, py, reason=why))
        else:
            d = m.detection
            out.append(FiducialFinding(fid.name, FOUND_MARK, m.x, m.y, d.sigma_x, d.sigma_y, px, py,
                                       reason=UNCONFIRMED, method=d.method, located=m))
    return tuple(out)


UNCONFIRMED = "named by the layout's hypothesis alone: no adjustment confirmed which fiducial this mark is"
"""The reason of a mark found in a frame without an orientation (:func:`_by_layout`): its name is the layout's guess
(a frame scaled down 4 times had two marks found under other fiducials' names: a helper's audit)."""


__all__ = ["LIE_UNTOLD", "MAX_RMS_PX", "adjusted_pixel_mm", "verdict"]
