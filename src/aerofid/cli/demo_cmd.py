"""``aerofid demo``: make a synthetic scanned frame with known marks, locate them, report the errors."""

from __future__ import annotations

import json
from pathlib import Path

import click
import numpy as np


@click.command(name="demo")
@click.option("--out", "out_dir", default="aerofid-demo", show_default=True,
              type=click.Path(file_okay=False, path_type=Path), help="Folder for the scan, overlays and results.")
@click.option("--seed", default=1, show_default=True, help="Random seed of the synthetic frame.")
def demo(out_dir: Path, seed: int) -> int:
    """Generate a 1600 x 1600 scan (tiled TIFF) with 8 film fiducials and 2 cloth panels at known
    sub-pixel positions, locate each from a loose box, write overlays, a diagnostic figure and
    results.json, and print the errors against the truth."""
    import tifffile

    from aerofid import synth
    from aerofid.errors import AerofidInputError
    from aerofid.io.atomic import write_bytes_atomic, write_text_atomic
    from aerofid.locate import locate
    from aerofid.render import diagnostic_png, overlay_png

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise AerofidInputError(f"cannot create folder {str(out_dir)!r}: {e.strerror}") from None
    click.echo(f"making a synthetic scan (seed {seed}) ...")
    scene = synth.demo_frame(np.random.default_rng(seed))
    scan = out_dir / "demo_scan.tif"
    tmp = out_dir / ".demo_scan.tif.tmp"
    tifffile.imwrite(tmp, synth.to_uint8(scene.image), tile=(256, 256), compression="deflate")
    tmp.replace(scan)
    write_text_atomic(out_dir / "demo_truth.json", json.dumps([m.to_dict() for m in scene.marks], indent=1))
    click.echo(f"wrote {scan} ({scene.image.shape[1]} x {scene.image.shape[0]}, tiled TIFF) and demo_truth.json")
    click.echo(f"{'mark':6} {'kind':8} {'true x':>9} {'true y':>9} {'found x':>9} {'found y':>9} "
               f"{'error px':>8} {'sigma px':>8} {'score':>5}")
    rows, errors = [], []
    for m in scene.marks:
        kind = "external" if m.style == "cross" else "panel"
        r = locate(scan, m.box, mark=kind)
        write_bytes_atomic(out_dir / f"overlay_{m.name}.png", overlay_png(r, m.name))
        if m.name == "P1":
            write_bytes_atomic(out_dir / "diagnostics_P1.png", diagnostic_png(r, m.name))
        err = float(np.hypot(r.x - m.x, r.y - m.y)) if r.found else float("nan")
        errors.append(err)
        rows.append({"name": m.name, "truth": [m.x, m.y], **r.to_dict(), "error_px": None if not r.found else err})
        if r.found:
            found = f"{r.x:9.3f} {r.y:9.3f} {err:8.3f} {r.sigma:8.3f} {r.score:5.2f}"
        else:
            found = f"{'not found: ' + r.reason:>44}"
        click.echo(f"{m.name:6} {kind:8} {m.x:9.3f} {m.y:9.3f} {found}")
    write_text_atomic(out_dir / "results.json", json.dumps(rows, indent=1))
    err_px = np.array(errors)
    ok = np.isfinite(err_px)
    click.echo(f"found {ok.sum()} of {len(err_px)}; RMS error {np.sqrt(np.mean(err_px[ok] ** 2)):.3f} px, "
               f"max {np.max(err_px[ok]):.3f} px; overlays, diagnostics_P1.png and results.json in {out_dir}/")
    click.echo("(error: the distance from the truth; sigma: per axis, so an honest error is about 1.4 sigma)")
    return 0 if ok.all() else 1
