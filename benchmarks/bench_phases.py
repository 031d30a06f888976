"""Where ``auto``'s time goes on a box: its steps and the seed methods they run, per mark style.

    python benchmarks/bench_phases.py [--n 8] [--styles cross,panel,...] [--calls 2]

bench_peers.py's synthetic 200 x 200 px boxes (seed 2026, ``n`` per style, each with the mark it names) go through
``auto`` (:func:`aerofid.detect.auto.detect`) once to warm up, then ``calls`` times; per style the table gives the
median time of a box and, per box on average, the time spent in each of ``auto``'s steps (the module docstring of
:mod:`aerofid.detect.auto`) and in each seed method wherever it runs. The steps nest (the twin check of a cloth panel
is part of the uniqueness pass, which is part of the conclusion), so the columns do not add up to the total. One
thread; wall time (``time.perf_counter``): compare styles and steps of one run, not runs of different sittings.
"""

from __future__ import annotations

import argparse
import importlib
import os
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from aerofid.detect import auto, registry  # noqa: E402
from aerofid.detect.auto import AutoParams  # noqa: E402
from bench_marks import STYLES  # noqa: E402
from bench_peers import scene  # noqa: E402

STEPS = ("run_candidates", "cross_check", "lone_answer_refused", "compact_dot", "conclude", "uniqueness",
         "second_marks", "panel_twins", "structure_left")
"""``auto``'s functions timed: step 1 (the whole-window methods), step 2 (the cross-check of a lone answer, the
checks of an answer left alone), step 4 (a compact dot), step 3 (the conclusion, its uniqueness pass and the parts of
that: second answers, a panel's twins, structure left)."""


def _timed(spent: Counter, name: str, f: Callable[..., Any]) -> Callable[..., Any]:
    def call(*args: Any, **kwargs: Any) -> Any:
        t = time.perf_counter()
        try:
            return f(*args, **kwargs)
        finally:
            spent[name] += time.perf_counter() - t
    return call


def install(spent: Counter) -> None:
    """Time every step of :data:`STEPS` and every seed method into ``spent`` (seconds by name)."""
    for name in STEPS:
        setattr(auto, name, _timed(spent, name, getattr(auto, name)))
    for name, method in registry.METHODS.items():
        module = importlib.import_module(method.module)
        module.detect = _timed(spent, name, module.detect)


def bench_style(style: str, n: int, calls: int, spent: Counter) -> tuple[float, dict[str, float]]:
    """(median seconds per box, seconds per box by step or method) of ``auto`` on ``n`` boxes of ``style``."""
    rng = np.random.default_rng(2026)
    boxes = [scene(style, rng) for _ in range(n)]
    for img, _, _, mark, _ in boxes:
        auto.detect(img, AutoParams(mark=mark))
    spent.clear()
    times = []
    for img, _, _, mark, _ in boxes:
        for _ in range(calls):
            t = time.perf_counter()
            auto.detect(img, AutoParams(mark=mark))
            times.append(time.perf_counter() - t)
    return float(np.median(times)), {k: v / (n * calls) for k, v in spent.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=8, help="boxes per style")
    ap.add_argument("--calls", type=int, default=2, help="timed calls per box")
    ap.add_argument("--styles", default=",".join(STYLES), help="comma-separated mark styles")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    spent: Counter = Counter()
    install(spent)
    columns = (*STEPS, *registry.SEED_METHODS)
    print(f"`python benchmarks/bench_phases.py --n {args.n} --calls {args.calls} --styles {args.styles}`, "
          "ms per box (median of the calls; the steps and methods: mean per box):\n")
    print("| style | total | " + " | ".join(columns) + " |")
    print("|---" * (len(columns) + 2) + "|")
    for style in args.styles.split(","):
        total, by = bench_style(style, args.n, args.calls, spent)
        print(f"| {style} | {1000 * total:.1f} | " + " | ".join(f"{1000 * by.get(c, 0.0):.1f}" for c in columns) + " |")


if __name__ == "__main__":
    main()
