"""Benchmark of the two noise estimators of aerofid.detect.noise against the true noise sigma.

    python benchmarks/bench_noise.py [--n 20] [--seed 0]

For each kind of noise (white Gaussian; white noise blurred by a Gaussian of 0.7 px; white noise saved as a
JPEG of quality 75; film grain, ``aerofid.synth.add_grain``), each true sigma (0.01, 0.02, 0.04 grey levels)
and each ground (flat grey, or a 40 px ring-and-cross mark in the 120 x 120 window), prints the median over
``--n`` windows of each estimate divided by the true sigma, as a Markdown table. The true sigma is the standard
deviation of the noise actually in the window: the image with noise less the same image without (after the
JPEG round trip, its whole error).
"""

from __future__ import annotations

import argparse

import cv2
import numpy as np

from aerofid import synth
from aerofid.detect.noise import laplacian_noise_sigma
from aerofid.robust import difference_noise_sigma

KINDS = ("white", "blurred 0.7 px", "JPEG q75", "film grain")
SIGMAS = (0.01, 0.02, 0.04)
GROUNDS = ("flat", "mark")
N_PX = 120


def clean_window(ground: str, rng: np.random.Generator) -> np.ndarray:
    """The window without noise: flat grey 0.3, or a ring-and-cross mark (40 px, contrast 0.6) on film."""
    if ground == "flat":
        return np.full((N_PX, N_PX), 0.3, np.float32)
    return synth.mark_scene("ring_cross", 40, window=N_PX, rng=rng, contrast=0.6, noise_sigma=0.0).image


def noisy(clean: np.ndarray, kind: str, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``clean`` with noise of ``kind`` whose pixel standard deviation is about ``sigma``."""
    if kind == "white":
        return (clean + rng.normal(0.0, sigma, clean.shape)).astype(np.float32)
    if kind == "blurred 0.7 px":
        n = cv2.GaussianBlur(rng.normal(0.0, 1.0, clean.shape), (0, 0), 0.7)
        return (clean + sigma * n / n.std()).astype(np.float32)
    if kind == "JPEG q75":
        g = synth.to_uint8(np.clip(clean + rng.normal(0.0, sigma, clean.shape), 0, 1))
        ok, buf = cv2.imencode(".jpg", g, [cv2.IMWRITE_JPEG_QUALITY, 75])
        return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE).astype(np.float32) / 255.0
    if kind == "film grain":
        return synth.add_grain(clean, sigma, rng)
    raise ValueError(kind)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--n", type=int, default=20, help="windows per cell")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    print("| noise | ground | true sigma | difference / true | laplacian / true | laplacian / difference |")
    print("|---|---|---|---|---|---|")
    for kind in KINDS:
        for ground in GROUNDS:
            for sigma in SIGMAS:
                rd, rl, rr = [], [], []
                for _ in range(a.n):
                    clean = clean_window(ground, rng)
                    img = noisy(clean, kind, sigma, rng)
                    true = float((img - clean).std())
                    d, lap = difference_noise_sigma(img), laplacian_noise_sigma(img)
                    rd.append(d / true)
                    rl.append(lap / true)
                    rr.append(lap / d)
                print(f"| {kind} | {ground} | {sigma} | {np.median(rd):.2f} | {np.median(rl):.2f} | "
                      f"{np.median(rr):.2f} |")


if __name__ == "__main__":
    main()
