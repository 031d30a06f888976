"""Benchmark of the reported sigma against the error, per mark style and kind of noise.

    python benchmarks/bench_sigma.py [--n 40] [--seed 7] [--styles cross,ring_x_dot,...]

For each mark style and each kind of noise of ``bench_noise.py`` (white; white blurred by 0.7 px; JPEG of
quality 75; film grain, ``synth.add_grain``, white noise smoothed over 1.2 px), ``--n`` marks of 20-44 px at a
random sub-pixel centre and rotation (blur 0.5-1.0 px, contrast 0.6-0.85) on film border, 120 x 120 px, and cloth
panels of ``bench_marks.py`` (7-11 px, contrast 0.2-0.35 on aerial ground, ``mark="panel"``), each with noise of
pixel standard deviation 0.02; ``auto`` locates each. Per method ``auto`` answered with: how many, the
RMS error per axis ``sqrt(mean(dx^2 + dy^2) / 2)`` over the answers within 1.5 px of the truth, the RMS reported
sigma ``sqrt(mean(sigma_x^2 + sigma_y^2) / 2)`` and their ratio (1 when the sigma is honest; above 1 it claims
more precision than the answers have).

The error holds the synthetic renderer's own: it blurs on the pixel grid, which moves a '+' along the pixel axes
by up to 0.03 px (docs/hough.md); the random rotations spread that out.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from aerofid import synth  # noqa: E402
from aerofid.methods import make_detector  # noqa: E402
from bench_noise import KINDS, noisy  # noqa: E402

STYLES = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye", "panel")
NOISE = 0.02


def scene(style: str, kind: str, rng: np.random.Generator) -> tuple[np.ndarray, float, float]:
    """One mark of ``style`` with noise of ``kind`` (pixel sigma :data:`NOISE`): the window, the true centre. A
    cloth panel is ``synth.panel_scene``'s (7-11 px on aerial ground), in its box."""
    if style == "panel":
        sc = synth.panel_scene(rng, shape_hw=(160, 160), size=rng.uniform(7, 11), contrast=rng.uniform(0.2, 0.35),
                               noise_sigma=0.0)
        m = sc.marks[0]
        x0, y0, x1, y1 = m.box
        return noisy(sc.image[y0:y1, x0:x1], kind, NOISE, rng), m.x - x0, m.y - y0
    sc = synth.mark_scene(style, size=rng.uniform(20, 44), window=120, rng=rng, noise_sigma=0.0,
                          blur_sigma=rng.uniform(0.5, 1.0), contrast=rng.uniform(0.6, 0.85),
                          angle_deg=rng.uniform(0, 90))
    m = sc.marks[0]
    return noisy(sc.image, kind, NOISE, rng), m.x, m.y


def row(style: str, kind: str, n: int, seed: int) -> str:
    rng = np.random.default_rng(seed)
    detector = make_detector("auto", "panel" if style == "panel" else "auto", {})
    per: dict[str, list[tuple[float, float, float, float]]] = {}
    missed = 0
    for _ in range(n):
        img, tx, ty = scene(style, kind, rng)
        d = detector(img)
        if d.status != "found":
            missed += 1
            continue
        per.setdefault(d.method, []).append((d.x - tx, d.y - ty, d.sigma_x, d.sigma_y))
    cells = []
    for method, values in sorted(per.items(), key=lambda kv: -len(kv[1])):
        a = np.array(values)
        a = a[np.hypot(a[:, 0], a[:, 1]) < 1.5]
        err = float(np.sqrt(np.mean(a[:, 0] ** 2 + a[:, 1] ** 2) / 2))
        sig = float(np.sqrt(np.mean(a[:, 2] ** 2 + a[:, 3] ** 2) / 2))
        cells.append(f"{method} {len(a)}: {err:.4f} / {sig:.4f} = **{err / sig:.2f}**")
    if missed:
        cells.append(f"not found {missed}")
    return f"| {style} | {kind} | {'; '.join(cells)} |"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="marks per style and kind of noise")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--styles", default=",".join(STYLES))
    a = ap.parse_args(argv)
    print("| style | noise | method n: RMS error / RMS sigma (px) = **ratio** |")
    print("|---|---|---|")
    for style in a.styles.split(","):
        for kind in KINDS:
            print(row(style, kind, a.n, a.seed), flush=True)


if __name__ == "__main__":
    main()
