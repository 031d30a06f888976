"""One frame of a batch: :func:`run_frame_job` orients it, writes its outputs and returns a small record.

The job is a top-level function of picklable arguments (paths and :class:`~aerofid.batch.plan.BatchSettings`), so
that a local process or a Dask worker runs it as it is: the worker reads the scan and the camera file itself
and writes the frame's outputs into the output folder; only the :class:`FrameRecord` travels back. It never
raises: a scan that cannot be read (corrupt, truncated, not an image) is a record with status
:data:`ERROR` and the one-line reason, a frame whose marks are not found is ``failed`` with its reasons.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerofid.batch.gallery import crop_sheet_png
from aerofid.batch.plan import BatchSettings, frame_outputs, scan_identity
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.micmac import micmac_texts
from aerofid.formats.orientation import from_result
from aerofid.frame.orient import orient_frame
from aerofid.frame.profile import read_profile
from aerofid.frame.report import frame_html
from aerofid.frame.result import OK, FrameOrientation
from aerofid.io.atomic import Staging
from aerofid.resample import resample_frame, sidecar_path

ERROR = "error"
"""A frame that could not be processed at all (its scan unreadable, corrupt, or a failure): no outputs."""
STATUS_ORDER = (ERROR, "failed", "doubtful", "ok")
"""Frames' statuses, worst first (the summary's order)."""


@dataclass(frozen=True)
class MarkRecord:
    """One fiducial of a frame: its status (found / rejected / not_found), its residual in px and its reason."""

    name: str
    status: str
    residual_px: float | None
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "status": self.status, "residual_px": self.residual_px, "reason": self.reason}


@dataclass(frozen=True)
class FrameRecord:
    """What one frame's job reports: ``frame`` (its key, the name of its outputs), the scan's ``path``,
    ``status`` (ok / doubtful / failed, or :data:`ERROR`), the ``reasons``, a :class:`MarkRecord` per camera
    fiducial, the adjustment's ``rms_px`` (None without an orientation), the ``seconds`` it took and, for an
    error, the ``error`` line."""

    frame: str
    path: str
    status: str
    reasons: tuple[str, ...] = ()
    marks: tuple[MarkRecord, ...] = ()
    rms_px: float | None = None
    seconds: float = 0.0
    error: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        return {"frame": self.frame, "path": self.path, "status": self.status, "reasons": list(self.reasons),
                "marks": [m.to_dict() for m in self.marks], "rms_px": self.rms_px, "seconds": self.seconds,
                "error": self.error}


def record_from_document(frame: str, path: str, doc: dict[str, Any]) -> FrameRecord:
    """The record of a frame from its orientation JSON (a fresh one, or a complete frame's on a rerun)."""
    orientation = doc.get("orientation") or {}
    marks = tuple(MarkRecord(str(f["name"]), str(f["status"]), f.get("residual_px"), str(f.get("reason", "")))
                  for f in doc["fiducials"])
    return FrameRecord(frame, path, str(doc["status"]), tuple(doc.get("reasons", ())), marks,
                       orientation.get("rms_px"), float(doc["batch"]["seconds"]))


def error_text(e: BaseException) -> str:
    """The one line that says why a frame could not be processed (as ``aerofid``'s ``error:`` lines)."""
    if isinstance(e, AerofidInputError):
        return str(e)
    if isinstance(e, MemoryError):
        return "out of memory (the memory budget is set with AEROFID_MEMORY_BUDGET_GB)"
    if isinstance(e, OSError):
        return f"cannot read or write {e.filename or 'a file'}: {e.strerror or e}"
    return f"internal error, a bug in aerofid ({type(e).__name__}: {' '.join(str(e).split())}); please report it"


def run_frame_job(path: str, frame: str, settings: BatchSettings) -> FrameRecord:
    """Orient the scan ``path`` (:func:`aerofid.orient_frame`), write its outputs named ``frame`` in
    ``settings.outdir`` (:func:`aerofid.batch.plan.frame_outputs`: JSON, HTML report, mark crops, MicMac
    MeasuresIm and AffinePlane) all together, the JSON last, and return its record. Never raises."""
    t0 = time.perf_counter()
    try:
        _forget_earlier(frame, settings)
        return record_from_document(frame, path, _orient_and_write(path, frame, settings, t0))
    except Exception as e:  # every failure is the frame's record (module docstring)
        return FrameRecord(frame, path, ERROR, seconds=time.perf_counter() - t0, error=error_text(e))


def _forget_earlier(frame: str, settings: BatchSettings) -> None:
    """Remove what an earlier run wrote for ``frame``, its JSON first: a frame is done again only when its scan, the
    batch's settings or its outputs changed, so they describe another scan or other settings, and a run that writes
    fewer of them (a frame now failed, another model, no resampling) left them beside its own (a helper's audit:
    MicMac files and a resampled frame of a scan since replaced by a blank one)."""
    out = Path(settings.outdir)
    names = [frame_outputs(frame, model) for model in ("affine", "projective")]
    resampled = out / names[0].resampled
    for path in (out / names[0].json, out / names[0].html, out / names[0].crops, out / names[0].measures_im,
                 *(out / n.affine_plane for n in names if n.affine_plane is not None), resampled,
                 sidecar_path(resampled)):
        path.unlink(missing_ok=True)


def _resampled(path: str, res: FrameOrientation, output: Path, settings: BatchSettings) -> list[str]:
    """With ``--resample``, a frame oriented ok resampled into its camera's film mm (:func:`resample_frame`: the
    image and its pixel -> mm sidecar, each put in place whole, before the frame's JSON makes it complete); the
    names written, relative to the output folder."""
    if settings.resample_mm is None or res.status != OK or res.orientation is None:
        return []
    output.parent.mkdir(parents=True, exist_ok=True)
    resample_frame(path, from_result(res.orientation), output, pixel_size_mm=settings.resample_mm,
                   kernel=settings.kernel)
    base = Path(settings.outdir)
    return [output.relative_to(base).as_posix(), sidecar_path(output).relative_to(base).as_posix()]


def _orient_and_write(path: str, frame: str, settings: BatchSettings, t0: float) -> dict[str, Any]:
    """The job's work; returns the JSON document written."""
    cam = read_camera(settings.camera_path)
    outs = frame_outputs(frame, settings.model)
    out = Path(settings.outdir)
    scan = scan_identity(path)
    profile = read_profile(settings.profile_path) if settings.profile_path is not None else None
    res = orient_frame(path, cam, pixel_size_mm=settings.pixel_size_mm, model=settings.model, lie=settings.lie,
                       profile=profile)
    files: dict[str, str | bytes] = {outs.html: frame_html(res, path)}
    if res.fiducials:                                     # none when the camera's layout is not on the scan
        files[outs.crops] = crop_sheet_png(path, res)
    if res.orientation is not None:
        texts = micmac_texts(cam, res.orientation)        # MeasuresIm, MeasuresCamera (the batch's), AffinePlane
        files[outs.measures_im] = texts[0]
        if outs.affine_plane is not None:
            files[outs.affine_plane] = texts[2]
    resampled = _resampled(path, res, out / outs.resampled, settings)
    doc = res.to_dict()
    doc["batch"] = {"frame": frame, "path": path, "fingerprint": settings.fingerprint, "scan": scan,
                    "outputs": sorted([*files, *resampled]), "seconds": time.perf_counter() - t0}
    with Staging([p for p in (path, settings.camera_path, settings.profile_path) if p]) as staging:
        for name, data in files.items():
            staging.put(out / name, data)
        staging.put(out / outs.json, json.dumps(doc, indent=2) + "\n")   # renamed last: the frame is complete
        staging.commit()
    return doc


__all__ = ["ERROR", "STATUS_ORDER", "FrameRecord", "MarkRecord", "error_text", "record_from_document",
           "run_frame_job"]
