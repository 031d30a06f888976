"""The outputs of ``aerofid orient`` (from measurements or from the whole frame): the report (-o) and the files
``--micmac`` writes (MeasuresIm of the used fiducials, MeasuresCamera, the AffinePlane pixel -> mm)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.micmac import affine_plane_xml, measures_camera_xml, measures_im_xml
from aerofid.io.atomic import Staging
from aerofid.orientation.camera import Camera
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.result import InteriorOrientation

REPORT_SUFFIXES = (".json", ".html", ".htm", ".txt")


def check_outputs(output: str | None, micmac_dir: str | None) -> None:
    """The report's suffix and the MicMac folder, checked before anything is read."""
    if output is not None and Path(output).suffix.lower() not in REPORT_SUFFIXES:
        raise AerofidInputError(f"report {output!r} must end in .json, .html or .txt")
    if micmac_dir is not None and not Path(micmac_dir).is_dir():
        raise AerofidInputError(f"MicMac folder {micmac_dir!r} does not exist")


def micmac_files(folder: Path, image: str, model: str, staging: Staging) -> list[Path]:
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


def micmac_texts(cam: Camera, res: InteriorOrientation) -> list[str]:
    """The texts of :func:`micmac_files`, in its order."""
    used = res.used
    m = Measurements(np.array([[f.x_px, f.y_px] for f in used]), tuple(f.name for f in used), res.image or "image")
    texts = [measures_im_xml(m), measures_camera_xml(cam)]
    if res.model != "projective":
        texts.append(affine_plane_xml(res.pixel_to_mm))
    return texts


__all__ = ["REPORT_SUFFIXES", "check_outputs", "micmac_files", "micmac_texts"]
