"""Before and after a change, on a shared noisy machine: two versions of aerofid time the same boxes alternately.

    python benchmarks/bench_paired.py --before OTHER/src [--after src] [--method auto] [--styles cross,dot,...]
                                      [--rounds 2] [--calls 3]

``--before`` and ``--after`` are the ``src`` folders of two checkouts (e.g. ``git worktree add ../before
<commit>``). Each runs in a worker process of its own (``PYTHONPATH`` set to it, one thread); the script sends both
workers the same box in turn, alternating which goes first, so that both see the machine in the same state. A worker
measures ``method`` on the box ``calls`` times, each a first call on the box (``aerofid.kept.forget_kept`` before
it; in a version without it, ``hough``'s kept analyses and fits made anew), and answers the least CPU time
(``time.process_time``) and its centre. Per box the least time over ``rounds`` rounds is kept; per style the table
gives the median time of each version and the median over the boxes of after / before, and whether every centre
agrees within 1e-9 px.

Boxes: bench_peers.py's synthetic 200 x 200 px scenes (seed 2026, 20 per style, the same as its tables) and, where
``../shared/realdata`` holds it, the 8 marks of the real Wild RC20 frame in the boxes of bench_rc20.py (style
``rc20``, the grey window ``locate`` would give them, ``mark="external"``).

Single timings on this project's shared machines vary by +-30 % from run to run, more than most changes move them;
the ratio of two versions timed side by side does not.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
WORKER = r"""
import sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np, cv2
cv2.setNumThreads(1)
from bench_marks import STYLES
from bench_peers import scene
from aerofid.methods import make_detector
try:
    from aerofid.kept import forget_kept
except ImportError:
    try:                        # sessions 37 and 38 (5f08e22 on): hough's two stores made anew
        from aerofid.detect.hough import analysis, detector
        from aerofid.kept import Kept

        def forget_kept():
            analysis._ANALYSES, detector._FITS = Kept(analysis.ANALYSES_KEPT), Kept(detector.FITS_KEPT)
    except (ImportError, AttributeError):   # older: timed as it runs (its repeated calls may reuse what it kept)
        def forget_kept():
            pass
rng = np.random.default_rng(2026)
boxes = {}
for s in STYLES:
    boxes[s] = []
    for _ in range(20):
        img, _, _, mark, _ = scene(s, rng)
        boxes[s].append((img, mark))
from bench_rc20 import HALF, MARKS, REAL
if REAL.exists():
    from aerofid.io.colour import to_grey
    from aerofid.io.raster import open_raster
    with open_raster(REAL) as r:
        boxes["rc20"] = [(to_grey(np.ascontiguousarray(r.read_window((x - HALF, y - HALF, x + HALF, y + HALF))),
                                  "auto", "bright"), "external") for x, y in MARKS.values()]
print(" ".join(f"{s}:{len(b)}" for s, b in boxes.items()), flush=True)
for line in sys.stdin:
    style, i, method, calls = line.split()
    img, mark = boxes[style][int(i)]
    det = make_detector(method, mark, {})
    best, d = float("inf"), None
    for _ in range(int(calls)):
        forget_kept()
        t = time.process_time()
        d = det(img)
        best = min(best, time.process_time() - t)
    print(best, d.x if d.found else "nan", d.y if d.found else "nan", flush=True)
"""


class Worker:
    """One version of aerofid in a process of its own, answering (least CPU time, x, y) for a box."""

    def __init__(self, src: Path):
        env = dict(os.environ, PYTHONPATH=str(src), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
        self.proc = subprocess.Popen([sys.executable, "-c", WORKER, str(HERE)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, env=env, cwd=HERE)
        assert self.proc.stdout is not None
        self.counts = {s: int(n) for s, n in (w.split(":") for w in self.proc.stdout.readline().split())}

    def __call__(self, style: str, i: int, method: str, calls: int) -> tuple[float, float, float]:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(f"{style} {i} {method} {calls}\n")
        self.proc.stdin.flush()
        t, x, y = self.proc.stdout.readline().split()
        return float(t), float(x), float(y)

    def close(self) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        self.proc.wait()


def paired(before: Worker, after: Worker, style: str, method: str, rounds: int, calls: int) -> str:
    """The table row of one style."""
    n = before.counts[style]
    t = np.full((2, rounds, n), np.inf)
    xy = np.zeros((2, n, 2))
    for r in range(rounds):
        for i in range(n):
            for k in ((0, 1) if (i + r) % 2 == 0 else (1, 0)):
                t[k, r, i], xy[k, i, 0], xy[k, i, 1] = (before, after)[k](style, i, method, calls)
    least = t.min(axis=1)
    same = np.array_equal(np.isnan(xy[0]), np.isnan(xy[1])) and bool(
        np.all(np.nan_to_num(np.abs(xy[0] - xy[1])) <= 1e-9))
    return (f"| {style} | {1e3 * np.median(least[0]):.1f} | {1e3 * np.median(least[1]):.1f} | "
            f"{np.median(least[1] / least[0]):.2f} | {'yes' if same else 'NO'} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", type=Path, required=True, help="the src folder of the version before")
    ap.add_argument("--after", type=Path, default=HERE.parent / "src", help="the src folder of the version after")
    ap.add_argument("--method", default="auto")
    ap.add_argument("--styles", default=None, help="comma-separated (default: every style, and rc20 if present)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--calls", type=int, default=3)
    a = ap.parse_args()
    for src in (a.before, a.after):
        if not (src / "aerofid" / "__init__.py").is_file():
            ap.error(f"{src} holds no aerofid package: give the src folder of a checkout")
    before, after = Worker(a.before), Worker(a.after)
    styles = a.styles.split(",") if a.styles else list(before.counts)
    print(f"`{a.method}`, least CPU time of {a.calls} calls per box over {a.rounds} rounds, the two versions "
          f"alternating:\n")
    print("| boxes | before (median ms) | after (median ms) | median after / before | same centres |")
    print("|---|---|---|---|---|")
    try:
        for style in styles:
            print(paired(before, after, style, a.method, a.rounds, a.calls), flush=True)
    finally:
        before.close()
        after.close()


if __name__ == "__main__":
    main()
