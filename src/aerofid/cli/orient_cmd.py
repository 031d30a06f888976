"""`aerofid orient`: interior orientation from measured fiducial centres.

Exit status: 0 success; 1 when it ran but could not decide (ambiguous fiducial correspondence);
2 on bad input (one line ``error: ...`` on stderr, nothing written).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.measurements import read_measurements_and_not_found
from aerofid.formats.micmac import write_affine_plane, write_measures_camera, write_measures_im
from aerofid.io.atomic import write_text_atomic
from aerofid.orientation.camera import Camera
from aerofid.orientation.correspondence import AmbiguousCorrespondenceError
from aerofid.orientation.interior import orient as run_orient
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.report import to_html, to_text
from aerofid.orientation.result import InteriorOrientation

REPORT_SUFFIXES = (".json", ".html", ".htm", ".txt")


@click.command()
@click.argument("image", required=False)
@click.option("--camera", "camera_path", required=True, metavar="CAMERA",
              help="camera file: JSON/YAML certificate or MicMac MeasuresCamera.xml")
@click.option("--measurements", "-m", "meas_path", metavar="FILE",
              help="fiducial pixel measurements: JSON (as aerofid locate --json writes it; marks it did not "
                   "find are left out), CSV (name,x,y) or MicMac MeasuresIm-*.xml")
@click.option("--model", type=click.Choice(["affine", "similarity", "projective"]), default="affine",
              show_default=True, help="pixel -> mm transformation")
@click.option("--correspondence", type=click.Choice(["names", "auto"]), default=None,
              help="trust the point names, or assign points by testing the 8 film arrangements "
                   "(default: names when the points have names)")
@click.option("--no-reject", is_flag=True, help="keep every fiducial (no blunder rejection)")
@click.option("--json", "as_json", is_flag=True, help="print the result as one JSON object")
@click.option("-o", "--output", metavar="REPORT", help="write a report: .json, .html or .txt")
@click.option("--micmac", "micmac_dir", metavar="DIR",
              help="write MeasuresIm-<image>.xml, MeasuresCamera.xml and <image>-AffinePlane-px2mm.xml into DIR")
def orient(image, camera_path, meas_path, model, correspondence, no_reject, as_json, output, micmac_dir) -> int:
    """Interior orientation (pixel -> film mm) of a scan from its measured fiducials."""
    if meas_path is None:
        if image:
            raise AerofidInputError(
                f"finding the fiducials in {image!r} automatically is not available yet: give --measurements FILE")
        raise AerofidInputError("give --measurements FILE (fiducial pixel coordinates)")
    if output is not None and Path(output).suffix.lower() not in REPORT_SUFFIXES:
        raise AerofidInputError(f"report {output!r} must end in .json, .html or .txt")
    if micmac_dir is not None and not Path(micmac_dir).is_dir():
        raise AerofidInputError(f"MicMac folder {micmac_dir!r} does not exist")
    cam = read_camera(camera_path)
    meas, not_found = read_measurements_and_not_found(meas_path)
    image_name = meas.image or (Path(image).name if image else "") or Path(meas_path).stem
    try:
        res = _run_orient(cam, meas, not_found, meas_path, model=model, correspondence=correspondence,
                          reject=not no_reject, image=image_name)
    except AmbiguousCorrespondenceError as e:
        if as_json:
            click.echo(json.dumps({"status": "ambiguous", "error": str(e),
                                   "correspondence": e.correspondence.to_dict()}))
        click.echo(f"error: {e}", err=True)
        return 1

    if not_found:
        click.echo(f"note: {', '.join(not_found)} not found in {meas_path!r}; oriented with the "
                   f"{len(meas.xy)} found", err=True)
    if output is not None:
        write_text_atomic(output, _report(res, Path(output).suffix.lower()))
    if micmac_dir is not None:
        _write_micmac(Path(micmac_dir), cam, res)
    if as_json:
        click.echo(json.dumps(res.to_dict()))
    else:
        click.echo(to_text(res), nl=False)
    return 0


def _run_orient(cam: Camera, meas: Measurements, not_found: tuple[str, ...], meas_path: str,
                **options: Any) -> InteriorOrientation:
    """:func:`aerofid.orientation.interior.orient`; an input error names the points the measurements file
    marks as not found (too few fiducials left is the usual cause)."""
    try:
        return run_orient(cam, meas, **options)
    except AmbiguousCorrespondenceError:
        raise
    except AerofidInputError as e:
        if not_found:
            raise AerofidInputError(f"{e} (not found in {meas_path!r}: {', '.join(not_found)})") from None
        raise


def _report(res: InteriorOrientation, suffix: str) -> str:
    """The report for a file ending in ``suffix``: JSON, plain text or HTML."""
    if suffix == ".json":
        return json.dumps(res.to_dict(), indent=2) + "\n"
    if suffix == ".txt":
        return to_text(res)
    return to_html(res)


def _write_micmac(folder: Path, cam: Camera, res: InteriorOrientation) -> None:
    """MeasuresIm of the used fiducials, MeasuresCamera, and the AffinePlane pixel -> mm (not projective)."""
    used = res.used
    name = res.image or "image"
    m = Measurements(np.array([[f.x_px, f.y_px] for f in used]), tuple(f.name for f in used), name)
    write_measures_im(folder / f"MeasuresIm-{name}.xml", m)
    write_measures_camera(folder / "MeasuresCamera.xml", cam)
    if res.model != "projective":
        write_affine_plane(folder / f"{name}-AffinePlane-px2mm.xml", res.pixel_to_mm)
