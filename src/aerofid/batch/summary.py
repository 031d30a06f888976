"""A batch's summary: ``summary.csv`` (a row per frame), ``summary.json`` (the settings, the counts, the residual
statistics and every frame's record) and ``summary.html`` (the same for a person, with a gallery of every mark
crop for review, the worst frames and within each the worst marks first).

The texts are pure functions of the records; :func:`write_summary` writes the three files together (staged and
renamed into place: a batch killed while writing leaves the previous summary).
"""

from __future__ import annotations

import csv
import html
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from aerofid.batch.gallery import RESIDUAL_SCALE, TILE_PX
from aerofid.batch.job import STATUS_ORDER, FrameRecord, MarkRecord
from aerofid.batch.plan import BatchSettings, frame_outputs
from aerofid.frame.result import FOUND_MARK, MISSING_MARK
from aerofid.io.atomic import Staging

SUMMARY_FILES = ("summary.csv", "summary.json", "summary.html")
"""The summary's files in the output folder."""
MARK_ORDER = (MISSING_MARK, "rejected", FOUND_MARK)
"""Marks' statuses, worst first (the gallery's order within a frame)."""
CSV_COLUMNS = ("frame", "path", "status", "rms_px", "marks_found", "marks", "max_residual_px", "worst_mark",
               "seconds", "reasons", "error")


def frame_order(r: FrameRecord) -> tuple[int, int, float, str]:
    """Sort key of a frame, worst first: by status (:data:`~aerofid.batch.job.STATUS_ORDER`), then by the marks
    not found or rejected, then by RMS."""
    rank = STATUS_ORDER.index(r.status) if r.status in STATUS_ORDER else 0
    return rank, -sum(m.status != FOUND_MARK for m in r.marks), -(r.rms_px or 0.0), r.frame


def mark_order(m: MarkRecord) -> tuple[int, float, str]:
    """Sort key of a mark, worst first: not found, rejected, then by residual."""
    rank = MARK_ORDER.index(m.status) if m.status in MARK_ORDER else 0
    return rank, -(m.residual_px or 0.0), m.name


def _stats(values: Sequence[float]) -> dict[str, Any]:
    """Count, median, 95th percentile and largest of ``values`` (None when empty)."""
    a = np.asarray(values, dtype=float)
    if not a.size:
        return {"n": 0, "median": None, "p95": None, "max": None}
    return {"n": int(a.size), "median": float(np.median(a)), "p95": float(np.percentile(a, 95)),
            "max": float(a.max())}


def statistics(records: Sequence[FrameRecord]) -> dict[str, Any]:
    """The counts per status, the frames' RMS, the used marks' residuals (px), and per fiducial name its
    counts and residuals (a fiducial that fails on many frames shows there)."""
    counts = {s: sum(r.status == s for r in records) for s in STATUS_ORDER}
    used = [(m.name, m.residual_px) for r in records for m in r.marks
            if m.status == FOUND_MARK and m.residual_px is not None]
    names = sorted({m.name for r in records for m in r.marks})
    per = {n: {"found": sum(m.name == n and m.status == FOUND_MARK for r in records for m in r.marks),
               "rejected": sum(m.name == n and m.status == "rejected" for r in records for m in r.marks),
               "not_found": sum(m.name == n and m.status == MISSING_MARK for r in records for m in r.marks),
               "residual_px": _stats([v for name, v in used if name == n])} for n in names}
    return {"frames": len(records), "counts": counts,
            "rms_px": _stats([r.rms_px for r in records if r.rms_px is not None]),
            "residual_px": _stats([v for _, v in used]), "fiducials": per}


def _worst_mark(r: FrameRecord) -> MarkRecord | None:
    return min(r.marks, key=mark_order) if r.marks else None


def summary_csv(records: Sequence[FrameRecord]) -> str:
    """A row per frame (:data:`CSV_COLUMNS`), in the given order."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in records:
        worst = _worst_mark(r)
        residuals = [m.residual_px for m in r.marks if m.residual_px is not None and m.status == FOUND_MARK]
        w.writerow([r.frame, r.path, r.status, _num(r.rms_px), sum(m.status != MISSING_MARK for m in r.marks),
                    len(r.marks), _num(max(residuals, default=None)), "" if worst is None else worst.name,
                    f"{r.seconds:.2f}", "; ".join(r.reasons), r.error])
    return buf.getvalue()


def _num(v: float | None) -> str:
    return "" if v is None else f"{v:.4f}"


def summary_json(records: Sequence[FrameRecord], settings: BatchSettings, planned: int | None = None) -> str:
    """The settings, the number of frames ``planned`` (the records' by default; more while the batch runs or
    when it was interrupted), :func:`statistics` and every record."""
    return json.dumps({"settings": settings.options(), "planned": len(records) if planned is None else planned,
                       "statistics": statistics(records), "frames": [r.to_dict() for r in records]},
                      indent=1) + "\n"


def _heading(done: int, planned: int | None) -> str:
    """``40 frames``, or ``12 of 40 frames done`` while a batch runs or after it was interrupted."""
    return f"{done} frames" if planned is None or planned == done else f"{done} of {planned} frames done"


def _frame_rows(records: Sequence[FrameRecord], settings: BatchSettings) -> str:
    e = html.escape
    rows = []
    for r in sorted(records, key=frame_order):
        link = (e(r.frame) if r.status == "error" else
                f'<a href="{e(frame_outputs(r.frame, settings.model).html)}">{e(r.frame)}</a>')
        why = e(r.error or "; ".join(r.reasons))
        rows.append(f'<tr><td>{link}</td><td class="{e(r.status)}">{e(r.status)}</td><td>{_num(r.rms_px)}</td>'
                    f'<td>{sum(m.status != MISSING_MARK for m in r.marks)}/{len(r.marks)}</td><td>{why}</td></tr>')
    return "\n".join(rows)


def _gallery(records: Sequence[FrameRecord], settings: BatchSettings) -> str:
    """A row of tiles per frame (worst first), each frame's marks worst first (tile i of the frame's crops)."""
    e = html.escape
    out = []
    for r in sorted(records, key=frame_order):
        if not r.marks:
            continue
        src = e(frame_outputs(r.frame, settings.model).crops)
        tiles = "".join(
            f'<figure><div class="t"><img src="{src}" loading="lazy" style="margin-left:-{i * TILE_PX}px">'
            f'</div><figcaption class="{e(m.status)}">{e(m.name)} {e(m.status)} {_num(m.residual_px)}'
            f"</figcaption></figure>"
            for i, m in sorted(enumerate(r.marks), key=lambda im: mark_order(im[1])))
        out.append(f'<h3 class="{e(r.status)}">{e(r.frame)}: {e(r.status)}, RMS {_num(r.rms_px)} px</h3>{tiles}')
    return "\n".join(out)


def summary_html(records: Sequence[FrameRecord], settings: BatchSettings, planned: int | None = None) -> str:
    """The page (module docstring): counts (of ``planned`` frames), residual statistics, the frames worst first,
    the gallery."""
    e = html.escape
    st = statistics(records)
    counts = ", ".join(f'<span class="{s}">{n} {s}</span>' for s, n in st["counts"].items())
    res, rms = st["residual_px"], st["rms_px"]
    per = "".join(f"<tr><td>{e(n)}</td><td>{d['found']}</td><td>{d['rejected']}</td><td>{d['not_found']}</td>"
                  f"<td>{_num(d['residual_px']['median'])}</td><td>{_num(d['residual_px']['max'])}</td></tr>"
                  for n, d in st["fiducials"].items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>aerofid batch: {_heading(st['frames'], planned)}</title>
<style>body{{font-family:sans-serif;margin:2em}} td,th{{padding:2px 8px;text-align:left}}
figure{{display:inline-block;margin:3px}} .t{{width:{TILE_PX}px;height:{TILE_PX}px;overflow:hidden}}
figcaption{{font-size:small}} .ok,.found{{color:#080}} .doubtful,.rejected{{color:#b60}}
.failed,.error,.not_found{{color:#b00}}</style></head><body>
<h1>{_heading(st['frames'], planned)}: {counts}</h1>
<p>Camera {e(settings.camera_path)}, model {e(settings.model)}, settings {e(settings.fingerprint)}.
Frame RMS (px): median {_num(rms['median'])}, max {_num(rms['max'])}. Residuals of the used marks (px):
{res['n']} marks, median {_num(res['median'])}, 95th percentile {_num(res['p95'])}, max {_num(res['max'])}.</p>
<table><tr><th>fiducial</th><th>found</th><th>rejected</th><th>not found</th><th>median residual</th>
<th>max residual</th></tr>{per}</table>
<h2>Frames, worst first</h2>
<table><tr><th>frame</th><th>status</th><th>RMS px</th><th>marks</th><th>why</th></tr>
{_frame_rows(records, settings)}
</table>
<h2>Every mark, worst frames and marks first</h2>
<p>+ measured centre, o prediction, red: the residual vector x{RESIDUAL_SCALE:g}; a red frame: not found.</p>
{_gallery(records, settings)}
</body></html>
"""


def write_summary(records: Sequence[FrameRecord], settings: BatchSettings, planned: int | None = None
                  ) -> list[Path]:
    """Write :data:`SUMMARY_FILES` of ``records`` (of ``planned`` frames) into the output folder together
    (staged, then renamed); their paths."""
    out = Path(settings.outdir)
    texts = (summary_csv(records), summary_json(records, settings, planned),
             summary_html(records, settings, planned))
    paths = [out / name for name in SUMMARY_FILES]
    with Staging() as staging:
        for p, text in zip(paths, texts, strict=True):
            staging.put(p, text)
        staging.commit()
    return paths


__all__ = ["SUMMARY_FILES", "frame_order", "mark_order", "statistics", "summary_csv", "summary_html", "summary_json",
           "write_summary"]
