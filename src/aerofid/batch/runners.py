"""Where a batch's frames run: in this process, in local processes, or on a Dask distributed cluster.

Each runner takes the frames to do (scan path, frame key) and yields their
:class:`~aerofid.batch.job.FrameRecord` as they complete. The work is always
:func:`~aerofid.batch.job.run_frame_job`; a worker reads its frame and writes that frame's outputs itself, and
only the small record comes back. A worker that dies (a local process killed, a lost Dask worker) does not stop
the batch: the local runner does its frames again (:func:`process_runner`), Dask does so itself (its
``allowed-failures``); a frame that still has no record is an ``error``.

Dask is an optional extra (``pip install 'aerofid[cluster]'``), imported only when a scheduler is given.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable, Generator, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

from aerofid.batch.job import ERROR, FrameRecord, run_frame_job
from aerofid.batch.plan import BatchSettings
from aerofid.errors import AerofidInputError

Task = tuple[str, str]
"""One frame to do: its scan's absolute path and its key (the name of its outputs)."""
Runner = Callable[[Sequence[Task], BatchSettings], Iterator[FrameRecord]]
"""A runner: the frames and the settings in, the records out as the frames complete."""

START_METHOD = "spawn"
"""How local worker processes start: a fresh interpreter (as on macOS and Windows), never a fork of a process
that may hold threads (Dask's, a progress bar's)."""
CONNECT_TIMEOUT_S = 20
"""How long to wait for a Dask scheduler to answer."""
CLUSTER_START_S = 60
"""How long a local cluster's scheduler (:func:`local_cluster`) may take to write its address."""
CLUSTER_STOP_S = 10
"""How long a local cluster's process may take to end once asked before it is killed."""
CLUSTER_EXTRA = "pip install 'aerofid[cluster]'"
"""The command that installs what ``--scheduler`` needs."""
WORKER_ENVIRONMENT = {"DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED": "False"}
"""What :func:`local_cluster`'s workers run with: Dask's statistical profiler (a thread that samples the worker's
stack every 10 ms, for the dashboard) off: on frame jobs it costs a few percent of a worker's CPU."""


def run_sequential(tasks: Sequence[Task], settings: BatchSettings) -> Iterator[FrameRecord]:
    """The frames one after another in this process."""
    for path, frame in tasks:
        yield run_frame_job(path, frame, settings)


def _said(e: BaseException) -> str:
    """An exception in one line: ``Type: message``."""
    return f"{type(e).__name__}: {' '.join(str(e).split()) or 'no message'}"


def _lost(path: str, frame: str, e: BaseException, why: str = "run the batch again") -> FrameRecord:
    """The record of a frame whose worker did not return (killed, out of memory, lost by the cluster)."""
    return FrameRecord(frame, path, ERROR, error=f"its worker was lost ({_said(e)}); {why}")


LOST_ALONE = ("it was lost again running alone: the frame itself ends its worker (out of memory?); try it with "
              "'aerofid orient'")
"""What the record of a frame says whose worker died twice, the second time with no other frame running."""

Job = Callable[[str, str, BatchSettings], FrameRecord]
"""The work of one frame (:func:`~aerofid.batch.job.run_frame_job`; a test may give another)."""


def _until_broken(queue: deque[Task], settings: BatchSettings, workers: int, job: Job
                  ) -> Generator[FrameRecord, None, tuple[list[Task], BaseException | None]]:
    """Run the frames of ``queue`` (taken from it) on a fresh pool of ``workers`` processes, ``workers`` frames at
    a time, and yield their records; when a worker dies, the pool is broken: return the frames then in flight
    (any of them may be the one that ended the worker) and the error; ``([], None)`` when the queue is done."""
    ex = ProcessPoolExecutor(max_workers=min(workers, len(queue)),
                             mp_context=multiprocessing.get_context(START_METHOD))
    running: dict[Future[FrameRecord], Task] = {}
    try:
        while queue or running:
            broken = _submit(ex, queue, running, workers, job, settings)
            done: set[Future[FrameRecord]] = set()
            if broken is None:
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                broken = next((e for f in done if isinstance(e := f.exception(), BrokenExecutor)), None)
            if broken is not None:
                wait(running)  # a broken pool ends every future it holds: the finished ones keep their records
                yield from (f.result() for f in running if f.exception() is None)
                return [t for f, t in running.items() if f.exception() is not None], broken
            for f in done:
                task = running.pop(f)
                try:
                    yield f.result()
                except Exception as e:  # the job's record could not come back (pickling)
                    yield FrameRecord(task[1], task[0], ERROR,
                                      error=f"its record did not come back from its worker ({_said(e)})")
        return [], None
    finally:
        ex.shutdown(wait=True, cancel_futures=True)


def _submit(ex: ProcessPoolExecutor, queue: deque[Task], running: dict[Future[FrameRecord], Task], workers: int,
            job: Job, settings: BatchSettings) -> BrokenExecutor | None:
    """Submit frames of ``queue`` to ``ex`` until ``workers`` run; the error when the pool is found broken (a
    worker died since the last look; the frame not submitted stays first in the queue)."""
    while queue and len(running) < workers:
        try:
            future = ex.submit(job, *queue[0], settings)
        except BrokenExecutor as e:
            return e
        running[future] = queue.popleft()
    return None


def process_runner(workers: int, job: Job = run_frame_job) -> Runner:
    """A runner on ``workers`` local processes (``concurrent.futures.ProcessPoolExecutor``), each given one frame
    at a time. A worker that dies breaks the pool: the frames then in flight are done again one after another,
    each alone on a fresh pool of one process, and then the rest go on on a fresh pool of ``workers``; a frame
    whose worker dies again alone is an ``error`` (:data:`LOST_ALONE`) - the others caught in its break are
    not."""

    def run(tasks: Sequence[Task], settings: BatchSettings) -> Iterator[FrameRecord]:
        queue = deque(tasks)
        while queue:
            suspects, _ = yield from _until_broken(queue, settings, workers, job)
            for task in suspects:
                _, broken = yield from _until_broken(deque([task]), settings, 1, job)
                if broken is not None:
                    yield _lost(*task, broken, LOST_ALONE)

    return run


def _dask() -> tuple[Any, Any]:
    """``distributed.Client`` and ``distributed.as_completed``, or the error that says how to install them."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise AerofidInputError(f"--scheduler needs Dask's distributed, which is not installed: {CLUSTER_EXTRA}"
                                ) from None
    return Client, as_completed


@contextlib.contextmanager
def dask_runner(address: str) -> Iterator[Runner]:
    """A runner on the Dask distributed cluster whose scheduler is at ``address`` (``tcp://HOST:PORT``): each
    frame is one ``client.submit`` of the job, the records come back by ``as_completed``.

    Raises
    ------
    AerofidInputError
        Dask is not installed, or the scheduler does not answer (before any frame is done).
    """
    client_class, dask_completed = _dask()
    try:
        client = client_class(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError, TypeError) as e:
        raise AerofidInputError(f"cannot reach the Dask scheduler at {address!r} ({' '.join(str(e).split())}); "
                                "check the address (tcp://HOST:PORT) and that the scheduler runs") from None

    def run(tasks: Sequence[Task], settings: BatchSettings) -> Iterator[FrameRecord]:
        futures = {client.submit(run_frame_job, p, k, settings, pure=False): (p, k) for p, k in tasks}
        try:
            for f in dask_completed(list(futures), loop=client.loop):
                try:
                    yield f.result()
                except Exception as e:  # KilledWorker, a lost connection
                    yield _lost(*futures[f], e)
        finally:
            client.cancel(list(futures))

    try:
        yield run
    finally:
        client.close()


@contextlib.contextmanager
def local_cluster(folder: str | Path, workers: int = 2) -> Iterator[str]:
    """A Dask cluster on this machine for tests, benchmarks and trying ``--scheduler``: a ``dask scheduler`` and
    ``workers`` single-threaded ``dask worker`` processes on 127.0.0.1 (with :data:`WORKER_ENVIRONMENT`; their
    log and the scheduler file in ``folder``); its address once the scheduler has written it (workers join when
    they are up: submitted frames wait for them); every process ended on leaving."""
    dask = [sys.executable, "-m", "dask"]
    sched = Path(folder) / "scheduler.json"
    with open(Path(folder) / "dask.log", "w") as log:
        procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                   "--scheduler-file", str(sched)], stdout=log, stderr=log)]
        try:
            deadline = time.monotonic() + CLUSTER_START_S
            while not sched.exists() and time.monotonic() < deadline and procs[0].poll() is None:
                time.sleep(0.1)
            address = json.loads(sched.read_text())["address"]
            procs += [subprocess.Popen([*dask, "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                        "--host", "127.0.0.1"], stdout=log, stderr=log,
                                       env={**os.environ, **WORKER_ENVIRONMENT}) for _ in range(workers)]
            yield address
        finally:  # the workers first (they tell the scheduler they leave), then the scheduler
            for group in (procs[1:], procs[:1]):
                for p in group:
                    p.terminate()
                for p in group:
                    try:
                        p.wait(timeout=CLUSTER_STOP_S)
                    except subprocess.TimeoutExpired:
                        p.kill()
                        p.wait()


@contextlib.contextmanager
def open_runner(workers: int = 1, scheduler: str | None = None) -> Iterator[Runner]:
    """The runner for the options: a Dask cluster (``scheduler``), local processes (``workers`` > 1), or this
    process; a Dask client is connected on entering (errors before any work) and closed on leaving."""
    if scheduler is not None:
        with dask_runner(scheduler) as run:
            yield run
    else:
        yield run_sequential if workers <= 1 else process_runner(workers)


__all__ = ["CLUSTER_EXTRA", "LOST_ALONE", "Job", "Runner", "Task", "dask_runner", "local_cluster", "open_runner",
           "process_runner", "run_sequential", "WORKER_ENVIRONMENT"]
