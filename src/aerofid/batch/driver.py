"""A whole batch: plan it (the frames, their settings, which are already complete), then run what is left on a
runner, keeping the summary up to date as frames complete.

No printing here: :func:`run_batch` calls back with each record (the command line shows progress with it).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from aerofid.batch.exports import write_metashape
from aerofid.batch.inputs import expand_inputs, frame_keys
from aerofid.batch.job import FrameRecord, record_from_document
from aerofid.batch.plan import (
    CROPS_FOLDER,
    MEASURES_CAMERA,
    MICMAC_FOLDER,
    RESAMPLED_FOLDER,
    BatchSettings,
    batch_settings,
    frame_outputs,
    prepare_outdir,
    read_complete,
)
from aerofid.batch.runners import Runner, Task
from aerofid.batch.summary import write_summary
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.micmac import write_measures_camera
from aerofid.orientation.camera import Camera
from aerofid.resample.warp import DEFAULT_KERNEL

SUMMARY_REFRESH_S = 10.0
"""The summary is rewritten at most this often while frames complete (and at the end), so that a batch killed
part-way leaves a summary of what it did, without rewriting a summary of thousands of frames after each one."""


@dataclass(frozen=True)
class BatchPlan:
    """A batch before it runs: its settings, every frame (absolute scan path, key) in order, and the records of
    the frames already complete (read from their JSON: a rerun skips them)."""

    camera: Camera
    settings: BatchSettings
    frames: tuple[Task, ...]
    done: dict[str, FrameRecord]

    @property
    def todo(self) -> tuple[Task, ...]:
        """The frames to do: those not complete."""
        return tuple(t for t in self.frames if t[1] not in self.done)

    def ordered(self, records: dict[str, FrameRecord]) -> list[FrameRecord]:
        """``records`` (by key) in the frames' order."""
        return [records[k] for _, k in self.frames if k in records]


def _complete_record(path: str, frame: str, settings: BatchSettings) -> FrameRecord | None:
    doc = read_complete(path, frame, settings)
    if doc is None:
        return None
    try:
        return record_from_document(frame, path, doc)
    except (KeyError, TypeError, ValueError):  # a JSON edited by hand: the frame is done again
        return None


def plan_batch(inputs: Iterable[str], camera_path: str | os.PathLike[str], outdir: str | os.PathLike[str], *,
               model: str = "affine", pixel_size_mm: float | None = None,
               lie: tuple[int, bool] | None = None,
               profile_path: str | os.PathLike[str] | None = None, resample_mm: float | None = None,
               kernel: str = DEFAULT_KERNEL) -> BatchPlan:
    """The plan of a batch (reads the camera file and the complete frames' JSON; writes nothing).

    Raises
    ------
    AerofidInputError
        Inputs that name no scan, a bad camera file, a bad option: before any work.
    """
    paths = expand_inputs(inputs, exclude=[Path(outdir) / CROPS_FOLDER, Path(outdir) / RESAMPLED_FOLDER])
    keys = frame_keys(paths)
    camera = read_camera(os.fspath(camera_path))
    settings = batch_settings(camera, camera_path, outdir, model=model, pixel_size_mm=pixel_size_mm, lie=lie,
                              profile_path=profile_path, resample_mm=resample_mm, kernel=kernel)
    frames = tuple((os.path.abspath(p), k) for p, k in zip(paths, keys, strict=True))
    if resample_mm is not None:
        _check_resampled_names(keys, settings.model)
    done = {k: r for p, k in frames if (r := _complete_record(p, k, settings)) is not None}
    return BatchPlan(camera, settings, frames, done)


def _check_resampled_names(keys: Sequence[str], model: str) -> None:
    """Refuse (one line, before any work) frames whose resampled frames would share a name (case-insensitively):
    ReSampFid's name drops the scan's ending (``a.tif`` and ``a.jpg`` are both ``OIS-Reech_a.tif``), and one would
    overwrite the other."""
    named: dict[str, str] = {}
    for key in keys:
        other = named.setdefault(frame_outputs(key, model).resampled.lower(), key)
        if other != key:
            raise AerofidInputError(f"frames {other!r} and {key!r} would share the resampled frame "
                                    f"{frame_outputs(key, model).resampled!r}: rename one of the scans, or "
                                    "process them in separate batches")


def start_batch(plan: BatchPlan) -> Path:
    """Create the output folder and write the batch's MicMac ``MeasuresCamera.xml``; the folder."""
    out = prepare_outdir(plan.settings.outdir)
    write_measures_camera(out / MICMAC_FOLDER / MEASURES_CAMERA, plan.camera)
    return out


def run_batch(plan: BatchPlan, runner: Runner, on_record: Callable[[FrameRecord], None] | None = None,
              refresh_s: float = SUMMARY_REFRESH_S, metashape: bool = False) -> list[FrameRecord]:
    """Run the frames :attr:`BatchPlan.todo` on ``runner`` (:mod:`aerofid.batch.runners`), call ``on_record``
    with each record as it completes, write the summary of every frame (the complete ones' too) at the start,
    every ``refresh_s`` seconds and at the end (also an interrupted end), and return all the records in the
    frames' order. With ``metashape``, the roll's Metashape script (:func:`aerofid.batch.exports.write_metashape`)
    is written with the summary at the end."""
    start_batch(plan)
    records = dict(plan.done)
    write_summary(plan.ordered(records), plan.settings, len(plan.frames))
    last = time.monotonic()
    try:
        for rec in runner(plan.todo, plan.settings):
            records[rec.frame] = rec
            if on_record is not None:
                on_record(rec)
            if time.monotonic() - last >= refresh_s:
                write_summary(plan.ordered(records), plan.settings, len(plan.frames))
                last = time.monotonic()
    finally:  # also when interrupted (Ctrl-C): the summary of what was done, frames finished meanwhile too
        records |= {k: r for p, k in plan.frames
                    if k not in records and (r := _complete_record(p, k, plan.settings)) is not None}
        final = plan.ordered(records)
        write_summary(final, plan.settings, len(plan.frames))
        if metashape:
            write_metashape(final, plan.settings, plan.camera)
    return final


__all__ = ["SUMMARY_REFRESH_S", "BatchPlan", "plan_batch", "run_batch", "start_batch"]
