"""Every method, and ``auto``, on the 8 fiducial marks of the real Wild RC20 frame, with mirror consistency.

    python benchmarks/bench_rc20.py [--out docs/benchmarks_rc20.md]

The frame ../shared/realdata/unbc_bc_wild_rc20/15BCC02013_114.jpg (5908 x 5408 RGB) prints its marks in red
on the black film border: corners a ring with an X (and index dots beside it), midsides a ring with a '+' in a
dark notch of the border. The approximate positions below were read off downsampled crops (the peak of the
red-dominance image smoothed by 8 px); each mark is searched in a 120 x 120 box centred on it.

Mirror consistency: the box's RGB crop is located as it is, mirrored left-right, mirrored up-down and
transposed; mapped back, the four centres should agree to 0.1 px. The table gives the largest distance
between any two of them (or which orientations were not found).

An independent check: the four corner marks found by ``auto`` are fitted (similarity and affine) to their
calibrated coordinates (../shared/realdata/unbc_bc_wild_rc20/MeasuresCamera.xml; P1 lower right, P2 lower
left, P3 upper left, P4 upper right), and the midside marks are mapped to film millimetres by the affine: the
camera file gives the midside spans (SzCaptMm 220.033 x 220.005 mm). The script skips cleanly (exit 0, no
report written) when ../shared/realdata is absent; the data never enters the repository.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import aerofid  # noqa: E402
from aerofid.formats.camera_file import read_camera  # noqa: E402
from aerofid.io.array import ArrayRaster  # noqa: E402
from aerofid.io.raster import open_raster  # noqa: E402
from aerofid.orientation.adjustment import adjust  # noqa: E402

REAL = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "unbc_bc_wild_rc20" / "15BCC02013_114.jpg"
MARKS = {  # approximate centres (x, y), full-image pixels
    "corner TL": (665, 179), "corner TR": (5690, 202), "corner BL": (660, 5213), "corner BR": (5678, 5225),
    "midside T": (3183, 98), "midside B": (3146, 5302), "midside L": (554, 2679), "midside R": (5764, 2723),
}
METHODS = ("hough", "symmetry", "circles", "lines", "auto")
HALF = 60
CALIBRATED = {"P1": "corner BR", "P2": "corner BL", "P3": "corner TL", "P4": "corner TR"}
SPANS_MM = (220.033, 220.005)  # MicMac-LocalChantierDescripteur.xml, SzCaptMm (midside spans x, y)
PIXEL_UM = 25400.0 / 600.0


def orientation_check(auto_px: dict) -> list[str]:
    """The corner marks against their calibrated coordinates; the midsides mapped to mm (module docstring)."""
    cam = read_camera(REAL.parent / "MeasuresCamera.xml")
    names = [f.name for f in cam.fiducials if CALIBRATED.get(f.name) in auto_px]
    out = ["\n## Interior orientation check (auto's centres against the calibration)\n"]
    if len(names) < 4:
        return out + [f"only {len(names)} of the 4 calibrated corners found: no check\n"]
    px = np.array([auto_px[CALIBRATED[n]] for n in names])
    mm = np.array([[f.x_mm, f.y_mm] for f in cam.fiducials if f.name in names])
    out += ["Residuals (calibrated minus transformed, um; 1 px = 42.3 um) of the four corners:\n",
            "| model | " + " | ".join(f"{n} ({CALIBRATED[n]}) x, y" for n in names) + " | RMS (um) | RMS (px) |",
            "|---|" + "---|" * (len(names) + 2)]
    fits = {}
    for model in ("similarity", "affine"):
        fit = fits[model] = adjust(px, mm, model)
        v = -1000.0 * fit.v.reshape(-1, 2)
        rms = float(np.sqrt(np.mean(v ** 2)))
        out.append(f"| {model} | " + " | ".join(f"{a:+.1f}, {b:+.1f}" for a, b in v) + f" | {rms:.1f} | "
                   f"{rms / PIXEL_UM:.2f} |")
    mids = {k: auto_px[k] for k in ("midside T", "midside B", "midside L", "midside R") if k in auto_px}
    if len(mids) == 4:
        to_mm = fits["affine"].transform
        mm_mid = {k: to_mm(np.array([v]))[0] for k, v in mids.items()}
        span_x = float(np.hypot(*(mm_mid["midside R"] - mm_mid["midside L"])))
        span_y = float(np.hypot(*(mm_mid["midside T"] - mm_mid["midside B"])))
        out += ["\nThe midside marks mapped to film mm by the corners' affine transformation:\n",
                "| mark | x (mm) | y (mm) |", "|---|---|---|"]
        out += [f"| {k} | {p[0]:+.3f} | {p[1]:+.3f} |" for k, p in mm_mid.items()]
        out.append(f"\nSpans between opposite midsides: x {span_x:.3f} mm, y {span_y:.3f} mm; the camera file: "
                   f"{SPANS_MM[0]:.3f} x {SPANS_MM[1]:.3f} mm (differences {1000 * (span_x - SPANS_MM[0]):+.0f} "
                   f"and {1000 * (span_y - SPANS_MM[1]):+.0f} um).\n")
    return out


def orientations(crop: np.ndarray):
    """(name, image, map back (x, y) -> (x, y) in the crop) for the crop and its three mirrors."""
    h, w = crop.shape[:2]
    return [("as is", crop, lambda x, y: (x, y)),
            ("left-right", crop[:, ::-1], lambda x, y: (w - 1 - x, y)),
            ("up-down", crop[::-1], lambda x, y: (x, h - 1 - y)),
            ("transpose", np.swapaxes(crop, 0, 1), lambda x, y: (y, x))]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/benchmarks_rc20.md")
    args = ap.parse_args()
    if not REAL.exists():
        print(f"skipped: {REAL} is absent")
        return 0
    t0 = time.time()
    with open_raster(REAL) as r:
        subsampled = r.chroma_subsampled         # 4:2:0: luminance preferred, as on the file (aerofid.io.colour)
        crops = {}
        for name, (x, y) in MARKS.items():
            box = (x - HALF, y - HALF, x + HALF, y + HALF)
            crops[name] = (box, np.ascontiguousarray(r.read_window(box)))
    pos = ["| mark | box | " + " | ".join(METHODS) + " |", "|---|---|" + "---|" * len(METHODS)]
    mir = ["| mark | " + " | ".join(METHODS) + " |", "|---|" + "---|" * len(METHODS)]
    times = {m: [] for m in METHODS}
    auto_px: dict = {}
    for name, (box, crop) in crops.items():
        prow, mrow = [], []
        for m in METHODS:
            pts, missing = [], []
            for oname, img, back in orientations(crop):
                img = np.ascontiguousarray(img)
                t = time.perf_counter()
                loc = aerofid.locate(ArrayRaster(img, chroma_subsampled=subsampled),
                                     (0, 0, img.shape[1], img.shape[0]), mark="external", method=m)
                times[m].append(time.perf_counter() - t)
                if oname == "as is":
                    if loc.found and m == "auto":
                        auto_px[name] = (loc.x + box[0], loc.y + box[1])
                    if loc.found:
                        prow.append(f"{loc.x + box[0]:.2f}, {loc.y + box[1]:.2f} (s {loc.sigma:.3f}, q {loc.score:.2f}"
                                    + (f", {loc.method}" if m == "auto" else "") + ")")
                    else:
                        prow.append("not found")
                if loc.found:
                    pts.append(back(loc.x, loc.y))
                else:
                    missing.append(oname)
            if len(pts) >= 2:
                p = np.asarray(pts)
                d = max(float(np.hypot(*(a - b))) for i, a in enumerate(p) for b in p[i + 1:])
                txt = f"{d:.3f}" + (" **(> 0.1)**" if d > 0.1 else "")
            else:
                txt = "-"
            if missing:
                txt += f" (not found: {', '.join(missing)})"
            mrow.append(txt)
        pos.append(f"| {name} | {box} | " + " | ".join(prow) + " |")
        mir.append(f"| {name} | " + " | ".join(mrow) + " |")
        print(f"{name} done ({time.time() - t0:.0f} s)", flush=True)
    trow = "| median ms per locate | " + " | ".join(f"{1000 * np.median(times[m]):.0f}" for m in METHODS) + " |"
    colour = ("luminance, the one mix at the JPEG's full resolution, wherever it shows the mark with half the best "
              "mix's contrast, `aerofid.io.colour.LUMA_SHARE`" if subsampled else "the mix that shows the mark best")
    parts = ["# The real Wild RC20 frame: every method on its 8 fiducial marks\n",
             f"Produced by `python benchmarks/bench_rc20.py` on {platform.machine()} / Python "
             f"{platform.python_version()}, one thread, in {time.time() - t0:.0f} s. Frame: "
             "`../shared/realdata/unbc_bc_wild_rc20/15BCC02013_114.jpg` (not in the repository).\n",
             "Each mark is located with `aerofid.locate(ArrayRaster(crop, chroma_subsampled=...), whole crop, "
             "mark=\"external\", method=M)` on the 120 x 120 RGB crop around its approximate centre, the crop "
             f"declared {'4:2:0' if subsampled else 'not subsampled'} like its file (colour `auto`: {colour}, "
             "polarity bright). There is no ground truth for a real scan: the tables give the positions and how "
             "well each method agrees with itself under mirroring.\n",
             "## Positions (full-image pixels; s = sigma per axis in px, q = score)\n", *pos,
             "\n## Mirror consistency\n",
             "Largest distance (px) between the centres found in the crop, its left-right and up-down mirrors and "
             "its transpose, mapped back. Target: <= 0.1 px.\n", *mir,
             *orientation_check(auto_px),
             "\n## Time\n", "| | " + " | ".join(METHODS) + " |", "|---|" + "---|" * len(METHODS), trow]
    with open(args.out, "w") as f:
        f.write("\n".join(parts) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
