"""``aerofid.locate`` on regions: random loose boxes on the real Wild RC20 frame, then time and peak memory
against the region's size (the RC20 JPEG and a synthetic 20000 x 20000 tiled TIFF).

    python benchmarks/bench_regions.py [--out docs/benchmarks_regions.md] [--boxes 16] [--seed 20240611]

Part 1, loose boxes. The frame ../shared/realdata/unbc_bc_wild_rc20/15BCC02013_114.jpg (5908 x 5408 RGB JPEG)
is opened once (``aerofid.io.raster.open_raster``) and for each of its 8 fiducial marks ``--boxes`` random square
boxes are drawn (side uniform in 100..420 px, the mark's reference centre at least 45 px inside each edge, the
box inside the image; one generator ``numpy.random.default_rng(seed)``) and located with
``aerofid.locate(raster, box)`` (default mark and method). The reference centres are auto's answers in centred
120 px boxes (docs/benchmarks_rc20.md). Per mark: found n / N, the largest distance to the reference, the
box-to-box spread (std per axis of the found centres) against the median reported sigma_x / sigma_y, the
median and largest time per box.

Part 2, region size. Each case is ``aerofid.locate(path, box)`` in a fresh subprocess (this script with
``--child``): peak RSS is ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` after the call, as it is (the RSS of a
process that only imported aerofid is given as the baseline). Square regions around the top-left corner mark
(placed so the mark is inside but not centred: 0.3 and 0.4 of the side from the left and top edges, clipped to
the image) and the whole image, on the RC20 JPEG and on a synthetic 20000 x 20000 uint8 tiled TIFF (256 px
zlib tiles, a dark film-like ground with grain and 8 Wild-like fiducials at known sub-pixel positions; written
tile row by tile row into a temporary directory and deleted afterwards). Small regions are run 3 times (the
median is reported), the largest once. Stages are timed by wrapping (in the child only) the raster's
``__init__`` (opening; a JPEG that fits the budget is decoded whole there), ``aerofid.locate``'s
``screen_region`` (screening, which includes the reduced read) and ``Raster.read_reduced``.

The script skips cleanly (exit 0, no report written) when ../shared/realdata is absent; the data never enters
the repository. OPENBLAS / OMP threads are set to 1.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import tifffile  # noqa: E402

import aerofid  # noqa: E402
from aerofid import synth  # noqa: E402
from aerofid.io.raster import Raster, open_raster  # noqa: E402

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "unbc_bc_wild_rc20" / "15BCC02013_114.jpg"
REAL_SHOWN = "../shared/realdata/unbc_bc_wild_rc20/15BCC02013_114.jpg"
REFERENCE = {  # auto's answers in centred 120 px boxes, docs/benchmarks_rc20.md (x, y)
    "corner TL": (652.66, 189.13), "corner TR": (5672.11, 199.90), "corner BL": (648.55, 5201.39),
    "corner BR": (5666.64, 5213.44), "midside T": (3167.49, 99.37), "midside B": (3162.52, 5302.29),
    "midside L": (554.71, 2695.41), "midside R": (5763.82, 2706.96),
}
APPROX = {  # bench_rc20.py's approximate centres: its 120 px crops, in which the reference was measured
    "corner TL": (665, 179), "corner TR": (5690, 202), "corner BL": (660, 5213), "corner BR": (5678, 5225),
    "midside T": (3183, 98), "midside B": (3146, 5302), "midside L": (554, 2679), "midside R": (5764, 2723),
}
EXTRA_RC20 = ("641 px, border and image (extra)", (172, 842, 813, 1483))
"""A region with no fiducial, half film border, half image area: a large screening candidate in the image makes
the circles detector vote on a 613 px window (peak memory; see the report)."""
SIDE = (100, 420)
INSIDE = 45
WRONG_PX = 1.5
RC20_SIDES = (200, 400, 800, 1400, 2800)
TIFF_SIZE = 20000
TIFF_TILE = 256
TIFF_SIDES = (200, 400, 800, 1400, 2800, 5600, 11200)
SMALL_SIDE = 1400
"""Regions up to this side are run 3 times, larger ones and whole images once."""
OFFSET = (0.3, 0.4)
"""The corner mark lies this share of the region's side from its left and top edges (before clipping)."""
MARK_SIZE = 120.0
"""Diameter (px) of the synthetic fiducials: a 1.5 mm ring at 12.5 um per pixel."""
TIFF_MARKS = {  # (x, y, style); each y is in the middle of a tile row, so a mark lies in one written strip
    "corner TL": (1216.37, 1152.62, "ring_x_dot"), "midside T": (10000.21, 1152.41, "ring_cross"),
    "corner TR": (18784.73, 1152.28, "ring_x_dot"), "midside L": (1216.55, 10112.83, "ring_cross"),
    "midside R": (18784.12, 10112.47, "ring_cross"), "corner BL": (1216.81, 18816.35, "ring_x_dot"),
    "midside B": (10000.64, 18816.71, "ring_cross"), "corner BR": (18784.29, 18816.16, "ring_x_dot"),
}
CHILD_TIMEOUT = 900
LAUNCH = ("/bin/sh", "-c", '"$0" "$@"; exit $?')
"""Children are started through a shell that forks them (the command is not its last, so it cannot exec it):
a process started by Python's subprocess directly (vfork + exec) inherits the parent's peak RSS in its
``ru_maxrss`` (Linux keeps the larger of the old and new address spaces' high-water marks across exec), and this
process holds the decoded frame of part 1; a forked grandchild of the small shell starts from the shell's."""


# --- part 1: random loose boxes ---------------------------------------------------------------------------

def random_boxes(rng: np.random.Generator, centre: tuple[float, float], n: int, width: int,
                 height: int) -> list[tuple[int, int, int, int]]:
    """``n`` square boxes of side uniform in SIDE, ``centre`` at least INSIDE px inside each edge, in the image."""
    cx, cy = centre
    out = []
    for _ in range(n):
        s = int(rng.integers(SIDE[0], SIDE[1] + 1))
        x0 = int(rng.integers(max(0, int(np.ceil(cx + INSIDE - s))), min(width - s, int(np.floor(cx - INSIDE))) + 1))
        y0 = int(rng.integers(max(0, int(np.ceil(cy + INSIDE - s))), min(height - s, int(np.floor(cy - INSIDE))) + 1))
        out.append((x0, y0, x0 + s, y0 + s))
    return out


def first_words(reason: str, n: int = 6) -> str:
    words = reason.replace("|", "/").split()
    return " ".join(words[:n]) + (" ..." if len(words) > n else "")


def loose_boxes(n: int, seed: int) -> tuple[list[str], dict]:
    """Part 1: the table rows, the misses and the overall numbers."""
    rng = np.random.default_rng(seed)
    rows, misses, all_d, ratios = [], [], [], []
    found_total = 0
    times: list[float] = []
    slowest = (0.0, "", ())
    medians: dict = {}
    with open_raster(REAL) as raster:
        for name, ref in REFERENCE.items():
            xs, ys, sx, sy, ts, ds = [], [], [], [], [], []
            for box in random_boxes(rng, ref, n, raster.width, raster.height):
                t = time.perf_counter()
                loc = aerofid.locate(raster, box)
                ts.append(time.perf_counter() - t)
                slowest = max(slowest, (ts[-1], name, box))
                if not loc.found:
                    misses.append(f"| {name} | {box} | {first_words(loc.reason, 12)} |")
                    continue
                xs.append(loc.x)
                ys.append(loc.y)
                sx.append(loc.sigma_x)
                sy.append(loc.sigma_y)
                ds.append(float(np.hypot(loc.x - ref[0], loc.y - ref[1])))
                if ds[-1] > WRONG_PX:
                    misses.append(f"| {name} | {box} | found at {loc.x:.2f}, {loc.y:.2f}: {ds[-1]:.2f} px off |")
            found_total += len(xs)
            times += ts
            all_d += ds
            rows.append(loose_row(name, n, xs, ys, sx, sy, ts, ds, ratios))
            if xs:
                medians[name] = (float(np.median(xs)), float(np.median(ys)), float(np.median(sx)),
                                 float(np.median(sy)))
            print(f"  {name}: {len(xs)}/{n} found, {np.sum(ts):.1f} s", flush=True)
        crops = crop_rows(raster, medians)
    summary = {"found": found_total, "n": n * len(REFERENCE), "max_d": max(all_d, default=float("nan")),
               "wrong": sum(d > WRONG_PX for d in all_d), "max_ratio": max(ratios, default=float("nan")),
               "median_t": float(np.median(times)), "slowest": slowest, "misses": misses, "crops": crops}
    return rows, summary


def crop_rows(raster: Raster, medians: dict) -> list[str]:
    """auto on bench_rc20.py's 120 px crops (nothing read beyond them) with today's code, against the reference
    and the loose boxes' median answer (also per axis in units of the boxes' median sigma: another window's
    answer, so a check that the sigma covers the window)."""
    rows = []
    for name, (x, y) in APPROX.items():
        box = (x - 60, y - 60, x + 60, y + 60)
        crop = np.ascontiguousarray(raster.read_window(box))
        loc = aerofid.locate(crop, (0, 0, 120, 120), mark="external")
        ref, med = REFERENCE[name], medians.get(name)
        if not loc.found:
            rows.append(f"| {name} | {box} | not found: {first_words(loc.reason)} | - | - | - |")
            continue
        cx, cy = loc.x + box[0], loc.y + box[1]
        to_med = f"{float(np.hypot(cx - med[0], cy - med[1])):.3f}" if med else "-"
        in_sigma = f"{abs(cx - med[0]) / med[2]:.1f}, {abs(cy - med[1]) / med[3]:.1f}" if med else "-"
        rows.append(f"| {name} | {box} | {cx:.2f}, {cy:.2f} (sigma {loc.sigma_x:.3f}, {loc.sigma_y:.3f}) | "
                    f"{float(np.hypot(cx - ref[0], cy - ref[1])):.3f} | {to_med} | {in_sigma} |")
    return rows


def loose_row(name: str, n: int, xs: list, ys: list, sx: list, sy: list, ts: list, ds: list,
              ratios: list) -> str:
    """One mark's row of the part 1 table (``ratios`` collects spread / sigma)."""
    t = f"{1000 * np.median(ts):.0f} / {1000 * np.max(ts):.0f}"
    if not xs:
        return f"| {name} | 0/{n} | - | - | - | - | - | - | {t} |"
    mx, my = float(np.median(xs)), float(np.median(ys))
    ref = REFERENCE[name]
    if len(xs) >= 2:
        spread = (float(np.std(xs, ddof=1)), float(np.std(ys, ddof=1)))
        span = max(float(np.hypot(a - c, b - d)) for a, b in zip(xs, ys) for c, d in zip(xs, ys))
    else:
        spread, span = (float("nan"), float("nan")), float("nan")
    sig = (float(np.median(sx)), float(np.median(sy)))
    r = (spread[0] / sig[0], spread[1] / sig[1])
    ratios.extend(v for v in r if np.isfinite(v))
    return (f"| {name} | {len(xs)}/{n} | {mx - ref[0]:+.3f}, {my - ref[1]:+.3f} | {max(ds):.3f} | "
            f"{spread[0]:.4f}, {spread[1]:.4f} ({span:.3f}) | {sig[0]:.4f}, {sig[1]:.4f} | "
            f"{min(sx):.4f}-{max(sx):.4f}, {min(sy):.4f}-{max(sy):.4f} | {r[0]:.2f}, {r[1]:.2f} | "
            f"{t} |")


# --- part 2: one case in a fresh process ------------------------------------------------------------------

def _timed(fn, key: str, acc: dict):
    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[key] = acc.get(key, 0.0) + time.perf_counter() - t
    return wrapper


def child(path: str, box: tuple[int, ...]) -> int:
    """Locate in ``box`` of ``path`` once; print one JSON line of times, RSS and the answer."""
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    acc: dict = {}
    locate_module = importlib.import_module("aerofid.locate")  # import aerofid is lazy: load it before timing
    if hasattr(locate_module, "screen_region"):
        locate_module.screen_region = _timed(locate_module.screen_region, "screen", acc)
    Raster.__init__ = _timed(Raster.__init__, "open", acc)
    Raster.read_reduced = _timed(Raster.read_reduced, "reduced", acc)
    t = time.perf_counter()
    loc = aerofid.locate(path, box)
    total = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    hwm = re.search(r"VmHWM:\s+(\d+)", Path("/proc/self/status").read_text())
    search = loc.search
    out = {"total": total, "open": acc.get("open"), "screen": acc.get("screen"), "reduced": acc.get("reduced"),
           "rss_before_kb": rss_before, "peak_kb": peak,
           "hwm_kb": int(hwm.group(1)) if hwm else None, "found": loc.found, "x": loc.x, "y": loc.y,
           "reason": loc.reason, "marks": [] if search is None else [(m.x, m.y) for m in search.marks],
           "reduction": None if search is None else search.reduction,
           "candidates": None if search is None else len(search.candidates),
           "attempts": None if search is None else len(search.attempts)}
    print(json.dumps(out))
    return 0


def run_case(path: Path, box: tuple[int, int, int, int], repeats: int) -> dict:
    """``repeats`` fresh processes on one case: the median time and peak, the answer of the first."""
    runs = []
    for _ in range(repeats):
        cmd = [*LAUNCH, sys.executable, str(Path(__file__).resolve()), "--child", str(path), *map(str, box)]
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=CHILD_TIMEOUT)
        if p.returncode != 0:
            raise RuntimeError(f"child {cmd} failed ({p.returncode}):\n{p.stderr[-2000:]}")
        runs.append(json.loads(p.stdout.strip().splitlines()[-1]))
    first = dict(runs[0])
    for key in ("total", "open", "screen", "reduced", "peak_kb", "rss_before_kb", "hwm_kb"):
        vals = [r[key] for r in runs if r[key] is not None]
        first[key] = float(np.median(vals)) if vals else None
    first["totals"] = [r["total"] for r in runs]
    first["repeats"] = repeats
    return first


def baseline_rss_kb() -> int:
    """Peak RSS of a fresh process that only imports aerofid."""
    code = "import resource, aerofid; print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
    p = subprocess.run([*LAUNCH, sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(p.stdout)


def region_box(mark: tuple[float, float], side: int, width: int, height: int) -> tuple[int, int, int, int]:
    """A square region of ``side`` with ``mark`` at OFFSET of the side from its left and top (clipped)."""
    x0 = min(max(0, int(round(mark[0] - OFFSET[0] * side))), max(0, width - side))
    y0 = min(max(0, int(round(mark[1] - OFFSET[1] * side))), max(0, height - side))
    return x0, y0, min(width, x0 + side), min(height, y0 + side)


def marks_in(box: tuple[int, ...], marks: dict) -> int:
    return sum(box[0] - 0.5 <= p[0] < box[2] - 0.5 and box[1] - 0.5 <= p[1] < box[3] - 0.5 for p in marks.values())


def answer_text(r: dict, truth: dict, box: tuple[int, ...]) -> str:
    """found at x, y (error to the nearest truth) / not found: first words; the number of marks named."""
    if r["found"]:
        d = min(float(np.hypot(r["x"] - p[0], r["y"] - p[1])) for p in truth.values())
        if d > WRONG_PX:
            return f"found {r['x']:.2f}, {r['y']:.2f}: no fiducial there (the nearest reference is {d:.0f} px away)"
        return f"found {r['x']:.2f}, {r['y']:.2f} ({d:.3f} px from the nearest reference)"
    named = len(r["marks"])
    extra = ""
    if named:
        far = [m for m in r["marks"] if min(np.hypot(m[0] - p[0], m[1] - p[1]) for p in truth.values()) > WRONG_PX]
        extra = f"; {named} marks named, {named - len(far)} of them fiducials" + (
            f" (others at {', '.join(f'{m[0]:.0f}, {m[1]:.0f}' for m in far)})" if far else "")
        inside = {k: p for k, p in truth.items() if marks_in(box, {k: p})}
        missed = [k for k, p in inside.items()
                  if all(np.hypot(m[0] - p[0], m[1] - p[1]) > WRONG_PX for m in r["marks"])]
        extra += f"; not named: {', '.join(missed)}" if missed else ""
    return f"not found: {first_words(r['reason'])}{extra}"


def sec(v: float | None) -> str:
    return "-" if v is None else f"{v:.2f}"


def mb(kb: float | None) -> str:
    return "-" if kb is None else f"{kb * 1024 / 1e6:.0f}"


def size_rows(path: Path, cases: list[tuple[str, tuple[int, int, int, int]]], truth: dict,
              results: dict) -> list[str]:
    """Part 2 table rows for one image (``results`` collects each case's result by label)."""
    rows = []
    for label, box in cases:
        area = (box[2] - box[0]) * (box[3] - box[1])
        repeats = 3 if max(box[2] - box[0], box[3] - box[1]) <= SMALL_SIDE else 1
        r = results[label] = run_case(path, box, repeats)
        r["area"] = area
        screen = r["screen"]
        per_mpx = f"{screen / (area / 1e6):.3f}" if screen is not None else "-"
        rows.append(f"| {label} | {box} | {area / 1e6:.2f} | {marks_in(box, truth)} | {repeats} | "
                    f"{sec(r['total'])} | {sec(r['open'])} | {sec(screen)} | {sec(r['reduced'])} | {per_mpx} | "
                    f"{sec(r['total'] - (r['open'] or 0) - (screen or 0))} | {r['reduction']} | "
                    f"{r['candidates']} / {r['attempts']} | {r['peak_kb'] * 1024 / 1e6:.0f} | {mb(r['hwm_kb'])} | "
                    f"{answer_text(r, truth, box)} |")
        print(f"  {label} {box}: {r['totals']} s, {r['peak_kb'] / 1024:.0f} MiB peak", flush=True)
    return rows


# --- the synthetic 20000 x 20000 TIFF ---------------------------------------------------------------------

def tiff_tiles(seed: int):
    """The tiles of the synthetic scan, row-major, one tile row (strip) at a time."""
    rng = np.random.default_rng(seed)
    n = -(-TIFF_SIZE // TIFF_TILE)
    cols = np.arange(n * TIFF_TILE, dtype=np.float32)[None, :] / TIFF_SIZE
    for k in range(n):
        r0 = k * TIFF_TILE
        rows = (r0 + np.arange(TIFF_TILE, dtype=np.float32)[:, None]) / TIFF_SIZE
        strip = 0.06 + 0.02 * cols + 0.015 * rows  # a gentle density gradient over the film border
        for x, y, style in TIFF_MARKS.values():
            if r0 <= y < r0 + TIFF_TILE:
                shape = synth.mark_shape(style, MARK_SIZE, angle_deg=0.3, width=4.0)
                strip = synth.paint_shape(strip, (x, y - r0), shape, 0.75, supersample=8, extent=MARK_SIZE / 2 + 3)
        strip = synth.add_grain(synth.blur(strip, 0.8), 0.012, rng)
        u8 = synth.to_uint8(np.clip(strip, 0.0, 1.0))
        for j in range(n):
            yield u8[:, j * TIFF_TILE:(j + 1) * TIFF_TILE]


def make_tiff(path: Path, seed: int) -> None:
    """Write the synthetic scan to ``path``: one strip of tiles in memory at a time."""
    for x, y, _ in TIFF_MARKS.values():  # each mark (and its blur) inside one tile row
        r0 = int(y // TIFF_TILE) * TIFF_TILE
        assert r0 + MARK_SIZE / 2 + 6 <= y and y + MARK_SIZE / 2 + 6 <= r0 + TIFF_TILE, (x, y)
    tifffile.imwrite(path, tiff_tiles(seed), shape=(TIFF_SIZE, TIFF_SIZE), dtype=np.uint8,
                     tile=(TIFF_TILE, TIFF_TILE), compression="zlib", photometric="minisblack", maxworkers=1)


# --- the report -------------------------------------------------------------------------------------------

SIZE_HEADER = ["| region | box | Mpx | fiducials in it | runs | total (s) | open (s) | screen (s) | of which "
               "reduced read (s) | screen (s / Mpx) | measure (s) | reduction | candidates / measured | peak RSS (MB) "
               "| VmHWM (MB) | answer |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]


def loose_part(args) -> tuple[list[str], dict]:
    rows, s = loose_boxes(args.boxes, args.seed)
    rate = s["found"] / s["n"]
    out = ["## 1. Random loose boxes on the real frame\n",
           f"{args.boxes} boxes per mark, side uniform in {SIDE[0]}..{SIDE[1]} px, the reference centre at least "
           f"{INSIDE} px inside each edge, each box inside the image (`numpy.random.default_rng({args.seed})`, "
           "marks in the table's order). One open raster, `aerofid.locate(raster, box)`, default mark and method. "
           "Offset: the median found centre minus the reference; max d: the largest distance of a found centre to "
           "the reference; spread: std per axis of the found centres (ddof 1) and, in brackets, the largest "
           "distance between two of them; sigma: the median reported sigma_x, sigma_y, and their smallest and "
           "largest over the boxes (the same in every box when the sigma does not depend on the box).\n",
           "| mark | found | offset x, y (px) | max d (px) | spread x, y (px) | sigma x, y (px) | sigma x, y over the "
           "boxes (px) | spread / sigma x, y | median / max time (ms) |", "|---|---|---|---|---|---|---|---|---|",
           *rows,
           f"\nOverall: **found {s['found']}/{s['n']} ({100 * rate:.1f} %)** (target >= 98 %); largest distance to "
           f"the reference **{s['max_d']:.3f} px**, answers > {WRONG_PX} px from it: **{s['wrong']}** (target none); "
           f"largest spread / sigma **{s['max_ratio']:.2f}** (target <= ~1.5-2); time per box median "
           f"{1000 * s['median_t']:.0f} ms, largest {1000 * s['slowest'][0]:.0f} ms ({s['slowest'][1]}, box "
           f"{s['slowest'][2]}).\n"]
    out += ["The reference was measured with an earlier state of the code on bench_rc20.py's 120 px crops, with "
            "nothing read beyond the crop. The same crops with today's code:\n",
            "| mark | crop (full-image box) | auto on the crop: x, y | to the reference (px) | to the loose boxes' "
            "median (px) | per axis, in the boxes' sigma |", "|---|---|---|---|---|---|", *s["crops"], ""]
    if s["misses"]:
        out += ["Boxes not found or answered wrong (reproduce: `aerofid.locate(\"" + REAL_SHOWN + "\", box)`):\n",
                "| mark | box | answer |", "|---|---|---|", *s["misses"], ""]
    return out, s


def size_part(args, base_kb: int) -> list[str]:
    with open_raster(REAL) as r:
        w, h = r.width, r.height
    tl = REFERENCE["corner TL"]
    cases = [(f"{s} px", region_box(tl, s, w, h)) for s in RC20_SIDES] + [("whole frame", (0, 0, w, h)), EXTRA_RC20]
    print("region sizes, RC20 JPEG", flush=True)
    res_rc20: dict = {}
    rc20 = size_rows(REAL, cases, REFERENCE, res_rc20)
    res_tiff: dict = {}
    tmp = Path(tempfile.mkdtemp(prefix="aerofid_regions_"))
    try:
        path = tmp / "synthetic_20000.tif"
        t = time.perf_counter()
        make_tiff(path, args.seed)
        t_make, mb = time.perf_counter() - t, path.stat().st_size / 1e6
        print(f"synthetic TIFF written in {t_make:.0f} s ({mb:.0f} MB)", flush=True)
        truth = {k: v[:2] for k, v in TIFF_MARKS.items()}
        tl = truth["corner TL"]
        cases = [(f"{s} px", region_box(tl, s, TIFF_SIZE, TIFF_SIZE)) for s in TIFF_SIDES]
        cases.append(("whole image", (0, 0, TIFF_SIZE, TIFF_SIZE)))
        tiff = size_rows(path, cases, truth, res_tiff)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    marks = "; ".join(f"{k} {v[0]:.2f}, {v[1]:.2f} ({v[2]})" for k, v in TIFF_MARKS.items())
    return ["## 2. Time and peak memory against region size\n",
            f"Each row is `aerofid.locate(path, box)` (default mark and method) in a fresh process; runs: how many "
            f"processes (3 for regions up to {SMALL_SIDE} px, else 1), times and peak are their medians. Peak RSS "
            "is `ru_maxrss` after the call, as it is (VmHWM of /proc/self/status, the high-water mark of the process's "
            "own address space, as a check): a process that only ran `import aerofid` peaks at "
            f"**{base_kb * 1024 / 1e6:.0f} MB** (MB = 10^6 bytes). Stages: open (a JPEG within the decode budget "
            "is decoded whole here), screen (`screen_region`, including the reduced read), measure (the rest: "
            "the detectors on windows around the candidates, re-centring, the one-mark rule). The regions hold "
            "the top-left corner mark 0.3 / 0.4 of their side from their left / top edge (clipped to the image); "
            "'fiducials in it' counts the reference centres inside the box. Each process is started through "
            "`/bin/sh -c '\"$0\" \"$@\"; exit $?'`, which forks it: started directly by `subprocess` (vfork + exec), "
            "a child's `ru_maxrss` starts at this process's own peak (it holds the decoded frame of part 1): in a "
            "first run every row, the import-only baseline too, read the same ~750 MB.\n",
            f"### The RC20 JPEG ({w} x {h} RGB, `{REAL_SHOWN}`)\n", *SIZE_HEADER, *rc20,
            f"\n### A synthetic {TIFF_SIZE} x {TIFF_SIZE} tiled TIFF\n",
            f"uint8 grey, {TIFF_TILE} px zlib tiles, {mb:.0f} MB on disk, written in {t_make:.0f} s tile row by tile "
            "row (`tifffile.imwrite` from a generator of tiles) into a temporary directory, deleted afterwards. "
            "Ground: film border grey 0.06 with a gradient of 0.02-0.035 and grain (std 0.012, 1.2 px); marks: "
            f"`aerofid.synth.mark_shape` rings of {MARK_SIZE:.0f} px with an X (corners) or a '+' (midsides), "
            f"4 px lines, grey 0.75, blurred 0.8 px, at (x, y): {marks}. The reference for 'answer' is these "
            "positions.\n", *SIZE_HEADER, *tiff, *size_summary(res_rc20, res_tiff), ""]


def size_summary(rc20: dict, tiff: dict) -> list[str]:
    """The targets of part 2 against this run's numbers."""
    everything = [*(("RC20 " + k, r) for k, r in rc20.items()), *(("TIFF " + k, r) for k, r in tiff.items())]
    label, worst = max(everything, key=lambda kr: kr[1]["peak_kb"])
    peak = worst["peak_kb"] * 1024 / 1e6
    big = [r for r in tiff.values() if r["area"] >= 30e6 and r["reduced"]]
    read = ", ".join(f"{1000 * r['reduced'] / (r['area'] / 1e6):.1f}" for r in big)
    screen = ", ".join(f"{r['screen']:.2f} s at {r['area'] / 1e6:.3g} Mpx" for r in tiff.values() if r["screen"])
    return ["\n### Targets\n",
            f"- Peak memory < 1 GB for any region up to the whole frame: largest peak RSS **{peak:.0f} MB** "
            f"({label}): {'met' if peak < 1000 else '**not met**'}.",
            f"- Screening roughly linear in area: the screening stage of the TIFF took {screen}. The reduced read "
            f"costs {read} ms per Mpx for the regions of 30 Mpx and more (linear in area); the screening on the "
            "reduced image is bounded by the reduction (at most 2 Mpx are screened), so the whole stage grows "
            "more slowly than the area.",
            f"- 1400 px region \"a few seconds\": **{rc20['1400 px']['total']:.1f} s** on the RC20 JPEG (of which "
            f"{rc20['1400 px']['open']:.1f} s opening the JPEG), **{tiff['1400 px']['total']:.1f} s** on the TIFF."]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/benchmarks_regions.md")
    ap.add_argument("--boxes", type=int, default=16)
    ap.add_argument("--seed", type=int, default=20240611)
    ap.add_argument("--child", nargs=5, metavar=("PATH", "X0", "Y0", "X1", "Y1"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        return child(args.child[0], tuple(int(v) for v in args.child[1:]))
    if not REAL.exists():
        print(f"skipped: {REAL} is absent")
        return 0
    repo = Path(__file__).resolve().parents[1]
    git = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=repo).stdout
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "src"], capture_output=True, text=True,
                           cwd=repo).stdout
    t0 = time.time()
    load0 = os.getloadavg()
    print("loose boxes", flush=True)
    part1, _ = loose_part(args)
    base_kb = baseline_rss_kb()
    part2 = size_part(args, base_kb)
    load1 = os.getloadavg()
    cmd = " ".join(["python benchmarks/bench_regions.py", *sys.argv[1:]])
    commit = (git.strip() or "?") + (" with uncommitted changes in src/" if dirty else "")
    head = ["# Regions: loose boxes on the real RC20 frame; time and memory against region size\n",
            f"Produced by `{cmd}` on {platform.machine()} ({os.cpu_count()} cores, shared: load average "
            f"{load0[0]:.1f} at the start, {load1[0]:.1f} at the end, so times are noisy) / Python "
            f"{platform.python_version()}, numpy {np.__version__}, OPENBLAS / OMP threads 1, in "
            f"{time.time() - t0:.0f} s, at commit {commit}. Frame: `{REAL_SHOWN}` (not in the repository).\n"]
    out = Path(args.out)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text("\n".join(head + part1 + part2) + "\n")
    tmp.replace(out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
