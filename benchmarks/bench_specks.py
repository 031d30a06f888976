"""Every method and ``auto`` with a dust speck on the mark's centre: on the crossing of a '+', on a dot's core.

    python benchmarks/bench_specks.py [--n 30] [--seed 2027] [--out docs/benchmarks_specks.md]

bench_marks.py's scenes (its styles, its moderate condition) with a dark speck of 0.24 x the mark's size across within
0.05 x size of the centre (``bench_marks.SPECKED``). Its ``occluded`` condition puts the speck 0.25-0.45 x size from
the centre, never on the crossing. A '+' whose crossing a speck hides has no stroke where its Hough lines meet (the
crossing gap, ``HoughParams.max_crossing_gap``, docs/hough.md); the cross fit finds it when the speck is small. Per
style and method: found, erroneous (> 1.5 px, > 0.5 px), RMS and maximum error, median time per call.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from bench_marks import SPECKED, bench_condition  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=30, help="marks per style")
    ap.add_argument("--seed", type=int, default=2027)
    ap.add_argument("--out", default="docs/benchmarks_specks.md")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    t0 = time.time()
    body: list[str] = []
    for cond in SPECKED:
        body += bench_condition(cond, args.n, rng, {})
    head = ["# A dust speck on the mark's centre\n",
            f"Produced by `python benchmarks/bench_specks.py --n {args.n} --seed {args.seed}` on "
            f"{platform.machine()} / Python {platform.python_version()}, one thread, in {time.time() - t0:.0f} s. "
            "Every number below comes from that run; the columns are those of docs/benchmarks_marks.md (found, found "
            "but further than 1.5 px or 0.5 px from the truth, RMS and maximum error of the found, median ms per "
            "call).\n"]
    tmp = args.out + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(head + body) + "\n")
    os.replace(tmp, args.out)
    print(f"wrote {args.out} in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
