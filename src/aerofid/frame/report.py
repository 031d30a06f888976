"""A frame's reports: plain text (what ``aerofid orient IMAGE --camera`` prints) and a self-contained HTML page
with a thumbnail of the frame and its fiducial areas, a zoomed crop of every mark with its centre and residual
vector, and the adjustment's statistics (:mod:`aerofid.orientation.report`)."""

from __future__ import annotations

import base64
import html
import math
from typing import Any

import cv2
import numpy as np

from aerofid.find import reduction_for
from aerofid.frame.result import (
    FOUND_MARK,
    LIE_ASSUMED,
    LIE_GIVEN,
    MISSING_MARK,
    ROLL_AREAS,
    FiducialFinding,
    FrameOrientation,
)
from aerofid.io.array import open_image
from aerofid.io.raster import part_inside
from aerofid.orientation.report import residual_plot_svg, to_text

THUMBNAIL_PIXELS = 600_000
"""Most pixels of the frame's thumbnail."""
CROP_HALF = 3.0
"""A mark's crop reaches this many of its extents (at least :data:`MIN_CROP_HALF` px) around its centre."""
MIN_CROP_HALF = 24
CROP_SIDE = 240
"""Side (px) of a mark's crop on the page."""
RESIDUAL_SCALE = 20.0
"""A residual vector is drawn this many times its length."""
COLOURS = {FOUND_MARK: (40, 200, 40), MISSING_MARK: (40, 40, 230)}
"""BGR colour of a fiducial by status (others, i.e. rejected: orange)."""


LIE_NOTES = {LIE_GIVEN: " as given (the fiducials fit several lies equally and cannot check it)",
             LIE_ASSUMED: " assumed"}
"""What the text says of a lie the fiducials did not tell (``FrameOrientation.lie_source``)."""


def frame_text(res: FrameOrientation) -> str:
    """The frame's verdict, a line per fiducial, then the orientation's report."""
    size = "-" if res.pixel_size_mm is None else f"{res.pixel_size_mm * 1000:.3f} um ({res.pixel_size_source})"
    lie = "-" if res.rotation_deg is None else f"rotation {res.rotation_deg} deg{' mirrored' if res.mirrored else ''}"
    lie += LIE_NOTES.get(res.lie_source, "")
    L = [f"Frame {res.image or '(image)'} ({res.width} x {res.height}) with camera {res.camera!r}: {res.status}"]
    L += [f"  - {r}" for r in res.reasons]
    w = max([10] + [len(f.name) for f in (*res.fiducials, *res.extra_marks)])
    searched = (f"{res.features} features screened at 1/{res.reduction} ({res.searched})" if res.searched != ROLL_AREAS
                else "marks sought in the roll areas (where the profile's frame had them; nothing screened)")
    L += [f"pixel size {size}; film lie {lie}; {searched}", "",
          f"{'fiducial':>{w}} {'x_px':>11} {'y_px':>11} {'sx_px':>7} {'sy_px':>7} {'resid_px':>8}  status"]
    L += [_line(f, w) for f in res.fiducials]
    if res.extra_marks:
        L += ["", "Marks of the film's format that the camera file does not list (not used in the adjustment; "
              "resid_px: distance from the nominal position):"]
        L += [_line(f, w) for f in res.extra_marks]
    if res.orientation is not None:
        L += ["", to_text(res.orientation).rstrip("\n")]
    return "\n".join(L) + "\n"


def _line(f: FiducialFinding, width: int) -> str:
    return (f"{f.name:>{width}} {_n(f.x, '11.3f')} {_n(f.y, '11.3f')} {_n(f.sigma_x, '7.3f')} {_n(f.sigma_y, '7.3f')} "
            f"{_n(f.residual_px, '8.3f')}  {f.status}" + (f" ({f.reason})" if f.reason else ""))


def _n(v: float | None, fmt: str) -> str:
    return format(v, fmt) if v is not None and math.isfinite(v) else format("-", fmt.split(".")[0] + "s")


def frame_html(res: FrameOrientation, image: Any) -> str:
    """The HTML page (module docstring); ``image`` is read again for the thumbnail and the crops."""
    e = html.escape
    with open_image(image) as source:
        thumb = _thumbnail(source, res)
        marks = (*res.fiducials, *res.extra_marks)
        crops = [_crop(source, f, res) for f in marks]
    extra = {f.name for f in res.extra_marks}
    figs = "\n".join(f'<figure><img src="data:image/png;base64,{c}" width="{CROP_SIDE}"><figcaption>{e(f.name)}: '
                     f'{e(f.status)}{" " + e(f.reason) if f.reason else ""}'
                     f'{" (not in the camera file: o is its nominal position)" if f.name in extra else ""}'
                     '</figcaption></figure>' for f, c in zip(marks, crops, strict=True) if c)
    reasons = "".join(f"<li>{e(r)}</li>" for r in res.reasons)
    orientation = ("<p>No orientation.</p>" if res.orientation is None else
                   f"<h2>Residual vectors</h2>{residual_plot_svg(res.orientation)}")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Frame {e(res.image)}</title>
<style>body{{font-family:sans-serif;margin:2em}} figure{{display:inline-block;margin:4px}}
figcaption{{font-size:small;max-width:{CROP_SIDE}px}} pre{{background:#f6f6f6;padding:1em}}
.ok{{color:#080}} .doubtful{{color:#b60}} .failed{{color:#b00}}</style></head><body>
<h1>Frame {e(res.image or '(image)')}: <span class="{e(res.status)}">{e(res.status)}</span></h1>
<ul>{reasons}</ul>
<h2>The frame and its fiducial areas</h2>
<img src="data:image/png;base64,{thumb}" style="max-width:100%">
<h2>The marks (centre +, residual vector x{RESIDUAL_SCALE:g}, prediction o)</h2>
{figs}
{orientation}
<h2>Summary</h2>
<pre>{e(frame_text(res))}</pre>
</body></html>
"""


def _png(img: np.ndarray) -> str:
    ok, buf = cv2.imencode(".png", img)
    assert ok
    return base64.b64encode(buf.tobytes()).decode("ascii")


def _bgr(samples: np.ndarray) -> np.ndarray:
    """Samples (grey or RGB, any depth) as 8-bit BGR, stretched to the 1st-99th percentiles."""
    a = samples.astype(np.float32)
    lo, hi = np.percentile(a, (1, 99)) if a.size else (0.0, 1.0)
    a = np.clip((a - lo) / max(hi - lo, 1e-6) * 255, 0, 255).astype(np.uint8)
    return cv2.cvtColor(a, cv2.COLOR_GRAY2BGR) if a.ndim == 2 else np.ascontiguousarray(a[:, :, 2::-1])


def _thumbnail(source: Any, res: FrameOrientation) -> str:
    f = reduction_for(source.width, source.height, THUMBNAIL_PIXELS)
    img = _bgr(source.read_reduced((0, 0, source.width, source.height), f))
    for fid in (*res.fiducials, *res.extra_marks):
        x, y = (fid.x, fid.y) if fid.x is not None and fid.y is not None else (fid.predicted_x, fid.predicted_y)
        c = COLOURS.get(fid.status, (0, 140, 255))
        p = (int(round((x + 0.5) / f - 0.5)), int(round((y + 0.5) / f - 0.5)))
        cv2.circle(img, p, 12, c, 2)
        cv2.putText(img, fid.name, (p[0] + 14, p[1] + 5), cv2.FONT_HERSHEY_SIMPLEX, 0.5, c, 1, cv2.LINE_AA)
    return _png(img)


def _crop(source: Any, fid: FiducialFinding, res: FrameOrientation) -> str:
    """A mark's zoomed crop: the centre (+), the prediction (o) and the residual vector (exaggerated)."""
    x = fid.x if fid.x is not None else fid.predicted_x
    y = fid.y if fid.y is not None else fid.predicted_y
    extent = fid.located.extent if fid.located is not None else 20.0
    h = int(max(CROP_HALF * extent, MIN_CROP_HALF))
    box = part_inside((int(round(x)) - h, int(round(y)) - h, int(round(x)) + h + 1, int(round(y)) + h + 1),
                      source.width, source.height)
    if box is None:                             # a mark predicted off the scan
        return ""
    img = _bgr(source.read_window(box))
    k = CROP_SIDE / max(img.shape[:2])
    img = cv2.resize(img, None, fx=k, fy=k, interpolation=cv2.INTER_NEAREST)

    def at(px: float, py: float) -> tuple[int, int]:
        return int(round((px - box[0] + 0.5) * k)), int(round((py - box[1] + 0.5) * k))

    c = COLOURS.get(fid.status, (0, 140, 255))
    cv2.circle(img, at(fid.predicted_x, fid.predicted_y), 6, (255, 200, 0), 1)
    if fid.x is not None and fid.y is not None:
        cv2.drawMarker(img, at(fid.x, fid.y), c, cv2.MARKER_CROSS, 14, 1)
        v = _residual_px(fid, res)
        if v is not None:
            cv2.arrowedLine(img, at(fid.x, fid.y), at(fid.x + RESIDUAL_SCALE * v[0], fid.y + RESIDUAL_SCALE * v[1]),
                            (0, 0, 255), 1, tipLength=0.2)
    return _png(img)


def _residual_px(fid: FiducialFinding, res: FrameOrientation) -> tuple[float, float] | None:
    if res.orientation is None:
        return None
    r = next((r for r in res.orientation.fiducials if r.name == fid.name), None)
    return None if r is None else (r.residual_x_px, r.residual_y_px)


__all__ = ["frame_html", "frame_text"]
