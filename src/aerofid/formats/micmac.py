"""MicMac XML files: MeasuresIm / MeasuresCamera (fiducial measurements) and AffinitePlane.

Layouts (as written by MicMac's SaisieAppuisInit / Kugelhupf and read by ReSampFid)::

    <SetOfMesureAppuisFlottants>
      <MesureAppuiFlottant1Im>
        <NameIm>scan.tif</NameIm>
        <OneMesureAF1I><NamePt>P1</NamePt><PtIm>1234.5 678.25</PtIm></OneMesureAF1I>
        ...
      </MesureAppuiFlottant1Im>
    </SetOfMesureAppuisFlottants>

``MeasuresIm-<image>.xml`` holds pixel coordinates; ``MeasuresCamera.xml`` has the same layout with the
calibrated coordinates in mm (``NameIm`` is often ``Glob``). Both files are accepted with or without the
``SetOfMesureAppuisFlottants`` wrapper (real examples have a bare ``MesureAppuiFlottant1Im`` root).

An affine map ``P -> I00 + P.x * V10 + P.y * V01`` is MicMac's ``AffinitePlane``::

    <AffinitePlane><I00>c f</I00><V10>a d</V10><V01>b e</V01></AffinitePlane>

i.e. for ``X = a x + b y + c, Y = d x + e y + f``: I00 = (c, f), V10 = (a, d), V01 = (b, e).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.text import parse_xml
from aerofid.io.atomic import write_text_atomic
from aerofid.io.files import read_text_input
from aerofid.orientation.camera import Camera, Fiducial
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.result import InteriorOrientation


def _parse(path: Path) -> ET.Element:
    path, text = read_text_input(path, "MicMac file")
    return parse_xml(text, f"MicMac file {str(path)!r}")


def _pair(text: str | None, what: str, path: Path) -> tuple[float, float]:
    parts = (text or "").split()
    try:
        if len(parts) != 2:
            raise ValueError
        x, y = float(parts[0]), float(parts[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError
    except ValueError:
        raise AerofidInputError(f"{what} must be two numbers 'x y', not {text!r} in {str(path)!r}") from None
    return x, y


def read_mesure_appuis(path: str | Path) -> dict[str, list[tuple[str, float, float]]]:
    """All images of a SetOfMesureAppuisFlottants file: {NameIm: [(NamePt, x, y), ...]}."""
    path = Path(path)
    root = _parse(path)
    if root.tag == "MesureAppuiFlottant1Im":
        blocks = [root]
    elif root.tag == "SetOfMesureAppuisFlottants":
        blocks = root.findall("MesureAppuiFlottant1Im")
    else:
        raise AerofidInputError(
            f"{str(path)!r} is not a MicMac measures file (root <{root.tag}>, expected "
            "<SetOfMesureAppuisFlottants> or <MesureAppuiFlottant1Im>)")
    out: dict[str, list[tuple[str, float, float]]] = {}
    for b in blocks:
        name_im = (b.findtext("NameIm") or "").strip()
        pts = []
        for m in b.findall("OneMesureAF1I"):
            name = (m.findtext("NamePt") or "").strip()
            if not name:
                raise AerofidInputError(f"a measure without <NamePt> in {str(path)!r}")
            x, y = _pair(m.findtext("PtIm"), f"<PtIm> of {name!r}", path)
            pts.append((name, x, y))
        out.setdefault(name_im, []).extend(pts)
    if not out or not any(out.values()):
        raise AerofidInputError(f"no <OneMesureAF1I> measures in {str(path)!r}")
    return out


def read_measures_im(path: str | Path, image: str | None = None) -> Measurements:
    """Pixel measurements of one image from a MicMac MeasuresIm file.

    Args:
        image: which image (NameIm) to take when the file holds several.
    """
    path = Path(path)
    data = read_mesure_appuis(path)
    if image is None:
        if len(data) > 1:
            raise AerofidInputError(
                f"{str(path)!r} holds measures of {len(data)} images ({', '.join(data)}): say which image")
        image = next(iter(data))
    elif image not in data:
        raise AerofidInputError(f"{str(path)!r} has no measures of image {image!r} (it has {', '.join(data)})")
    pts = data[image]
    return Measurements(np.array([[x, y] for _, x, y in pts], dtype=float), tuple(n for n, _, _ in pts), image)


def read_measures_camera(path: str | Path, name: str | None = None, y_axis: str = "auto") -> Camera:
    """Calibrated fiducials (mm) from a MicMac MeasuresCamera.xml.

    Args:
        name: camera name (default: from the file name and NameIm).
        y_axis: ``"up"``, ``"down"`` or ``"auto"``: down (image-like) when every coordinate is >= 0 (the
            origin in a corner, as in MicMac's own examples), else up (origin at the principal point).
    """
    path = Path(path)
    data = read_mesure_appuis(path)
    if len(data) > 1:
        raise AerofidInputError(f"{str(path)!r} holds {len(data)} sets of measures; a camera file has one")
    name_im, pts = next(iter(data.items()))
    if y_axis == "auto":
        y_axis = "down" if all(x >= 0 and y >= 0 for _, x, y in pts) else "up"
    cam_name = name or (f"{path.stem} ({name_im})" if name_im else path.stem)
    return Camera(name=cam_name, fiducials=tuple(Fiducial(n, x, y) for n, x, y in pts), y_axis=y_axis,
                  source=str(path))


def _mesure_xml(name_im: str, pts: list[tuple[str, float, float]]) -> str:
    lines = ['<?xml version="1.0" ?>', "<SetOfMesureAppuisFlottants>", "     <MesureAppuiFlottant1Im>",
             f"          <NameIm>{_esc(name_im)}</NameIm>"]
    for n, x, y in pts:
        lines += ["          <OneMesureAF1I>", f"               <NamePt>{_esc(n)}</NamePt>",
                  f"               <PtIm>{number_text(x)} {number_text(y)}</PtIm>", "          </OneMesureAF1I>"]
    lines += ["     </MesureAppuiFlottant1Im>", "</SetOfMesureAppuisFlottants>", ""]
    return "\n".join(lines)


def measures_im_xml(m: Measurements, image: str = "") -> str:
    """A MicMac ``MeasuresIm`` file's text (named points only) for ``m`` (its ``image``, else ``image``)."""
    if m.names is None:
        raise AerofidInputError("MicMac measures need point names: assign the points to fiducials first")
    return _mesure_xml(m.image or image, [(n, float(x), float(y)) for n, (x, y) in zip(m.names, m.xy)])


def measures_camera_xml(camera: Camera, name_im: str = "Glob") -> str:
    """A MicMac ``MeasuresCamera.xml``'s text: the camera's calibrated fiducials (mm, as stored)."""
    return _mesure_xml(name_im, [(f.name, f.x_mm, f.y_mm) for f in camera.fiducials])


def write_measures_im(path: str | Path, m: Measurements) -> None:
    """Write a MicMac ``MeasuresIm-<image>.xml`` (named points only), atomically."""
    write_text_atomic(path, measures_im_xml(m, Path(path).stem.removeprefix("MeasuresIm-")))


def write_measures_camera(path: str | Path, camera: Camera, name_im: str = "Glob") -> None:
    """Write the camera's calibrated fiducials as a MicMac MeasuresCamera.xml (mm, as stored), atomically."""
    write_text_atomic(path, measures_camera_xml(camera, name_im))


Y_AXIS_NOTE = re.compile(r"<!--\s*aerofid: film y axis (up|down)\s*-->")
"""The comment an AffinitePlane aerofid writes carries its film y axis in (:func:`affine_plane_xml`): the plane's mm
are the camera file's, and MicMac's own files, which have no such note, run y down."""


def affine_plane_xml(H, y_axis: str | None = None) -> str:
    """MicMac ``<AffinitePlane>`` for the affine map ``[[a, b, c], [d, e, f]]``, with a comment giving the film's
    ``y_axis`` where it is known (:data:`Y_AXIS_NOTE`: MicMac ignores it; ``aerofid resample`` reads it)."""
    H = np.asarray(H, dtype=float)
    if H.shape == (3, 3):
        if not np.allclose(H[2], [0, 0, 1]):
            raise AerofidInputError("a projective transformation has no MicMac AffinitePlane form")
        H = H[:2]
    (a, b, c), (d, e, f) = H
    note = [] if y_axis is None else [f"<!-- aerofid: film y axis {y_axis} -->"]
    return "\n".join(['<?xml version="1.0" ?>', *note, "<AffinitePlane>",
                      f"     <I00>{number_text(c)} {number_text(f)}</I00>",
                      f"     <V10>{number_text(a)} {number_text(d)}</V10>",
                      f"     <V01>{number_text(b)} {number_text(e)}</V01>",
                      "</AffinitePlane>", ""])


def write_affine_plane(path: str | Path, H) -> None:
    """Write the affine map as a MicMac AffinitePlane XML file, atomically."""
    write_text_atomic(path, affine_plane_xml(H))


def read_affine_plane(path: str | Path) -> np.ndarray:
    """Read an AffinitePlane (the root or the first one nested anywhere) as ``[[a, b, c], [d, e, f]]``."""
    path = Path(path)
    root = _parse(path)
    node = root if root.tag == "AffinitePlane" else root.find(".//AffinitePlane")
    if node is None:
        raise AerofidInputError(f"no <AffinitePlane> in {str(path)!r}")
    c, f = _pair(node.findtext("I00"), "<I00>", path)
    a, d = _pair(node.findtext("V10"), "<V10>", path)
    b, e = _pair(node.findtext("V01"), "<V01>", path)
    return np.array([[a, b, c], [d, e, f]])


def number_text(v: float) -> str:
    """A number as the shortest text that reads back to the same float."""
    return repr(float(v))


def _esc(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def micmac_texts(cam: Camera, res: InteriorOrientation) -> list[str]:
    """The MicMac files of an orientation, as texts: ``MeasuresIm`` of the used (not rejected) fiducials,
    ``MeasuresCamera`` of ``cam``, and the ``AffinePlane`` pixel -> mm (not for the projective model)."""
    used = res.used
    m = Measurements(np.array([[f.x_px, f.y_px] for f in used]), tuple(f.name for f in used), res.image or "image")
    texts = [measures_im_xml(m), measures_camera_xml(cam)]
    if res.model != "projective":
        texts.append(affine_plane_xml(res.pixel_to_mm, cam.y_axis))
    return texts
