"""`aerofid batch INPUTS... --camera CAMERA -o OUTDIR`: a roll or an archive of whole frames (issue 13).

Every frame is oriented from the camera file alone (:func:`aerofid.orient_frame`) in this process, in local
processes (``--workers N``) or on a Dask cluster (``--scheduler tcp://HOST:PORT``); each frame's outputs and
the summary go to OUTDIR (:mod:`aerofid.batch`). A rerun skips the frames that are complete.

Exit status: 0 when every frame is ok; 1 when any is doubtful, failed or could not be read (every frame is still
done and reported); 2 on bad input (no scans, a bad camera file, OUTDIR not creatable...), before any work.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TextIO

import click

from aerofid.batch.driver import BatchPlan, plan_batch, run_batch
from aerofid.batch.job import STATUS_ORDER, FrameRecord
from aerofid.batch.plan import MODELS
from aerofid.batch.runners import open_runner
from aerofid.cli.frame_cmd import parse_lie
from aerofid.cli.output import EXIT_FOUND, EXIT_NOT_FOUND
from aerofid.errors import AerofidInputError
from aerofid.resample.warp import DEFAULT_KERNEL, KERNELS


@click.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option("--camera", "camera_path", required=True, metavar="CAMERA",
              help="camera file: JSON/YAML certificate or MicMac MeasuresCamera.xml")
@click.option("-o", "--output", "outdir", required=True, metavar="OUTDIR",
              help="folder of the outputs (created): per frame <scan>.json, <scan>.html, crops/<scan>.png, "
                   "Ori-InterneScan/MeasuresIm-<scan>.xml; summary.csv, summary.json, summary.html "
                   "(and metashape_fiducials.py with --metashape)")
@click.option("--workers", type=click.IntRange(min=1), metavar="N",
              help="local processes (default 1: this process)")
@click.option("--scheduler", metavar="tcp://HOST:PORT",
              help="run on this Dask distributed cluster (pip install 'aerofid[cluster]'); every worker must see "
                   "the scans, the camera file and OUTDIR at the same paths")
@click.option("--pixel-size", type=float, metavar="MM",
              help="the scans' pixel size in mm (default: each file's resolution tags, the camera file)")
@click.option("--lie", metavar="ROT[m]",
              help="the film's lie when the fiducials cannot tell it: 0, 90, 180 or 270 degrees, 'm' if mirrored")
@click.option("--model", type=click.Choice(MODELS), default="affine", show_default=True,
              help="pixel -> mm transformation")
@click.option("--profile", "profile_path", metavar="ROLL",
              help="the roll's profile (aerofid learn): its pixel size, lie, polarity, method and mark size are "
                   "used; frames that disagree with it are doubtful ('review: ...')")
@click.option("--resample", "resample_mm", type=float, metavar="MM",
              help="also resample each frame oriented ok into its camera's film mm at this pixel size "
                   "(resampled/OIS-Reech_<scan>.tif, as MicMac ReSampFid; docs/resample.md)")
@click.option("--kernel", type=click.Choice(KERNELS), default=DEFAULT_KERNEL, show_default=True,
              help="the resampling's interpolation")
@click.option("--metashape", is_flag=True,
              help="also write OUTDIR/metashape_fiducials.py: a script for Agisoft Metashape Pro that places the "
                   "fiducials of every frame oriented ok on its scan in the open project (docs/exports.md)")
def batch(inputs, camera_path, outdir, workers, scheduler, pixel_size, lie, model, profile_path, resample_mm,
          kernel, metashape) -> int:
    """Orient every frame of a roll or an archive: INPUTS are scan files, folders or globs ('roll1/*.tif')."""
    if workers is not None and scheduler is not None:
        raise AerofidInputError("give --workers (local processes) or --scheduler (a Dask cluster), not both")
    plan = plan_batch(inputs, camera_path, outdir, model=model, pixel_size_mm=pixel_size, lie=parse_lie(lie),
                      profile_path=profile_path, resample_mm=resample_mm, kernel=kernel)
    with open_runner(workers or 1, scheduler) as runner:
        if plan.done:
            click.echo(f"note: {len(plan.done)} of {len(plan.frames)} frames are complete in {outdir!r}: "
                       f"skipped; {len(plan.todo)} to do", err=True)
        with _progress(plan) as on_record:
            records = run_batch(plan, runner, on_record, metashape=metashape)
    return _report(records, Path(outdir))


def _line(i: int, n: int, rec: FrameRecord) -> str:
    """The log line of a frame: ``frame 3/40 x.tif: ok, rms 0.031 px``."""
    text = f"frame {i}/{n} {rec.frame}: {rec.status}"
    if rec.rms_px is not None:
        text += f", rms {rec.rms_px:.3f} px"
    why = rec.error or "; ".join(rec.reasons)
    return text + (f" ({why})" if why else "")


class _Counts:
    """Frames done, not ok, and the rate, for the progress bar and the log lines."""

    def __init__(self, plan: BatchPlan):
        self.total, self.before, self.done, self.bad = len(plan.frames), len(plan.done), 0, 0
        self.t0 = time.monotonic()

    def add(self, rec: FrameRecord) -> None:
        self.done += 1
        self.bad += not rec.ok

    def text(self, rec: Any) -> str:
        rate = self.done / max(time.monotonic() - self.t0, 1e-9)
        last = "" if rec is None else f" | {rec.frame}: {rec.status}"
        return f"not ok {self.bad} | {rate:.2f} frames/s{last}"


@contextmanager
def _progress(plan: BatchPlan, stream: TextIO | None = None) -> Iterator[Any]:
    """The callback of each record: a progress bar on a terminal (frames done, not ok, rate, time left), else one
    log line per frame (stderr)."""
    err = stream or sys.stderr
    counts = _Counts(plan)
    if not err.isatty() or not plan.todo:
        def log(rec: FrameRecord) -> None:
            counts.add(rec)
            click.echo(_line(counts.before + counts.done, counts.total, rec), file=err)

        yield log
        return
    with click.progressbar(length=len(plan.todo), label="frames", file=err, show_eta=True, show_pos=True,
                           item_show_func=counts.text) as bar:
        def tick(rec: FrameRecord) -> None:
            counts.add(rec)
            bar.update(1, rec)

        yield tick


def _report(records: list[FrameRecord], outdir: Path) -> int:
    """The frames that are not ok (stderr), the counts (stdout), and the exit status."""
    for rec in records:
        if not rec.ok:
            click.echo(f"note: {rec.frame}: {rec.status}: {rec.error or '; '.join(rec.reasons)}", err=True)
    counts = ", ".join(f"{sum(r.status == s for r in records)} {s}" for s in reversed(STATUS_ORDER))
    click.echo(f"{len(records)} frames: {counts}; summary: {outdir / 'summary.html'}")
    return EXIT_FOUND if all(r.ok for r in records) else EXIT_NOT_FOUND
