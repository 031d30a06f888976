"""Pictures of a result: the delineation overlay and the diagnostic figure.

- :func:`overlay_png`: "the fiducial marks are delineated by drawing an orange fiducial mark over the
  aerial photograph centered at the generated coordinates" (thesis 000, section 5.9): a crop of the image
  around the box, enlarged, with the searched box, an orange cross at the sub-pixel centre, a circle of
  radius 3 sigma, the mark's name beside its centre and a caption with the result above the crop.
- :func:`overlay_sheet_png`: the overlays of several marks on one sheet, each with its name.
- :func:`diagnostic_png`: the method's own diagnostic figure (each result type draws its own; for ``hough``
  the thesis figures 5.2-5.5: the optimally thresholded window, the Hough accumulator before and after
  thresholding, and the theta projection with the fitted similarity model).

Every caption is light text on a dark box, so it stays legible on bright ground, and is wrapped and placed
inside the picture, never cut by its border. All return PNG bytes (or a figure); the CLI writes them with
:func:`aerofid.io.atomic.write_bytes_atomic`.
"""

from __future__ import annotations

import io
import math
import textwrap
from collections.abc import Sequence
from typing import TYPE_CHECKING

import cv2
import numpy as np

from aerofid.detect.result import Detection
from aerofid.locate import Location

if TYPE_CHECKING:
    from matplotlib.figure import Figure

ORANGE = (0, 140, 255)   # BGR
BOX_COLOUR = (255, 200, 0)
TEXT_COLOUR = (255, 255, 255)
TEXT_GROUND = (0, 0, 0)
SHEET_GROUND = (64, 64, 64)
SHIFT = 4                # cv2 fixed-point bits: sub-pixel drawing to 1/16 px
FONT = cv2.FONT_HERSHEY_SIMPLEX
CAPTION_SCALE = 0.45
TAG_SCALE = 0.5
PAD = 4                  # px between a text and the edge of its dark box
TITLE_CHARS = 100        # characters a line of the diagnostic figure's title holds


def _to_uint8_grey(grey: np.ndarray) -> np.ndarray:
    """Contrast-stretched 8-bit grey (0.5 to 99.5 percentile); a flat window keeps its own level."""
    lo, hi = np.percentile(grey, [0.5, 99.5])
    if hi - lo <= 1e-6:
        return np.full(grey.shape, np.clip(lo * 255.0, 0, 255), np.uint8)
    return np.clip((grey - lo) / (hi - lo) * 255.0, 0, 255).astype(np.uint8)


def text_size(text: str, scale: float) -> tuple[int, int, int]:
    """(width, height above the baseline, depth below it) of ``text`` in px at font ``scale``."""
    (w, h), base = cv2.getTextSize(text, FONT, scale, 1)
    return w, h, base


def wrap_caption(text: str, max_width: int, scale: float = CAPTION_SCALE) -> list[str]:
    """``text`` in lines no wider than ``max_width`` px at font ``scale`` (broken between words; a word
    longer than a line is broken inside). Joining the lines with blanks gives ``text`` back (up to blanks).

    Examples
    --------
    >>> lines = wrap_caption("not found: " + "no corroborated centre " * 8, 200)
    >>> all(text_size(line, CAPTION_SCALE)[0] <= 200 for line in lines) and len(lines) > 1
    True
    """
    lines: list[str] = []
    current = ""
    for word in text.split():
        trial = f"{current} {word}" if current else word
        if text_size(trial, scale)[0] <= max_width:
            current = trial
            continue
        if current:
            lines.append(current)
        while text_size(word, scale)[0] > max_width and len(word) > 1:
            cut = 1
            while cut < len(word) - 1 and text_size(word[:cut + 1], scale)[0] <= max_width:
                cut += 1
            lines.append(word[:cut])
            word = word[cut:]
        current = word
    if current:
        lines.append(current)
    return lines


def _caption_band(text: str, width: int) -> np.ndarray:
    """A dark band ``width`` px wide holding ``text`` in light lines, wrapped to fit inside it."""
    lines = wrap_caption(text, max(1, width - 2 * PAD)) or [""]
    _, h, base = text_size("Ag", CAPTION_SCALE)
    line_h = h + base + 3
    band = np.zeros((len(lines) * line_h + 2 * PAD, width, 3), np.uint8)
    band[:] = TEXT_GROUND
    for i, line in enumerate(lines):
        cv2.putText(band, line, (PAD, PAD + i * line_h + h), FONT, CAPTION_SCALE, TEXT_COLOUR, 1, cv2.LINE_AA)
    return band


def draw_tag(img: np.ndarray, text: str, near: tuple[float, float], gap: float) -> tuple[int, int, int, int]:
    """Write ``text`` on a dark box beside the point ``near`` (px of ``img``), ``gap`` px from it to the upper
    right, or wherever it fits, always wholly inside ``img``. Returns the box (x0, y0, x1, y1), x1/y1
    exclusive."""
    w, h, base = text_size(text, TAG_SCALE)
    bw, bh = w + 2 * PAD, h + base + 2 * PAD
    height, width = img.shape[:2]
    x = near[0] + gap if near[0] + gap + bw <= width else near[0] - gap - bw
    y = near[1] - gap - bh if near[1] - gap - bh >= 0 else near[1] + gap
    x0 = int(min(max(0, round(x)), max(0, width - bw)))
    y0 = int(min(max(0, round(y)), max(0, height - bh)))
    cv2.rectangle(img, (x0, y0), (x0 + bw - 1, y0 + bh - 1), TEXT_GROUND, cv2.FILLED)
    cv2.putText(img, text, (x0 + PAD, y0 + PAD + h), FONT, TAG_SCALE, TEXT_COLOUR, 1, cv2.LINE_AA)
    return x0, y0, min(width, x0 + bw), min(height, y0 + bh)


def _caption(location: Location, name: str | None) -> str:
    head = f"{name}: " if name else ""
    clipped = " (box clipped to the image)" if location.clipped else ""
    if location.found:
        return (f"{head}({location.x:.2f}, {location.y:.2f}) sigma {location.sigma:.3f} px "
                f"score {location.score:.2f} {location.method}{clipped}")
    return f"{head}not found: {location.reason}{clipped}"


def _window(location: Location) -> tuple[np.ndarray, tuple[int, int, int, int] | None]:
    """The grey window the detector saw and the searched box in its pixels (None: the whole window)."""
    if location.window is None:
        return np.zeros((8, 8), np.float32), None
    origin = getattr(location, "window_box", None) or location.box  # the window may be read round the box
    x0, y0, x1, y1 = location.box
    return location.window, (x0 - origin[0], y0 - origin[1], x1 - origin[0], y1 - origin[1])


def overlay_image(location: Location, name: str | None = None, min_side: int = 480,
                  cross_px: float = 11.0) -> np.ndarray:
    """The overlay as a BGR array: the window the detector saw enlarged to at least ``min_side`` px (whole
    pixels), the searched box framed, the orange cross and 3-sigma circle at the centre when found, ``name``
    beside it, and the result in a caption band above."""
    grey, box = _window(location)
    img = _to_uint8_grey(grey)
    h, w = img.shape
    scale = max(1, int(np.ceil(min_side / max(h, w))))
    big = cv2.cvtColor(cv2.resize(img, (w * scale, h * scale), interpolation=cv2.INTER_NEAREST),
                       cv2.COLOR_GRAY2BGR)
    bx0, by0, bx1, by1 = box if box is not None else (0, 0, w, h)
    cv2.rectangle(big, (bx0 * scale, by0 * scale), (bx1 * scale - 1, by1 * scale - 1), BOX_COLOUR, 1)
    if location.found:
        ox, oy = location.box[0] - bx0, location.box[1] - by0  # full-image pixels of the window's origin
        centre = ((location.x - ox + 0.5) * scale - 0.5, (location.y - oy + 0.5) * scale - 0.5)
        gap = _draw_centre(big, centre, scale, location.sigma, cross_px)
        if name:
            draw_tag(big, name, centre, gap + 3)
    elif name:
        draw_tag(big, name, (bx0 * scale, by0 * scale), 0.0)
    return np.vstack([_caption_band(_caption(location, name), big.shape[1]), big])


def _draw_centre(big: np.ndarray, centre: tuple[float, float], scale: int, sigma: float, cross_px: float) -> float:
    """The orange cross (``cross_px`` window pixels long) and 3-sigma circle at ``centre`` (px of ``big``);
    returns the cross's half length in px of ``big``."""
    def pt(x: float, y: float) -> tuple[int, int]:  # fixed point, sub-pixel
        return round(x * (1 << SHIFT)), round(y * (1 << SHIFT))

    x, y = centre
    half = max(cross_px / 2.0, 6.0 / scale) * scale
    thick = max(1, scale // 4)
    cv2.line(big, pt(x - half, y), pt(x + half, y), ORANGE, thick, cv2.LINE_AA, SHIFT)
    cv2.line(big, pt(x, y - half), pt(x, y + half), ORANGE, thick, cv2.LINE_AA, SHIFT)
    if np.isfinite(sigma):
        r = int(round(max(3 * sigma * scale, 2) * (1 << SHIFT)))
        cv2.circle(big, pt(x, y), r, ORANGE, 1, cv2.LINE_AA, SHIFT)
    return half


def _png(img: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()


def overlay_png(location: Location, name: str | None = None, min_side: int = 480, cross_px: float = 11.0) -> bytes:
    """PNG of :func:`overlay_image`: the searched window with the result drawn on it (orange cross when
    found, the box always) and ``name`` beside the centre."""
    return _png(overlay_image(location, name, min_side, cross_px))


def overlay_sheet_png(named: Sequence[tuple[str, Location]], min_side: int = 320, gap: int = 8) -> bytes:
    """PNG of the overlays of several marks on one sheet, row by row in the given order, each with its box,
    centre and name (:func:`overlay_image`); ``named`` holds (name, location) pairs."""
    panels = [overlay_image(loc, name, min_side) for name, loc in named]
    if not panels:
        raise ValueError("overlay_sheet_png needs at least one location")
    cols = math.ceil(math.sqrt(len(panels)))
    rows = math.ceil(len(panels) / cols)
    cell_h = max(p.shape[0] for p in panels)
    cell_w = max(p.shape[1] for p in panels)
    sheet = np.zeros((rows * cell_h + (rows + 1) * gap, cols * cell_w + (cols + 1) * gap, 3), np.uint8)
    sheet[:] = SHEET_GROUND
    for k, p in enumerate(panels):
        top = gap + (k // cols) * (cell_h + gap)
        left = gap + (k % cols) * (cell_w + gap)
        sheet[top:top + p.shape[0], left:left + p.shape[1]] = p
    return _png(sheet)


def diagnostic_figure(location: Location, name: str | None = None) -> Figure:
    """The method's own diagnostic figure (:meth:`aerofid.detect.result.Detection.plot`) for the window it
    saw: for ``hough`` the thesis figures 5.2-5.5, for ``auto`` the figure of the method whose centre it
    returns, with the result (and ``name``) in the title, wrapped to stay inside the figure."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # matplotlib only when a figure is asked for
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 8.5))
    FigureCanvasAgg(fig)
    window = location.window if location.window is not None else np.zeros((8, 8), np.float32)
    det = location.detection if location.detection is not None else Detection.not_found(location.method,
                                                                                          location.reason)
    det.plot(fig, window)
    head = f"{name}: " if name else ""
    if location.found:
        title = (f"{head}{location.method}: x={location.x:.3f} y={location.y:.3f} sigma={location.sigma:.3f} px "
                 f"score={location.score:.2f}")
    else:
        title = f"{head}not found: {location.reason}"
    fig.suptitle("\n".join(textwrap.wrap(title, TITLE_CHARS)), fontsize=10)
    return fig


def diagnostic_png(location: Location, name: str | None = None) -> bytes:
    """PNG of :func:`diagnostic_figure`."""
    buf = io.BytesIO()
    diagnostic_figure(location, name).savefig(buf, format="png", dpi=90)
    return buf.getvalue()


__all__ = ["diagnostic_figure", "diagnostic_png", "draw_tag", "overlay_image", "overlay_png", "overlay_sheet_png",
           "text_size", "wrap_caption"]
