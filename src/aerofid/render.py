"""Pictures of a result: the delineation overlay and the diagnostic figure.

- :func:`overlay_png`: "the fiducial marks are delineated by drawing an orange fiducial mark over the
  aerial photograph centered at the generated coordinates" (thesis 000, section 5.9): a crop of the image
  around the box, enlarged, with the searched box, an orange cross at the sub-pixel centre and a circle
  of radius 3 sigma.
- :func:`diagnostic_png`: the method's own diagnostic figure (each result type draws its own; for ``hough``
  the thesis figures 5.2-5.5: the optimally thresholded window, the Hough accumulator before and after
  thresholding, and the theta projection with the fitted similarity model).

Both return PNG bytes; the CLI writes them with :func:`aerofid.io.atomic.write_bytes_atomic`.
"""

from __future__ import annotations

import io

import cv2
import numpy as np

from aerofid.detect.result import Detection
from aerofid.locate import Location

ORANGE = (0, 140, 255)   # BGR
BOX_COLOUR = (255, 200, 0)
SHIFT = 4                # cv2 fixed-point bits: sub-pixel drawing to 1/16 px


def _to_uint8_grey(grey: np.ndarray) -> np.ndarray:
    lo, hi = np.percentile(grey, [0.5, 99.5])
    if hi <= lo:
        hi = lo + 1e-6
    return np.clip((grey - lo) / (hi - lo) * 255.0, 0, 255).astype(np.uint8)


def overlay_png(location: Location, min_side: int = 480, cross_px: float = 11.0) -> bytes:
    """PNG of the searched window with the result drawn on it (orange cross when found, the box always)."""
    grey = location.window if location.window is not None else np.zeros((8, 8), np.float32)
    img = _to_uint8_grey(grey)
    h, w = img.shape
    scale = max(1, int(np.ceil(min_side / max(h, w))))
    big = cv2.resize(img, (w * scale, h * scale), interpolation=cv2.INTER_NEAREST)
    big = cv2.cvtColor(big, cv2.COLOR_GRAY2BGR)
    cv2.rectangle(big, (0, 0), (w * scale - 1, h * scale - 1), BOX_COLOUR, 1)

    def pt(x: float, y: float) -> tuple[int, int]:  # window pixel centre -> enlarged image, fixed point
        return (round(((x + 0.5) * scale - 0.5) * (1 << SHIFT)), round(((y + 0.5) * scale - 0.5) * (1 << SHIFT)))

    if location.found:
        x = location.x - location.box[0]
        y = location.y - location.box[1]
        half = max(cross_px / 2.0, 6.0 / scale)
        thick = max(1, scale // 4)
        cv2.line(big, pt(x - half, y), pt(x + half, y), ORANGE, thick, cv2.LINE_AA, SHIFT)
        cv2.line(big, pt(x, y - half), pt(x, y + half), ORANGE, thick, cv2.LINE_AA, SHIFT)
        if np.isfinite(location.sigma):
            r = int(round(max(3 * location.sigma * scale, 2) * (1 << SHIFT)))
            cv2.circle(big, pt(x, y), r, ORANGE, 1, cv2.LINE_AA, SHIFT)
        label = f"({location.x:.2f}, {location.y:.2f}) score {location.score:.2f} sigma {location.sigma:.3f} px"
    else:
        label = f"not found: {location.reason}"
    cv2.putText(big, label[:80], (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(big, label[:80], (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1, cv2.LINE_AA)
    ok, buf = cv2.imencode(".png", big)
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()


def diagnostic_png(location: Location) -> bytes:
    """PNG of the method's own diagnostic figure (:meth:`aerofid.detect.result.Detection.plot`) for the window
    it saw: for ``hough`` the thesis figures 5.2-5.5, for ``auto`` the figure of the method whose centre it
    returns, with the result in the title."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 8.5))
    FigureCanvasAgg(fig)
    window = location.window if location.window is not None else np.zeros((8, 8), np.float32)
    det = location.detection if location.detection is not None else Detection.not_found(location.method,
                                                                                          location.reason)
    det.plot(fig, window)
    if location.found:
        title = (f"{location.method}: x={location.x:.3f} y={location.y:.3f} sigma={location.sigma:.3f} px "
                 f"score={location.score:.2f}")
    else:
        title = f"not found: {location.reason}"
    fig.suptitle(title[:110], fontsize=10)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return buf.getvalue()
