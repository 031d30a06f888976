"""Benchmark of ``aerofid.locate`` per box kind: tight, mid and loose boxes around synthetic marks with exact truth.

    python benchmarks/bench_boxes.py [--quick] [--n N] [--seed S] [--out docs/benchmarks_boxes.md]
    python benchmarks/bench_boxes.py --show STYLE I       # one scene of the tables, every box, in full
    python benchmarks/bench_boxes.py --show CASE:STYLE I  # one rejection scene (CASE: two_marks, half_mark,
                                                          # border_edge; or --show clutter I)

What aerofid did before ``locate`` became a search (the *baseline*): ``make_detector("auto", mark, {})`` on the
grey crop of a mid-size box, nothing read outside it. What it does now: ``aerofid.locate(image, box)``, which
screens the box for candidates, measures each on a window of its own size read around it (clipped only by the
image) and keeps exactly one mark. Per mark style and box kind (tight, mid, loose 4x, loose 10x): found rate,
wrong answers (found but > 1.5 px / > 0.5 px from the truth), RMS and maximum error, median wall time per box,
the median reported sigma and the ratio of the RMS error per axis to the RMS reported sigma. Then the rejection
scenes of :mod:`aerofid.testing` and clutter-only aerial ground through ``locate`` (every found answer is wrong)
and the box-to-box spread of the centre against the reported sigma.

Every scene is drawn from its own generator ``numpy.random.default_rng((seed, group, style, i))``, so any line of
the report can be reproduced alone with ``--show``.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

import aerofid  # noqa: E402
from aerofid import synth, testing  # noqa: E402
from aerofid.io.colour import to_grey  # noqa: E402
from aerofid.methods import make_detector  # noqa: E402

cv2.setNumThreads(1)


@dataclass(frozen=True)
class Style:
    """A row group of the tables: the synthetic style, its size range (px) and the ``mark`` passed."""

    key: str
    label: str
    synth_style: str
    sizes: tuple[float, float]
    mark: str = "auto"


STYLES = (
    Style("cross", "cross", "cross", (26, 34)),
    Style("ring_x_dot", "ring+X+dot (Wild corner)", "ring_x_dot", (26, 34)),
    Style("ring_cross", "ring+'+' (Wild midside)", "ring_cross", (26, 34)),
    Style("dot", "dot", "dot", (26, 34)),
    Style("dot_small", "small dot", "dot", (9, 11)),
    Style("bullseye", "bull's-eye", "bullseye", (26, 34)),
    Style("notch_dot", "Zeiss dot in a notch", "notch_dot", (26, 34)),
    Style("panel", "cloth panel (aerial ground)", "panel", (7, 11), mark="panel"),
)
STYLE_BY_KEY = {s.key: s for s in STYLES}
STYLE_ID = {s.key: k for k, s in enumerate(STYLES)}
KINDS = ("tight", "mid", "loose4", "loose10")
KIND_LABEL = {"tight": "tight", "mid": "mid", "loose4": "loose 4x", "loose10": "loose 10x", "baseline": "baseline"}
IMAGE = 520
"""Side of the film-border scenes (px): a 10x box of a 34 px mark still fits around the mark's centre."""
TRAP_IMAGE = 480
"""Side of the rejection scenes (px)."""
TRAP_SIZE = 30.0
"""Nominal mark size of the rejection scenes (their marks are 20-40 px) for the box sizes."""
TRAP_CASES = {"two_marks": "two marks", "half_mark": "half mark", "border_edge": "film-border edge"}
TRAP_STYLES = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")
GROUP_MAIN, GROUP_TRAP, GROUP_CLUTTER, GROUP_SPREAD = 1, 2, 3, 4
WRONG, OFF = 1.5, 0.5


# --- scenes and boxes -------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Case:
    """One image with its truth: the mark's centre, size S (px) and visible radius R (px)."""

    image: np.ndarray
    x: float
    y: float
    size: float
    radius: float
    mark: str


def make_case(style: Style, i: int, seed: int) -> Case:
    """Scene ``i`` of ``style``: moderate conditions as bench_marks (blur 0.5-1 px, noise 0.02, contrast
    0.6-0.85, random rotation and sub-pixel centre); cloth panels on 404 x 404 aerial ground."""
    rng = np.random.default_rng((seed, GROUP_MAIN, STYLE_ID[style.key], i))
    size = float(rng.uniform(*style.sizes))
    if style.key == "panel":
        sc = synth.panel_scene(rng, shape_hw=(404, 404), size=size, contrast=rng.uniform(0.2, 0.35))
    else:
        sc = synth.mark_scene(style.synth_style, size=size, window=IMAGE, rng=rng, noise_sigma=0.02,
                              blur_sigma=rng.uniform(0.5, 1.0), contrast=rng.uniform(0.6, 0.85),
                              angle_deg=0.0 if style.key == "notch_dot" else rng.uniform(0, 90))
    m = sc.marks[0]
    radius = testing.MARK_RADIUS.get(style.synth_style, 0.5) * size
    return Case(sc.image, m.x, m.y, size, radius, style.mark)


def clip(box: tuple[int, int, int, int], shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    h, w = shape[:2]
    return max(box[0], 0), max(box[1], 0), min(box[2], w), min(box[3], h)


def box_with(x: float, y: float, side: int, u: float, v: float, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """The ``side`` x ``side`` box in which the point (x, y) lies ``u``, ``v`` px from the left and top edges
    (pixel edges: pixel k covers [k - 0.5, k + 0.5]), clipped to the image."""
    x0 = int(round(x + 0.5 - u))
    y0 = int(round(y + 0.5 - v))
    return clip((x0, y0, x0 + side, y0 + side), shape)


def tight_box(x: float, y: float, radius: float, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """The pixels whose centres lie within the mark's extent + 2 px each side, centred on the mark."""
    h = radius + 2.0
    return clip((int(np.ceil(x - h)), int(np.ceil(y - h)), int(np.floor(x + h)) + 1, int(np.floor(y + h)) + 1),
                shape)


def mid_box(x, y, size, rng, shape, offset=0.5):
    """Side 4 S (the mark plus 1.5 S around it, bench_marks' 120 px window for 30 px marks), the box's centre
    up to ``offset`` S from the mark's per axis (the whole mark stays inside, at least S/2 from each edge)."""
    side = int(round(4 * size))
    u, v = side / 2 + rng.uniform(-offset, offset, 2) * size
    return box_with(x, y, side, u, v, shape)


def loose_box(x, y, size, margin, factor, rng, shape):
    """Side ``factor`` x S, the point (x, y) anywhere at least ``margin`` px inside each edge; clipped."""
    side = int(round(factor * size))
    margin = min(margin, side / 2)
    u, v = rng.uniform(margin, side - margin, 2)
    return box_with(x, y, side, u, v, shape)


def boxes_for(case: Case, rng: np.random.Generator) -> dict[str, tuple[int, int, int, int]]:
    shape = case.image.shape
    return {"tight": tight_box(case.x, case.y, case.radius, shape),
            "mid": mid_box(case.x, case.y, case.size, rng, shape),
            "loose4": loose_box(case.x, case.y, case.size, case.radius, 4, rng, shape),
            "loose10": loose_box(case.x, case.y, case.size, case.radius, 10, rng, shape)}


def main_boxes(style: Style, i: int, seed: int, case: Case) -> dict[str, tuple[int, int, int, int]]:
    return boxes_for(case, np.random.default_rng((seed, GROUP_MAIN, STYLE_ID[style.key], i, 1)))


def edge_point(img: np.ndarray) -> tuple[float, float]:
    """Where ``testing.half_mark`` put the cut mark: the midpoint of the image edge with the brightest patch."""
    h, w = img.shape
    pts = [(0.0, h / 2), (w - 1.0, h / 2), (w / 2, 0.0), (w / 2, h - 1.0)]
    patch = [float(img[max(int(y) - 20, 0):int(y) + 21, max(int(x) - 20, 0):int(x) + 21].mean()) for x, y in pts]
    return pts[int(np.argmax(patch))]


def trap_case(case: str, style: str, i: int, seed: int):
    """(image, reference point, margin) of one rejection scene: two marks around the image's centre, a half
    mark at the midpoint of one image edge, a mark on the film-border edge at the centre; the boxes contain the
    reference point at least ``margin`` px inside each edge (two marks: both centres inside)."""
    rng = np.random.default_rng((seed, GROUP_TRAP, list(TRAP_CASES).index(case), TRAP_STYLES.index(style), i))
    img = testing.TRAPS[TRAP_CASES[case]](rng, style, TRAP_IMAGE)
    c = TRAP_IMAGE / 2.0
    if case == "two_marks":  # centres within 0.8 x 30 + 3 px of the centre per axis
        return img, (c, c), 0.8 * TRAP_SIZE + 3 + 0.5 * TRAP_SIZE, rng
    if case == "half_mark":
        return img, edge_point(img), 0.5 * TRAP_SIZE, rng
    return img, (c, c), 0.5 * TRAP_SIZE, rng


def rejection_boxes(img, point, margin, rng) -> dict[str, tuple[int, int, int, int]]:
    x, y = point
    s = TRAP_SIZE
    return {"mid": mid_box(x, y, s, rng, img.shape, offset=min(0.5, 2 - margin / s)),
            "loose4": loose_box(x, y, s, margin, 4, rng, img.shape),
            "loose10": loose_box(x, y, s, margin, 10, rng, img.shape)}


def clutter_case(i: int, seed: int):
    rng = np.random.default_rng((seed, GROUP_CLUTTER, i))
    img = synth.aerial_ground((TRAP_IMAGE, TRAP_IMAGE), rng)
    x, y = rng.uniform(0, TRAP_IMAGE, 2)
    return img, (float(x), float(y)), 0.5 * TRAP_SIZE, rng


# --- measuring ----------------------------------------------------------------------------------------------

@dataclass
class Answer:
    found: bool
    x: float
    y: float
    sigma: float
    sigma_x: float
    sigma_y: float
    t: float
    reason: str
    method: str


def run_locate(img, box, mark) -> Answer:
    t = time.perf_counter()
    try:
        r = aerofid.locate(img, box, mark=mark)
    except Exception as e:  # a crash is a result: counted and listed, the run goes on
        return Answer(False, np.nan, np.nan, np.nan, np.nan, np.nan, time.perf_counter() - t,
                      f"ERROR {type(e).__name__}: {e}", "")
    dt = time.perf_counter() - t
    sx = r.sigma_x if np.isfinite(r.sigma_x) else r.sigma
    sy = r.sigma_y if np.isfinite(r.sigma_y) else r.sigma
    return Answer(r.found, r.x, r.y, r.sigma, sx, sy, dt, r.reason, r.method)


def run_baseline(img, box, mark) -> Answer:
    """The detector on the grey crop of the box (what aerofid did before ``locate`` searched)."""
    x0, y0, x1, y1 = box
    grey = to_grey(img[y0:y1, x0:x1])
    detector = make_detector("auto", mark, {})
    t = time.perf_counter()
    try:
        d = detector(grey)
    except Exception as e:
        return Answer(False, np.nan, np.nan, np.nan, np.nan, np.nan, time.perf_counter() - t,
                      f"ERROR {type(e).__name__}: {e}", "")
    dt = time.perf_counter() - t
    sx = d.sigma_x if np.isfinite(d.sigma_x) else d.sigma
    sy = d.sigma_y if np.isfinite(d.sigma_y) else d.sigma
    return Answer(d.found, d.x + x0, d.y + y0, d.sigma, sx, sy, dt, d.reason, d.method)


def first_words(reason: str, k: int = 5) -> str:
    words = reason.replace(":", "").split()
    return " ".join(words[:k]) if words else "(no reason)"


def cell_stats(rows: list[tuple[Answer, float, float]]) -> dict:
    """rows: (answer, truth x, truth y)."""
    found = [(a, a.x - tx, a.y - ty) for a, tx, ty in rows if a.found]
    dx = np.array([f[1] for f in found])
    dy = np.array([f[2] for f in found])
    err = np.hypot(dx, dy)
    sig = np.array([f[0].sigma for f in found])
    ok = err <= WRONG  # the sigma is judged on the answers that are not wrong
    axis_rms = float(np.sqrt(np.mean((dx[ok] ** 2 + dy[ok] ** 2) / 2))) if ok.any() else np.nan
    sig_rms = float(np.sqrt(np.nanmean(sig[ok] ** 2))) if ok.any() and np.isfinite(sig[ok]).any() else np.nan
    return {"n": len(rows), "found": len(found), "gt15": int((err > WRONG).sum()), "gt05": int((err > OFF).sum()),
            "rms": float(np.sqrt(np.mean(err ** 2))) if found else np.nan,
            "max": float(err.max()) if found else np.nan,
            "t": 1000 * float(np.median([a.t for a, _, _ in rows])),
            "sigma": float(np.nanmedian(sig)) if found and np.isfinite(sig).any() else np.nan,
            "ratio": axis_rms / sig_rms if sig_rms > 0 else np.nan}


def num(v: float, f: str = ".3f") -> str:
    return "-" if not np.isfinite(v) else format(v, f)


def bench_main(n: int, seed: int, log) -> tuple[list[str], list[str], list[str]]:
    """The main tables, the list of wrong answers, the reasons of misses."""
    out = ["\n## Found rate and accuracy per box kind\n",
           "| style | box | found | wrong > 1.5 px | > 0.5 px | RMS (px) | max (px) | median ms | median sigma (px) "
           "| RMS err / RMS sigma |", "|---|---|---|---|---|---|---|---|---|---|"]
    wrong, misses = [], []
    summary = {}
    for style in STYLES:
        rows: dict[str, list] = {k: [] for k in ("baseline", *KINDS)}
        for i in range(n):
            case = make_case(style, i, seed)
            boxes = main_boxes(style, i, seed, case)
            answers = {"baseline": run_baseline(case.image, boxes["mid"], case.mark)}
            answers.update({k: run_locate(case.image, boxes[k], case.mark) for k in KINDS})
            for k, a in answers.items():
                rows[k].append((a, case.x, case.y))
                err = float(np.hypot(a.x - case.x, a.y - case.y)) if a.found else np.nan
                if a.found and err > OFF:
                    wrong.append((style.key, i, k, err, a, boxes["mid" if k == "baseline" else k]))
                elif not a.found:
                    misses.append((style.key, k, first_words(a.reason)))
        for k in ("baseline", *KINDS):
            s = cell_stats(rows[k])
            summary[(style.key, k)] = s
            pct = 100.0 * s["found"] / s["n"]
            name = f"{KIND_LABEL[k]} (detector on the mid box)" if k == "baseline" else f"**{KIND_LABEL[k]}**"
            out.append(f"| {style.label} | {name} | {s['found']}/{s['n']} ({pct:.0f} %) | {s['gt15']} | {s['gt05']} | "
                       f"{num(s['rms'])} | {num(s['max'])} | {s['t']:.0f} | {num(s['sigma'], '.4f')} | "
                       f"{num(s['ratio'], '.1f')} |")
        log(f"{style.key} done")
    return out, headline(summary), wrong_lines(wrong) + miss_lines(misses)


def headline(summary: dict) -> list[str]:
    out = ["\n## Summary: found rate per box kind (all styles)\n",
           "| box | " + " | ".join(s.label for s in STYLES) + " | all |", "|---|" + "---|" * (len(STYLES) + 1)]
    for k in ("baseline", *KINDS):
        cells = [summary[(s.key, k)] for s in STYLES]
        f, n = sum(c["found"] for c in cells), sum(c["n"] for c in cells)
        w = sum(c["gt15"] for c in cells)
        name = "baseline (detector on the mid box)" if k == "baseline" else KIND_LABEL[k]
        out.append(f"| {name} | " + " | ".join(f"{100 * c['found'] / c['n']:.0f} %" for c in cells)
                   + f" | {100 * f / n:.1f} % ({w} wrong > 1.5 px) |")
    return out


def wrong_lines(wrong) -> list[str]:
    out = ["\n## Wrong answers (found, > 0.5 px from the truth)\n"]
    if not wrong:
        return out + ["None.\n"]
    out += ["Reproduce one with `python benchmarks/bench_boxes.py --show STYLE I` (same `--seed`).\n",
            "| style | i | box | box (x0, y0, x1, y1) | error (px) | answer (x, y) | sigma | method |",
            "|---|---|---|---|---|---|---|---|"]
    for key, i, k, err, a, box in wrong:
        out.append(f"| {key} | {i} | {KIND_LABEL[k]} | {box} | {err:.2f} | ({a.x:.2f}, {a.y:.2f}) | "
                   f"{num(a.sigma, '.4f')} | {a.method} |")
    return out


def miss_lines(misses) -> list[str]:
    out = ["\n## Why marks were not found (first words of the reason)\n"]
    if not misses:
        return out + ["Every mark was found.\n"]
    out += ["| style | box | count | reason |", "|---|---|---|---|"]
    for (key, k, words), c in sorted(Counter(misses).items(), key=lambda t: (STYLE_ID[t[0][0]], t[0][1], -t[1])):
        out.append(f"| {key} | {KIND_LABEL[k]} | {c} | {words} |")
    return out


def bench_rejections(n: int, n_clutter: int, seed: int, log) -> list[str]:
    kinds = ("baseline", "mid", "loose10")
    out = ["\n## Rejection scenes through `locate`\n",
           f"Every found answer here is wrong. Scenes of {TRAP_IMAGE} x {TRAP_IMAGE} px from `aerofid.testing.TRAPS` "
           "(marks 20-40 px): *two marks* 1.1-1.6 sizes apart at the centre (the box holds both centres), "
           "*half mark* with its centre 0-0.6 of its radius inside an image edge (the box holds its centre), "
           "*film-border edge*: a mark at the centre straddling the edge between the dark border and aerial ground; "
           "and *clutter*: `synth.aerial_ground` only. Each box holds a *reference point*: the centre of the image "
           "(two marks: their midpoint, within 3 px; film-border edge: the mark), the midpoint of the cut image edge "
           "(half mark), a random point (clutter). Boxes for a nominal 30 px mark, clipped to the image: mid 120 px "
           "(its centre up to 15 px from the reference point), loose 10x 300 px (the reference point anywhere at "
           "least 15 px inside, 42 px for two marks); loose 4x boxes are left out here to keep the run short. "
           "*baseline*: the detector on the grey crop of the mid box, as before `locate` searched. Count of found "
           "answers of n per box kind (must be 0).\n",
           "| case | style | n | " + " | ".join(KIND_LABEL[k] for k in kinds) + " |",
           "|---|---|---|" + "---|" * len(kinds)]
    found_list, reasons = [], {c: Counter() for c in (*TRAP_CASES, "clutter")}
    total = Counter()
    scenes = [(c, s) for c in TRAP_CASES for s in TRAP_STYLES] + [("clutter", None)]
    for case, style in scenes:
        count = Counter()
        reps = n if style is not None else n_clutter
        for i in range(reps):
            img, point, margin, rng = trap_case(case, style, i, seed) if style else clutter_case(i, seed)
            boxes = rejection_boxes(img, point, margin, rng)
            for k in kinds:
                box = boxes["mid" if k == "baseline" else k]
                a = (run_baseline if k == "baseline" else run_locate)(img, box, "auto")
                if a.found:
                    count[k] += 1
                    found_list.append((f"{case}:{style}" if style else "clutter", i, k, box, a, point))
                else:
                    reasons[case][first_words(a.reason, 4)] += 1
        total.update(count)
        label = TRAP_CASES.get(case, "clutter only (aerial ground)")
        out.append(f"| {label} | {STYLE_BY_KEY[style].label if style else '-'} | {reps} | "
                   + " | ".join(str(count[k]) for k in kinds) + " |")
        log(f"rejection {case} {style or ''} done")
    out.append("| **all** | | | " + " | ".join(f"**{total[k]}**" for k in kinds) + " |")
    out += ["\nFound answers (each is wrong); reproduce with `python benchmarks/bench_boxes.py --show CASE:STYLE I`:\n"]
    if not found_list:
        out.append("None.")
    else:
        out += ["| scene | i | box | box (x0, y0, x1, y1) | answer (x, y) | px from the reference point | sigma | "
                "method |", "|---|---|---|---|---|---|---|---|"]
        out += [f"| {sc} | {i} | {KIND_LABEL[k]} | {box} | ({a.x:.1f}, {a.y:.1f}) | "
                f"{np.hypot(a.x - p[0], a.y - p[1]):.0f} | {num(a.sigma, '.4f')} | {a.method} |"
                for sc, i, k, box, a, p in found_list]
    out += ["\nReasons given (first four words, all boxes of the case):\n", "| case | count | reason |",
            "|---|---|---|"]
    for case, cnt in reasons.items():
        out += [f"| {TRAP_CASES.get(case, 'clutter')} | {c} | {w} |" for w, c in cnt.most_common(6)]
    return out


def bench_spread(marks: int, boxes: int, seed: int, log) -> list[str]:
    out = ["\n## Box-to-box spread\n",
           f"{marks} marks per style (scenes 0-{marks - 1} of the tables above), each located in {boxes} different "
           "loose boxes (alternately 4x and 10x its size, the mark anywhere at least its radius inside). Per mark: the "
           "standard deviation of the found centres per axis, against the median reported sigma_x, sigma_y (sigma "
           "where a method reports no per-axis value). *spread / sigma*: the larger of the two axes' ratios, median "
           "and worst over the marks (target <= ~1.5). *distinct*: how many different centres (to 1e-6 px) the "
           "boxes gave, median over the marks. *bias*: RMS over the marks of the distance from the mean centre to "
           "the truth, in units of the median sigma. *sigma max / min*: the largest reported sigma of a mark over its "
           "boxes divided by the smallest, worst over the marks (1.00: the sigma does not depend on the box).\n",
           "| style | found | std x, std y (px, RMS over marks) | median sigma_x, sigma_y (px) | spread / sigma "
           "median, worst | distinct | bias / sigma | sigma max / min |", "|---|---|---|---|---|---|---|---|"]
    for style in STYLES:
        stds, sigs, ratios, distinct, bias, sigma_range = [], [], [], [], [], []
        found = total = 0
        for i in range(marks):
            case = make_case(style, i, seed)
            rng = np.random.default_rng((seed, GROUP_SPREAD, STYLE_ID[style.key], i))
            got = []
            for j in range(boxes):
                box = loose_box(case.x, case.y, case.size, case.radius, 4 if j % 2 == 0 else 10, rng, case.image.shape)
                a = run_locate(case.image, box, case.mark)
                total += 1
                if a.found and np.hypot(a.x - case.x, a.y - case.y) <= WRONG:
                    got.append(a)
            found += len(got)
            if len(got) < 3:
                continue
            xy = np.array([(a.x, a.y) for a in got])
            sd = xy.std(axis=0, ddof=1)
            sg = np.array([np.median([a.sigma_x for a in got]), np.median([a.sigma_y for a in got])])
            stds.append(sd)
            sigs.append(sg)
            ratios.append(float(np.max(sd / sg)))
            distinct.append(len({(round(a.x, 6), round(a.y, 6)) for a in got}))
            sigma_range.append(max(a.sigma for a in got) / min(a.sigma for a in got))
            bias.append(float(np.hypot(*(xy.mean(axis=0) - (case.x, case.y))) / np.mean(sg)))
        if not stds:
            out.append(f"| {style.label} | {found}/{total} | - | - | - | - | - | - |")
            continue
        sd = np.sqrt(np.mean(np.square(stds), axis=0))
        sg = np.median(sigs, axis=0)
        out.append(f"| {style.label} | {found}/{total} | {sd[0]:.4f}, {sd[1]:.4f} | {sg[0]:.4f}, {sg[1]:.4f} | "
                   f"{np.median(ratios):.2f}, {np.max(ratios):.2f} | {np.median(distinct):.0f} | "
                   f"{np.sqrt(np.mean(np.square(bias))):.1f} | {np.max(sigma_range):.2f} |")
        log(f"spread {style.key} done")
    return out


# --- reproducing one scene ---------------------------------------------------------------------------------

def show(key: str, i: int, seed: int) -> None:
    """Print one scene's truth, boxes and answers in full."""
    if key in STYLE_BY_KEY:
        style = STYLE_BY_KEY[key]
        case = make_case(style, i, seed)
        boxes = main_boxes(style, i, seed, case)
        print(f"{key} scene {i} (seed {seed}): truth ({case.x:.3f}, {case.y:.3f}), size {case.size:.1f}, "
              f"radius {case.radius:.1f}, image {case.image.shape}, mark={case.mark!r}")
        runs = [("baseline", boxes["mid"], run_baseline)] + [(k, boxes[k], run_locate) for k in KINDS]
        tx, ty = case.x, case.y
        img, mark = case.image, case.mark
    else:
        if key == "clutter":
            img, point, margin, rng = clutter_case(i, seed)
        else:
            case_name, style_key = key.split(":")
            img, point, margin, rng = trap_case(case_name, style_key, i, seed)
        print(f"{key} scene {i} (seed {seed}): reference point ({point[0]:.1f}, {point[1]:.1f}); every answer is wrong")
        boxes = rejection_boxes(img, point, margin, rng)
        runs = [("baseline", boxes["mid"], run_baseline)] + [(k, b, run_locate) for k, b in boxes.items()]
        tx = ty = np.nan
        img, mark = img, "auto"
    for k, box, fn in runs:
        a = fn(img, box, mark)
        err = np.hypot(a.x - tx, a.y - ty)
        print(f"  {KIND_LABEL[k]:>9} box {box}: {'found' if a.found else 'not found'} ({a.x:.3f}, {a.y:.3f}) "
              f"error {num(err)} sigma {num(a.sigma, '.4f')} ({num(a.sigma_x, '.4f')}, {num(a.sigma_y, '.4f')}) "
              f"{a.method} {1000 * a.t:.0f} ms {a.reason}")
    made = "make_case(STYLE_BY_KEY[KEY], I, SEED).image" if key in STYLE_BY_KEY else \
        "clutter_case(I, SEED)[0]" if key == "clutter" else "trap_case(CASE, STYLE, I, SEED)[0]"
    print(f"  each row: aerofid.locate(img, box, mark={mark!r}) (baseline: the auto detector on the crop), "
          f"img = bench_boxes.{made}")


# --- report ------------------------------------------------------------------------------------------------

def provenance() -> str:
    """Which aerofid ran: its commit and whether its src/ had uncommitted changes."""
    src = Path(aerofid.__file__).resolve().parents[1]
    try:
        commit = subprocess.run(["git", "-C", str(src), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--", "."], capture_output=True,
                               text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return f"aerofid from {src} (not a git checkout)"
    return f"aerofid at commit {commit}" + (" with uncommitted changes in src/" if dirty else " (src/ clean)")


def cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def write_atomic(path: str, text: str) -> None:
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: few scenes")
    ap.add_argument("--n", type=int, default=None, help="scenes per style and clutter scenes (default 20)")
    ap.add_argument("--n-rej", type=int, default=None, help="rejection scenes per case and style (default n / 6)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--out", default="docs/benchmarks_boxes.md")
    ap.add_argument("--show", nargs=2, metavar=("KEY", "I"), help="print one scene in full and stop")
    args = ap.parse_args()
    if args.show:
        show(args.show[0], int(args.show[1]), args.seed)
        return
    n = args.n or (3 if args.quick else 20)
    n_rej = args.n_rej or max(2, n // 6)
    spread_marks, spread_boxes = (2, 4) if args.quick else (5, 12)
    cmd = "python benchmarks/bench_boxes.py" + (" --quick" if args.quick else "") + \
          (f" --n {args.n}" if args.n else "") + (f" --n-rej {args.n_rej}" if args.n_rej else "") + \
          (f" --seed {args.seed}" if args.seed != 2026 else "")
    t0 = time.time()

    def log(msg: str) -> None:
        print(f"{msg} ({time.time() - t0:.0f} s)", flush=True)

    main_tab, head, lists = bench_main(n, args.seed, log)
    rej = bench_rejections(n_rej, n, args.seed, log)
    spread = bench_spread(spread_marks, spread_boxes, args.seed, log)
    parts = [
        "# `locate` per box kind: benchmarks on synthetic marks\n",
        f"Produced by `{cmd}` (seed {args.seed}, {n} scenes per style and of clutter, {n_rej} per rejection case and "
        f"style) with "
        f"{provenance()}, on {platform.machine()} / {cpu()} ({os.cpu_count()} cores) / Python "
        f"{platform.python_version()}, one thread, in {time.time() - t0:.0f} s. Every number below comes from "
        "that run.\n",
        "Scenes: one mark per image, rendered by `aerofid.synth` at a random sub-pixel centre near the middle of a "
        f"{IMAGE} x {IMAGE} px film-border image (moderate conditions of bench_marks: blur 0.5-1.0 px, noise 0.02, "
        "contrast 0.6-0.85, random rotation); marks 26-34 px (the small dots 9-11 px); cloth panels 7-11 px by "
        "`synth.panel_scene` on 404 x 404 px aerial ground with `mark=\"panel\"` (all others `mark=\"auto\"`).\n",
        "Boxes (S: the mark's size; R: its visible radius, S/2, and 0.075 S for the Zeiss dot): **tight**, the "
        "pixels within R + 2 px of the centre; **mid**, 4 S square (the mark plus 1.5 S around it, bench_marks' "
        "120 px window), its centre up to S/2 from the mark's per axis; **loose 4x / 10x**, 4 S / 10 S square with "
        "the mark's centre anywhere at least R inside each edge; every box clipped to the image. **baseline**: "
        "what aerofid did before `locate` searched, `make_detector(\"auto\", mark, {})` on the grey crop of the "
        "same mid box (nothing read outside it); its time is the detector's alone. Every other row is "
        "`aerofid.locate(image, box, mark=mark)`, timed whole (screening, every measurement, the one-mark rule).\n",
        "*found*: status found; *wrong*: found but further than 1.5 px (0.5 px) from the truth; RMS and max error "
        "over the found answers; *median sigma*: of the reported `sigma` (per axis); *RMS err / RMS sigma*: the RMS "
        "error per axis, sqrt(mean(dx^2 + dy^2) / 2), over the RMS reported sigma (1 when the sigma is honest; over "
        "the answers within 1.5 px, wrong answers would swamp it).\n",
        *head, *main_tab, *lists, *rej, *spread]
    write_atomic(args.out, "\n".join(parts) + "\n")
    print(f"wrote {args.out} in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
