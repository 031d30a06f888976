"""Interior-orientation reports: plain text and a self-contained HTML page with a residual plot.

The plot shows the fiducials on the film frame (mm, x right, y up as the certificate) with their residual
vectors (calibrated minus adjusted) exaggerated so that the largest is about a tenth of the frame; it is an
inline SVG made with matplotlib's SVG backend (no display needed), so the HTML file needs nothing else.
"""

from __future__ import annotations

import html
import io
import math

import numpy as np

from aerofid.orientation.result import USED, InteriorOrientation


def _f(v, fmt: str = ".4f") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    return format(v, fmt)


def _matrix_lines(res: InteriorOrientation) -> list[str]:
    d = res.to_dict()
    rows = d["pixel_to_mm"]
    std = d["parameter_std"]
    out = []
    if res.model == "projective":
        out.append("  X = (a x + b y + c) / (g x + h y + 1),  Y = (d x + e y + f) / (g x + h y + 1)")
    else:
        out.append("  X = a x + b y + c,  Y = d x + e y + f   (x = column, y = row; X, Y in mm)")
    names = "abcdefgh"
    k = 0
    for i, row in enumerate(rows):
        for j, v in enumerate(row):
            if k >= len(names):
                break
            out.append(f"  {names[k]} = {v: .10g}   +- {_f(std[i][j], '.3g')}")
            k += 1
    return out


def to_text(res: InteriorOrientation) -> str:
    """A plain-text report (what ``aerofid orient`` prints without --json)."""
    L = [f"Interior orientation of {res.image or '(image)'} with camera {res.camera!r}: {res.model} model",
         "", "Parameters (pixel -> mm):"]
    L += _matrix_lines(res)
    L += ["", f"{'fiducial':>10} {'x_px':>11} {'y_px':>11} {'x_mm':>10} {'y_mm':>10} "
              f"{'vx_um':>8} {'vy_um':>8} {'vx_px':>7} {'vy_px':>7}  status"]
    for f in res.fiducials:
        L.append(f"{f.name:>10} {f.x_px:11.3f} {f.y_px:11.3f} {f.x_mm:10.4f} {f.y_mm:10.4f} "
                 f"{f.residual_x_mm * 1000:8.2f} {f.residual_y_mm * 1000:8.2f} {f.residual_x_px:7.3f} "
                 f"{f.residual_y_px:7.3f}  {f.status}" + (f" ({f.reason})" if f.reason else ""))
    if res.missing:
        L.append(f"not measured: {', '.join(res.missing)}")
    L += ["",
          f"redundancy r = {res.redundancy}",
          f"variance of unit weight sigma0^2 = {_f(res.variance_of_unit_weight, '.6g')} mm^2 "
          f"(sigma0 = {_f(res.sigma0_mm * 1000, '.2f')} um)",
          f"RMS residual = {res.rms_mm * 1000:.2f} um = {res.rms_px:.3f} px "
          f"(x {res.rms_x_mm * 1000:.2f} um, y {res.rms_y_mm * 1000:.2f} um)",
          f"pixel size = {res.pixel_size_um[0]:.4f} x {res.pixel_size_um[1]:.4f} um, rotation "
          f"{res.rotation_deg:.4f} deg, non-orthogonality {res.non_orthogonality_deg:.4f} deg, "
          f"scale difference {res.scale_difference_ppm:.0f} ppm" + (", mirrored" if res.mirrored else "")]
    if res.scale_vs_nominal_ppm is not None:
        L.append(f"scale vs nominal pixel size: x {res.scale_vs_nominal_ppm[0]:.0f} ppm, "
                 f"y {res.scale_vs_nominal_ppm[1]:.0f} ppm")
    L.append(f"principal point ({res.principal_point_source}) = ({res.principal_point_px[0]:.3f}, "
             f"{res.principal_point_px[1]:.3f}) px; fiducial centre = ({res.fiducial_centre_px[0]:.3f}, "
             f"{res.fiducial_centre_px[1]:.3f}) px")
    if res.correspondence is not None:
        c = res.correspondence.best
        L.append(f"correspondence: arrangement rotation {c.rotation_deg} deg"
                 f"{', mirrored' if c.mirrored else ''} ({res.correspondence.status})")
    for w in res.warnings:
        L.append(f"warning: {w}")
    return "\n".join(L) + "\n"


def residual_plot_svg(res: InteriorOrientation) -> str:
    """Residual vectors on the film layout as an SVG string (matplotlib, no display needed)."""
    # matplotlib is imported here, not at the top: it would add ~0.3 s to every start of the CLI
    from matplotlib.figure import Figure

    xy = np.array([[f.x_mm, f.y_mm] for f in res.fiducials])
    v = np.array([[f.residual_x_mm, f.residual_y_mm] for f in res.fiducials])
    size = float(np.max(np.ptp(xy, axis=0))) or 1.0
    vmax = float(np.max(np.hypot(v[:, 0], v[:, 1]))) if len(v) else 0.0
    k = 0.1 * size / vmax if vmax > 0 else 1.0
    fig = Figure(figsize=(6, 6))
    ax = fig.add_subplot(1, 1, 1)
    used = np.array([f.status == USED for f in res.fiducials])
    ax.scatter(xy[used, 0], xy[used, 1], c="k", s=20, label="used")
    if (~used).any():
        ax.scatter(xy[~used, 0], xy[~used, 1], marker="x", c="r", s=40, label="rejected")
    for f, (x, y), (dx, dy), u in zip(res.fiducials, xy, v, used):
        ax.annotate("", xy=(x + k * dx, y + k * dy), xytext=(x, y),
                    arrowprops={"arrowstyle": "->", "color": "tab:blue" if u else "tab:red", "lw": 1.5})
        ax.text(x, y, f"  {f.name}", fontsize=8, va="bottom")
    pad = 0.15 * size
    ax.set_xlim(xy[:, 0].min() - pad, xy[:, 0].max() + pad)
    ax.set_ylim(xy[:, 1].min() - pad, xy[:, 1].max() + pad)
    pp = res.principal_point_px
    ppmm = res.to_mm([pp])[0]
    ax.plot([ppmm[0]], [ppmm[1]], "+", c="gray", ms=12)
    ax.set_aspect("equal")
    ax.set_xlabel("film x (mm)")
    ax.set_ylabel("film y (mm)")
    ax.set_title(f"residuals (calibrated - adjusted) x {k:.3g}; largest {vmax * 1000:.1f} um")
    ax.legend(loc="upper right", fontsize=8)
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight")
    svg = buf.getvalue()
    return svg[svg.find("<svg"):]


def to_html(res: InteriorOrientation) -> str:
    """A self-contained HTML report: parameters, the residual table, statistics and the residual plot."""
    e = html.escape
    rows = []
    for f in res.fiducials:
        cls = "" if f.status == USED else ' class="rej"'
        rows.append(
            f"<tr{cls}><td>{e(f.name)}</td><td>{f.x_px:.3f}</td><td>{f.y_px:.3f}</td><td>{f.x_mm:.4f}</td>"
            f"<td>{f.y_mm:.4f}</td><td>{f.adjusted_x_mm:.4f}</td><td>{f.adjusted_y_mm:.4f}</td>"
            f"<td>{f.residual_x_mm * 1000:.2f}</td><td>{f.residual_y_mm * 1000:.2f}</td>"
            f"<td>{f.residual_x_px:.3f}</td><td>{f.residual_y_px:.3f}</td><td>{e(f.status)}</td>"
            f"<td>{e(f.reason)}</td></tr>")
    text = to_text(res)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Interior orientation {e(res.image)}</title>
<style>body{{font-family:sans-serif;margin:2em}} table{{border-collapse:collapse}}
td,th{{border:1px solid #bbb;padding:2px 6px;text-align:right}} tr.rej{{color:#b00}}
pre{{background:#f6f6f6;padding:1em}}</style></head><body>
<h1>Interior orientation: {e(res.image or '(image)')}</h1>
<p>Camera {e(res.camera)}, model <b>{e(res.model)}</b>. RMS residual {res.rms_mm * 1000:.2f} &micro;m
({res.rms_px:.3f} px), variance of unit weight {_f(res.variance_of_unit_weight, '.6g')} mm&sup2;,
redundancy {res.redundancy}.</p>
<h2>Fiducials</h2>
<table><tr><th>name</th><th>x px</th><th>y px</th><th>x mm</th><th>y mm</th><th>adjusted x</th>
<th>adjusted y</th><th>v<sub>x</sub> &micro;m</th><th>v<sub>y</sub> &micro;m</th><th>v<sub>x</sub> px</th>
<th>v<sub>y</sub> px</th><th>status</th><th>reason</th></tr>
{chr(10).join(rows)}
</table>
<h2>Residual vectors</h2>
{residual_plot_svg(res)}
<h2>Summary</h2>
<pre>{e(text)}</pre>
</body></html>
"""
