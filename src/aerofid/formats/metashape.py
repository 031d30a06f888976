"""Agisoft Metashape Professional: a Python script that places aerofid's measured fiducials on the original scans
of an open Metashape project (docs/exports.md).

Metashape orients scanned film itself once told where the fiducials are: the scans' sensor is a film camera
("film camera with fiducial marks"), each fiducial is a marker of type Fiducial belonging to that sensor with its
calibrated film coordinates (mm) as its reference location, and each scan carries the fiducial's pinned
projection, its pixel position on that scan; Metashape then fits the scan -> film transformation. No file format
for this is documented, so aerofid writes what Metashape's Python API does (:func:`metashape_script`): a script
the user runs in Metashape Pro on the open project (Tools > Run Script, or ``metashape.sh -r SCRIPT``), which

* finds each scan's camera by its label (the scan's file name without extension, Metashape's default label; the
  whole file name is accepted too) and reports the scans the project does not have;
* sets the camera's sensor as a film camera (``Sensor.film_camera``) and, when the camera file gives them, its
  focal length (``Sensor.focal_length``, mm) and pixel size (``Sensor.pixel_size``, mm, the median scan pixel
  size of the frames it places);
* creates one fiducial marker per fiducial name and sensor (``Chunk.addMarker``, ``Marker.type =
  Metashape.Marker.Type.Fiducial``, ``Marker.sensor``, ``Marker.label``), or reuses the one with that label and
  sensor, and sets its ``Marker.reference.location`` to the calibrated ``(x, y, 0)`` mm;
* sets ``Marker.projections[camera] = Metashape.Marker.Projection(Metashape.Vector([u, v]), True)`` (pinned) for
  every fiducial the orientation used; rejected fiducials get none.

The data are one JSON text embedded as a literal (no code is generated per fiducial), in aerofid's conventions;
the script converts them with two constants at its top:

``PIXEL_OFFSET = 0.5``
    Metashape's pixel (0, 0) is the top-left corner of the image, the centre of the top-left pixel (0.5, 0.5);
    aerofid's is that centre (0, 0). Source: Agisoft's own scripts (github.com/agisoft-llc/metashape-scripts,
    src/export_for_gaussian_splatting.py before its removal in commit 39a990b: the centre of pixel ``i`` is
    passed to ``Calibration.unproject`` as ``i + 0.5``, an image spans ``0 <= x < width``, and ``cx + width * 0.5``
    is written unchanged as COLMAP's principal point, whose pixel centres are also at half-integers). Marker
    projections are in the coordinates ``Camera.project`` returns, which are these.
``FILM_Y``
    ``-1`` when the camera file's film y axis is up (calibration certificates), ``+1`` when it is down (MicMac):
    the script gives Metashape the fiducials with y down, like its image and camera frames (x right, y down).
    **Not confirmed from a primary source**: neither Agisoft's scripts nor a reference page at hand says which
    way the y of a fiducial's reference location runs. Third-party pipelines that place fiducials this way
    negate a certificate's y (another leaves it). A wrong sign mirrors the film; check the first project on a
    known ground shape (the fiducial residuals may not show it: an affine fit can absorb a reflection) and, if
    needed, change this one constant.

Agisoft's API names used here are those its scripts use (src/frame_based_fiducials_detector.py:
``Marker.Type.Fiducial``, ``Marker.sensor``, ``Sensor.film_camera``, ``Marker.projections[camera]``,
``Metashape.Marker.Projection``; src/contrib/remove_unpinned_projections.py: ``Projection.pinned``). The
two-argument ``Projection(coord, pinned)``, ``Sensor.focal_length`` / ``pixel_size`` in mm and the ``z = 0`` of a
fiducial's location are taken from third-party scripts, not from Agisoft's reference (not available here).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import PurePath, PureWindowsPath
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.orientation import StoredOrientation
from aerofid.orientation.camera import Camera
from aerofid.orientation.interior import scan_geometry
from aerofid.orientation.result import USED

PIXEL_OFFSET = 0.5
"""Metashape pixel = aerofid pixel + this, in x and y (module docstring: Metashape puts the top-left pixel's centre
at (0.5, 0.5), aerofid at (0, 0))."""
METASHAPE_Y_AXIS = "down"
"""The way the film y of a fiducial's reference location runs in Metashape (module docstring: inferred, not
confirmed)."""
SCRIPT_FILE = "metashape_fiducials.py"
"""The roll-level script's name in a batch's output folder."""

_NUMBERS = re.compile(r"\[\n\s*([-+.0-9eE]+(?:,\n\s*[-+.0-9eE]+)*)\n\s*\]")
"""An indented JSON list of numbers (:func:`_json_text`)."""


@dataclass(frozen=True)
class LeftOut:
    """A frame the script does not place, and why (a comment in the script; printed when it runs)."""

    image: str
    reason: str


def camera_label(image: str) -> str:
    """The label Metashape gives the camera of scan ``image``: its file name without extension.

    Examples
    --------
    >>> camera_label("roll1/DZB1214-500425L002001.tif"), camera_label(r"C:\\scans\\a.b.tif")
    ('DZB1214-500425L002001', 'a.b')
    """
    return PurePath(PureWindowsPath(image).as_posix()).stem


def film_y_sign(camera: Camera) -> int:
    """``FILM_Y`` of the script: -1 when the camera's film y runs the other way than :data:`METASHAPE_Y_AXIS`."""
    return 1 if camera.y_axis == METASHAPE_Y_AXIS else -1


def metashape_data(frames: Sequence[StoredOrientation], camera: Camera,
                   left_out: Sequence[LeftOut] = ()) -> dict[str, Any]:
    """The script's data (aerofid's conventions): the camera's fiducials (mm), focal length and principal point,
    and per frame its camera label and the pixel position of every fiducial the orientation used.

    A frame whose label another frame already has is left out (the script could not tell their cameras apart).

    Raises
    ------
    AerofidInputError
        An orientation names a fiducial the camera file does not have (it is of another camera).
    """
    known = set(camera.names)
    placed: list[dict[str, Any]] = []
    skipped = list(left_out)
    sizes = []
    for stored in frames:
        label = camera_label(stored.image)
        if any(f["label"] == label for f in placed):
            skipped.append(LeftOut(stored.image, f"another frame has the camera label {label!r}"))
            continue
        used = {f.name: [f.x_px, f.y_px] for f in stored.fiducials if f.status == USED}
        if not used.keys() <= known:
            raise AerofidInputError(f"the orientation of {stored.image!r} has fiducials {sorted(used.keys() - known)} "
                                    f"that camera {camera.name!r} does not: give the camera file it was oriented with")
        placed.append({"label": label, "image": stored.image, "fiducials_px": used})
        sizes.append(float(np.mean(scan_geometry(stored.transform)["pixel_size_um"])) / 1000.0)
    (ppx, ppy), pp_kind = camera.principal_point_mm
    return {"camera": {"name": camera.name, "y_axis": camera.y_axis, "focal_length_mm": camera.focal_length_mm,
                       "principal_point_mm": [ppx, ppy], "principal_point": pp_kind,
                       "fiducials_mm": {f.name: [f.x_mm, f.y_mm] for f in camera.fiducials}},
            "pixel_size_mm": float(np.median(sizes)) if sizes else None,
            "frames": placed, "left_out": [{"image": s.image, "reason": s.reason} for s in skipped]}


def metashape_script(frames: Sequence[StoredOrientation], camera: Camera, left_out: Sequence[LeftOut] = ()) -> str:
    """The Metashape Pro script that places the fiducials of ``frames`` (module docstring); ``left_out``: the
    frames it does not place, listed in its header and printed when it runs.

    Examples
    --------
    >>> from aerofid.synth_frame import wild_rc10_camera
    >>> text = metashape_script([], wild_rc10_camera(), [LeftOut("b.tif", "failed: no marks")])
    >>> compile(text, "metashape_fiducials.py", "exec") is not None
    True
    >>> "#   b.tif: failed: no marks" in text
    True
    """
    data = metashape_data(frames, camera, left_out)
    blob = _json_text(data)
    notes = "".join(f"#   {_comment(d['image'])}: {_comment(d['reason'])}\n" for d in data["left_out"]) or "#   none\n"
    return (_HEADER.format(n=len(data["frames"]), camera=_comment(camera.name), left_out=notes)
            + f"PIXEL_OFFSET = {PIXEL_OFFSET!r}\n"
            + f"FILM_Y = {film_y_sign(camera)}  # camera file y {camera.y_axis}, given to Metashape y "
              f"{METASHAPE_Y_AXIS} (inferred, not confirmed)\n"
            + f"DATA = json.loads(r'''\n{blob}\n''')\n" + _BODY)


def _json_text(data: dict[str, Any]) -> str:
    """Indented JSON with each list of numbers on one line (a line break is never inside a JSON string, so only
    the structure's lists match), every ``'`` escaped so that the text can sit in a ``r'''...'''`` literal."""
    text = json.dumps(data, indent=1, ensure_ascii=True, allow_nan=False)
    text = _NUMBERS.sub(lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text)
    return text.replace("'", "\\u0027")


def _comment(text: str) -> str:
    """``text`` on one comment line (no line breaks, printable)."""
    return " ".join(str(text).split()).encode("ascii", "backslashreplace").decode("ascii")


_HEADER = '''\
# Fiducials measured by aerofid for Agisoft Metashape Professional: {n} scan(s) of camera {camera}.
#
# Run on the open project (its cameras are the ORIGINAL scans): Tools > Run Script, or
# metashape.sh -r THIS_FILE. For each scan whose camera label is its file name without extension, the script
# sets the camera's sensor as a film camera (with the calibrated focal length and the scan pixel size when
# known), creates or reuses one Fiducial marker per fiducial with its calibrated film coordinates (mm), and pins
# the fiducial's measured position on that scan (fiducials the adjustment rejected get none). Metashape then
# computes each scan's film transformation itself. Scans the project does not have are listed at the end.
#
# aerofid pixels: x = column, y = row, the centre of the top-left pixel (0, 0); Metashape's: that centre is
# (0.5, 0.5) (PIXEL_OFFSET). FILM_Y: the film y the fiducials are given to Metashape with (docs/exports.md).
# The principal point (DATA["camera"]["principal_point_mm"], film mm) is not set: Metashape fits its own.
#
# Frames not placed:
{left_out}
import json

import Metashape

'''

_BODY = '''

def place_fiducials(chunk):
    """Set the film camera, the fiducial markers and their pinned projections; print what matched."""
    cameras, alike = {}, {}
    for camera in chunk.cameras:
        cameras.setdefault(camera.label, camera)
        alike[camera.label] = alike.get(camera.label, 0) + 1
    markers = {}
    for marker in chunk.markers:
        if marker.type == Metashape.Marker.Type.Fiducial and marker.sensor is not None:
            markers.setdefault((marker.sensor.key, marker.label), marker)
    cam = DATA["camera"]
    missing, unplaced = [], 0
    for frame in DATA["frames"]:
        labels = [frame["label"], frame["image"].replace("\\\\", "/").split("/")[-1]]
        camera = next((cameras[k] for k in labels if alike.get(k) == 1), None)
        shared = [k for k in labels if alike.get(k, 0) > 1]
        if camera is None and shared:
            print("aerofid: {}: {} cameras in the chunk have this label: not placed (give them distinct labels "
                  "and run the script again)".format(shared[0], alike[shared[0]]))
            unplaced += 1
            continue
        if camera is None:
            missing.append(frame["label"])
            continue
        sensor = camera.sensor
        sensor.film_camera = True
        if cam["focal_length_mm"] is not None:
            sensor.focal_length = cam["focal_length_mm"]
        if DATA["pixel_size_mm"] is not None:
            sensor.pixel_size = Metashape.Vector([DATA["pixel_size_mm"], DATA["pixel_size_mm"]])
        for name, (x, y) in sorted(frame["fiducials_px"].items()):
            marker = markers.get((sensor.key, name))
            if marker is None:
                marker = chunk.addMarker()
                marker.type = Metashape.Marker.Type.Fiducial
                marker.sensor = sensor
                marker.label = name
                markers[(sensor.key, name)] = marker
            x_mm, y_mm = cam["fiducials_mm"][name]
            marker.reference.location = Metashape.Vector([x_mm, FILM_Y * y_mm, 0.0])
            marker.projections[camera] = Metashape.Marker.Projection(
                Metashape.Vector([x + PIXEL_OFFSET, y + PIXEL_OFFSET]), True)
        print("aerofid: {}: {} fiducials placed".format(camera.label, len(frame["fiducials_px"])))
    for label in missing:
        print("aerofid: {}: no camera with this label in the chunk: not placed".format(label))
    for item in DATA["left_out"]:
        print("aerofid: {}: left out: {}".format(item["image"], item["reason"]))
    print("aerofid: {} of {} scans placed".format(len(DATA["frames"]) - len(missing) - unplaced,
                                                  len(DATA["frames"])))
    return missing


chunk = Metashape.app.document.chunk
if chunk is None:
    print("aerofid: open the project and select the chunk of the scans, then run this script again")
else:
    place_fiducials(chunk)
'''


__all__ = ["METASHAPE_Y_AXIS", "PIXEL_OFFSET", "SCRIPT_FILE", "LeftOut", "camera_label", "film_y_sign",
           "metashape_data", "metashape_script"]
