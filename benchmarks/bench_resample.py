"""Resampling whole frames: time, peak memory and where the fiducials land in the output, per frame size and
kernel.

    python benchmarks/bench_resample.py [--sizes 11000 20000] [--kernels bilinear bicubic lanczos]
                                        [--degradation clean] [--repeats 3] [--cache DIR] [--out FILE.md]
                                        [--baseline-writer REV]

Frames: synthetic (:mod:`aerofid.synth_frame`, the Wild RC10-like test camera, 8 marks, the film turned 90
degrees and shifted up to 3 mm and turned up to 0.5 degrees in the scanner), ``SIZE`` px square (a 250 mm film
plus margins: 22.7 um pixels at 11000, 12.5 um at 20000), uint8 tiled TIFF (512 px tiles, uncompressed), clean
or ``--degradation noisy`` (film grain and sensor noise, which compress about as badly as a real scan; the clean
frames compress many times better), written once to the cache folder (``--cache``, by default
``~/.cache/aerofid-bench/resample``, never the repository). The interior orientation is the frame's exact
pixel -> mm (its truth), so the landing error is the resampling's and the locating's alone.

Each run is a fresh process: ``aerofid.resample.resample_frame`` onto the film's -115..115 mm square at the
scan's own pixel size, timed around the call (imports excluded), peak memory the process's ``ru_maxrss``
(imports included) read right after it. Then, in the same process, every fiducial is located in the output
(``aerofid.locate``, mark ``external``, a 6 mm box around where the grid puts its calibrated position) and its
landing error is the located centre minus that position, in output pixels; for comparison each fiducial is
also located in the scan itself (the same box around its true centre) and its error against the truth given
in scan pixels ("scan" columns). Times are medians of
``--repeats`` runs; the load average (1 minute) is read before and after each size.

``--baseline-writer REV`` also runs each case with the TIFF writer of git revision ``REV``
(``src/aerofid/resample/tiff.py`` as it was there, loaded in place of today's ``write_tiled``; everything else
today's), alternating with today's runs, so that the two writers are compared under the same load ("writer"
column). Whether the output is in GDAL's COG layout is checked by tests/test_resample.py, not here.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

import numpy as np

import aerofid
from aerofid import synth_frame
from aerofid.formats.orientation import FiducialRecord, StoredOrientation
from aerofid.orientation.transform import AffineTransform
from aerofid.resample import KERNELS, resample_frame
from aerofid.resample import frame as resample_module

FILM_MM = 250.0
"""Film (240 mm) plus margins: the scan's side in mm, as benchmarks/bench_frames.py."""
EXTENT_MM = (-115.0, -115.0, 115.0, 115.0)
"""The output: the film's image area and every fiducial (corners near 106 mm, midsides near 110 mm)."""
BOX_MM = 3.0
"""Half side of the box each fiducial is located in: marks are 3.5-4 mm across, and the midside mark at -110 mm
has the data strip's bars from -113.5 mm (a 4 mm box reached them: ambiguous, not found)."""


def source_hash() -> str:
    return hashlib.sha256(Path(synth_frame.__file__).read_bytes()).hexdigest()[:10]


def maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def frame(size: int, degradation: str, cache: Path) -> tuple[Path, dict]:
    """The cached frame of ``size`` px and its truth (written by a worker process the first time)."""
    cache.mkdir(parents=True, exist_ok=True)
    path = cache / f"tiled_{degradation}_90_{size}_{source_hash()}.tif"
    truth_path = path.with_suffix(".json")
    if not (path.exists() and truth_path.exists()):
        out = worker([sys.executable, __file__, "--worker", "generate", str(path), str(size), degradation])
        truth_path.write_text(json.dumps(out), encoding="utf-8")
        print(f"wrote {path.name} in {out['time_s']:.0f} s, peak {out['maxrss_mb']:.0f} MB", flush=True)
    return path, json.loads(truth_path.read_text(encoding="utf-8"))


def generate(path: str, size: str, degradation: str) -> dict:
    """Worker: write one frame and report its truth."""
    n = int(size)
    spec = synth_frame.frame_spec(synth_frame.wild_rc10_camera(), FILM_MM / n, np.random.default_rng(n),
                                  rotation_deg=90, size_px=n, degradation=degradation)
    t = time.perf_counter()
    truth = synth_frame.write_frame(spec, path, "tiled")
    return {"truth": truth.to_dict(), "time_s": time.perf_counter() - t, "maxrss_mb": maxrss_mb()}


def use_writer(rev: str) -> None:
    """Resample with the TIFF writer of git revision ``rev`` (its ``resample/tiff.py`` loaded as a module)."""
    src = subprocess.run(["git", "show", f"{rev}:src/aerofid/resample/tiff.py"], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).parent).stdout
    module = types.ModuleType(f"tiff_{rev}")
    exec(compile(src, f"{rev}:tiff.py", "exec"), module.__dict__)
    resample_module.write_tiled = module.write_tiled  # type: ignore[attr-defined]


def resample(path: str, truth_path: str, kernel: str, out: str, writer: str = "") -> dict:
    """Worker: resample one frame with its exact orientation (with the TIFF writer of git revision ``writer``,
    default today's), then locate every fiducial in the output."""
    if writer:
        use_writer(writer)
    truth = synth_frame.FrameTruth.from_dict(json.loads(Path(truth_path).read_text(encoding="utf-8"))["truth"])
    cam = synth_frame.wild_rc10_camera()
    fids = tuple(FiducialRecord(f.name, *truth.marks[f.name], f.x_mm, f.y_mm, 0.0, 0.0, "used")
                 for f in cam.fiducials)
    stored = StoredOrientation(AffineTransform(truth.px_to_mm), fids, cam.y_axis, Path(path).name, cam.name, "")
    t = time.perf_counter()
    res = resample_frame(path, stored, out, pixel_size_mm=truth.pixel_size_mm, extent_mm=EXTENT_MM, kernel=kernel,
                         sidecar=False)
    t = time.perf_counter() - t
    peak = maxrss_mb()
    half = BOX_MM / truth.pixel_size_mm
    errors, in_scan = {}, {}
    for f in cam.fiducials:
        x, y = res.grid.to_pixel([(f.x_mm, f.y_mm)])[0]
        loc = aerofid.locate(out, (x - half, y - half, x + half, y + half), mark="external")
        errors[f.name] = [loc.x - x, loc.y - y] if loc.found else loc.reason
        x, y = truth.marks[f.name]
        loc = aerofid.locate(path, (x - half, y - half, x + half, y + half), mark="external")
        in_scan[f.name] = [loc.x - x, loc.y - y] if loc.found else loc.reason
    return {"time_s": t, "maxrss_mb": peak, "size": [res.grid.width, res.grid.height],
            "bytes": os.path.getsize(out), "errors": errors, "in_scan": in_scan}


def worker(cmd: list[str]) -> dict:
    """Run one worker process; its last stdout line is its JSON answer."""
    p = subprocess.run(cmd, capture_output=True, text=True)
    lines = p.stdout.strip().splitlines()
    if p.returncode != 0 or not lines:
        raise SystemExit(f"worker {' '.join(cmd[2:])} failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(lines[-1])


def row(size: int, degradation: str, kernel: str, writer: str, runs: list[dict]) -> str:
    found = [e for r in runs for e in r["errors"].values() if isinstance(e, list)]
    errs = [np.hypot(*e) for e in found]
    missing = sorted({n for r in runs for n, e in r["errors"].items() if not isinstance(e, list)})
    scan_missing = sorted({n for r in runs for n, e in r["in_scan"].items() if not isinstance(e, list)})
    scan_errs = [np.hypot(*e) for r in runs for e in r["in_scan"].values() if isinstance(e, list)]
    mean = np.mean(found, axis=0)
    w, h = runs[0]["size"]
    return (f"| {size}² {degradation} | {w} x {h} | {kernel} | {writer} | "
            f"{statistics.median(r['time_s'] for r in runs):.1f} | "
            f"{max(r['maxrss_mb'] for r in runs):.0f} | {runs[0]['bytes'] / 1e6:.0f} | "
            f"{max(errs):.3f} | {float(np.sqrt(np.mean(np.square(errs)))):.3f} | "
            f"({mean[0]:+.3f}, {mean[1]:+.3f}) | {', '.join(missing) or '-'} | {max(scan_errs):.3f} | "
            f"{', '.join(scan_missing) or '-'} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[11000, 20000])
    ap.add_argument("--kernels", nargs="+", default=list(KERNELS), choices=list(KERNELS))
    ap.add_argument("--degradation", default="clean", choices=["clean", "noisy"])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cache", default=str(Path.home() / ".cache" / "aerofid-bench" / "resample"))
    ap.add_argument("--out", default=None, help="write the table (markdown) here too")
    ap.add_argument("--baseline-writer", default="", metavar="REV",
                    help="also run with the TIFF writer of this git revision, alternating with today's")
    args = ap.parse_args()
    lines = [f"`python benchmarks/bench_resample.py --sizes {' '.join(map(str, args.sizes))} --kernels "
             f"{' '.join(args.kernels)} --degradation {args.degradation} --repeats {args.repeats}"
             f"{' --baseline-writer ' + args.baseline_writer if args.baseline_writer else ''}` on "
             f"{platform.node()} ({os.cpu_count()} cores, Python {platform.python_version()})", "",
             "| frame | output px | kernel | writer | time s (median) | peak MB | output MB | max landing px | "
             "RMS px | mean (x, y) px | not found | scan: max error px | scan: not found |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    writers = ["", args.baseline_writer] if args.baseline_writer else [""]
    loads = []
    with tempfile.TemporaryDirectory(dir=args.cache if Path(args.cache).is_dir() else None) as tmp:
        for size in args.sizes:
            path, _ = frame(size, args.degradation, Path(args.cache))
            loads.append(f"{size}²: load {os.getloadavg()[0]:.1f} before")
            for kernel in args.kernels:
                runs: dict[str, list[dict]] = {w: [] for w in writers}
                for _ in range(args.repeats):
                    for w in writers:
                        runs[w].append(worker([sys.executable, __file__, "--worker", "resample", str(path),
                                               str(path.with_suffix(".json")), kernel, str(Path(tmp) / "out.tif"), w]))
                for w in writers:
                    lines.append(row(size, args.degradation, kernel, w or "today's", runs[w]))
                    print(lines[-1], flush=True)
            loads[-1] += f", {os.getloadavg()[0]:.1f} after"
    lines += ["", "Load average (1 min): " + "; ".join(loads) + "."]
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        print(json.dumps({"generate": generate, "resample": resample}[sys.argv[2]](*sys.argv[3:])))
    else:
        main()
