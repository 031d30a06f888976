"""The long fuzz run of the command line (issue 11): random hostile commands over corrupt and lying files, special
files and careless output paths (tests/fuzz_cli.py), each in a forked child under an address-space limit and a
time limit, counting tracebacks, hangs, undocumented exit statuses, noise on stderr, files changed outside the
requested outputs and outputs written by failed commands.

Usage::

    python benchmarks/fuzz.py --n 10000 [--seed 0] [--workers 2] [--show 10]

Prints the counts as a Markdown table (docs/errors.md quotes it) and the first failing cases; exits 1 when any
case failed.
"""

from __future__ import annotations

import argparse
import collections
import multiprocessing
import os
import random
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzz_cli import (  # noqa: E402
    judge,
    make_workspace,
    pristine_copy,
    random_case,
    restore,
    run_case,
    snapshot,
    warm_up,
)


def _worker(args: tuple[int, int, int]) -> dict:
    """Cases ``start::step`` of ``n`` in a workspace of its own; the counts and the first failures."""
    start, step, n = args
    counts: collections.Counter = collections.Counter()
    failures: list[str] = []
    statuses: collections.Counter = collections.Counter()
    max_rss = 0
    seconds = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "ws"
        root.mkdir()
        ws = make_workspace(root, seed=0)
        pristine = pristine_copy(ws, Path(tmp) / "pristine")
        scratch = Path(tmp) / "scratch"
        scratch.mkdir()
        warm_up(ws, scratch)
        for i in range(start, n, step):
            case = random_case(random.Random(i), ws, i)
            before = snapshot(root)
            outcome = run_case(case, ws, scratch)
            after = snapshot(root)
            verdict = judge(case, outcome, before, after)
            restore(ws, before, after, pristine)
            counts["cases"] += 1
            statuses[str(outcome.status)] += 1
            max_rss = max(max_rss, outcome.max_rss_kb)
            seconds.append(outcome.seconds)
            for name in ("traceback", "hang", "undocumented_status"):
                counts[name] += bool(getattr(verdict, name))
            counts["noise"] += bool(verdict.noise)
            counts["changed"] += bool(verdict.changed)
            counts["written_on_failure"] += bool(verdict.written_on_failure)
            if not verdict.ok and len(failures) < 20:
                failures.append(f"case {i}: {' '.join(map(repr, case.args))} stdout={case.stdout} -> "
                                f"{outcome.status}; {verdict}; stderr: {outcome.stderr.strip()[-300:]!r}")
    return {"counts": counts, "statuses": statuses, "failures": failures, "max_rss": max_rss, "seconds": seconds}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=10000, help="number of cases")
    parser.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument("--show", type=int, default=10, help="failing cases to print")
    opts = parser.parse_args()
    start = time.monotonic()
    jobs = [(w, opts.workers, opts.n) for w in range(opts.workers)]
    with multiprocessing.get_context("fork").Pool(opts.workers) as pool:
        results = pool.map(_worker, jobs)
    counts: collections.Counter = collections.Counter()
    statuses: collections.Counter = collections.Counter()
    seconds: list[float] = []
    for r in results:
        counts.update(r["counts"])
        statuses.update(r["statuses"])
        seconds += r["seconds"]
    failures = [f for r in results for f in r["failures"]]
    seconds.sort()
    print(f"| cases | tracebacks | hangs | undocumented exit statuses | noise on stderr | files changed outside the "
          f"outputs | outputs written by a failed command |\n|---|---|---|---|---|---|---|\n"
          f"| {counts['cases']} | {counts['traceback']} | {counts['hang']} | {counts['undocumented_status']} | "
          f"{counts['noise']} | {counts['changed']} | {counts['written_on_failure']} |")
    print("\nexit statuses: " + ", ".join(f"{k}: {v}" for k, v in sorted(statuses.items())))
    print(f"peak RSS of a case: {max(r['max_rss'] for r in results) / 1024:.0f} MB; case time median "
          f"{seconds[len(seconds) // 2]:.2f} s, mean {sum(seconds) / len(seconds):.2f} s, max {seconds[-1]:.1f} s; "
          f"wall {time.monotonic() - start:.0f} s "
          f"with {opts.workers} workers")
    for f in failures[: opts.show]:
        print(f)
    bad = sum(counts[k] for k in ("traceback", "hang", "undocumented_status", "noise", "changed",
                                  "written_on_failure"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
