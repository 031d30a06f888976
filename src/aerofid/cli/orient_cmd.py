"""`aerofid orient`: interior orientation from measured fiducial centres.

Exit status: 0 success; 1 when it ran but could not decide (ambiguous fiducial correspondence);
2 on bad input or a failed output (one line ``error: ...`` on stderr, nothing written). Every output (the
report, the MicMac files) is checked before the files are read and written only once the whole command has
succeeded (:class:`aerofid.io.atomic.Staging`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import numpy as np

from aerofid.cli.output import flush_stdout
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.measurements import read_measurements_and_not_found
from aerofid.formats.micmac import affine_plane_xml, measures_camera_xml, measures_im_xml
from aerofid.io.atomic import Staging
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
    inputs = [p for p in (image, camera_path, meas_path) if p]
    with Staging(inputs) as staging:
        if output is not None:
            staging.plan(output, "report")
        cam = read_camera(camera_path)
        meas, not_found = read_measurements_and_not_found(meas_path)
        image_name = meas.image or (Path(image).name if image else "") or Path(meas_path).stem
        micmac = _micmac_files(Path(micmac_dir), image_name, model, staging) if micmac_dir is not None else None
        try:
            res = _run_orient(cam, meas, not_found, meas_path, model=model, correspondence=correspondence,
                              reject=not no_reject, image=image_name)
        except AmbiguousCorrespondenceError as e:
            if as_json:
                click.echo(json.dumps({"status": "ambiguous", "error": str(e),
                                       "correspondence": e.correspondence.to_dict()}))
            flush_stdout()
            click.echo(f"error: {e}", err=True)
            return 1
        if not_found:
            click.echo(f"note: {', '.join(not_found)} not found in {meas_path!r}; oriented with the "
                       f"{len(meas.xy)} found", err=True)
        if output is not None:
            staging.put(output, _report(res, Path(output).suffix.lower()))
        if micmac is not None:
            for path, text in zip(micmac, _micmac_texts(cam, res)):
                staging.put(path, text)
        click.echo(json.dumps(res.to_dict()) if as_json else to_text(res), nl=as_json)
        flush_stdout()
        staging.commit()
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


def _micmac_files(folder: Path, image: str, model: str, staging: Staging) -> list[Path]:
    """The MicMac files ``--micmac`` writes, planned (checked) before any work: MeasuresIm of the used
    fiducials, MeasuresCamera, and the AffinePlane pixel -> mm (not for the projective model)."""
    name = image or "image"
    if Path(name).name != name or name in (".", ".."):
        raise AerofidInputError(f"image name {name!r} cannot name MicMac files (it holds a folder); give the "
                                "scan's file name in the measurements' \"image\"")
    paths = [folder / f"MeasuresIm-{name}.xml", folder / "MeasuresCamera.xml"]
    if model != "projective":
        paths.append(folder / f"{name}-AffinePlane-px2mm.xml")
    return [staging.plan(p, "--micmac") for p in paths]


def _micmac_texts(cam: Camera, res: InteriorOrientation) -> list[str]:
    """The texts of :func:`_micmac_files`, in its order."""
    used = res.used
    m = Measurements(np.array([[f.x_px, f.y_px] for f in used]), tuple(f.name for f in used), res.image or "image")
    texts = [measures_im_xml(m), measures_camera_xml(cam)]
    if res.model != "projective":
        texts.append(affine_plane_xml(res.pixel_to_mm))
    return texts
