"""Each frame's mark crops for the summary's review gallery: one PNG per frame, a row of square tiles, one per
camera fiducial in the camera's order, each centred on the mark (or on its prediction when it was not found).

A tile shows the scan around the mark (contrast stretched), the measured centre (+, green when used, orange
when rejected), the prediction (o) and the residual vector enlarged (red); a fiducial not found has a red
frame. The summary page shows tile ``i`` of a frame's row by offsetting the row (:data:`TILE_PX`), so an archive
of thousands of frames has one small image per frame, not one per mark.
"""

from __future__ import annotations

import os

import cv2
import numpy as np

from aerofid.frame.result import FOUND_MARK, MISSING_MARK, FiducialFinding, FrameOrientation
from aerofid.io.array import open_image
from aerofid.io.raster import part_inside

TILE_PX = 128
"""Side of one mark's tile (px of the PNG and of the summary page)."""
EXTENTS = 3.0
"""A tile shows this many of the mark's extents (its radius by the detector's model) around its centre ..."""
MIN_HALF_PX = 20
"""... and at least this many scan pixels on each side."""
UNKNOWN_EXTENT_PX = 16.0
"""The extent assumed for a fiducial that was not found."""
RESIDUAL_SCALE = 20.0
"""A residual vector is drawn this many times its length."""
STRETCH_PERCENTILES = (1.0, 99.0)
"""The grey levels mapped to black and white."""
COLOURS = {FOUND_MARK: (40, 200, 40), MISSING_MARK: (40, 40, 230)}
"""BGR colour of a fiducial by status (any other, i.e. rejected: orange)."""
ORANGE, CYAN, RED = (0, 140, 255), (255, 200, 0), (0, 0, 255)


def crop_sheet_png(image: str | os.PathLike[str], res: FrameOrientation) -> bytes:
    """The row of tiles of ``res``'s fiducials (module docstring) as PNG bytes; ``image`` is the scan."""
    residuals = {} if res.orientation is None else {
        r.name: (r.residual_x_px, r.residual_y_px) for r in res.orientation.fiducials}
    with open_image(image) as source:
        tiles = [_tile(source, f, residuals.get(f.name)) for f in res.fiducials]
    ok, buf = cv2.imencode(".png", np.hstack(tiles))
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()


def _grey_u8(samples: np.ndarray) -> np.ndarray:
    """Samples (grey or RGB, any depth) as 8-bit grey stretched to :data:`STRETCH_PERCENTILES`."""
    a = samples.astype(np.float32)
    a = a.mean(axis=2) if a.ndim == 3 else a
    lo, hi = np.percentile(a, STRETCH_PERCENTILES) if a.size else (0.0, 1.0)
    return np.clip((a - lo) / max(hi - lo, 1e-6) * 255, 0, 255).astype(np.uint8)


def _tile(source, fid: FiducialFinding, residual: tuple[float, float] | None) -> np.ndarray:
    """One fiducial's tile, TILE_PX square, BGR."""
    found = fid.x is not None and fid.y is not None
    cx, cy = (fid.x, fid.y) if found else (fid.predicted_x, fid.predicted_y)
    assert cx is not None and cy is not None
    extent = fid.located.extent if fid.located is not None else UNKNOWN_EXTENT_PX
    h = int(max(EXTENTS * extent, MIN_HALF_PX))
    x0, y0 = int(round(cx)) - h, int(round(cy)) - h
    tile = np.zeros((TILE_PX, TILE_PX, 3), np.uint8)
    box = part_inside((x0, y0, x0 + 2 * h + 1, y0 + 2 * h + 1), source.width, source.height)
    k = TILE_PX / (2 * h + 1)
    if box is not None:                         # a mark predicted off the scan: a blank tile
        grey = _grey_u8(source.read_window(box))
        part = cv2.resize(grey, None, fx=k, fy=k, interpolation=cv2.INTER_AREA if k < 1 else cv2.INTER_NEAREST)
        r0, c0 = int(round((box[1] - y0) * k)), int(round((box[0] - x0) * k))
        part = part[:TILE_PX - r0, :TILE_PX - c0]
        tile[r0:r0 + part.shape[0], c0:c0 + part.shape[1]] = part[:, :, None]

    def at(px: float, py: float) -> tuple[int, int]:
        return int(round((px - x0 + 0.5) * k)), int(round((py - y0 + 0.5) * k))

    cv2.circle(tile, at(fid.predicted_x, fid.predicted_y), 6, CYAN, 1, cv2.LINE_AA)
    colour = COLOURS.get(fid.status, ORANGE)
    if found:
        cv2.drawMarker(tile, at(cx, cy), colour, cv2.MARKER_CROSS, 14, 1)
        if residual is not None:
            end = at(cx + RESIDUAL_SCALE * residual[0], cy + RESIDUAL_SCALE * residual[1])
            cv2.arrowedLine(tile, at(cx, cy), end, RED, 1, cv2.LINE_AA, tipLength=0.2)
    else:
        cv2.rectangle(tile, (0, 0), (TILE_PX - 1, TILE_PX - 1), colour, 2)
    return tile


__all__ = ["RESIDUAL_SCALE", "TILE_PX", "crop_sheet_png"]
