"""The outputs of ``aerofid orient`` (from measurements or from the whole frame): the report (-o), the files
``--micmac`` writes (MeasuresIm of the used fiducials, MeasuresCamera, the AffinePlane pixel -> mm) and the
Metashape script ``--metashape`` writes (:mod:`aerofid.formats.metashape`)."""

from __future__ import annotations

from pathlib import Path

from aerofid.errors import AerofidInputError
from aerofid.formats.metashape import metashape_script
from aerofid.formats.micmac import micmac_texts
from aerofid.formats.orientation import from_result
from aerofid.io.atomic import Staging
from aerofid.orientation.camera import Camera
from aerofid.orientation.result import InteriorOrientation

REPORT_SUFFIXES = (".json", ".html", ".htm", ".txt")


def check_outputs(output: str | None, micmac_dir: str | None, metashape: str | None = None) -> None:
    """The report's suffix, the MicMac folder and the Metashape script's suffix, checked before anything is read."""
    if output is not None and Path(output).suffix.lower() not in REPORT_SUFFIXES:
        raise AerofidInputError(f"report {output!r} must end in .json, .html or .txt")
    if metashape is not None and Path(metashape).suffix.lower() != ".py":
        raise AerofidInputError(f"--metashape {metashape!r} is a Python script for Metashape: give a name ending in "
                                ".py")
    if micmac_dir is not None and not Path(micmac_dir).is_dir():
        raise AerofidInputError(f"MicMac folder {micmac_dir!r} does not exist: make it first (mkdir), or give the "
                                "folder of the MicMac project")


def micmac_files(folder: Path, image: str, model: str, staging: Staging) -> list[Path]:
    """The MicMac files ``--micmac`` writes, planned (checked) before any work: MeasuresIm of the used
    fiducials, MeasuresCamera, and the AffinePlane pixel -> mm (not for the projective model); their texts are
    :func:`aerofid.formats.micmac.micmac_texts`, in this order."""
    name = image or "image"
    if Path(name).name != name or name in (".", ".."):
        raise AerofidInputError(f"image name {name!r} cannot name MicMac files (it holds a folder); give the "
                                "scan's file name in the measurements' \"image\"")
    paths = [folder / f"MeasuresIm-{name}.xml", folder / "MeasuresCamera.xml"]
    if model != "projective":
        paths.append(folder / f"{name}-AffinePlane-px2mm.xml")
    return [staging.plan(p, "--micmac") for p in paths]


def metashape_text(cam: Camera, res: InteriorOrientation) -> str:
    """The ``--metashape`` script of one scan's orientation (:func:`aerofid.formats.metashape.metashape_script`)."""
    return metashape_script([from_result(res)], cam)


__all__ = ["REPORT_SUFFIXES", "check_outputs", "metashape_text", "micmac_files", "micmac_texts"]
