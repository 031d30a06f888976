"""Trap scenes for tests and benchmarks: windows in which any found centre is wrong or ambiguous.

``method="auto"`` (:mod:`aerofid.detect.auto`) must answer ``not_found`` on each of them: two marks in one
box, half a mark cut by the box edge, a mark straddling the edge between the dark film border and the bright
image area. Built from :mod:`aerofid.synth`'s primitives; like them, each takes a ``numpy.random.Generator``
and draws from it in a fixed order (the same generator state gives the same scene).

Examples
--------
>>> img = two_marks(np.random.default_rng(0), "dot")
>>> img.shape, img.dtype, bool(0.0 <= img.min() and img.max() <= 1.0)
((120, 120), dtype('float32'), True)
"""

from __future__ import annotations

import numpy as np

from aerofid.synth import (
    add_gaussian_noise,
    aerial_ground,
    blur,
    film_border,
    mark_scene,
    mark_shape,
    paint_shape,
    panel_scene,
)

MARK_RADIUS = {"notch_dot": 0.075}
"""The visible mark's radius as a fraction of its size, by style (0.5 for the styles not listed)."""


def _blur_noise(img: np.ndarray, rng: np.random.Generator, noise: float = 0.02, sigma: float = 0.7) -> np.ndarray:
    """Blur ``sigma`` px, Gaussian noise, clip to [0, 1]."""
    return np.clip(add_gaussian_noise(blur(img, sigma), noise, rng), 0, 1).astype(np.float32)


def two_marks(rng: np.random.Generator, style: str, n: int = 120) -> np.ndarray:
    """Two marks of one style side by side, 1.1-1.6 sizes apart, on film border: an ambiguous box (cloth panels:
    :func:`two_panels`)."""
    if style == "panel":
        return two_panels(rng, n)
    img = film_border((n, n), rng)
    size = rng.uniform(20, 30)
    a = rng.uniform(0, np.pi)
    sep = rng.uniform(1.1, 1.6) * size
    c = np.array([n / 2, n / 2]) + rng.uniform(-3, 3, 2)
    for s in (-1, 1):
        p = c + s * 0.5 * sep * np.array([np.cos(a), np.sin(a)])
        img = paint_shape(img, (float(p[0]), float(p[1])), mark_shape(style, size, rng.uniform(0, 90)), 0.85, 8,
                          extent=size)
    return _blur_noise(img, rng)


def two_panels(rng: np.random.Generator, n: int = 120) -> np.ndarray:
    """Two cloth panels of 7-11 px (sizes within 10 %, each turned at random, each on its patch of lawn) 1.8-4.5
    sizes apart on aerial ground, both at least 2 sizes inside the box, blurred (0.6 px) and noisy (0.015) together:
    an ambiguous box.

    Examples
    --------
    >>> box = two_panels(np.random.default_rng(3))
    >>> box.shape, box.dtype.name, bool(0 <= box.min() and box.max() <= 1)
    ((120, 120), 'float32', True)
    """
    size = rng.uniform(7, 11)
    contrast = rng.uniform(0.2, 0.35)
    lo, hi = 2 * size, n - 2 * size
    first = rng.uniform(lo, hi, 2)
    second = first
    while np.hypot(*(second - first)) < 1.8 * size or not np.all((second >= lo) & (second <= hi)):
        a, d = rng.uniform(0, 2 * np.pi), rng.uniform(1.8, 4.5) * size
        second = first + d * np.array([np.cos(a), np.sin(a)])
    img = panel_scene(rng, shape_hw=(n, n), centre=(float(first[0]), float(first[1])), size=size,
                      contrast=contrast, blur_sigma=0.0, noise_sigma=0.0).image
    img = panel_scene(rng, centre=(float(second[0]), float(second[1])), size=size * rng.uniform(0.9, 1.1),
                      contrast=contrast, blur_sigma=0.0, noise_sigma=0.0, ground=img).image
    return _blur_noise(img, rng, 0.015, 0.6)


def half_mark(rng: np.random.Generator, style: str, n: int = 120) -> np.ndarray:
    """A mark whose centre lies 0..0.6 of its radius inside the box edge: part of it is cut off."""
    size = rng.uniform(20, 40)
    d = rng.uniform(0.0, 0.6) * MARK_RADIUS.get(style, 0.5) * size
    big = mark_scene(style, size=size, window=n + 80, centre=(40 + d, n / 2 + 40 + rng.uniform(-3, 3)),
                     rng=rng, angle_deg=0.0 if style == "notch_dot" else rng.uniform(0, 90))
    w = np.ascontiguousarray(big.image[40:40 + n, 40:40 + n])
    out: np.ndarray = [w, w[:, ::-1], w.T, w.T[::-1]][int(rng.integers(4))].copy()
    return out


def border_edge(rng: np.random.Generator, style: str, n: int = 120) -> np.ndarray:
    """A mark straddling the edge between the dark film border and the bright image area."""
    size = rng.uniform(20, 40)
    c = (n / 2 + rng.uniform(-3, 3), n / 2 + rng.uniform(-3, 3))
    img = film_border((n, n), rng)
    ground = aerial_ground((n, n), rng)
    off = rng.uniform(-0.5, 0.5) * MARK_RADIUS.get(style, 0.5) * size
    a = rng.uniform(0, 2 * np.pi)
    yy, xx = np.mgrid[0:n, 0:n]
    img = np.where((xx - c[0]) * np.cos(a) + (yy - c[1]) * np.sin(a) > off, ground, img).astype(np.float32)
    img = paint_shape(img, c, mark_shape(style, size, rng.uniform(0, 90)), 0.85, 8, extent=size)
    return _blur_noise(img, rng, 0.015)


TRAPS = {"two marks": two_marks, "half mark": half_mark, "film-border edge": border_edge}
"""Every trap scene generator by name."""

__all__ = ["MARK_RADIUS", "TRAPS", "border_edge", "half_mark", "two_marks", "two_panels"]
