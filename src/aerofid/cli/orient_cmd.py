"""`aerofid orient`: interior orientation from measured fiducial centres, or of a whole frame (`frame_cmd`).

Exit status: 0 success; 1 when it ran but could not decide (ambiguous fiducial correspondence);
2 on bad input or a failed output (one line ``error: ...`` on stderr, nothing written). Every output (the
report, the MicMac files, the Metashape script) is checked before the files are read and written only once the
whole command has succeeded (:class:`aerofid.io.atomic.Staging`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import numpy as np

from aerofid.cli.frame_cmd import run_frame
from aerofid.cli.orient_outputs import check_outputs, metashape_text, micmac_files, micmac_texts
from aerofid.cli.output import flush_stdout
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.measurements import read_measurements_and_not_found
from aerofid.frame.nominal import DEFAULT_FORMAT
from aerofid.io.atomic import Staging
from aerofid.io.raster import image_size
from aerofid.orientation.camera import Camera
from aerofid.orientation.correspondence import NAME_THE_POINTS, AmbiguousCorrespondenceError
from aerofid.orientation.interior import orient as run_orient
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.report import to_html, to_text
from aerofid.orientation.result import InteriorOrientation


@click.command()
@click.argument("image", required=False)
@click.option("--camera", "camera_path", metavar="CAMERA",
              help="camera file: JSON/YAML certificate or MicMac MeasuresCamera.xml; for a scan also a film format "
                   f"alone (e.g. 23cm; without --camera: {DEFAULT_FORMAT}): marks found, orientation uncalibrated")
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
@click.option("--metashape", "metashape_path", metavar="SCRIPT.py",
              help="write a script for Agisoft Metashape Pro that places the fiducials measured here on this scan "
                   "in the open project (film camera, Fiducial markers in mm, pinned projections; docs/exports.md)")
@click.option("--pixel-size", type=float, metavar="MM",
              help="whole frame: the scan's pixel size in mm (default: the file's resolution tags, the camera file)")
@click.option("--lie", metavar="ROT[m]",
              help="whole frame: the film's lie when the fiducials cannot tell it: 0, 90, 180 or 270 degrees, "
                   "'m' if mirrored (e.g. 90m)")
@click.option("--profile", "profile_path", metavar="ROLL",
              help="whole frame: the roll's profile (aerofid learn): its pixel size, lie, polarity, method and mark "
                   "size are used; a frame that disagrees with it is doubtful")
def orient(image, camera_path, meas_path, model, correspondence, no_reject, as_json, output, micmac_dir,
           metashape_path, pixel_size, lie, profile_path) -> int:
    """Interior orientation (pixel -> film mm) of a scan: from its measured fiducials (--measurements), or from
    the scan itself (IMAGE alone: the fiducials found from the camera file's layout; without --camera on the
    23 cm format's nominal layout, uncalibrated)."""
    if meas_path is None:
        if image:
            return run_frame(image, camera_path, pixel_size=pixel_size, lie=lie, model=model, as_json=as_json,
                             output=output, micmac_dir=micmac_dir, profile_path=profile_path,
                             metashape=metashape_path)
        raise AerofidInputError("give the scan (aerofid orient IMAGE [--camera CAMERA]) or --measurements FILE "
                                "(fiducial pixel coordinates)")
    if camera_path is None:
        raise AerofidInputError("--measurements needs the camera file: --camera CAMERA (JSON/YAML certificate or "
                                "MicMac MeasuresCamera.xml)")
    if pixel_size is not None or lie is not None or profile_path is not None:
        raise AerofidInputError("--pixel-size, --lie and --profile are for a whole frame (IMAGE without "
                                "--measurements)")
    check_outputs(output, micmac_dir, metashape_path)
    inputs = [p for p in (image, camera_path, meas_path) if p]
    with Staging(inputs) as staging:
        if output is not None:
            staging.plan(output, "report")
        if metashape_path is not None:
            staging.plan(metashape_path, "--metashape")
        cam = read_camera(camera_path)
        meas, not_found = read_measurements_and_not_found(meas_path)
        if image:
            _check_scan(image, meas, meas_path)
        image_name = meas.image or (Path(image).name if image else "") or Path(meas_path).stem
        micmac = micmac_files(Path(micmac_dir), image_name, model, staging) if micmac_dir is not None else None
        try:
            res = _run_orient(cam, meas, not_found, meas_path, model=model, correspondence=correspondence,
                              reject=not no_reject, image=image_name)
        except AmbiguousCorrespondenceError as e:
            if as_json:
                click.echo(json.dumps({"status": "ambiguous", "error": str(e),
                                       "correspondence": e.correspondence.to_dict()}))
            flush_stdout()
            why = str(e)
            if meas.names is not None and set(meas.names) <= set(cam.names) and why.endswith(NAME_THE_POINTS):
                why = why[:-len(NAME_THE_POINTS)] + "the points are named as in the camera file: give " \
                                                    "--correspondence names"
            click.echo(f"error: {why}", err=True)
            return 1
        if not_found:
            click.echo(f"note: {', '.join(not_found)} not found in {meas_path!r}; oriented with the "
                       f"{len(meas.xy)} found", err=True)
        _put_outputs(staging, cam, res, output, micmac, metashape_path)
        click.echo(json.dumps(res.to_dict()) if as_json else to_text(res), nl=as_json)
        flush_stdout()
        staging.commit()
    return 0


def _check_scan(image: str, meas: Measurements, meas_path: str) -> None:
    """The scan IMAGE given with ``--measurements`` (it names the outputs; it must be a scan aerofid reads): refused
    where the measurements are of another scan (by its file name) or hold points outside it (its size read from its
    header, no pixel decoded)."""
    name = Path(image).name
    if meas.image and Path(meas.image).name != name:
        raise AerofidInputError(f"the measurements in {meas_path!r} are of {meas.image!r}, not of {name!r}: give "
                                "that scan, or leave IMAGE out")
    width, height = image_size(image)
    x, y = meas.xy[:, 0], meas.xy[:, 1]
    outside = (x < -0.5) | (y < -0.5) | (x > width - 0.5) | (y > height - 0.5)
    if outside.any():
        k = int(np.argmax(outside))
        raise AerofidInputError(f"point {meas.names[k] if meas.names else k + 1} of {meas_path!r} at ({x[k]:g}, "
                                f"{y[k]:g}) lies outside {name!r} ({width} x {height} px): these are not its "
                                "measurements; give their scan, or leave IMAGE out")


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


def _put_outputs(staging: Staging, cam: Camera, res: InteriorOrientation, output: str | None,
                 micmac: list[Path] | None, metashape_path: str | None) -> None:
    """Stage the report, the MicMac files and the Metashape script asked for (planned before the work)."""
    if output is not None:
        staging.put(output, _report(res, Path(output).suffix.lower()))
    if micmac is not None:
        for path, text in zip(micmac, micmac_texts(cam, res)):  # no AffinePlane for projective
            staging.put(path, text)
    if metashape_path is not None:
        staging.put(metashape_path, metashape_text(cam, res))


def _report(res: InteriorOrientation, suffix: str) -> str:
    """The report for a file ending in ``suffix``: JSON, plain text or HTML."""
    if suffix == ".json":
        return json.dumps(res.to_dict(), indent=2) + "\n"
    if suffix == ".txt":
        return to_text(res)
    return to_html(res)
