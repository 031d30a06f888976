"""How many model evaluations the cross fit of ``hough``'s verification needs, accepted against refused.

    python benchmarks/bench_fits.py [--n 8] [--max-evaluations 100] [--seed 7] [--marks 30]

Every candidate ``hough`` verifies (:func:`aerofid.detect.hough.detector.verify_candidate`) is recorded with the
evaluations of each least-squares pass of its cross fit and whether the verification accepted it, over the scenes
where ``hough`` runs: ``n`` scenes per condition and style of bench_marks.py (``hough`` alone and ``auto``), ``n``
of each rejection case there, ``n`` 200 px boxes per style of bench_peers.py (``auto``) and ``aerofid.locate`` on
the 8 real RC20 boxes of bench_rc20.py (skipped when ``../shared/realdata`` is absent). ``--max-evaluations``
sets :data:`aerofid.detect.hough.cross_fit.MAX_EVALUATIONS` for the run, so that the passes a lower limit would
cut short can be seen. The cross fit's own CPU time per verification is summed as well, and each candidate's crossing
gap (:func:`aerofid.detect.hough.detector.crossing_gap`) is recorded: beyond ``AutoParams.cross_check_crossing_gap``,
``auto``'s cross-check refuses a candidate before any fit.

Screens weighed and not adopted (docs/benchmarks_peers.md): for each verification, the half-arms of the thresholded
window it screens (:func:`aerofid.detect.hough.detector.half_arm_steps`) and, in its first least-squares pass, how far
the centre of each iterate (a point where the solver asks for the Jacobian) lay from the pass's start: how many
refused candidates, and how much of their fits' work, a rule on either would have spared, and how many accepted '+'
it would have refused. bench_marks.py's scenes with a speck on the centre are verified too, last (a '+' whose
crossing a speck hides).

``--marks N`` adds ``hough`` alone on bench_marks.py's own scenes (its seed 2026, ``N`` per condition and style,
in its order) and reports the bounded solver's retries (a least-squares pass that ran out of evaluations, then
the trust-region solver from the same start): how many, how many verifications they rescued, and how far the
centre had moved in the pass that ran out.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable, Mapping
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.optimize  # noqa: E402

import aerofid  # noqa: E402
from aerofid import synth, testing  # noqa: E402
from aerofid.detect.auto import AutoParams  # noqa: E402
from aerofid.detect.auto import detect as auto_detect  # noqa: E402
from aerofid.detect.hough import cross_fit  # noqa: E402
from aerofid.detect.hough import detector as hough_detector  # noqa: E402
from aerofid.io.raster import open_raster  # noqa: E402
from aerofid.methods import make_detector  # noqa: E402
from bench_marks import CONDITIONS, SPECKED, STYLES  # noqa: E402
from bench_marks import scene as marks_scene  # noqa: E402
from bench_peers import scene as peers_scene  # noqa: E402
from bench_rc20 import HALF, MARKS, REAL  # noqa: E402

REJECTION_STYLES = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")


class Recorder:
    """Wraps the cross fit's solvers and ``verify_candidate`` to record each verification's passes and outcome."""

    def __init__(self) -> None:
        self.records: list[dict[str, Any]] = []
        self.passes: list[tuple[str, int, float]] = []
        self.source = ""
        self.analysis: Any = None
        self.iterates: list[list[tuple[str, float]]] = []

    def install(self) -> None:
        solve, verify = scipy.optimize.least_squares, hough_detector.verify_candidate
        lm = cross_fit.levenberg_marquardt
        refine = hough_detector.refine_window

        def refine_window(*args: Any, **kwargs: Any) -> Any:
            got = refine(*args, **kwargs)
            self.analysis = got[0]    # the window analysis verify_candidate screens and fits
            return got

        def least_squares(fun: Any, x0: np.ndarray, *args: Any, **kwargs: Any) -> Any:
            sol = solve(fun, x0, *args, **kwargs)
            shift = float(np.hypot(sol.x[0] - x0[0], sol.x[1] - x0[1]))
            self.passes.append((str(kwargs.get("method", "trf")), int(sol.nfev), shift))
            return sol

        def levenberg_marquardt(fun: Any, jac: Any, x0: np.ndarray, max_evaluations: int) -> Any:
            path: list[tuple[str, float]] = []   # each evaluation: residuals or Jacobian, its distance from x0
            self.iterates.append(path)

            def traced(kind: str, f: Any) -> Any:
                def call(p: np.ndarray) -> Any:
                    path.append((kind, float(np.hypot(p[0] - x0[0], p[1] - x0[1]))))
                    return f(p)
                return call

            sol = lm(traced("f", fun), traced("j", jac), x0, max_evaluations)
            self.passes.append(("lm", sol.nfev, float(np.hypot(sol.x[0] - x0[0], sol.x[1] - x0[1]))))
            return sol

        def verify_candidate(*args: Any, **kwargs: Any) -> Any:
            self.passes, self.iterates = [], []
            t = time.process_time()
            out = verify(*args, **kwargs)
            cpu = time.process_time() - t
            gap = hough_detector.crossing_gap(self.analysis, AutoParams().cross_check_crossing_gap)
            self.records.append({"source": self.source, "accepted": not isinstance(out, str),
                                 "passes": list(self.passes), "cpu": cpu, "gap": gap,
                                 "arms": hough_detector.half_arm_steps(self.analysis),
                                 "first_pass": self.iterates[0] if self.iterates else []})
            return out

        scipy.optimize.least_squares = least_squares          # the bounded solver's retries
        cross_fit.levenberg_marquardt = levenberg_marquardt   # MINPACK's passes (aerofid.scipy_kernels)
        hough_detector.refine_window = refine_window
        hough_detector.verify_candidate = verify_candidate

    def run(self, source: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> None:
        self.source = source
        fn(*args, **kwargs)


def collect(rec: Recorder, n: int, rng: np.random.Generator) -> list[dict[str, Any]]:
    """Every verification of the scenes of the module docstring (``n`` per cell)."""
    rec.records = []
    _marks_scenes(rec, CONDITIONS, n, rng)
    for case in ("two marks", "half mark", "film-border edge"):
        for style in REJECTION_STYLES:
            for _ in range(n):
                img = testing.TRAPS[case](rng, style)
                rec.run(f"rejection/{case}/{style}", make_detector("hough", "auto", {}), img)
                rec.run(f"rejection/{case}/{style}", auto_detect, img)
    for _ in range(n):
        img = synth.aerial_ground((120, 120), rng)
        rec.run("rejection/clutter", make_detector("hough", "auto", {}), img)
        rec.run("rejection/clutter", auto_detect, img)
    for style in STYLES:
        for _ in range(n):
            img, _, _, mark, _ = peers_scene(style, rng)
            rec.run(f"peers/{style}", auto_detect, img, AutoParams(mark=mark))
    if REAL.exists():
        with open_raster(REAL) as r:
            for name, (x, y) in MARKS.items():
                crop = np.ascontiguousarray(r.read_window((x - HALF, y - HALF, x + HALF, y + HALF)))
                rec.run(f"rc20/{name}", aerofid.locate, crop, (0, 0, crop.shape[1], crop.shape[0]), mark="external")
    _marks_scenes(rec, SPECKED, n, rng)
    return rec.records


def _marks_scenes(rec: Recorder, conditions: Mapping[str, str], n: int, rng: np.random.Generator) -> None:
    """``hough`` alone and ``auto`` on ``n`` of bench_marks.py's scenes per condition and style."""
    for cond in conditions:
        for style in STYLES:
            for _ in range(n):
                img, _, _, mark = marks_scene(style, cond, rng)
                rec.run(f"marks/{cond}/{style}", make_detector("hough", mark, {}), img)
                rec.run(f"marks/{cond}/{style}", auto_detect, img, AutoParams(mark=mark))


def collect_marks(rec: Recorder, n: int) -> list[dict[str, Any]]:
    """``hough`` alone on bench_marks.py's scenes (its seed and order, ``n`` per condition and style)."""
    rec.records = []
    rng = np.random.default_rng(2026)
    for cond in CONDITIONS:
        for style in STYLES:
            for _ in range(n):
                img, _, _, mark = marks_scene(style, cond, rng)
                rec.run(f"marks/{cond}/{style}", make_detector("hough", mark, {}), img)
    return rec.records


def retry_report(records: list[dict[str, Any]]) -> list[str]:
    """The bounded solver's retries: count, rescued verifications, the centre's move in the pass that ran out."""
    out = ["| verifications with a retry | count | centre's move before the retry (px): min / median / max | "
           "moved <= 1 px |", "|---|---|---|---|"]
    for label, accepted in (("accepted", True), ("refused", False)):
        moves = []
        for r in records:
            if r["accepted"] != accepted:
                continue
            methods = [p[0] for p in r["passes"]]
            if "trf" in methods[1:]:
                moves.append(r["passes"][methods.index("trf", 1) - 1][2])
        cell = f"{min(moves):.2f} / {np.median(moves):.2f} / {max(moves):.2f}" if moves else "-"
        out.append(f"| {label} | {len(moves)} | {cell} | {sum(m <= 1.0 for m in moves)} |")
    return out


def report(records: list[dict[str, Any]], limit: int) -> list[str]:
    out = ["| verifications | count | evaluations, first pass: median / 99 % / max | any pass: max | "
           f"ran out of {limit} | cross-fit CPU s |", "|---|---|---|---|---|---|"]
    for label, accepted in (("accepted", True), ("refused", False)):
        rs = [r for r in records if r["accepted"] == accepted]
        first = [r["passes"][0][1] for r in rs if r["passes"]]
        every = [p[1] for r in rs for p in r["passes"]]
        if not first:
            out.append(f"| {label} | {len(rs)} | - | - | - | - |")
            continue
        out.append(f"| {label} | {len(rs)} | {np.median(first):.0f} / {np.percentile(first, 99):.0f} / "
                   f"{max(first)} | {max(every)} | "
                   f"{sum(max((p[1] for p in r['passes']), default=0) >= limit for r in rs)} | "
                   f"{sum(r['cpu'] for r in rs):.1f} |")
    slow = [r for r in records if r["accepted"] and any(p[1] > 0.6 * limit for p in r["passes"])]
    out.append("")
    out.append(crossing_report(records))
    out.append("")
    out.append("Accepted fits with a pass above 60 % of the limit: " + (
        "; ".join(f"{r['source']} {[p[1] for p in r['passes']]}" for r in slow) if slow else "none") + ".")
    return out


def crossing_report(records: list[dict[str, Any]]) -> str:
    """The screening before the fit: how near the accepted '+' had a bright pixel to their Hough centre, and how
    many refused candidates had none within ``AutoParams.cross_check_crossing_gap`` (where ``auto``'s cross-check
    refuses them unfitted; the search of a box fits them)."""
    limit = AutoParams().cross_check_crossing_gap
    accepted = [r["gap"] for r in records if r["accepted"]]
    refused = [r for r in records if not r["accepted"]]
    beyond = sum(r["gap"] > limit for r in refused)
    largest = f"{max(accepted):.2f} px" if accepted else "-"
    return (f"Crossing gap (`detector.crossing_gap`, the nearest bright pixel of the thresholded window to the Hough "
            f"centre): largest of the accepted {largest}; {beyond} of the {len(refused)} refused beyond {limit:g} px "
            "(`auto`'s cross-check refuses such a candidate before any fit).")


SCREENED_RUN = 2
"""The arm screen on steps looks only where the longest half-arm's run reaches this far (px)."""
ITERATE_LIMITS = (3.0, 4.0, 6.0)
"""The distances (px) from a first pass's start at which an abort of the pass is weighed."""


def _arm_screens(arms: list[set[int]]) -> tuple[bool, bool]:
    """(a half-arm with no bright step at 1 or 2 px from the centre; a half-arm with no bright step as far as the
    longest half-arm's run reaches, where that is at least :data:`SCREENED_RUN` px)."""
    runs = hough_detector.half_arm_runs(arms)
    reach = int(max(runs))
    empty = reach >= SCREENED_RUN and any(not any(1 <= k <= reach for k in steps) for steps in arms)
    return min(runs) < 1.0, empty


def _aborted(path: list[tuple[str, float]], limit: float) -> int | None:
    """The evaluations a first pass would have been spared had it stopped at its first iterate beyond ``limit`` px
    of its start (None: no iterate went that far)."""
    k = next((i for i, (kind, d) in enumerate(path) if kind == "j" and d > limit), None)
    return None if k is None else sum(kind == "f" for kind, _ in path[k + 1:])


def screens_report(records: list[dict[str, Any]]) -> list[str]:
    """The screens weighed and not adopted (module docstring): refused candidates each would have refused unfitted or
    cut short, and accepted '+' it would have refused."""
    accepted = [r for r in records if r["accepted"]]
    refused = [r for r in records if not r["accepted"]]
    screened = {id(r): _arm_screens(r["arms"]) for r in records}
    refused_cpu = sum(r["cpu"] for r in refused)
    out = ["| rule | refused candidates it refuses | their fits' CPU s (of the refused's) | accepted '+' it refuses |",
           "|---|---|---|---|"]
    for label, which in (("a half-arm's run below 1 px (no bright pixel 1-2 px from the centre)", 0),
                         ("a half-arm with no bright pixel as far as the longest half-arm reaches", 1)):
        hit = [r for r in refused if screened[id(r)][which]]
        out.append(f"| {label} | {len(hit)} of {len(refused)} | {sum(r['cpu'] for r in hit):.1f} of "
                   f"{refused_cpu:.1f} | {sum(screened[id(r)][which] for r in accepted)} of {len(accepted)} |")
    evaluations = sum(kind == "f" for r in refused for kind, _ in r["first_pass"])
    for limit in ITERATE_LIMITS:
        cut = [k for k in (_aborted(r["first_pass"], limit) for r in refused) if k is not None]
        out.append(f"| first pass stopped at an iterate whose centre lies beyond {limit:g} px of its start | "
                   f"{len(cut)} cut short | {sum(cut)} of the refused first passes' {evaluations} evaluations | "
                   f"{sum(_aborted(r['first_pass'], limit) is not None for r in accepted)} of {len(accepted)} |")
    furthest = max((d for r in accepted for kind, d in r["first_pass"] if kind == "j"), default=0.0)
    out.append("")
    out.append(f"The accepted '+'s furthest first-pass iterate: its centre {furthest:.2f} px from the pass's start.")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=8, help="scenes per style and condition")
    ap.add_argument("--max-evaluations", type=int, default=cross_fit.MAX_EVALUATIONS,
                    help="cross_fit.MAX_EVALUATIONS for this run")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--marks", type=int, default=0, help="also hough alone on N bench_marks.py scenes per cell")
    args = ap.parse_args()
    cross_fit.MAX_EVALUATIONS = args.max_evaluations
    t = time.perf_counter()
    rec = Recorder()
    rec.install()
    records = collect(rec, args.n, np.random.default_rng(args.seed))
    marks = collect_marks(rec, args.marks) if args.marks else []
    print(f"`python benchmarks/bench_fits.py --n {args.n} --max-evaluations {args.max_evaluations} "
          f"--seed {args.seed}" + (f" --marks {args.marks}" if args.marks else "")
          + f"`, {time.perf_counter() - t:.0f} s:\n")
    print("\n".join(report(records, args.max_evaluations)))
    print("\nRetries by the bounded solver, these scenes:\n")
    print("\n".join(retry_report(records)))
    print("\nScreens weighed and not adopted, these scenes:\n")
    print("\n".join(screens_report(records)))
    if marks:
        print(f"\n`hough` alone on bench_marks.py's scenes ({args.marks} per condition and style):\n")
        print("\n".join(report(marks, args.max_evaluations)))
        print("\nRetries by the bounded solver, bench_marks.py's scenes:\n")
        print("\n".join(retry_report(marks)))


if __name__ == "__main__":
    main()
