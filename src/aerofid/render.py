"""Pictures of a result: the delineation overlay and the diagnostic figure.

- :func:`overlay_png`: "the fiducial marks are delineated by drawing an orange fiducial mark over the
  aerial photograph centered at the generated coordinates" (thesis 000, section 5.9): a crop of the image
  around the box, enlarged, with the searched box, an orange cross at the sub-pixel centre and a circle
  of radius 3 sigma.
- :func:`diagnostic_png`: the thesis figures 5.2-5.5 for the winning window: the optimally thresholded
  window, the Hough accumulator before and after thresholding, and the theta projection with the fitted
  similarity model.

Both return PNG bytes; the CLI writes them with :func:`aerofid.io.atomic.write_bytes_atomic`.
"""

from __future__ import annotations

import io

import cv2
import numpy as np

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

    def pt(x, y):  # window pixel centre -> enlarged image, fixed point
        return (int(round(((x + 0.5) * scale - 0.5) * (1 << SHIFT))), int(round(((y + 0.5) * scale - 0.5) * (1 << SHIFT))))

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
    """PNG of the diagnostic figure for a ``hough`` result (thesis figures 5.2-5.5); for other methods or
    when nothing was found, the searched window with the reason."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    det = location.detection
    diag = det.diagnostics if det is not None else {}
    a = diag.get("analysis")
    if a is None:
        fig, ax = plt.subplots(figsize=(5, 5))
        if location.window is not None:
            ax.imshow(location.window, cmap="gray", interpolation="nearest")
        ax.set_title(f"{location.method}: {location.status} {location.reason}"[:70], fontsize=9)
        return _fig_png(fig)
    fig, axes = plt.subplots(2, 2, figsize=(10, 8.5))
    ox, oy = diag["window_origin"]
    ax = axes[0, 0]
    ax.imshow(a.binary, cmap="gray", interpolation="nearest")
    ax.plot([a.x], [a.y], "+", color="orange", ms=14, mew=2)
    ax.set_title(f"Optimally thresholded window (stage {diag['stage']}, origin {ox},{oy} in box)", fontsize=9)
    for ax, acc, title in ((axes[0, 1], a.accumulator, "Hough accumulator"),
                           (axes[1, 0], a.accumulator_thresholded, "Thresholded accumulator")):
        theta_step = 180.0 / len(a.thetas)
        ax.imshow(acc, aspect="auto", cmap="magma", interpolation="nearest", origin="lower",
                  extent=[a.rho_min, a.rho_min + acc.shape[1] * a.rho_step, 0.0, 180.0])
        ax.set_ylim(0.0, 180.0 - theta_step)
        ax.set_xlabel("rho (px)")
        ax.set_ylabel("theta (deg)")
        ax.set_title(title, fontsize=9)
    ax = axes[1, 1]
    proj = a.projection / (a.projection.max() or 1.0)
    model = np.asarray(diag["model"], float)
    model = model / (model.max() or 1.0)
    ax.plot(a.thetas, proj, "o-", label="projection (eq. 5)")
    ax.plot(a.thetas, model, "--", label=f"{diag['model_name']} model")
    ax.set_xlabel("theta (deg)")
    ax.set_title(f"Theta projection, similarity {diag['metric']:.2f}", fontsize=9)
    ax.legend(fontsize=8)
    fig.suptitle(f"{location.status}: x={location.x:.3f} y={location.y:.3f} sigma={location.sigma:.3f} px", fontsize=10)
    fig.tight_layout()
    return _fig_png(fig)


def _fig_png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    plt.close(fig)
    return buf.getvalue()
