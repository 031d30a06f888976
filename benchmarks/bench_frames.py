"""Whole frames: aerofid's ``orient_frame`` against hipp 0.2.0 on the same synthetic frames with exact truth and
on the real RC20 frame, one run.

    python benchmarks/bench_frames.py [--quick] [--size 11000] [--repeats 3] [--hipp PYTHON]
                                      [--cache DIR] [--out docs/benchmarks_frames.md]

Synthetic frames (:mod:`aerofid.synth_frame`, the Wild RC10-like test camera with 8 marks, the film shifted up to
3 mm and turned up to 0.5 degrees in the scanner): ``--size`` px square (11000 by default: 22.7 um pixels),
as a tiled TIFF (512 px tiles), a striped TIFF or a JPEG, clean, noisy (grain and noise), faded (a fifth of
the contrast), JPEG-blocky (quality 20) or damaged (two marks painted over, :data:`DAMAGE_MM`: they must be
reported not found, and a frame ok with either found is ok but wrong), the film in each of the 8 lies
(:data:`FRAMES`). ``--quick``: four
frames of 2500 px. Frames are written once to the cache folder (``--cache``, by default
``~/.cache/aerofid-bench/frames``, never the repository), named by their parameters and the hash of
synth_frame.py. Their TIFFs carry the pixel size as resolution tags; the JPEGs carry none.

Each (contender, frame) run is a fresh process, timed inside around the one call that reads the frame and
answers (imports excluded), its peak memory the process's ``ru_maxrss`` (imports included):

- aerofid: ``aerofid.orient_frame(path, camera)`` (the camera as a JSON file; no pixel size given);
- hipp: ``hipp.aerial.core.detect_fiducials(path, templates)`` run by ``--hipp`` (its own virtual environment;
  hipp is no dependency of aerofid), given a corner and a midside template cut from the frame around the
  true centre of one corner and one midside mark (200 px, hipp's ``distance_around_fiducial``) and the
  sub-pixel templates made as benchmarks/bench_peers.py makes them (the 8 x bicubic upscale cut so its
  middle falls on the true centre). hipp answers in pixel-corner coordinates: 0.5 px is subtracted. hipp
  has no verdict and no lie; each answer is taken for the nearest true mark.

Per frame kind: median time per frame, the largest peak memory, the error RMS of every found mark against
its truth and the mean error (x, y: a systematic offset), the lie recovered, frames ok / doubtful / failed,
and ``ok but wrong``: a frame reported ok with a mark further than :data:`WRONG` px from its truth or the
wrong lie (it must be 0). A roll (:data:`ROLL`, tiled clean frames of one lie): a profile learnt from its first
frame (``aerofid learn``), the others oriented with it and without it, median times. The real RC20 frame
(../shared/realdata, skipped when absent): the person's measurement of the four corners is the truth
(:data:`RC20_PERSON`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

import aerofid  # noqa: E402
from aerofid import synth_frame  # noqa: E402
from aerofid.formats.camera_file import read_camera  # noqa: E402
from aerofid.frame.profile import learn_profile, read_profile  # noqa: E402
from aerofid.io.raster import open_raster  # noqa: E402
from aerofid.orientation.adjustment import adjust  # noqa: E402
from aerofid.parallel import THREADS  # noqa: E402
from bench_peers import hipp_subpixel_template  # noqa: E402
from bench_rc20 import MARKS as RC20_APPROX  # noqa: E402
from bench_rc20 import REAL as RC20  # noqa: E402
from bench_rc20 import SPANS_MM as RC20_SPANS_MM  # noqa: E402

cv2.setNumThreads(1)

LIES = tuple((rot, mir) for mir in (False, True) for rot in (0, 90, 180, 270))
FRAMES = ([("tiled", "clean", lie) for lie in LIES]
          + [("tiled", d, lie) for d in ("noisy", "faded", "jpeg") for lie in ((90, False), (180, True))]
          + [("striped", d, lie) for d, lie in (("clean", (270, True)), ("noisy", (0, False)))]
          + [("jpeg", d, lie) for d, lie in (("clean", (90, True)), ("noisy", (180, False)))]
          + [("tiled", "damaged", lie) for lie in ((0, False), (270, True))])
"""(file kind, degradation, lie) of the full run: every lie on clean tiled TIFFs, each degradation twice."""
DAMAGE_MM = 3.0
"""A ``damaged`` frame is a clean one with a corner mark and a midside mark painted over: a square of this half-size
(film mm) around each, a little off its centre, filled with the square's median grey (a blot of the scan or the
film; the marks are 4 and 3.5 mm across)."""
ROLL = [("tiled", "clean", (90, True))] * 5
"""A roll: frames of one lie (each film shifted and turned anew); a profile learnt from the first orients the rest."""
ROLL_SEED = 100
"""The roll's frames' seeds start here (the other frames' are their index)."""
QUICK = [("tiled", "clean", (0, False)), ("tiled", "noisy", (90, True)), ("striped", "faded", (180, False)),
         ("jpeg", "jpeg", (270, True))]
QUICK_SIZE = 2500
FILM_MM = 2 * (synth_frame.FILM_HALF_MM + synth_frame.MARGIN_MM)
"""The scan covers the film and a margin: the pixel size is this over the frame's size in px."""
WRONG = 1.5
"""A mark further than this (px) from its truth is wrong."""
HIPP_HALF = 100
"""hipp's ``distance_around_fiducial`` (px): the coarse template is 2 x 100 px (used on the RC20 frame)."""
HIPP_HALF_MM = 2.25
"""The same in film mm on the synthetic frames (100 px at 22.5 um): a template of the mark and its dark
border at every frame size, not of the film's edges around it."""
SUBPIXEL = 8
"""hipp's sub-pixel upscaling factor (its default)."""
HIPP_KEYS = ("corner_top_left", "corner_top_right", "corner_bottom_left", "corner_bottom_right",
             "midside_top", "midside_bottom", "midside_left", "midside_right")
RC20_PERSON = {"P1": (5666.83777225829908, 5213.43416799840088), "P2": (648.746502108926506, 5202.00174926286491),
               "P3": (652.643834832399534, 190.350545163999413), "P4": (5671.95649931225762, 200.506888373784022)}
"""A person's measurement of the RC20 frame's four corners, MicMac ``MeasuresIm-15BCC02013_114.jpg.xml`` of
github unbc-gis/HistoricalAirPhotos (Mic_Mac_scripts/Ori-InterneScan, commit 44c26ea, MIT)."""
RC20_HIPP_KEYS = {"corner_bottom_right": "P1", "corner_bottom_left": "P2", "corner_top_left": "P3",
                  "corner_top_right": "P4"}

HIPP_WORKER = r"""
import json, resource, sys, time
from hipp.aerial.core import detect_fiducials
image, templates = sys.argv[1:3]
t, c = time.perf_counter(), time.process_time()
s = detect_fiducials(image, templates, 8, 3)
t, c = time.perf_counter() - t, time.process_time() - c
keys = sorted({k.rsplit("_", 1)[0] for k in s.index if k.endswith("_x")})
print(json.dumps({"time_s": t, "cpu_s": c, "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "marks": {k: [float(s[k + "_x"]) - 0.5, float(s[k + "_y"]) - 0.5] for k in keys}}))
"""


# --- the frames -------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Frame:
    """One benchmark frame on disk: its file, its truth, its camera file and its kind."""

    path: Path
    truth: dict
    camera: Path
    kind: str
    degradation: str
    lie: tuple[int, bool]

    @property
    def label(self) -> str:
        return f"{self.kind} {self.degradation}"


def source_hash() -> str:
    return hashlib.sha256(Path(synth_frame.__file__).read_bytes()).hexdigest()[:10]


def make_frames(plan, size: int, cache: Path, first_seed: int = 0) -> tuple[list[Frame], list[dict]]:
    """Every frame of ``plan`` written to ``cache`` (once; the i-th with seed ``first_seed + i``), and the time and
    peak memory of writing each."""
    cache.mkdir(parents=True, exist_ok=True)
    cam = synth_frame.wild_rc10_camera()
    cam_path = cache / "wild_rc10_synthetic.json"
    cam_path.write_text(json.dumps(cam.to_dict()), encoding="utf-8")
    frames, costs = [], []
    for i, (kind, deg, (rot, mir)) in enumerate(plan, first_seed):
        stem = f"{kind}_{deg}_{rot}{'m' if mir else ''}_{size}_{i}_{source_hash()}"
        path = cache / (stem + (".jpg" if kind == "jpeg" else ".tif"))
        truth_path = cache / (stem + ".json")
        if not (path.exists() and truth_path.exists()):
            out = worker([sys.executable, __file__, "--worker", "generate", str(path), kind, deg, str(rot),
                          str(int(mir)), str(size), str(i)])
            if "error" in out:
                raise SystemExit(f"could not write {path}: {out['error']}")
            truth_path.write_text(json.dumps(out), encoding="utf-8")
            print(f"wrote {path.name} in {out['time_s']:.0f} s, peak {out['maxrss_mb']:.0f} MB", flush=True)
        made = json.loads(truth_path.read_text(encoding="utf-8"))
        costs.append({"kind": kind, "degradation": deg, "time_s": made["time_s"], "maxrss_mb": made["maxrss_mb"]})
        frames.append(Frame(path, made["truth"], cam_path, kind, deg, (rot, mir)))
    return frames, costs


def generate(path: str, kind: str, deg: str, rot: str, mir: str, size: str, seed: str) -> dict:
    """Worker: write one frame, report its truth, time and peak memory."""
    n = int(size)
    rng = np.random.default_rng(int(seed))
    spec = synth_frame.frame_spec(synth_frame.wild_rc10_camera(), FILM_MM / n, rng, rotation_deg=int(rot),
                                  mirrored=bool(int(mir)), size_px=n,
                                  degradation="clean" if deg == "damaged" else deg)
    t = time.perf_counter()
    truth = synth_frame.write_frame(spec, path, kind).to_dict()
    if deg == "damaged":
        truth["damaged"] = damage(path, truth, rng)
    return {"truth": truth, "time_s": time.perf_counter() - t, "maxrss_mb": maxrss_mb()}


def damage(path: str, truth: dict, rng: np.random.Generator) -> list[str]:
    """Paint over a corner mark and a midside mark of the tiled TIFF at ``path`` (:data:`DAMAGE_MM`), rewritten
    with its tags; their names."""
    import tifffile  # the benchmark's frames only

    styles = synth_frame.default_styles(synth_frame.wild_rc10_camera())
    names = [str(rng.choice([n for n in truth["marks"] if styles[n].style == kind]))
             for kind in ("ring_x_dot", "ring_cross")]
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        image, resolution, tile = page.asarray(), page.resolution, (page.tilelength, page.tilewidth)
    half = DAMAGE_MM / truth["pixel_size_mm"]
    for name in names:
        x, y = np.asarray(truth["marks"][name]) + rng.uniform(-0.2, 0.2, 2) * half
        x0, y0, x1, y1 = (int(round(v)) for v in (x - half, y - half, x + half, y + half))
        patch = image[max(0, y0):y1, max(0, x0):x1]
        patch[...] = np.median(patch)
    tifffile.imwrite(path, image, photometric="minisblack", resolution=resolution, resolutionunit="INCH", tile=tile)
    return names


def hipp_templates(image: Path, centres: dict[str, tuple[float, float]], folder: Path, half: int) -> None:
    """hipp's four template files cut from ``image`` (2 ``half`` px) around the true centres of one corner and one
    midside."""
    folder.mkdir(parents=True, exist_ok=True)
    with open_raster(image) as r:
        for which, (x, y) in centres.items():
            xi, yi = int(round(x)), int(round(y))
            win = np.asarray(r.read_window((xi - half, yi - half, xi + half, yi + half)))
            tpl = np.ascontiguousarray(win[..., 0] if win.ndim == 3 else win)   # hipp reads band 1
            sub = hipp_subpixel_template(tpl, (x - xi + half, y - yi + half))
            cv2.imwrite(str(folder / f"{which}_fiducial.png"), tpl)
            cv2.imwrite(str(folder / f"subpixel_{which}_fiducial.png"), sub)


# --- running the contenders ---------------------------------------------------------------------------------

def maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def worker(cmd: list[str]) -> dict:
    """Run one worker process; its last stdout line is its JSON answer."""
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1",
                                                                 "OPENBLAS_NUM_THREADS": "1"})
    lines = p.stdout.strip().splitlines()
    if p.returncode != 0 or not lines:
        return {"error": (p.stderr.strip().splitlines() or [f"exit {p.returncode}"])[-1]}
    return json.loads(lines[-1])


def orient(path: str, camera: str, profile: str = "") -> dict:
    """Worker: ``aerofid.orient_frame`` on one frame (with a roll profile file if given)."""
    orient_frame = getattr(aerofid, "orient_frame", None)
    if orient_frame is None:
        return {"error": "aerofid.orient_frame is not there yet"}
    roll = read_profile(profile) if profile else None
    t, c = time.perf_counter(), time.process_time()
    res = orient_frame(path, camera, profile=roll)
    t, c = time.perf_counter() - t, time.process_time() - c
    marks = {f.name: [f.x, f.y] for f in res.fiducials if f.status == "found" and f.x is not None}
    return {"time_s": t, "cpu_s": c, "maxrss_mb": maxrss_mb(), "status": res.status, "reasons": list(res.reasons),
            "lie": [res.rotation_deg, res.mirrored], "marks": marks,
            "statuses": {f.name: f.status for f in res.fiducials},
            "pixel_size_mm": res.pixel_size_mm, "pixel_size_source": res.pixel_size_source,
            "searched": res.searched,
            "extra_marks": {f.name: [f.x, f.y, f.residual_px, *res.orientation.to_mm([[f.x, f.y]])[0].tolist()]
                            for f in res.extra_marks if f.status == "found" and res.orientation is not None}}


def learn(path: str, camera: str, out: str) -> dict:
    """Worker: the roll profile learnt from one frame (``aerofid learn``), written to ``out``."""
    res = aerofid.orient_frame(path, camera)
    Path(out).write_text(json.dumps(learn_profile(res).to_dict()), encoding="utf-8")
    return {"status": res.status}


def decode(path: str) -> dict:
    """Worker: the whole frame decoded to grey by OpenCV (the reference of a JPEG frame's time)."""
    t = time.perf_counter()
    img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    return {"time_s": time.perf_counter() - t, "maxrss_mb": maxrss_mb(), "shape": list(img.shape)}


def run_repeats(cmd: list[str], repeats: int) -> dict:
    """The first answer of ``repeats`` runs of ``cmd``, with the median time and the largest peak memory."""
    outs = [worker(cmd) for _ in range(repeats)]
    if any("error" in o for o in outs):
        return next(o for o in outs if "error" in o)
    return {**outs[0], "time_s": float(np.median([o["time_s"] for o in outs])),
            "cpu_s": float(np.median([o.get("cpu_s", np.nan) for o in outs])),
            "maxrss_mb": max(o["maxrss_mb"] for o in outs)}


def run_hipp(hipp: str, frame: Frame, repeats: int) -> dict:
    """hipp on one frame: templates from the truth, each answer assigned to its nearest true mark."""
    marks = frame.truth["marks"]
    folder = frame.path.with_suffix(".hipp")
    styles = synth_frame.default_styles(synth_frame.wild_rc10_camera())
    first = {styles[n].style: n for n in reversed(list(marks)) if n not in frame.truth.get("damaged", [])}
    hipp_templates(frame.path, {"corner": marks[first["ring_x_dot"]], "midside": marks[first["ring_cross"]]},
                   folder, round(HIPP_HALF_MM / frame.truth["pixel_size_mm"]))
    out = run_repeats([hipp, "-c", HIPP_WORKER, str(frame.path), str(folder)], repeats)
    if "error" in out:
        return out
    assigned = {k: min(marks, key=lambda n: np.hypot(xy[0] - marks[n][0], xy[1] - marks[n][1]))
                for k, xy in out["marks"].items()}
    return {**out, "assigned": assigned, "status": "ok", "lie": None}


# --- scoring and the report ---------------------------------------------------------------------------------

def score(truth: dict, out: dict) -> dict:
    """Errors (dx, dy) of the found marks, whether each is wrong (a mark of a damaged frame that was painted over
    is wrong wherever it is found), the lie recovered, 'ok but wrong'."""
    if "error" in out:
        return {"errors": [], "found": 0, "wrong": 0, "lie_ok": False, "status": "error", "ok_wrong": False}
    named = out.get("assigned", {})
    gone = set(truth.get("damaged", []))
    err = [(xy[0] - truth["marks"][named.get(k, k)][0], xy[1] - truth["marks"][named.get(k, k)][1])
           for k, xy in out["marks"].items() if named.get(k, k) not in gone]
    wrong = sum(np.hypot(*e) > WRONG for e in err) + sum(named.get(k, k) in gone for k in out["marks"])
    lie_ok = out.get("lie") is not None and tuple(out["lie"]) == (truth["rotation_deg"], truth["mirrored"])
    return {"errors": err, "found": len(err), "wrong": int(wrong), "lie_ok": lie_ok, "status": out["status"],
            "ok_wrong": out["status"] == "ok" and (wrong > 0 or (out.get("lie") is not None and not lie_ok))}


def summary_row(label: str, who: str, runs: list[tuple[Frame, dict, dict]]) -> str:
    n = len(runs)
    times = [o["time_s"] for _, o, _ in runs if "time_s" in o]
    cpu = [o.get("cpu_s", np.nan) for _, o, _ in runs if "time_s" in o]
    mem = [o["maxrss_mb"] for _, o, _ in runs if "maxrss_mb" in o]
    err = np.array([e for _, _, s in runs for e in s["errors"] if np.hypot(*e) <= WRONG]).reshape(-1, 2)
    rms = f"{np.sqrt(np.mean(np.sum(err ** 2, axis=1))):.3f}" if len(err) else "-"
    mean = f"{err[:, 0].mean():+.3f}, {err[:, 1].mean():+.3f}" if len(err) else "-"
    found = sum(s["found"] for _, _, s in runs)
    total = sum(len(f.truth["marks"]) - len(f.truth.get("damaged", [])) for f, _, _ in runs)
    wrong = sum(s["wrong"] for _, _, s in runs)
    statuses = [s["status"] for _, _, s in runs]
    verdicts = "/".join(str(statuses.count(k)) for k in ("ok", "doubtful", "failed"))
    errors = statuses.count("error")
    lie = "-" if who == "hipp" else f"{sum(s['lie_ok'] for _, _, s in runs)}/{n}"
    return (f"| {label} | {who} | {n} | {np.median(times):.2f} | {np.median(cpu):.2f} | {max(mem):.0f} "
            f"| {found}/{total} | {wrong} | {rms} "
            f"| {mean} | {lie} | {verdicts}{f' ({errors} errors)' if errors else ''} | "
            f"{sum(s['ok_wrong'] for _, _, s in runs)} |" if times else
            f"| {label} | {who} | {n} | - | - | - | - | - | - | - | - | {verdicts} ({errors} errors: "
            f"{runs[0][1].get('error', '?')}) | - |")


HEADER = ["| frames | contender | n | time (s, median) | CPU (s, median) | peak memory (MB) | marks found | "
          "wrong (> 1.5 px) | error RMS (px) | mean error x, y (px) | lie recovered | ok/doubtful/failed | "
          "ok but wrong |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]


def synthetic_tables(results: dict, frames: list[Frame], decodes: dict) -> list[str]:
    out = list(HEADER)
    labels = list(dict.fromkeys(f.label for f in frames))
    for label in labels:
        for who in results:
            runs = [(f, o, score(f.truth, o)) for f, o in zip(frames, results[who], strict=True) if f.label == label]
            out.append(summary_row(label, who, runs))
    out += ["", "Per frame (aerofid): status, lie, pixel size and its source, reasons.", "",
            "| frame | lie (truth) | status | lie | marks found | max error (px) | pixel size (mm) | reasons |",
            "|---|---|---|---|---|---|---|---|"]
    for f, o in zip(frames, results.get("aerofid", []), strict=False):
        s = score(f.truth, o)
        emax = max((np.hypot(*e) for e in s["errors"]), default=float("nan"))
        ps = f"{o['pixel_size_mm']:.5f} ({o['pixel_size_source']})" if o.get("pixel_size_mm") else "-"
        out.append(f"| {f.path.name} | {f.lie} | {o.get('status', o.get('error'))} | {o.get('lie')} | {s['found']} "
                   f"| {emax:.3f} | {ps} | {'; '.join(o.get('reasons', []))} |")
    if decodes:
        own = {f.path.name: o.get("time_s", float("nan")) for f, o in zip(frames, results.get("aerofid", []))}
        out += ["", "Whole-frame decode (OpenCV, grey) of the JPEG frames, the reference of the JPEG target, and "
                "aerofid's time over it (medians): " + ", ".join(f"{k} {v:.3f} s (aerofid {own[k]:.3f} s: "
                                                                  f"{own[k] / v:.3f}x)" for k, v in decodes.items())]
    return out


def roll(size: int, repeats: int, cache: Path) -> list[str]:
    """A roll (:data:`ROLL`): a profile learnt from its first frame, the others oriented with it (measured where the
    profile's frame had its marks) and without it (the whole frame screened), each a fresh process."""
    frames, _ = make_frames(ROLL, size, cache, ROLL_SEED)
    profile = cache / f"roll_{size}_{source_hash()}.json"
    learnt = worker([sys.executable, __file__, "--worker", "learn", str(frames[0].path), str(frames[0].camera),
                     str(profile)])
    if "error" in learnt:
        return [f"learning from {frames[0].path.name} failed: {learnt['error']}"]
    out = ["| frames | how | searched | median time per frame (s) | error RMS (px) | ok / doubtful / failed "
           "| ok but wrong |", "|---|---|---|---|---|---|---|"]
    for how, extra in (("with the profile", [str(profile)]), ("without", [])):
        runs = [run_repeats([sys.executable, __file__, "--worker", "orient", str(f.path), str(f.camera), *extra],
                            repeats) for f in frames[1:]]
        scores = [score(f.truth, o) for f, o in zip(frames[1:], runs, strict=True)]
        errors = [e for sc in scores for e in sc["errors"]]
        rms = np.sqrt(np.mean(np.sum(np.square(errors), axis=1))) if errors else float("nan")
        counts = " / ".join(str(sum(o.get("status") == s for o in runs)) for s in ("ok", "doubtful", "failed"))
        searched = ", ".join(sorted({str(o.get("searched", o.get("error"))) for o in runs}))
        out.append(f"| {len(runs)} | {how} | {searched} | {np.median([o.get('time_s', np.nan) for o in runs]):.2f} "
                   f"| {rms:.3f} | {counts} | {sum(sc['ok_wrong'] for sc in scores)} |")
    return out


def rc20(hipp: str | None, repeats: int, cache: Path) -> list[str]:
    """The real RC20 frame: both contenders against the person's corners, and the corners' affine residual."""
    if not RC20.exists():
        return [f"skipped: {RC20.name} is absent (../shared/realdata)"]
    cam_path = RC20.parent / "MeasuresCamera.xml"
    cam = read_camera(cam_path)
    truth = {"marks": RC20_PERSON, "rotation_deg": 0, "mirrored": False}
    frame = Frame(RC20, truth, cam_path, "RC20 JPEG", "real", (0, False))
    results = {"aerofid": run_repeats([sys.executable, __file__, "--worker", "orient", str(RC20), str(cam_path)],
                                      repeats)}
    if hipp:
        folder = cache / "rc20.hipp"
        hipp_templates(RC20, {"corner": RC20_PERSON["P3"], "midside": RC20_APPROX["midside L"]}, folder, HIPP_HALF)
        out = run_repeats([hipp, "-c", HIPP_WORKER, str(RC20), str(folder)], repeats)
        if "error" not in out:
            out = {**out, "status": "ok", "lie": None,
                   "marks": {RC20_HIPP_KEYS[k]: v for k, v in out["marks"].items() if k in RC20_HIPP_KEYS}}
        results["hipp"] = out
    lines = list(HEADER)
    for who, out in results.items():
        lines.append(summary_row("RC20 (4 corners)", who, [(frame, out, score(truth, out))]))
    lines += ["", "Affine fit of the four corners to the calibration (MeasuresCamera.xml): RMS of the residual "
              "vectors' lengths, px (1 px = 42.3 um):", ""]
    for who, out in [("person", {"marks": RC20_PERSON}), *results.items()]:
        marks = out.get("marks", {})
        names = [n for n in cam.names if n in marks]
        if len(names) < 4:
            lines.append(f"- {who}: {len(names)} corners, no fit")
            continue
        fit = adjust(np.array([marks[n] for n in names]), cam.xy_mm, "affine")
        v = fit.v.reshape(-1, 2) / (25.4 / 600)
        lines.append(f"- {who}: {np.sqrt(np.mean(np.sum(v ** 2, axis=1))):.2f} px")
    lines += rc20_midsides(results)
    if "aerofid" in results and "statuses" in results["aerofid"]:
        lines.append(f"\naerofid: {results['aerofid']['status']}, {results['aerofid']['statuses']}, "
                     f"reasons {results['aerofid']['reasons']}")
    return lines


def rc20_midsides(results: dict) -> list[str]:
    """The RC20's midside marks, which its camera file does not list: where aerofid found them (its
    ``extra_marks``, sought at the 23 cm format's nominal positions), their film mm by the corners' orientation,
    and the spans between opposite ones against the camera's ``SzCaptMm`` (no one here measured the marks
    themselves; hipp's midside template is cut at an approximate centre, so its midsides are not compared)."""
    extra = results.get("aerofid", {}).get("extra_marks", {})
    lines = ["", f"The 4 midside marks (not in MeasuresCamera.xml): aerofid found {len(extra)} of 4", "",
             "| mark | x, y (px) | from the nominal position (px) | film x, y (mm) |", "|---|---|---|---|"]
    for name, (x, y, nominal, x_mm, y_mm) in sorted(extra.items()):
        lines.append(f"| {name} | {x:.2f}, {y:.2f} | {nominal:.2f} | {x_mm:+.3f}, {y_mm:+.3f} |")
    if {"midside_left", "midside_right", "midside_top", "midside_bottom"} <= set(extra):
        sx = extra["midside_right"][3] - extra["midside_left"][3]
        sy = extra["midside_top"][4] - extra["midside_bottom"][4]
        dx, dy = 1000 * (sx - RC20_SPANS_MM[0]), 1000 * (sy - RC20_SPANS_MM[1])
        lines.append(f"\nSpans between opposite midsides: x {sx:.3f} mm, y {sy:.3f} mm; the camera's SzCaptMm "
                     f"(MicMac-LocalChantierDescripteur.xml) {RC20_SPANS_MM[0]:.3f} x {RC20_SPANS_MM[1]:.3f} mm "
                     f"(differences {dx:+.0f} and {dy:+.0f} um)")
    return lines


RUN_START, RUN_END = "<!-- bench_frames run -->", "<!-- end of bench_frames run -->"
"""The run replaces what lies between these lines of ``--out``; the prose around them stays."""


def write_doc(path: Path, args, parts: list[str]) -> None:
    cmd = "python benchmarks/bench_frames.py" + (" --quick" if args.quick else "") + f" --size {args.size}" + \
        f" --repeats {args.repeats}" + (" --hipp <venv>/bin/python" if args.hipp else "")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    run = "\n".join([f"Produced by `{cmd}` at {commit} on {platform.machine()} / Python "
                     f"{platform.python_version()}, OpenCV and BLAS on one thread per process; aerofid's own threads "
                     f"(aerofid.parallel.THREADS = {THREADS} here) read a TIFF's reduced frame and screen its levels, "
                     "and a JPEG is decoded on a second one, overlapping its screening (CPU time above wall time).",
                     "", *parts])
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    head, rest = old.split(RUN_START, 1) if RUN_START in old and RUN_END in old else ("", RUN_END)
    path.write_text(head + RUN_START + "\n" + run + "\n" + RUN_END + rest.split(RUN_END, 1)[1], encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=f"four frames of {QUICK_SIZE} px")
    ap.add_argument("--size", type=int, default=None, help="frame side in px (11000; --quick: 2500)")
    ap.add_argument("--repeats", type=int, default=3, help="runs per frame and contender (median time)")
    ap.add_argument("--hipp", default=None, help="a Python interpreter that imports hipp 0.2.0")
    ap.add_argument("--cache", default=str(Path.home() / ".cache" / "aerofid-bench" / "frames"))
    ap.add_argument("--out", default=None, help="the Markdown report (default: print only)")
    args = ap.parse_args()
    args.size = args.size or (QUICK_SIZE if args.quick else 11000)
    t0 = time.time()
    cache = Path(args.cache)
    frames, costs = make_frames(QUICK if args.quick else FRAMES, args.size, cache)
    results: dict[str, list[dict]] = {"aerofid": [], **({"hipp": []} if args.hipp else {})}
    for f in frames:
        results["aerofid"].append(run_repeats([sys.executable, __file__, "--worker", "orient", str(f.path),
                                               str(f.camera)], args.repeats))
        if args.hipp:
            results["hipp"].append(run_hipp(args.hipp, f, args.repeats))
        print(f.path.name, {k: (v[-1].get("time_s"), v[-1].get("status", v[-1].get("error")))
                            for k, v in results.items()}, flush=True)
    decodes = {f.path.name: run_repeats([sys.executable, __file__, "--worker", "decode", str(f.path)],
                                        args.repeats)["time_s"] for f in frames if f.kind == "jpeg"}
    parts = [f"## Synthetic frames, {args.size} x {args.size} px ({FILM_MM / args.size * 1000:.1f} um)", "",
             *synthetic_tables(results, frames, decodes), "",
             f"## A roll: {len(ROLL) - 1} frames oriented with the profile learnt from one more", "",
             *roll(args.size, args.repeats, cache), "", "## The real RC20 frame", "",
             *rc20(args.hipp, args.repeats, cache)]
    if costs:
        parts += ["", "Writing the frames (synth_frame.write_frame, one process each, time / peak memory): "
                  + "; ".join(f"{c['kind']} {c['degradation']} {c['time_s']:.0f} s / {c['maxrss_mb']:.0f} MB"
                              for c in costs)]
    parts += ["", f"Whole run {time.time() - t0:.0f} s."]
    print("\n".join(parts))
    if args.out:
        write_doc(Path(args.out), args, parts)
        print(f"wrote {args.out}")


WORKERS = {"generate": generate, "orient": orient, "learn": learn, "decode": decode}

if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        print(json.dumps(WORKERS[sys.argv[2]](*sys.argv[3:])))
    else:
        main()
