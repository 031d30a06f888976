"""Peak memory of a whole frame from a large colour JPEG (issue 12: "peak memory < 1 GB for any frame size").

    python benchmarks/bench_jpeg_memory.py [--size 17000] [--repeats 1]

A synthetic frame (``aerofid.synth_frame``, the Wild RC10-like test camera, turned 90 degrees) of ``size`` x ``size``
px written once as an RGB JPEG (quality 90; the red channel 6 grey levels above the others, a colour scan) to
``~/.cache/aerofid-bench/jpeg_memory`` (outside the repository). Each measurement is a fresh process: OpenCV's own
whole decode of the file (``cv2.imread``) and aerofid's ``orient_frame`` of it, the whole decode into an array made
from the header (``aerofid.io.jpeg.IMREAD_INTO``, OpenCV 5) and, for comparison, by OpenCV's own decode; each with its
wall time and peak memory (``ru_maxrss``, imports included), the frame's status, marks found and largest error
against the truth.
A 17000 x 17000 RGB JPEG holds 0.87 GB of samples once decoded (289 MP, 3 bytes each).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

CACHE = Path.home() / ".cache" / "aerofid-bench" / "jpeg_memory"

WRITE = """
import json, sys, numpy as np, cv2
sys.path.insert(0, {bench!r})
from aerofid import synth_frame
from bench_frames import FILM_MM
n, path = int(sys.argv[1]), sys.argv[2]
spec = synth_frame.frame_spec(synth_frame.wild_rc10_camera(), FILM_MM / n, np.random.default_rng(7), rotation_deg=90,
                              size_px=n)
rgb = np.repeat(synth_frame.render_frame(spec)[:, :, None], 3, axis=2)
rgb[:, :, 2] = np.clip(rgb[:, :, 2].astype(np.int16) + 6, 0, 255)      # BGR: the red channel brighter
assert cv2.imwrite(path + ".tmp.jpg", rgb, [cv2.IMWRITE_JPEG_QUALITY, 90])
json.dump(synth_frame.frame_truth(spec).to_dict(), open(path + ".json", "w"))
import os; os.replace(path + ".tmp.jpg", path)
"""

DECODE = """
import resource, sys, time, cv2
t = time.perf_counter(); image = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED); t = time.perf_counter() - t
print(f"{t:.2f} {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")
"""

ORIENT = """
import json, resource, sys, time, math
import aerofid, aerofid.io.jpeg
aerofid.io.jpeg.IMREAD_INTO = sys.argv[3] == "into"
t = time.perf_counter(); r = aerofid.orient_frame(sys.argv[1], sys.argv[2]); t = time.perf_counter() - t
truth = json.load(open(sys.argv[1] + ".json"))["marks"]
err = [math.hypot(f.x - truth[f.name][0], f.y - truth[f.name][1]) for f in r.fiducials if f.status == "found"]
print(f"{t:.2f} {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} {r.status} {len(err)} "
      f"{max(err, default=float('nan')):.4f}")
"""


def frame(size: int) -> Path:
    """The cached RGB JPEG frame of ``size`` px (written if missing)."""
    CACHE.mkdir(parents=True, exist_ok=True)
    path = CACHE / f"rgb_{size}.jpg"
    if not path.exists():
        bench = str(Path(__file__).resolve().parent)
        subprocess.run([sys.executable, "-c", WRITE.format(bench=bench), str(size), str(path)], check=True)
    return path


def camera() -> Path:
    """The test camera's file beside the frames."""
    path = CACHE / "wild_rc10_synthetic.json"
    if not path.exists():
        from aerofid import synth_frame
        path.write_text(json.dumps(synth_frame.wild_rc10_camera().to_dict()), encoding="utf-8")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=17000)
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args()
    path, cam = frame(args.size), camera()
    print(f"`python benchmarks/bench_jpeg_memory.py --size {args.size} --repeats {args.repeats}` "
          f"({path.stat().st_size / 1e6:.1f} MB file):\n")
    print("| run | what | wall (s) | peak memory (MB) | status | marks found | max error (px) |")
    print("|---|---|---|---|---|---|---|")
    for k in range(args.repeats):
        t, mb = subprocess.run([sys.executable, "-c", DECODE, str(path)], capture_output=True, text=True,
                               check=True).stdout.split()
        print(f"| {k + 1} | OpenCV's own whole decode | {t} | {mb} | | | |")
        for how, label in (("into", "decoded into an array from its header"), ("own", "OpenCV's own decode")):
            t, mb, status, found, err = subprocess.run([sys.executable, "-c", ORIENT, str(path), str(cam), how],
                                                       capture_output=True, text=True, check=True).stdout.split()
            print(f"| {k + 1} | aerofid orient_frame, {label} | {t} | {mb} | {status} | {found}/8 | {err} |")


if __name__ == "__main__":
    main()
