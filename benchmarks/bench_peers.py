"""aerofid's methods and ``auto`` against template matching (OpenCV) and hipp's fiducial matcher, same boxes.

    python benchmarks/bench_peers.py [--n 20] [--repeats 3] [--hipp PYTHON] [--out docs/benchmarks_peers.md]

Synthetic part: per mark style, ``n`` scenes of a 200 x 200 px box (the moderate condition of
bench_marks.py: marks 20-44 px, random rotation and sub-pixel centre, blur 0.5-1.0 px, noise 0.02; cloth
panels of 7-11 px on aerial ground, ``synth.panel_scene``), the whole box given to every contender:

- aerofid: each method and ``auto`` as ``locate`` configures them (``make_detector``), and ``aerofid.locate`` of the
  whole box (the user's call: the box screened, its candidates measured on their windows and re-centred, the
  one-mark rule; a cloth panel's box measured whole first);
- ``tm exact``: OpenCV ``matchTemplate`` (TM_CCOEFF_NORMED) with the exact noise-free template (same
  renderer, style, size, angle, blur and contrast, the mark on a pixel centre), sub-pixel by a parabola
  through the score peak and its neighbours on each axis;
- ``tm +10 %``: the same with a template rendered 10 % larger (a template from another camera or scan);
- ``hipp``: ``hipp.aerial.core.detect_fiducial`` (hipp 0.2.0: coarse TM_CCOEFF_NORMED, then the matched
  crop upscaled 8 x by bicubic interpolation and matched with an upscaled template) with the exact
  template, run by the interpreter ``--hipp`` (a separate virtual environment: hipp is no dependency of
  aerofid) in one worker process that times its own calls. hipp reports pixel-corner coordinates
  (centre = match + size / 2); 0.5 px is subtracted to give aerofid's pixel-centre convention.

Template matching and hipp always answer: *found* for them is every box, and an answer further than 1.5 px
from the truth counts as wrong. RMS is over the answers within 1.5 px for every contender.

Real part: the 8 fiducial marks of the Wild RC20 frame in the boxes of bench_rc20.py (120 x 120 px around the
approximate centres). aerofid's methods measure the grey window ``locate`` would give them (``to_grey(crop,
"auto")``: the channel mix with the most mark contrast), the peers the red channel (the marks are printed in
red); the template is cut (30 px half-size) from the corner TL box for the corners and from the midside T box
for the midsides around ``auto``'s centre there (so TL and T match themselves). No ground truth: the accuracy
row is the RMS residual (um) of an affine fit of the four corners to their calibrated coordinates (as in
bench_rc20.py), the next the largest distance from ``auto``'s centre.

Times: wall time of one call on the box, the median over the scenes of each scene's median of ``repeats`` calls, all
in one run, one thread; each call is a first call on its box, as a user's is (what aerofid keeps of a box's window
analyses and fits is forgotten before it, ``aerofid.kept.forget_kept``; before session 39 the second and third calls
reused them: notch dots' median 47 ms against 75 for a first call). Last, the command line as a user runs it:
``aerofid locate`` of one RC20 box in a fresh interpreter (start-up, imports, the JPEG's decode, the search) and its
imports alone, each the median of ``2 * repeats + 1`` runs after one untimed run, with the package's bytecode
written (as ``pip install`` leaves it; runs before session 11 compiled the changed modules in every call where the
environment set PYTHONDONTWRITEBYTECODE, as this machine's does)."""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

import aerofid  # noqa: E402
from aerofid import synth  # noqa: E402
from aerofid.formats.camera_file import read_camera  # noqa: E402
from aerofid.io.colour import to_grey  # noqa: E402
from aerofid.io.raster import open_raster  # noqa: E402
from aerofid.methods import make_detector  # noqa: E402
from aerofid.orientation.adjustment import adjust  # noqa: E402
from bench_marks import LABEL, STYLES  # noqa: E402
from bench_rc20 import CALIBRATED, HALF, MARKS, REAL  # noqa: E402

cv2.setNumThreads(1)

BOX = 200
"""Side (px) of the synthetic boxes."""
METHODS = ("hough", "symmetry", "circles", "lines", "auto")
PEERS = ("tm exact", "tm +10 %", "hipp")
WRONG = 1.5
"""An answer further than this (px) from the truth is wrong."""
SUBPIXEL = 8
"""hipp's default upscaling factor of its sub-pixel stage."""
REAL_TEMPLATE_HALF = 30
"""Half-size (px) of the templates cut from the real frame."""

HIPP_WORKER = r"""
import json, sys, time
import numpy as np
from hipp.aerial.core import detect_fiducial
for line in sys.stdin:
    job = json.loads(line)
    img = np.load(job["img"]); tpl = np.load(job["tpl"]); sub = np.load(job["sub"])
    times = []
    for _ in range(job["repeats"]):
        t = time.perf_counter()
        (x, y), score = detect_fiducial(img, tpl, sub, job["factor"])
        times.append(time.perf_counter() - t)
    print(json.dumps({"x": float(x), "y": float(y), "t": float(np.median(times))}), flush=True)
"""


class Hipp:
    """hipp's ``detect_fiducial`` in a worker process of another interpreter (None when it cannot start)."""

    def __init__(self, python: str | None, tmp: Path):
        self.proc = None
        self.why = "no interpreter with hipp given (--hipp)"
        self.tmp = tmp
        if not python:
            return
        check = subprocess.run([python, "-c", "import importlib.metadata as m, hipp.aerial.core; "
                                "print(m.version('hipp'))"],
                               capture_output=True, text=True)
        if check.returncode != 0:
            self.why = "hipp does not import: " + (check.stderr.strip().splitlines() or ["?"])[-1]
            return
        self.version = check.stdout.strip()
        self.proc = subprocess.Popen([python, "-c", HIPP_WORKER], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})

    def __call__(self, img_u8: np.ndarray, tpl_u8: np.ndarray, centre: tuple[float, float],
                 repeats: int) -> tuple[float, float, float]:
        """(x, y, median seconds) for the template ``tpl_u8`` whose mark centre is ``centre`` (pixel centres)."""
        sub = hipp_subpixel_template(tpl_u8, centre)
        paths = {}
        for k, a in (("img", img_u8), ("tpl", tpl_u8), ("sub", sub)):
            paths[k] = str(self.tmp / f"{k}.npy")
            np.save(paths[k], np.ascontiguousarray(a))
        assert self.proc is not None and self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(json.dumps({**paths, "repeats": repeats, "factor": SUBPIXEL}) + "\n")
        self.proc.stdin.flush()
        out = json.loads(self.proc.stdout.readline())
        return out["x"] - 0.5, out["y"] - 0.5, out["t"]


def hipp_subpixel_template(tpl: np.ndarray, centre: tuple[float, float]) -> np.ndarray:
    """hipp's sub-pixel template: the template upscaled ``SUBPIXEL`` x (bicubic, as hipp's ``resize_img``),
    cut so that its middle (hipp: offset + size / 2, pixel corners) falls on the mark's centre, 2 px in from
    the template's edges on the nearer side."""
    f = SUBPIXEL
    up = cv2.resize(tpl, (tpl.shape[1] * f, tpl.shape[0] * f), interpolation=cv2.INTER_CUBIC)
    cx, cy = ((c + 0.5) * f for c in centre)  # the centre in upscaled pixel-corner coordinates
    half_x = int(min(cx, up.shape[1] - cx) - 2 * f)
    half_y = int(min(cy, up.shape[0] - cy) - 2 * f)
    x0, y0 = int(round(cx)) - half_x, int(round(cy)) - half_y
    return up[y0:y0 + 2 * half_y, x0:x0 + 2 * half_x]


def match_template(img: np.ndarray, tpl: np.ndarray, centre: tuple[float, float]) -> tuple[float, float]:
    """OpenCV TM_CCOEFF_NORMED, the peak refined by a parabola on each axis; the mark's centre in ``img``."""
    score = cv2.matchTemplate(img, tpl, cv2.TM_CCOEFF_NORMED)
    _, _, _, (mx, my) = cv2.minMaxLoc(score)
    h, w = score.shape

    def vertex(a: float, b: float, c: float) -> float:
        den = a - 2.0 * b + c
        return 0.5 * (a - c) / den if den < 0 else 0.0

    dx = vertex(score[my, mx - 1], score[my, mx], score[my, mx + 1]) if 0 < mx < w - 1 else 0.0
    dy = vertex(score[my - 1, mx], score[my, mx], score[my + 1, mx]) if 0 < my < h - 1 else 0.0
    return mx + dx + centre[0], my + dy + centre[1]


def timed(repeats: int, fn, *args, **kwargs):
    """(last result, median seconds) of ``repeats`` calls of ``fn(*args, **kwargs)``, each a first call on its box:
    what aerofid keeps of the box's window analyses and fits is forgotten before it (``forget_kept``)."""
    from aerofid.kept import forget_kept  # here: bench_paired.py's workers import this module with older versions

    times, out = [], None
    for _ in range(repeats):
        forget_kept()
        t = time.perf_counter()
        out = fn(*args, **kwargs)
        times.append(time.perf_counter() - t)
    return out, float(np.median(times))


def scene(style: str, rng: np.random.Generator) -> tuple[np.ndarray, float, float, str, dict]:
    """(box, truth x, y, mark, how it was rendered) for one mark in a BOX x BOX box."""
    if style == "panel":
        size = rng.uniform(7, 11)
        spec = {"size": size, "contrast": rng.uniform(0.2, 0.35), "angle": rng.uniform(0, 90)}
        sc = synth.panel_scene(rng, shape_hw=(BOX, BOX), size=size, contrast=spec["contrast"],
                               angle_deg=spec["angle"])
        m = sc.marks[0]
        spec["ground"] = float(np.median(sc.image[int(m.y) - 20:int(m.y) + 20, int(m.x) - 20:int(m.x) + 20]))
        return sc.image, m.x, m.y, "panel", spec
    spec = {"size": rng.uniform(20, 44), "blur": rng.uniform(0.5, 1.0), "contrast": rng.uniform(0.6, 0.85)}
    spec["angle"] = 0.0 if style == "notch_dot" else rng.uniform(0, 90)
    sc = synth.mark_scene(style, size=spec["size"], window=BOX, rng=rng, noise_sigma=0.02, blur_sigma=spec["blur"],
                          contrast=spec["contrast"], angle_deg=spec["angle"])
    m = sc.marks[0]
    return sc.image, m.x, m.y, "auto", spec


def template(style: str, spec: dict, scale: float = 1.0) -> tuple[np.ndarray, tuple[float, float]]:
    """The noise-free mark of ``spec`` (``scale`` x its size) on its ground, centred on a pixel centre."""
    size = spec["size"] * scale
    half = int(np.ceil((1.5 if style == "panel" else 0.75) * size)) + 4
    n = 2 * half + 1
    rng = np.random.default_rng(0)
    if style == "panel":
        sc = synth.panel_scene(rng, centre=(half, half), size=size, angle_deg=spec["angle"], contrast=spec["contrast"],
                               noise_sigma=0.0, ground=np.full((n, n), spec["ground"], np.float32))
    else:
        sc = synth.mark_scene(style, size=size, window=n, centre=(half, half), rng=rng, noise_sigma=0.0,
                              blur_sigma=spec["blur"], contrast=spec["contrast"], angle_deg=spec["angle"])
    return sc.image, (float(half), float(half))


def bench_synthetic(n: int, repeats: int, rng: np.random.Generator, hipp: Hipp) -> dict:
    """{(style, contender): (errors, times)} over ``n`` scenes per style."""
    out: dict = {}
    for style in STYLES:
        for _ in range(n):
            img, tx, ty, mark, spec = scene(style, rng)
            for m in METHODS:
                d, t = timed(repeats, make_detector(m, mark, {}), img)
                _record(out, style, m, (d.x, d.y) if d.found else None, (tx, ty), t)
            loc, t = timed(repeats, aerofid.locate, img, (0, 0, BOX, BOX), mark=mark)
            _record(out, style, "locate", (loc.x, loc.y) if loc.found else None, (tx, ty), t)
            for peer, scale in (("tm exact", 1.0), ("tm +10 %", 1.1)):
                tpl, c = template(style, spec, scale)
                xy, t = timed(repeats, match_template, img, tpl, c)
                _record(out, style, peer, xy, (tx, ty), t)
            if hipp.proc is not None:
                tpl, c = template(style, spec)
                hx, hy, t = hipp(synth.to_uint8(img), synth.to_uint8(tpl), c, repeats)
                _record(out, style, "hipp", (hx, hy), (tx, ty), t)
        print(f"{style} done", flush=True)
    return out


def _record(out: dict, style: str, who: str, xy, truth, t: float) -> None:
    errs, times = out.setdefault((style, who), ([], []))
    errs.append(float(np.hypot(xy[0] - truth[0], xy[1] - truth[1])) if xy is not None else np.nan)
    times.append(t)


def cell(errs: list[float], times: list[float]) -> str:
    e = np.asarray(errs, float)
    found = np.isfinite(e)
    ok = e[found & (e <= WRONG)]
    rms = f"{np.sqrt(np.mean(ok ** 2)):.3f}" if ok.size else "-"
    return f"{found.sum()}/{e.size}, {(e[found] > WRONG).sum()} wrong, {rms} px, {1000 * np.median(times):.1f} ms"


def synthetic_table(res: dict, who: tuple[str, ...]) -> list[str]:
    out = ["| style | " + " | ".join(who) + " |", "|---|" + "---|" * len(who)]
    for style in STYLES:
        out.append(f"| {LABEL[style]} | " + " | ".join(cell(*res[(style, w)]) if (style, w) in res else "-"
                                                     for w in who) + " |")
    return out


def red(rgb: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(rgb[..., 0]).astype(np.float32) / 255.0


def bench_real(repeats: int, hipp: Hipp) -> list[str]:
    """The RC20 table (module docstring), or why it was skipped."""
    if not REAL.exists():
        return [f"skipped: {REAL.name} is absent (../shared/realdata)"]
    with open_raster(REAL) as r:
        crops = {k: np.ascontiguousarray(r.read_window((x - HALF, y - HALF, x + HALF, y + HALF)))
                 for k, (x, y) in MARKS.items()}
    pos: dict = {}
    times: dict = {}
    for name, crop in crops.items():
        x0, y0 = MARKS[name][0] - HALF, MARKS[name][1] - HALF
        grey = to_grey(crop, "auto", "bright")
        for m in METHODS:
            d, t = timed(repeats, make_detector(m, "external", {}), grey)
            times.setdefault(m, []).append(t)
            pos[(name, m)] = (d.x + x0, d.y + y0) if d.found else None
        _, t = timed(repeats, aerofid.locate, crop, (0, 0, crop.shape[1], crop.shape[0]), mark="external")
        times.setdefault("locate", []).append(t)
    templates = {}
    for kind, src in (("corner", "corner TL"), ("midside", "midside T")):
        ax, ay = pos[(src, "auto")]
        x0, y0 = MARKS[src][0] - HALF, MARKS[src][1] - HALF
        cx, cy = int(round(ax - x0)), int(round(ay - y0))
        k = REAL_TEMPLATE_HALF
        templates[kind] = (red(crops[src])[cy - k:cy + k + 1, cx - k:cx + k + 1],
                           (ax - x0 - cx + k, ay - y0 - cy + k))
    for name, crop in crops.items():
        x0, y0 = MARKS[name][0] - HALF, MARKS[name][1] - HALF
        tpl, c = templates[name.split()[0]]
        img = red(crop)
        xy, t = timed(repeats, match_template, img, tpl, c)
        times.setdefault("tm", []).append(t)
        pos[(name, "tm")] = (xy[0] + x0, xy[1] + y0)
        if hipp.proc is not None:
            hx, hy, t = hipp(synth.to_uint8(img), synth.to_uint8(tpl), c, repeats)
            times.setdefault("hipp", []).append(t)
            pos[(name, "hipp")] = (hx + x0, hy + y0)
    who = METHODS + ("tm",) + (("hipp",) if hipp.proc is not None else ())
    out = ["| | " + " | ".join(who) + " |", "|---|" + "---|" * len(who)]
    out.append("| found of 8 | " + " | ".join(str(sum(pos[(k, w)] is not None for k in MARKS)) for w in who) + " |")
    out.append("| corners: affine RMS (um) | " + " | ".join(_corner_rms(pos, w) for w in who) + " |")
    out.append("| largest distance from auto (px) | " + " | ".join(_from_auto(pos, w) for w in who) + " |")
    out.append("| median ms per mark | " + " | ".join(f"{1000 * np.median(times[w]):.1f}" for w in who) + " |")
    out.append("| slowest mark ms | " + " | ".join(f"{1000 * np.max(times[w]):.1f}" for w in who) + " |")
    out.append(f"\n`aerofid.locate(crop, whole crop, mark=\"external\")` (auto, with the colour choice and the "
               f"re-centred windows of find.py) on the same boxes: median {1000 * np.median(times['locate']):.1f} ms, "
               f"slowest {1000 * np.max(times['locate']):.1f} ms.")
    return out


CLI_BOX = "605,119,725,239"
"""The box of the command-line timing: corner TL, in the image's top rows."""
CLI_BOX_BOTTOM = "600,5153,720,5273"
"""The same timing on corner BL, in its bottom rows: a JPEG decodes its rows in order, so only a window in the top
rows can be read before the whole decode is done (``aerofid.io.jpeg_top``)."""


def bench_cli(repeats: int) -> list[str]:
    """Wall time of one ``aerofid locate`` of the RC20 JPEG (a fresh interpreter: start-up, imports, the JPEG's
    decode and the search) on a box in its top rows and on one in its bottom rows, of its imports alone and of the
    libraries' imports alone (what aerofid adds is the difference), median of ``2 * repeats + 1`` runs each."""
    if not REAL.exists():
        return []
    call = [sys.executable, "-m", "aerofid", "locate", str(REAL), "--box", CLI_BOX, "--mark", "external"]
    bottom = [sys.executable, "-m", "aerofid", "locate", str(REAL), "--box", CLI_BOX_BOTTOM, "--mark", "external"]
    # the command and the detection modules it imports once the scan is open (locate_cmd.locate_all)
    imports = [sys.executable, "-c", "import aerofid.cli.locate_cmd, aerofid.locate"]
    floor = [sys.executable, "-c", "import numpy, cv2, click"]
    # as installed: pip compiles the package's bytecode when it installs it; a PYTHONDONTWRITEBYTECODE in the
    # benchmark's environment would make every call compile the modules changed since their last .pyc
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    out = []
    for label, cmd in (("`aerofid locate` of one box (whole call)", call),
                       (f"the same on the bottom box {CLI_BOX_BOTTOM} (corner BL)", bottom),
                       ("`import aerofid.cli.locate_cmd, aerofid.locate` (start-up: the command and the detection "
                        "modules it imports once the scan is open)", imports),
                       ("`import numpy, cv2, click` alone (the start-up's floor: Python, the libraries it needs)",
                        floor)):
        subprocess.run(cmd, capture_output=True, check=True, env=env)   # writes the bytecode, not timed
        times = []
        for _ in range(2 * repeats + 1):
            t = time.perf_counter()
            subprocess.run(cmd, capture_output=True, check=True, env=env)
            times.append(time.perf_counter() - t)
        out.append(f"{label}: median {1000 * np.median(times):.0f} ms wall, fastest {1000 * min(times):.0f} ms")
    return ["", f"The command line on the RC20 JPEG (5908 x 5408, box {CLI_BOX}, `--mark external`), "
            f"{2 * repeats + 1} runs:", "", *[f"- {line}" for line in out]]


def _corner_rms(pos: dict, who: str) -> str:
    cam = read_camera(REAL.parent / "MeasuresCamera.xml")
    fid = [f for f in cam.fiducials if f.name in CALIBRATED and pos[(CALIBRATED[f.name], who)] is not None]
    if len(fid) < 4:
        return f"({len(fid)} corners)"
    px = np.array([pos[(CALIBRATED[f.name], who)] for f in fid])
    mm = np.array([[f.x_mm, f.y_mm] for f in fid])
    fit = adjust(px, mm, "affine")
    return f"{1000 * np.sqrt(np.mean(fit.v ** 2)):.1f}"


def _from_auto(pos: dict, who: str) -> str:
    d = [np.hypot(pos[(k, who)][0] - pos[(k, "auto")][0], pos[(k, who)][1] - pos[(k, "auto")][1])
         for k in MARKS if pos[(k, who)] is not None and pos[(k, "auto")] is not None]
    return f"{max(d):.3f}" if d else "-"


RUN_START, RUN_END = "<!-- bench_peers run -->", "<!-- end of bench_peers run -->"
"""The run's tables replace what lies between these lines of ``--out`` (the rest of the page is prose)."""


def write_run(path: Path, run: str) -> None:
    """Write ``run`` between :data:`RUN_START` and :data:`RUN_END` of ``path`` (the whole file when it has none)."""
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    if RUN_START in old and RUN_END in old:
        head, rest = old.split(RUN_START, 1)
        text = head + RUN_START + "\n" + run + "\n" + RUN_END + rest.split(RUN_END, 1)[1]
    else:
        text = RUN_START + "\n" + run + "\n" + RUN_END + "\n"
    path.write_text(text, encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="scenes per style")
    ap.add_argument("--repeats", type=int, default=3, help="calls per scene (their median is the scene's time)")
    ap.add_argument("--hipp", default=None, help="a Python interpreter that imports hipp 0.2.0")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--out", default="docs/benchmarks_peers.md")
    args = ap.parse_args()
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        hipp = Hipp(args.hipp, Path(tmp))
        res = bench_synthetic(args.n, args.repeats, np.random.default_rng(args.seed), hipp)
        real = bench_real(args.repeats, hipp) + bench_cli(args.repeats)
    peers = PEERS if hipp.proc is not None else PEERS[:2]
    hipp_line = (f"hipp {hipp.version} from `{Path(args.hipp).parent.parent.name}`" if hipp.proc is not None
                 else f"hipp not run: {hipp.why}")
    parts = [f"Produced by `python benchmarks/bench_peers.py --n {args.n} --repeats {args.repeats}"
             + (" --hipp <venv>/bin/python" if args.hipp else "") + f"` (seed {args.seed}) on {platform.machine()} / "
             f"Python {platform.python_version()}, OpenCV {cv2.__version__}, one thread, in {time.time() - t0:.0f} s; "
             f"{hipp_line}.\n",
             f"### Synthetic {BOX} px boxes: found, wrong (> {WRONG} px), RMS of the rest, median time\n",
             "aerofid:\n", *synthetic_table(res, (*METHODS, "locate")), "\nPeers (given the template):\n",
             *synthetic_table(res, peers), "\n### The real RC20 frame's 8 marks\n", *real]
    write_run(Path(args.out), "\n".join(parts))
    print("\n".join(parts))
    print(f"wrote {args.out} in {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
