"""Benchmark of every method and of ``method="auto"`` per mark style, on synthetic marks with exact truth.

    python benchmarks/bench_marks.py [--quick] [--n N] [--out docs/benchmarks_marks.md]

Writes a Markdown report with, per condition (moderate noise, heavy noise, JPEG, strong blur, small marks,
partial occlusion), per mark style (cross, cloth panel, ring+X+dot, ring+'+', dot, bull's-eye, Zeiss dot in a
notch) and per method (hough, symmetry, circles, lines, auto): found rate, erroneous rates (found but more
than 1.5 px / 0.5 px from the truth), RMS and maximum error, median time per mark; and a table of the
rejection cases (clutter only, two marks in the box, half a mark at the box edge, a mark on the film
border's edge), where every found answer is a wrong or ambiguous one.

Every method sees the same window (the bright-mark grey image ``locate`` would give it). ``hough`` and
``auto`` get ``mark="panel"`` for cloth panels and ``mark="auto"`` otherwise.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from aerofid import synth, testing  # noqa: E402
from aerofid.methods import make_detector  # noqa: E402

cv2.setNumThreads(1)

METHODS = ("hough", "symmetry", "circles", "lines", "auto")
STYLES = ("cross", "panel", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")
LABEL = {"cross": "cross", "panel": "cloth panel (aerial ground)", "ring_x_dot": "ring+X+dot (Wild corner)",
         "ring_cross": "ring+'+' (Wild midside)", "dot": "dot", "bullseye": "bull's-eye",
         "notch_dot": "Zeiss dot in a notch"}
RADIUS = testing.MARK_RADIUS


def run_method(method: str, img: np.ndarray, mark: str):
    """The method as ``locate`` configures it (default parameters, ``mark`` for those that take one)."""
    detector = make_detector(method, mark, {})
    t = time.perf_counter()
    d = detector(img)
    return d, time.perf_counter() - t


def jpeg(img: np.ndarray, quality: int) -> np.ndarray:
    ok, buf = cv2.imencode(".jpg", synth.to_uint8(img), [cv2.IMWRITE_JPEG_QUALITY, quality])
    return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE).astype(np.float32) / 255.0


def occlude(img: np.ndarray, x: float, y: float, size: float, rng,
            reach: tuple[float, float] = (0.25, 0.45)) -> np.ndarray:
    """A dust speck / scratch: a dark disc (the ground's grey level) of radius 0.12 x size on the mark, ``reach``
    x size from its centre."""
    a = rng.uniform(0, 2 * np.pi)
    d = rng.uniform(*reach) * size
    g = float(np.median(img))
    cov = synth.coverage(img.shape, (x + d * np.cos(a), y + d * np.sin(a)), synth.disc(0.12 * size), 4,
                         extent=0.2 * size)
    return synth.paint(img, cov, g)


CONDITIONS = {
    "moderate": "sizes 20-44 px, random rotation and sub-pixel centre, blur 0.5-1.0 px, noise 0.02, contrast 0.6-0.85",
    "heavy noise": "as moderate, noise 0.05 and film grain 0.02",
    "JPEG q=40": "as moderate, then JPEG-compressed at quality 40",
    "strong blur": "as moderate, blur 1.5-2.2 px",
    "small marks": "sizes 12-20 px, otherwise moderate",
    "occluded": "as moderate, a dark speck of 0.24 x size across on the mark 0.25-0.45 x size from its centre",
}
SPECKED = {
    "speck on the centre": "as moderate, a dark speck of 0.24 x size across within 0.05 x size of the mark's centre "
                           "(dust on the crossing of a '+' or on a dot's core)",
}
"""Conditions of ``benchmarks/bench_specks.py`` (a page of their own: this page's conditions keep their scenes)."""
REACH = {"occluded": (0.25, 0.45), "speck on the centre": (0.0, 0.05)}
"""How far from the mark's centre each occluding condition puts its speck (x size)."""


def scene(style: str, cond: str, rng):
    """(window, truth x, y, mark) for one mark."""
    if style == "panel":
        size = rng.uniform(7, 11)
        sc = synth.panel_scene(rng, shape_hw=(160, 160), size=size, contrast=rng.uniform(0.2, 0.35),
                               noise_sigma=0.04 if cond == "heavy noise" else 0.015,
                               blur_sigma=rng.uniform(1.2, 1.6) if cond == "strong blur" else 0.6)
        m = sc.marks[0]
        x0, y0, x1, y1 = m.box
        img = sc.image[y0:y1, x0:x1]
        tx, ty = m.x - x0, m.y - y0
        if cond == "JPEG q=40":
            img = jpeg(img, 40)
        if cond in REACH:
            img = occlude(img, tx, ty, size, rng, REACH[cond])
        return img, tx, ty, "panel"
    size = rng.uniform(12, 20) if cond == "small marks" else rng.uniform(20, 44)
    noise = 0.05 if cond == "heavy noise" else 0.02
    grain = 0.02 if cond == "heavy noise" else 0.0
    blur = rng.uniform(1.5, 2.2) if cond == "strong blur" else rng.uniform(0.5, 1.0)
    sc = synth.mark_scene(style, size=size, window=120, rng=rng, noise_sigma=noise, grain_sigma=grain,
                          blur_sigma=blur, contrast=rng.uniform(0.6, 0.85),
                          angle_deg=0.0 if style == "notch_dot" else rng.uniform(0, 90))
    m = sc.marks[0]
    img = sc.image
    if cond == "JPEG q=40":
        img = jpeg(img, 40)
    if cond in REACH:
        img = occlude(img, m.x, m.y, RADIUS.get(style, 0.5) * 2 * size, rng, REACH[cond])
    return img, m.x, m.y, "auto"


def stats(errs, times, n):
    e = np.asarray(errs, float)
    f = np.isfinite(e)
    ef = e[f]
    return {"n": n, "found": int(f.sum()), "gt15": int((ef > 1.5).sum()), "gt05": int((ef > 0.5).sum()),
            "rms": float(np.sqrt(np.mean(ef ** 2))) if ef.size else float("nan"),
            "max": float(ef.max()) if ef.size else float("nan"), "t": 1000 * float(np.median(times))}


def fmt(name, s):
    pct = 100.0 * s["found"] / s["n"]
    return (f"| {name} | {s['found']}/{s['n']} ({pct:.0f} %) | {s['gt15']} | {s['gt05']} | "
            f"{s['rms']:.3f} | {s['max']:.3f} | {s['t']:.0f} |")


HEAD = ("| method | found | erroneous > 1.5 px | > 0.5 px | RMS (px) | max (px) | median ms |\n"
        "|---|---|---|---|---|---|---|")


def bench_condition(cond, n, rng, summary):
    described = {**CONDITIONS, **SPECKED}[cond]
    out = [f"\n## {cond}\n", described + ". Box: the whole 120 x 120 window (panels: 3 x their size).\n"]
    for style in STYLES:
        errs = {m: [] for m in METHODS}
        times = {m: [] for m in METHODS}
        for _ in range(n):
            img, tx, ty, mark = scene(style, cond, rng)
            for m in METHODS:
                d, t = run_method(m, img, mark)
                errs[m].append(float(np.hypot(d.x - tx, d.y - ty)) if d.found else np.nan)
                times[m].append(t)
        out += [f"\n### {LABEL[style]}\n", HEAD]
        for m in METHODS:
            s = stats(errs[m], times[m], n)
            out.append(fmt(f"**{m}**" if m == "auto" else m, s))
            summary[(cond, style, m)] = s
    return out


def bench_rejections(n, rng):
    out = ["\n## Rejection cases\n",
           "Every found answer here is wrong (clutter, a half mark, a mark half on the bright image area) or "
           "ambiguous (two marks in the box): the count of found answers per method, of n cases. 120 x 120 "
           "windows; marks 20-40 px; the two marks 1.1-1.6 sizes apart (two cloth panels of 7-11 px, the last row: "
           "1.8-4.5 sizes apart on aerial ground, `mark=\"panel\"`); half marks have their centre 0-0.6 of "
           "their radius inside the box edge; film-border marks have the edge between the dark border and the "
           "aerial image area within half their radius of their centre.\n",
           "| case | style | n | " + " | ".join(METHODS) + " |", "|---|---|---|" + "---|" * len(METHODS)]
    styles = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")
    cases = [("clutter only (aerial ground)", None)] + [(c, s) for c in ("two marks", "half mark", "film-border edge")
                                                        for s in styles] + [("two marks", "panel")]
    total = {m: 0 for m in METHODS}
    count = 0
    for case, style in cases:
        found = {m: 0 for m in METHODS}
        for _ in range(n):
            if style is None:
                img = synth.aerial_ground((120, 120), rng)
            else:
                img = testing.TRAPS[case](rng, style)
            for m in METHODS:
                d, _ = run_method(m, img, "panel" if style == "panel" else "auto")
                found[m] += int(d.found)
        count += n
        for m in METHODS:
            total[m] += found[m]
        out.append(f"| {case} | {LABEL.get(style, '-')} | {n} | " + " | ".join(str(found[m]) for m in METHODS) + " |")
    out.append(f"| **all** | | {count} | " + " | ".join(f"**{total[m]}**" for m in METHODS) + " |")
    return out


def targets(summary, n):
    lines = ["\n## Targets (marks of 20 px and more at moderate noise)\n",
             "Target: found >= 98 %, erroneous (> 1.5 px) 0, RMS <= 0.1 px; auto never worse than the best single "
             "method (found rate, then RMS).\n",
             "| style | auto found | auto erroneous | auto RMS | best single method (found, RMS) | met |",
             "|---|---|---|---|---|---|"]
    for style in STYLES:
        a = summary[("moderate", style, "auto")]
        singles = [(m, summary[("moderate", style, m)]) for m in METHODS if m != "auto"]
        bm, bs = max(singles, key=lambda t: (t[1]["found"] - t[1]["gt15"], -np.nan_to_num(t[1]["rms"], nan=9)))
        fr = a["found"] / a["n"]
        not_worse = (a["found"] - a["gt15"]) >= (bs["found"] - bs["gt15"]) - 1 and (
            not np.isfinite(bs["rms"]) or a["rms"] <= bs["rms"] * 1.25 + 0.005)
        met = fr >= 0.98 and a["gt15"] == 0 and a["rms"] <= 0.1 and not_worse
        lines.append(f"| {LABEL[style]} | {100 * fr:.0f} % | {a['gt15']} | {a['rms']:.3f} | {bm} "
                     f"({100 * bs['found'] / bs['n']:.0f} %, {bs['rms']:.3f}) | {'yes' if met else 'no'} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer marks (a smoke run)")
    ap.add_argument("--n", type=int, default=None, help="marks per style and condition")
    ap.add_argument("--out", default="docs/benchmarks_marks.md")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args()
    n = args.n or (8 if args.quick else 50)
    rng = np.random.default_rng(args.seed)
    cmd = "python benchmarks/bench_marks.py" + (" --quick" if args.quick else "") + (f" --n {args.n}" if args.n else "")
    t0 = time.time()
    summary: dict = {}
    body = []
    for cond in CONDITIONS:
        body += bench_condition(cond, n, rng, summary)
        print(f"{cond} done ({time.time() - t0:.0f} s)", flush=True)
    rej = bench_rejections(max(4, n // 3), rng)
    parts = ["# Mark detectors and `auto`: benchmarks per style\n",
             f"Produced by `{cmd}` (seed {args.seed}, {n} marks per style and condition) on {platform.machine()} / "
             f"Python {platform.python_version()}, one thread, in {time.time() - t0:.0f} s. Every number below "
             "comes from that run.\n",
             "Truth: `aerofid.synth` renders each mark by area coverage at a random sub-pixel centre. *found*: the "
             "method's status is found; *erroneous*: found but further than 1.5 px (or 0.5 px) from the truth; "
             "RMS and max over the found marks; time: median wall time of one call on the window. `auto` is "
             "`aerofid.detect.auto.detect` (what `locate(..., method=\"auto\")` runs), see its docstring for the "
             "rule.\n", *targets(summary, n), *rej, *body]
    with open(args.out, "w") as f:
        f.write("\n".join(parts) + "\n")
    print(f"wrote {args.out} in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
