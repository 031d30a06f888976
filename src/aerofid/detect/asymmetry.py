"""Geometry checks shared by the detectors and ``auto``: a patch resampled about a sub-pixel point, and how far a
pattern is from being centrally symmetric about it (every supported mark style is). :func:`point_asymmetry` is
the package's one point-asymmetry measure (``symmetry``'s ``max_asymmetry``, ``lines``, ``auto``)."""

from __future__ import annotations

import functools

import cv2
import numpy as np


def patch(img: np.ndarray, x: float, y: float, k: int) -> np.ndarray:
    """The (2k+1) x (2k+1) patch centred exactly on (x, y), bilinear (edge pixels replicated)."""
    return cv2.getRectSubPix(np.ascontiguousarray(img, np.float32), (2 * k + 1, 2 * k + 1), (float(x), float(y)))


@functools.lru_cache(maxsize=64)
def disc_mask(k: int, radius: float) -> np.ndarray:
    """The offsets of the (2k+1)-square within ``radius`` of its centre (``hypot(dx, dy) <= radius``), a
    read-only mask made once per size (every measurement of a mark of one size asks for the same one).

    Examples
    --------
    >>> disc_mask(2, 1.0).astype(int).tolist()
    [[0, 0, 0, 0, 0], [0, 0, 1, 0, 0], [0, 1, 1, 1, 0], [0, 0, 1, 0, 0], [0, 0, 0, 0, 0]]
    """
    yy, xx = np.mgrid[-k:k + 1, -k:k + 1]
    m = np.hypot(xx, yy) <= radius
    m.setflags(write=False)
    return m


def point_asymmetry(img: np.ndarray, x: float, y: float, radius: float, noise: float) -> float:
    """Share of the structure within ``radius`` of (x, y) that changes under a 180-degree rotation about
    (x, y), net of noise: ``(mean (J - rot J)^2 - 2 n^2) / (2 (var J - n^2))`` over the disc (0: symmetric,
    about 1: unrelated). The patch is resampled so that (x, y) is exactly its centre.

    Examples
    --------
    >>> yy, xx = np.mgrid[0:41, 0:41]
    >>> dot = (np.hypot(xx - 20.0, yy - 20.0) < 6).astype(np.float32)
    >>> point_asymmetry(dot, 20.0, 20.0, 10, 0.0) < 0.01
    True
    >>> bump = np.maximum(dot, (np.hypot(xx - 26.0, yy - 20.0) < 3).astype(np.float32))
    >>> point_asymmetry(bump, 20.0, 20.0, 10, 0.0) > 0.1
    True
    """
    k = int(np.ceil(radius))
    p = patch(img, x, y, k).astype(np.float64)
    disc = disc_mask(k, float(radius))
    # bilinear resampling at a fractional phase averages neighbouring pixels: less noise than the window's
    fx, fy = x - np.floor(x), y - np.floor(y)
    gain = np.sqrt(((1 - fx) ** 2 + fx ** 2) * ((1 - fy) ** 2 + fy ** 2))
    n = noise * gain
    dd = (p - p[::-1, ::-1])[disc]
    sig = float(p[disc].var()) - n * n
    if sig <= 0:
        return float("inf")
    return float(max(0.0, (dd * dd).mean() - 2.0 * n * n) / (2.0 * sig))


__all__ = ["disc_mask", "patch", "point_asymmetry"]
