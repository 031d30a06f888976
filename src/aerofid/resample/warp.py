"""One block of a resampled frame: each output pixel's position in the scan, the scan window those positions
need, and OpenCV's ``cv2.remap`` with fixed-point maps.

Pixel centres are at integer coordinates in the scan and in the output (aerofid's convention, and
``cv2.remap``'s: ``dst(x, y) = src(map_x(x, y), map_y(x, y))`` with ``src(i, j)`` the sample of column i, row j).
OpenCV resamples at 1/32 px (``INTER_TAB_SIZE``): a float map is rounded to that step inside ``cv2.remap``. Here
the rounding is done first, in float64 on the whole-scan coordinates, and the maps are given as OpenCV's
fixed-point pair (``CV_16SC2`` integer parts relative to the window, ``CV_16UC1`` fraction index
``32 * fy + fx``), so a pixel's value does not depend on which block or window it was computed in: resampling
in blocks of any size gives the same frame as one block (tests/test_resample.py). The rounding moves a sample
position by at most 1/64 px. Fixed-point maps hold int16 window coordinates: a window stays below
:data:`MAX_WINDOW_PX` a side.

Kernels (:data:`KERNELS`): ``bilinear`` (2 x 2), ``bicubic`` (OpenCV's 4 x 4 cubic convolution, a = -0.75;
MicMac's ``Kern=1`` uses a = -0.5), ``lanczos`` (OpenCV's 8 x 8 Lanczos, a = 4; MicMac's default ``Kern=5`` is
a Tukey-apodised sinc of its own).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.io.raster import Raster
from aerofid.orientation.transform import ProjectiveTransform

SUBPIXEL = 32
"""Sub-pixel steps per pixel of ``cv2.remap`` (OpenCV's ``INTER_TAB_SIZE``)."""
KERNELS = {"bilinear": (cv2.INTER_LINEAR, 1), "bicubic": (cv2.INTER_CUBIC, 2), "lanczos": (cv2.INTER_LANCZOS4, 4)}
"""Kernel name -> (OpenCV interpolation, taps on each side of a sample: the window's margin)."""
DEFAULT_KERNEL = "bicubic"
"""OpenCV's 4 x 4 cubic convolution: sharper than bilinear, without Lanczos' wider ringing (MicMac's Kern=1)."""
MAX_WINDOW_PX = 32_000
"""Largest side of a scan window read for one block: fixed-point maps hold int16 coordinates (< 32767)."""
DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32), np.dtype(np.float64))
"""Sample types ``cv2.remap`` resamples (and the output keeps)."""

Box = tuple[int, int, int, int]


def check_kernel(kernel: str) -> tuple[int, int]:
    """OpenCV interpolation and margin of ``kernel``; an input error naming the kernels otherwise."""
    if kernel not in KERNELS:
        raise AerofidInputError(f"unknown kernel {kernel!r}: choose one of {', '.join(KERNELS)}")
    return KERNELS[kernel]


def check_dtype(dtype: np.dtype, what: str) -> None:
    """An input error unless the samples are of a type the resampling keeps."""
    if np.dtype(dtype) not in DTYPES:
        raise AerofidInputError(f"{what} has {dtype} samples; aerofid resamples 8- or 16-bit integer or float "
                                "samples: convert the scan to 8- or 16-bit")


def source_positions(out_to_src: np.ndarray, box: Box) -> tuple[np.ndarray, np.ndarray]:
    """Scan positions (x, y), float64, of the output pixels of ``box`` = (x0, y0, x1, y1): the homography
    ``out_to_src`` (3x3) applied to whole-output coordinates, so every block computes a pixel alike."""
    x0, y0, x1, y1 = box
    xs = np.arange(x0, x1, dtype=np.float64)[None, :]
    ys = np.arange(y0, y1, dtype=np.float64)[:, None]
    H = out_to_src
    w = H[2, 0] * xs + H[2, 1] * ys + H[2, 2]
    return (H[0, 0] * xs + H[0, 1] * ys + H[0, 2]) / w, (H[1, 0] * xs + H[1, 1] * ys + H[1, 2]) / w


def _window(ix: np.ndarray, iy: np.ndarray, margin: int, size: tuple[int, int]) -> Box:
    """The scan window (clipped to the scan) holding every tap of the integer positions ``ix``, ``iy``."""
    w, h = size
    return (max(int(ix.min()) - margin, 0), max(int(iy.min()) - margin, 0),
            min(int(ix.max()) + margin + 2, w), min(int(iy.max()) + margin + 2, h))


def remap_block(scan: Raster, out_to_src: np.ndarray, box: Box, kernel: str, fill: float = 0) -> np.ndarray:
    """The output pixels of ``box`` resampled from ``scan``: ``(h, w)`` or ``(h, w, 3)`` of the scan's dtype;
    pixels whose position lies outside the scan (beyond its pixels' outer edges) get ``fill``.

    Only the scan window those positions need (plus the kernel's taps) is read.
    """
    interpolation, margin = check_kernel(kernel)
    xs, ys = source_positions(out_to_src, box)
    inside = (xs >= -0.5) & (xs <= scan.width - 0.5) & (ys >= -0.5) & (ys <= scan.height - 0.5)
    shape = xs.shape + ((3,) if scan.bands == 3 else ())
    out = np.full(shape, fill, dtype=scan.dtype)
    if not inside.any():
        return out
    qx, qy = np.rint(np.where(inside, xs, 0.0) * SUBPIXEL), np.rint(np.where(inside, ys, 0.0) * SUBPIXEL)
    ix, iy = np.floor_divide(qx, SUBPIXEL), np.floor_divide(qy, SUBPIXEL)
    win = _window(ix[inside], iy[inside], margin, (scan.width, scan.height))
    if max(win[2] - win[0], win[3] - win[1]) > MAX_WINDOW_PX:
        raise AerofidInputError(f"one block of output needs a {win[2] - win[0]} x {win[3] - win[1]} px window of the "
                                "scan; give a smaller block or a pixel size closer to the scan's")
    map1 = np.stack([np.clip(ix - win[0], -1, win[2] - win[0]), np.clip(iy - win[1], -1, win[3] - win[1])],
                    axis=-1).astype(np.int16)
    map2 = ((qy - iy * SUBPIXEL) * SUBPIXEL + (qx - ix * SUBPIXEL)).astype(np.uint16)
    window = scan.read_window(win)
    res = cv2.remap(window, map1, map2, interpolation, borderMode=cv2.BORDER_REPLICATE)
    out[inside] = res.reshape(shape)[inside]
    return out


def block_boxes(width: int, height: int, block: Sequence[int]) -> list[list[Box]]:
    """The output split into blocks of ``block`` = (rows, columns), row of blocks by row of blocks.

    Examples
    --------
    >>> block_boxes(5, 3, (2, 4))
    [[(0, 0, 4, 2), (4, 0, 5, 2)], [(0, 2, 4, 3), (4, 2, 5, 3)]]
    """
    rows, cols = int(block[0]), int(block[1])
    if rows < 1 or cols < 1:
        raise AerofidInputError(f"block {tuple(block)} must be at least 1 x 1 px")
    return [[(x, y, min(x + cols, width), min(y + rows, height)) for x in range(0, width, cols)]
            for y in range(0, height, rows)]


def scale_ratio(out_to_src: np.ndarray, width: int, height: int) -> float:
    """Largest scan pixels per output pixel along an axis, at the output's corners (a bound for the window)."""
    T = ProjectiveTransform(out_to_src)
    corners = [(0, 0), (width - 1, 0), (0, height - 1), (width - 1, height - 1)]
    worst = max(float(np.abs(T.jacobian(c)).sum(axis=0).max()) for c in corners)
    return worst if math.isfinite(worst) else math.inf


__all__ = ["DEFAULT_KERNEL", "KERNELS", "SUBPIXEL", "block_boxes", "check_dtype", "check_kernel", "remap_block",
           "scale_ratio", "source_positions"]
