"""Benchmark of the Cho & Kim symmetry detector (aerofid.detect.symmetry) on synthetic marks with exact truth.

    python benchmarks/bench_symmetry.py [--n 100] [--seed 0] [--paper-centre] [--asymmetry]

Prints, per mark style: found / tried, RMS and max radial error (px), RMS error per axis vs the mean
reported sigma (their ratio should be near 1), median time per call; then, per rejection case, how many
windows were (correctly) not found; all as Markdown tables. ``--asymmetry`` instead prints, for the same
scenes, the point-asymmetry measure at the final centre (``max_asymmetry`` off) against the square sub-image
measure symmetry used before issue 8, and how many pass each limit (the recalibration of ``max_asymmetry``).
Marks: size 20-60 px, blur 0.5-1.0 px,
Gaussian noise 0.01-0.03, random sub-pixel centre near the middle of a 120 x 120 window on film border.
"""

from __future__ import annotations

import argparse
import re
import time
from collections import Counter

import numpy as np

from aerofid import synth
from aerofid.detect.symmetry import SymmetryParams, detect

STYLES = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")


def _reason(text: str) -> str:
    """A failure reason without its numbers, for counting."""
    return re.sub(r"[-+]?\d+(\.\d+)?", "#", text.split(":")[0])[:60]


def _shifted(shape, dx, dy):
    return lambda x, y: shape(x - dx, y - dy)


def _paint(shape, rng, n=120):
    img = synth.film_border((n, n), rng)
    cen = (n / 2 + rng.uniform(-3, 3), n / 2 + rng.uniform(-3, 3))
    img = synth.paint(img, synth.coverage((n, n), cen, shape, 8), 0.8)
    return np.clip(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng), 0, 1).astype(np.float32)


def _triangle(s):
    return lambda x, y: (y <= s / 2) & (y >= -s / 2) & (np.abs(x) <= (y + s / 2) / 2)


def rejection_cases(rng):
    """name -> function(rng) -> (image, truth or None)."""
    def noise(r):
        return np.clip(r.normal(r.uniform(0.1, 0.9), r.uniform(0.01, 0.05), (120, 120)), 0, 1).astype(np.float32)

    def flat(r):
        return np.full((120, 120), r.uniform(0, 1), np.float32)

    def edge(r):
        cov = synth.coverage((120, 120), tuple(60 + r.normal(0, 5, 2)), synth.bar(400, 200, r.uniform(0, 180)), 4)
        img = synth.paint(synth.film_border((120, 120), r), cov, 0.8)
        return np.clip(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, r), 0, 1)

    def line(r):
        return _paint(synth.bar(200, r.uniform(2, 5), r.uniform(0, 180)), r)

    def disc_bump(r):
        s = r.uniform(20, 50)
        return _paint(synth.union(synth.disc(s / 2), _shifted(synth.disc(s / 4), s / 2, 0)), r)

    def tee(r):
        s = r.uniform(20, 50)
        return _paint(synth.union(synth.bar(s, 3, 0), _shifted(synth.bar(s, 3, 90), 0, s / 2)), r)

    def ell(r):
        s = r.uniform(20, 50)
        return _paint(synth.union(_shifted(synth.bar(s, 3, 0), s / 2, 0), _shifted(synth.bar(s, 3, 90), 0, s / 2)), r)

    def tri(r):
        return _paint(_triangle(r.uniform(20, 50)), r)

    def half(r):
        edge_c = [(0.3, 60.4), (119.2, 60.4), (60.2, 0.4), (60.2, 118.8)][r.integers(4)]
        style = STYLES[r.integers(5)]
        return synth.mark_scene(style, r.uniform(20, 60), centre=edge_c, rng=r, noise_sigma=0.02).image

    return {"pure noise": noise, "homogeneous": flat, "straight edge": edge, "straight line": line,
            "disc + bump": disc_bump, "T shape": tee, "L shape": ell, "triangle": tri,
            "mark cut in half by window edge": half}


def square_asymmetry(img, x, y, r, noise):
    """The measure symmetry used before issue 8: on the (2r+1)-square sub-image, cubic-resampled about (x, y)."""
    from scipy import ndimage

    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(np.float64)
    j = ndimage.map_coordinates(img, [yy + y, xx + x], order=3, mode="nearest").astype(np.float32).astype(np.float64)
    dd = j - j[::-1, ::-1]
    sig = float(j.var()) - noise * noise
    return float(((dd * dd).mean() - 2.0 * noise * noise) / (2.0 * sig)) if sig > 0 else float("inf")


def asymmetry_table(rng, n, old_limit=0.1):
    """Both measures on the benchmark's scenes, and how many pass the old and the new limit."""
    new_limit = SymmetryParams().max_asymmetry
    print(f"| case | measured | disc (now) min-max | square (before) min-max | pass disc <= {new_limit} | "
          f"pass square <= {old_limit} | decisions that differ |")
    print("|---|---|---|---|---|---|---|")

    def rng_txt(c):
        return f"{c.min():.3f}-{c.max():.3f}" if len(c) else "-"

    def row(label, images):
        vals = []
        for img, params in images:
            d = detect(img, params.replace(max_asymmetry=np.inf))
            if d.found:
                vals.append((d.asymmetry, square_asymmetry(img, d.x, d.y, d.radius, d.noise_sigma)))
        v = np.array(vals).reshape(-1, 2)
        new, old = v[:, 0] <= new_limit, v[:, 1] <= old_limit
        print(f"| {label} | {len(v)}/{n} | {rng_txt(v[:, 0])} | {rng_txt(v[:, 1])} | {new.sum()} | {old.sum()} | "
              f"{(new != old).sum()} |")

    for label, style, ground, hint in _mark_rows():
        scenes = []
        for _ in range(n):
            size = rng.uniform(20, 60)
            s = synth.mark_scene(style, size, rng=rng, blur_sigma=rng.uniform(0.5, 1.0),
                                 noise_sigma=rng.uniform(0.01, 0.03), ground=ground)
            scenes.append((s.image, SymmetryParams(radius=int(0.3 * size) if hint else None)))
        row(label, scenes)
    for name, make in rejection_cases(rng).items():
        row(name, [(make(rng), SymmetryParams()) for _ in range(n)])


def _mark_rows():
    rows = [(st, st, "film", False) for st in STYLES]
    rows += [("notch_dot, radius = notch half-size", "notch_dot", "film", True)]
    rows += [(f"{st}, aerial ground", st, "aerial", False) for st in ("ring_cross", "dot")]
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100, help="marks per style and windows per rejection case")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--paper-centre", action="store_true",
                    help="point_refine=False: the centre of eq. (15) as published, without the refinement")
    ap.add_argument("--asymmetry", action="store_true",
                    help="the point-asymmetry measures at the final centre instead (max_asymmetry recalibration)")
    a = ap.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    if a.asymmetry:
        asymmetry_table(rng, a.n)
        return

    print("| style | found | RMS radial (px) | max radial (px) | RMS per axis (px) | mean sigma (px) | ratio | "
          "median ms |")
    print("|---|---|---|---|---|---|---|---|")
    for label, style, ground, hint in _mark_rows():
        errs, axis, sig, times, nf = [], [], [], [], Counter()
        for _ in range(a.n):
            size = rng.uniform(20, 60)
            s = synth.mark_scene(style, size, rng=rng, blur_sigma=rng.uniform(0.5, 1.0),
                                 noise_sigma=rng.uniform(0.01, 0.03), ground=ground)
            params = SymmetryParams(radius=int(0.3 * size) if hint else None, point_refine=not a.paper_centre)
            t0 = time.perf_counter()
            d = detect(s.image, params)
            times.append(time.perf_counter() - t0)
            if d.found:
                ex, ey = d.x - s.marks[0].x, d.y - s.marks[0].y
                errs.append(np.hypot(ex, ey))
                axis += [ex, ey]
                sig.append(d.sigma)
            else:
                nf[_reason(d.reason)] += 1
        e = np.array(errs)
        if len(e):
            rms_axis = np.sqrt(np.mean(np.square(axis)))
            print(f"| {label} | {len(e)}/{a.n} | {np.sqrt(np.mean(e ** 2)):.3f} | {e.max():.3f} | {rms_axis:.4f} | "
                  f"{np.mean(sig):.4f} | {rms_axis / np.mean(sig):.2f} | {1000 * np.median(times):.0f} |")
        else:
            print(f"| {label} | 0/{a.n} | - | - | - | - | - | {1000 * np.median(times):.0f} |")
        if nf:
            print(f"<!-- {label} not found: {'; '.join(f'{k} ({v})' for k, v in nf.most_common(4))} -->")

    print()
    print("| rejection case | not found | median ms | reasons |")
    print("|---|---|---|---|")
    for name, make in rejection_cases(rng).items():
        res, times = [], []
        for _ in range(a.n):
            img = make(rng)
            t0 = time.perf_counter()
            res.append(detect(img))
            times.append(time.perf_counter() - t0)
        reasons = Counter(_reason(r.reason) for r in res if not r.found)
        print(f"| {name} | {sum(not r.found for r in res)}/{a.n} | {1000 * np.median(times):.0f} | "
              f"{'; '.join(f'{k} ({v})' for k, v in reasons.most_common(3))} |")


if __name__ == "__main__":
    main()
