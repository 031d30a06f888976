"""Batches: frames per second of ``aerofid batch`` in one process, on 1 and 2 local worker processes and on a local
Dask cluster of 2 single-threaded workers, and the scaling efficiency per added worker.

    python benchmarks/bench_batch.py [--frames 8] [--size 2500] [--repeats 3] [--cache DIR]
                                     [--out docs/benchmarks_batch.md]

``--frames`` synthetic frames (:mod:`aerofid.synth_frame`, the Wild RC10-like test camera, each with its own
seed and lie; tiled TIFFs with the pixel size as resolution tags) of ``--size`` px square are written once to
the cache folder (never the repository). Each configuration runs the whole batch into a fresh output folder
(:func:`aerofid.batch.driver.run_batch`: every frame oriented, its outputs and the summary written), timed
from the call to the last summary, pool start-up and the workers' imports included; the Dask cluster
(``dask scheduler`` and two ``dask worker --nthreads 1 --no-nanny`` on 127.0.0.1) is started once before the
timing and waits for its workers, as an existing cluster would. Configurations are interleaved per repeat so
that a change of the machine's load hits them alike; the table gives the median over the repeats and the load
average (``os.getloadavg``) seen around the runs.

Scaling efficiency of n workers: frames/s on n divided by n times frames/s on 1 worker process. The CPU time
of each run (this process and its pool's workers, or the Dask workers' own) per frame says whether a worker
adds work (it should not), and CPU seconds per second of the run how many cores the batch obtained: on a
machine busy with other work, 2 workers cannot scale if they do not get 2 cores. Before each repeat a machine
control runs two pure CPU loops on 1 and on 2 worker processes: its efficiency is the most the machine allowed
then. The Dask run's
records (status, reasons, marks and residuals, RMS) are compared with the one-process run's.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import platform
import resource
import shutil
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")     # one thread per worker: the workers are the parallelism
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import aerofid  # noqa: E402
from aerofid.batch.driver import plan_batch, run_batch  # noqa: E402
from aerofid.batch.job import FrameRecord  # noqa: E402
from aerofid.batch.runners import (  # noqa: E402
    START_METHOD,
    Runner,
    dask_runner,
    local_cluster,
    process_runner,
    run_sequential,
)
from aerofid.formats.camera_file import write_camera  # noqa: E402
from aerofid.synth_frame import FILM_HALF_MM, MARGIN_MM, frame_spec, wild_rc10_camera, write_frame  # noqa: E402

CONTROL = "machine control"
"""Key of the machine control's efficiencies (:func:`machine_control`) among the times."""
LIES = [(r, m) for r in (0, 90, 180, 270) for m in (False, True)]
"""The frames' lies, in turn."""
DASK_WORKERS = 2
"""Workers of the local Dask cluster."""
CONTROL_STEPS = 30_000_000
"""Steps of each machine-control loop (about 3 s of one core)."""
START_TIMEOUT_S = 120
"""How long the local Dask cluster may take to start."""


def make_frames(n: int, size: int, cache: Path) -> tuple[Path, Path]:
    """``n`` frames of ``size`` px (written once) and the camera file, in ``cache``; (folder, camera file)."""
    folder = cache / f"frames-{size}"
    folder.mkdir(parents=True, exist_ok=True)
    cam = wild_rc10_camera()
    pixel_mm = 2 * (FILM_HALF_MM + MARGIN_MM) / size
    for i in range(n):
        path = folder / f"frame{i:03d}.tif"
        if not path.exists():
            rot, mir = LIES[i % len(LIES)]
            write_frame(frame_spec(cam, pixel_mm, np.random.default_rng(100 + i), rotation_deg=rot, mirrored=mir),
                        path, "tiled")
    camera = cache / "camera.json"
    write_camera(camera, cam)
    return folder, camera


@contextmanager
def ready_cluster(workdir: Path) -> Iterator[tuple[str, Any]]:
    """A local Dask cluster (:func:`aerofid.batch.runners.local_cluster`) once all its workers have joined: its
    address and a client of our own (to read the workers' CPU time)."""
    from distributed import Client

    with local_cluster(workdir, DASK_WORKERS) as address, Client(address, timeout=START_TIMEOUT_S) as client:
        client.wait_for_workers(DASK_WORKERS, timeout=START_TIMEOUT_S)
        yield address, client


def cpu_seconds() -> float:
    """CPU time of this process and of its children that have ended (a pool's workers, once it is shut down)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def timed_batch(folder: Path, camera: Path, runner: Runner, work: Path, cpu: Callable[[], float]
                ) -> tuple[float, float, list[FrameRecord]]:
    """One whole batch of ``folder`` into a fresh output folder: (seconds, CPU seconds by ``cpu``, records)."""
    out = work / "out"
    shutil.rmtree(out, ignore_errors=True)
    plan = plan_batch([str(folder)], camera, out)
    c0, t0 = cpu(), time.perf_counter()
    records = run_batch(plan, runner)
    return time.perf_counter() - t0, cpu() - c0, records


def spin(n: int) -> float:
    """A pure CPU loop of ``n`` steps; its CPU seconds (the machine control)."""
    t, x = time.process_time(), 0
    for i in range(n):
        x += i * i
    return time.process_time() - t


def machine_control(steps: int = CONTROL_STEPS) -> float:
    """Efficiency per worker that the machine allows now: two pure CPU loops on 2 worker processes against the
    same two loops on 1 (the same pool kind as the batch's), wall time."""
    walls = []
    for w in (1, 2):
        with ProcessPoolExecutor(w, mp_context=multiprocessing.get_context(START_METHOD)) as ex:
            list(ex.map(spin, [10] * w))                 # started and imported
            t0 = time.perf_counter()
            list(ex.map(spin, [steps] * 2))
            walls.append(time.perf_counter() - t0)
    return walls[0] / (2 * walls[1])


def comparable(records: list[FrameRecord]) -> list[dict]:
    """Records without their times."""
    return [{k: v for k, v in r.to_dict().items() if k != "seconds"} for r in records]


def run(args: argparse.Namespace) -> tuple[dict[str, list[float]], dict[str, list[float]], dict[str, list[dict]],
                                           list[tuple[float, ...]]]:
    folder, camera = make_frames(args.frames, args.size, Path(args.cache))
    times: dict[str, list[float]] = {}
    cpus: dict[str, list[float]] = {}
    records: dict[str, list[dict]] = {}
    loads = [os.getloadavg()]
    with tempfile.TemporaryDirectory() as tmp, ready_cluster(Path(tmp)) as (address, client), \
            dask_runner(address) as on_dask:
        def dask_cpu() -> float:  # the workers' own CPU time
            return cpu_seconds() + sum(client.run(cpu_seconds).values())

        configs: dict[str, tuple[Callable[[], Runner], Callable[[], float]]] = {
            "one process (no pool)": (lambda: run_sequential, cpu_seconds),
            "1 local worker process": (lambda: process_runner(1), cpu_seconds),
            "2 local worker processes": (lambda: process_runner(2), cpu_seconds),
            f"Dask, {DASK_WORKERS} workers x 1 thread": (lambda: on_dask, dask_cpu),
        }
        for rep in range(args.repeats):
            control = machine_control()
            times.setdefault(CONTROL, []).append(control)
            print(f"repeat {rep + 1} machine control: 2 CPU loops on 2 processes {control:.0%} efficient", flush=True)
            for name, (make, cpu) in configs.items():
                seconds, used, recs = timed_batch(folder, camera, make(), Path(tmp), cpu)
                times.setdefault(name, []).append(seconds)
                cpus.setdefault(name, []).append(used)
                records.setdefault(name, comparable(recs))
                loads.append(os.getloadavg())
                print(f"repeat {rep + 1} {name}: {seconds:.1f} s, CPU {used:.1f} s, {len(recs)} frames, "
                      f"{sum(r.ok for r in recs)} ok; load {loads[-1][0]:.2f}", flush=True)
    return times, cpus, records, loads


def source_version() -> str:
    """The commit of the aerofid that ran (its checkout's HEAD, ``+changes`` when its tree is not clean)."""
    src = Path(aerofid.__file__).resolve().parents[2]
    git = ["git", "-C", str(src)]
    try:
        head = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run([*git, "status", "--porcelain", "src"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "(not a git checkout)"
    return f"{head}{'+changes' if dirty else ''}"


def table(args: argparse.Namespace, times: dict[str, list[float]], cpus: dict[str, list[float]],
          records: dict[str, list[dict]], loads: list[tuple[float, ...]]) -> str:
    control = times[CONTROL]
    times = {k: v for k, v in times.items() if k != CONTROL}
    n = args.frames
    fps = {k: n / statistics.median(v) for k, v in times.items()}
    one = fps["1 local worker process"]
    workers = {"one process (no pool)": 1, "1 local worker process": 1, "2 local worker processes": 2}
    base = next(iter(records.values()))
    lines = [f"| configuration | median s ({args.repeats} runs) | frames/s | efficiency per worker | CPU s per frame | "
             "CPU cores obtained | same results as one process |", "|---|---|---|---|---|---|---|"]
    for k, v in times.items():
        w = workers.get(k, DASK_WORKERS)
        differ = [a["frame"] for a, b in zip(records[k], base, strict=True) if a != b]
        same = "yes" if not differ else f"NO: {', '.join(differ)}"
        cpu = statistics.median(cpus[k])
        lines.append(f"| {k} | {statistics.median(v):.1f} (runs {', '.join(f'{s:.1f}' for s in v)}) | "
                     f"{fps[k]:.3f} | {fps[k] / (w * one):.0%} | {cpu / n:.2f} | "
                     f"{statistics.median(c / t for c, t in zip(cpus[k], v, strict=True)):.2f} | {same} |")
    la = np.array(loads)
    lines += ["", f"{n} frames of {args.size} x {args.size} px; load average (1 min) during the runs "
              f"{la[:, 0].min():.2f}-{la[:, 0].max():.2f}; {os.cpu_count()} cores, {platform.python_version()}; "
              f"aerofid {source_version()}.",
              "", f"Machine control (two pure CPU loops on 2 worker processes against 1, before each repeat): "
              f"{', '.join(f'{c:.0%}' for c in control)} efficient: the most a batch could reach then."]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--size", type=int, default=2500, help="frame side in px")
    ap.add_argument("--repeats", type=int, default=3, help="runs per configuration (median time)")
    ap.add_argument("--cache", default=str(Path.home() / ".cache" / "aerofid-bench" / "batch"))
    ap.add_argument("--out", default=None, help="write the table to this Markdown file too")
    args = ap.parse_args()
    times, cpus, records, loads = run(args)
    text = table(args, times, cpus, records, loads)
    print(text)
    if args.out:
        Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
