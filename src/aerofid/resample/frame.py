"""A scanned frame resampled into the camera's fiducial (film mm) frame, block by block (docs/resample.md).

Each output pixel's film position (:class:`aerofid.orientation.grid.ResampleGrid`, MicMac ReSampFid's
geometry) is taken back to the scan by the inverse of the scan's interior orientation (pixel -> mm), and the
scan is interpolated there (:mod:`aerofid.resample.warp`). The output is made one band of
:data:`aerofid.resample.tiff.TILE` rows at a time, each band in blocks of :data:`BLOCK_COLUMNS` columns that
read only the scan window they need, and written as tiles as the bands are made
(:func:`aerofid.resample.tiff.write_tiled`): memory stays bounded whatever the frame's size.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.io.raster import Raster
from aerofid.orientation.grid import ResampleGrid
from aerofid.orientation.transform import ProjectiveTransform
from aerofid.resample.tiff import TILE, write_tiled
from aerofid.resample.warp import DEFAULT_KERNEL, block_boxes, check_dtype, check_kernel, remap_block, scale_ratio

BLOCK_COLUMNS = 2048
"""Output columns of one block: its scan window (about 512 x 2048 px for a frame resampled near its own pixel
size, a few MB) is read once, and a tile the window spans is decoded by at most 2-3 blocks."""
WINDOW_TARGET_PX = 8192
"""A block's scan window is kept below this side when the output pixels are much larger than the scan's."""
MAX_RATIO = 32.0
"""Largest output pixel, in scan pixels: one block of 512 output px then reads a window of 16384 scan px a side
(268 MB of 8-bit grey); resampling does not low-pass, so a coarser output would alias anyway."""
MICMAC_PREFIX = "OIS-Reech_"
"""MicMac ReSampFid's output name: ``OIS-Reech_`` + the scan's file name."""
SIDECAR_SUFFIX = ".px2mm.json"
"""The resampled frame's own pixel -> mm, beside it: ``OUT.tif`` -> ``OUT.px2mm.json``."""


@dataclass(frozen=True)
class Resampled:
    """A resampled frame: its grid, kernel, and the scan pixel -> output pixel homography.

    ``scan_to_output`` is a 3x3 matrix M with ``output ~ M @ (x, y, 1)`` (pixel centres at integers in both: what
    ``cv2.warpAffine`` / ``cv2.warpPerspective`` take as ``dst = M src``).
    """

    image: str
    source: str
    grid: ResampleGrid
    kernel: str
    scan_to_output: np.ndarray
    fiducials: tuple[tuple[str, float, float], ...] = ()

    def to_dict(self) -> dict:
        """The sidecar: the output's own orientation in :meth:`InteriorOrientation.to_dict`'s keys (so that
        ``aerofid resample --orientation OUT.px2mm.json`` reads it) with the grid and the source."""
        px = self.grid.to_pixel([(x, y) for _, x, y in self.fiducials]) if self.fiducials else np.empty((0, 2))
        return {"image": self.image, "source": self.source, "model": "affine",
                "pixel_to_mm": self.grid.pixel_to_mm[:2].tolist(), "mm_to_pixel": self.grid.mm_to_pixel[:2].tolist(),
                "mirrored": False, "grid": self.grid.to_dict(), "kernel": self.kernel,
                "scan_to_output": self.scan_to_output.tolist(),
                "fiducials": [{"name": n, "x_px": float(p[0]), "y_px": float(p[1]), "x_mm": x, "y_mm": y}
                              for (n, x, y), p in zip(self.fiducials, px)]}


def output_name(image: str | os.PathLike[str], folder: str | os.PathLike[str]) -> Path:
    """MicMac ReSampFid's name for the resampled ``image`` in ``folder``: ``OIS-Reech_<file name>``."""
    return Path(folder) / f"{MICMAC_PREFIX}{Path(image).name}"


def sidecar_path(output: str | os.PathLike[str]) -> Path:
    """Where the resampled frame's pixel -> mm goes: ``OUT.tif`` -> ``OUT.px2mm.json``."""
    p = Path(output)
    return p.with_name(p.stem + SIDECAR_SUFFIX)


def block_columns(out_to_src: np.ndarray, grid: ResampleGrid) -> int:
    """Columns per block: :data:`BLOCK_COLUMNS`, fewer when output pixels span many scan pixels; an input
    error when even one band of :data:`TILE` rows would need too large a window."""
    ratio = scale_ratio(out_to_src, grid.width, grid.height)
    if not math.isfinite(ratio) or ratio > MAX_RATIO:
        raise AerofidInputError(f"an output pixel spans {ratio:.3g} scan pixels: the pixel size is far coarser than "
                                f"the scan's; give a pixel size at most {MAX_RATIO:g} times the scan's")
    return max(TILE, min(BLOCK_COLUMNS, int(WINDOW_TARGET_PX / max(ratio, 1e-9)) // TILE * TILE))


def resampled_bands(scan: Raster, out_to_src: np.ndarray, grid: ResampleGrid, kernel: str,
                    block: tuple[int, int]) -> Iterator[np.ndarray]:
    """The output, one band of ``block[0]`` rows at a time, each computed in blocks of ``block`` (rows,
    columns). Blocks of any size give the same samples (:mod:`aerofid.resample.warp`)."""
    for row in block_boxes(grid.width, grid.height, block):
        yield np.concatenate([remap_block(scan, out_to_src, box, kernel) for box in row], axis=1)


def resample_scan(scan: Raster, pixel_to_mm: ProjectiveTransform, grid: ResampleGrid, path: str | os.PathLike[str],
                  *, kernel: str = DEFAULT_KERNEL, image: str = "",
                  fiducials: tuple[tuple[str, float, float], ...] = (), block_cols: int | None = None,
                  progress: Callable[[], None] | None = None) -> Resampled:
    """Resample the open ``scan`` onto ``grid`` and write it to ``path`` (a tiled Deflate TIFF with overviews,
    the scan's dtype and bands, the sidecar's JSON in its ImageDescription). Writes ``path`` directly: stage it
    (:func:`aerofid.resample.resample_frame` does).

    Parameters
    ----------
    pixel_to_mm : ProjectiveTransform
        The scan's interior orientation, scan pixel -> film mm.
    fiducials : tuple of (name, x_mm, y_mm)
        Recorded in the sidecar with their output pixel positions.
    block_cols : int, optional
        Columns per block (default :func:`block_columns`); rows per block are :data:`TILE`.
    """
    check_kernel(kernel)
    check_dtype(scan.dtype, str(scan.path))
    M = grid.scan_to_output(pixel_to_mm)
    out_to_src = np.linalg.inv(M)
    cols = block_cols or block_columns(out_to_src, grid)
    result = Resampled(image or Path(path).name, scan.path.name, grid, kernel, M, fiducials)
    write_tiled(path, resampled_bands(scan, out_to_src, grid, kernel, (TILE, cols)), grid.width, grid.height,
                scan.dtype, scan.bands, json.dumps(result.to_dict()), grid.pixel_size_mm, progress)
    return result


__all__ = ["BLOCK_COLUMNS", "MICMAC_PREFIX", "SIDECAR_SUFFIX", "Resampled", "output_name", "resample_scan",
           "resampled_bands", "sidecar_path"]
