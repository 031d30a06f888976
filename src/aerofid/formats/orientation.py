"""Reading an interior orientation back: the pixel -> film mm transformation of a scan, with its fiducials when
the file has them.

Accepted files (recognised from their content, not their names):

* the JSON ``aerofid orient IMAGE --camera C -o x.json`` writes for a whole frame
  (:meth:`aerofid.frame.result.FrameOrientation.to_dict`): its ``"orientation"`` entry; a failed frame (``null``
  there) has none and is refused;
* the JSON ``aerofid orient --measurements M --camera C -o x.json`` (or ``--json``) writes
  (:meth:`aerofid.orientation.result.InteriorOrientation.to_dict`), and the sidecar ``aerofid resample`` writes
  beside a resampled frame (the same keys);
* MicMac's ``<AffinitePlane>`` pixel -> mm (``<image>-AffinePlane-px2mm.xml`` as ``aerofid orient --micmac``
  writes it; :func:`aerofid.formats.micmac.read_affine_plane`), which has no fiducials, nor a y axis but the one
  aerofid notes in the files it writes (:data:`aerofid.formats.micmac.Y_AXIS_NOTE`).

Every refusal is one :class:`~aerofid.errors.AerofidInputError` line naming the file.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.micmac import Y_AXIS_NOTE, read_affine_plane
from aerofid.formats.text import load_json
from aerofid.io.files import read_text_input
from aerofid.orientation.result import InteriorOrientation
from aerofid.orientation.transform import AffineTransform, ProjectiveTransform, as_matrix, transform_class


@dataclass(frozen=True)
class FiducialRecord:
    """One fiducial of a stored orientation: pixel and calibrated mm coordinates, residual (calibrated minus
    adjusted, mm) and status (``used`` / ``rejected``)."""

    name: str
    x_px: float
    y_px: float
    x_mm: float
    y_mm: float
    residual_x_mm: float
    residual_y_mm: float
    status: str


@dataclass(frozen=True)
class StoredOrientation:
    """An interior orientation read from a file.

    Attributes
    ----------
    transform : ProjectiveTransform
        Pixel (x = column, y = row, centre of the top-left pixel (0, 0)) -> film mm.
    fiducials : tuple of FiducialRecord
        Empty for a MicMac AffinitePlane.
    y_axis : str or None
        The camera's film y axis (``"up"`` / ``"down"``) when the file tells it (aerofid's JSON: from the
        transformation's handedness and ``mirrored``), else None.
    """

    transform: ProjectiveTransform
    fiducials: tuple[FiducialRecord, ...]
    y_axis: str | None
    image: str
    camera: str
    source: str

    @property
    def fiducials_mm(self) -> np.ndarray:
        """n x 2 calibrated coordinates (mm) of the fiducials."""
        return np.array([[f.x_mm, f.y_mm] for f in self.fiducials], dtype=float).reshape(-1, 2)


def read_orientation(path: str | os.PathLike[str]) -> StoredOrientation:
    """Read the pixel -> mm transformation (and fiducials) of a scan from an aerofid JSON or a MicMac
    AffinitePlane XML (module docstring).

    Examples
    --------
    >>> import json, tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "failed.json"
    >>> _ = p.write_text(json.dumps({"image": "f.tif", "status": "failed", "reasons": ["no marks"],
    ...                              "orientation": None}))
    >>> read_orientation(p)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: ...failed.json' is the orientation of frame 'f.tif', which failed (no marks)...
    """
    p, text = read_text_input(path, "orientation file")
    where = repr(str(p))
    if text.lstrip().startswith("<"):
        H = read_affine_plane(p)
        note = Y_AXIS_NOTE.search(text)
        return StoredOrientation(AffineTransform(H), (), note.group(1) if note else None, "", "", str(p))
    data = load_json(text, f"orientation file {where}")
    if isinstance(data, dict) and "orientation" in data and "pixel_to_mm" not in data:
        if data["orientation"] is None:
            reasons = "; ".join(str(r) for r in data.get("reasons") or []) or "no reason given"
            raise AerofidInputError(
                f"{where} is the orientation of frame {data.get('image', '?')!r}, which {data.get('status', 'failed')}"
                f" ({reasons}): it has no pixel -> mm transformation; orient the frame again or measure its marks")
        data = data["orientation"]
    if not isinstance(data, dict) or "pixel_to_mm" not in data:
        raise AerofidInputError(f"{where} holds no interior orientation (no \"pixel_to_mm\"): give the JSON that "
                                "'aerofid orient ... -o FILE.json' writes, or a MicMac AffinePlane px2mm XML")
    return _from_dict(data, where, str(p))


def from_result(result: InteriorOrientation) -> StoredOrientation:
    """An orientation just computed, as :func:`read_orientation` would read it from its JSON (for a caller that
    resamples without writing the JSON first, such as a batch)."""
    return _from_dict(result.to_dict(), f"the orientation of {result.image!r}", "")


def _from_dict(d: dict[str, Any], where: str, source: str) -> StoredOrientation:
    model = d.get("model", "affine")
    try:
        H = as_matrix(np.asarray(d["pixel_to_mm"], dtype=float))
    except (TypeError, ValueError):
        raise AerofidInputError(f"\"pixel_to_mm\" in {where} must be a 2x3 or 3x3 matrix of numbers") from None
    if not np.all(np.isfinite(H)) or abs(np.linalg.det(H)) < 1e-300:
        raise AerofidInputError(f"\"pixel_to_mm\" in {where} is not an invertible finite matrix")
    cls = transform_class(str(model)) if isinstance(model, str) else ProjectiveTransform
    T = ProjectiveTransform(H) if cls is ProjectiveTransform else AffineTransform(H)
    fiducials = tuple(_fiducial(f, where) for f in d.get("fiducials") or [])
    mirrored = d.get("mirrored")
    y_axis = None
    if isinstance(mirrored, bool):
        y_axis = "up" if (np.linalg.det(H[:2, :2]) > 0) == mirrored else "down"
    return StoredOrientation(T, fiducials, y_axis, str(d.get("image", "")), str(d.get("camera", "")), source)


def _fiducial(f: Any, where: str) -> FiducialRecord:
    try:
        values = [float(f[k]) for k in ("x_px", "y_px", "x_mm", "y_mm")]
        res = [float(f.get(k) or 0.0) for k in ("residual_x_mm", "residual_y_mm")]
        if not all(math.isfinite(v) for v in values + res):
            raise ValueError
        return FiducialRecord(str(f["name"]), values[0], values[1], values[2], values[3], res[0], res[1],
                              str(f.get("status", "used")))
    except (TypeError, KeyError, ValueError, AttributeError):
        raise AerofidInputError(f"a fiducial in {where} lacks name, x_px, y_px, x_mm or y_mm numbers: "
                                f"{str(f)[:80]}") from None


__all__ = ["FiducialRecord", "StoredOrientation", "from_result", "read_orientation"]
