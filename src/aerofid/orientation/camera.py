"""The camera's calibration certificate: fiducial coordinates in mm, focal length, principal point.

A camera file is JSON or YAML (see docs/orientation.md)::

    name: Wild RC20 s/n 5046                # required
    focal_length_mm: 153.664                # calibrated focal length (optional)
    principal_point:                        # optional; mm in the fiducial frame
      ppa: [0.001, 0.002]                   #   principal point of autocollimation
      pbs: [0.000, -0.003]                  #   principal point of best symmetry
    pixel_size_um: 21.0                     # nominal scan pixel size (optional)
    y_axis: up                              # film y axis: up (certificates) or down (image-like)
    fiducials:                              # >= 3, unique names
      P1: [106.004, -106.002]               #   name: [x_mm, y_mm]
      P2: {x: -105.998, y: -105.998, style: wild_corner}

The minimal JSON ``{"name": "...", "fiducials": {"P1": [x_mm, y_mm], ...}}`` is always accepted; the
fiducials may also be a list of ``{"name", "x", "y", "style"}`` objects. MicMac's ``MeasuresCamera.xml``
is read as well (:func:`aerofid.formats.camera_file.read_camera`).

Film coordinates: mm as the certificate gives them, x right, y up (``y_axis: up``) unless stated.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerofid.conventions import MAX_DPI, MAX_GIVEN_MM, MIN_PIXEL_MM, plausible_pixel_size
from aerofid.errors import AerofidInputError
from aerofid.orientation.measurements import finite_number

#: Largest plausible |coordinate| of a fiducial, mm (the largest film formats are 23 x 46 cm).
MAX_FIDUCIAL_MM = 500.0
#: Plausible calibrated focal lengths, mm.
FOCAL_RANGE_MM = (1.0, 5000.0)


@dataclass(frozen=True)
class Fiducial:
    """One calibrated fiducial mark: name, x and y in mm, optional mark style (e.g. ``wild_corner``)."""

    name: str
    x_mm: float
    y_mm: float
    style: str | None = None

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"x": self.x_mm, "y": self.y_mm}
        if self.style:
            d["style"] = self.style
        return d


@dataclass(frozen=True)
class Camera:
    """A camera's calibration certificate as far as interior orientation needs it; validated when made.

    Attributes
    ----------
    name : str
        Camera name (make, model, serial, report number...).
    fiducials : tuple of Fiducial
        The calibrated fiducials, in file order (at least 3, unique names, not collinear).
    focal_length_mm : float or None
        Calibrated focal length.
    ppa_mm, pbs_mm : tuple of float or None
        Principal point of autocollimation / of best symmetry (x, y) in mm.
    pixel_size_um : float or None
        Nominal scan pixel size.
    y_axis : str
        ``"up"`` (certificate convention) or ``"down"`` (image-like, e.g. MicMac's corner origin).
    source : str
        The file it was read from (not compared).

    Raises
    ------
    AerofidInputError
        An implausible certificate (duplicate names, fewer than 3 fiducials, coordinates beyond 500 mm,
        coincident or collinear fiducials, implausible focal length or pixel size).

    Examples
    --------
    >>> cam = Camera.from_dict({"name": "RC10", "principal_point": {"ppa": [0.01, -0.02]},
    ...                         "fiducials": {"1": [-106, -106], "2": [106, 106], "3": [-106, 106], "4": [106, -106]}})
    >>> cam.names, cam.xy_mm.shape, cam.principal_point_mm
    (('1', '2', '3', '4'), (4, 2), ((0.01, -0.02), 'ppa'))
    >>> cam.fiducial_centre_mm()
    (0.0, 0.0)
    """

    name: str
    fiducials: tuple[Fiducial, ...]
    focal_length_mm: float | None = None
    ppa_mm: tuple[float, float] | None = None
    pbs_mm: tuple[float, float] | None = None
    pixel_size_um: float | None = None
    y_axis: str = "up"
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        _validate(self)

    # -- access -------------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.fiducials)

    @property
    def xy_mm(self) -> np.ndarray:
        """n x 2 array of calibrated coordinates in file order."""
        return np.array([[f.x_mm, f.y_mm] for f in self.fiducials], dtype=float)

    def fiducial(self, name: str) -> Fiducial:
        for f in self.fiducials:
            if f.name == name:
                return f
        raise AerofidInputError(
            f"camera {self.name!r} has no fiducial {name!r} (it has {', '.join(self.names)})")

    @property
    def principal_point_mm(self) -> tuple[tuple[float, float], str]:
        """The principal point to report in pixels and which one it is (ppa, pbs, or the origin)."""
        if self.ppa_mm is not None:
            return self.ppa_mm, "ppa"
        if self.pbs_mm is not None:
            return self.pbs_mm, "pbs"
        return (0.0, 0.0), "origin"

    def fiducial_centre_mm(self, names: Iterable[str] | None = None) -> tuple[float, float]:
        """Fiducial centre: least-squares intersection of the lines joining opposite fiducials.

        Opposite pairs are the largest group of long chords (over half the frame) whose midpoints agree
        within 2 % of the frame size; with fewer than two such pairs the centroid is returned.
        """
        xy = self.xy_mm if names is None else np.array([[self.fiducial(n).x_mm, self.fiducial(n).y_mm]
                                                        for n in names])
        c = xy.mean(axis=0)
        size = float(np.max(np.ptp(xy, axis=0))) or 1.0
        pairs = [(i, j) for i in range(len(xy)) for j in range(i + 1, len(xy))
                 if np.hypot(*(xy[i] - xy[j])) > 0.5 * size]
        mids = np.array([(xy[i] + xy[j]) / 2 for i, j in pairs]).reshape(-1, 2)
        lines = []
        if len(mids):
            # the largest group of long chords sharing (nearly) the same midpoint: the opposite pairs
            close = np.hypot(*(mids[:, None, :] - mids[None, :, :]).transpose(2, 0, 1)) < 0.02 * size
            k = int(np.argmax(close.sum(axis=1)))
            lines = [(xy[pairs[m][0]], xy[pairs[m][1]]) for m in np.flatnonzero(close[k])]
        if len(lines) < 2:
            return float(c[0]), float(c[1])
        # point minimising the squared distances to the lines
        A = np.zeros((2, 2))
        b = np.zeros(2)
        for p, q in lines:
            d = (q - p) / np.hypot(*(q - p))
            Pn = np.eye(2) - np.outer(d, d)
            A += Pn
            b += Pn @ p
        if np.linalg.cond(A) > 1e8:
            return float(c[0]), float(c[1])
        s = np.linalg.solve(A, b)
        return float(s[0]), float(s[1])

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "") -> Camera:
        """Build a camera from the JSON/YAML structure (see the module docstring)."""
        where = f" in {source!r}" if source else ""
        if not isinstance(data, Mapping):
            raise AerofidInputError(f"a camera must be an object with 'name' and 'fiducials'{where}")
        unknown = set(data) - {"name", "fiducials", "focal_length_mm", "principal_point", "ppa_mm", "pbs_mm",
                               "pixel_size_um", "y_axis", "description", "serial", "lens", "report"}
        if unknown:
            raise AerofidInputError(f"unknown camera field(s) {', '.join(sorted(unknown))}{where}")
        name = data.get("name")
        if not isinstance(name, str) or not name.strip():
            raise AerofidInputError(f"the camera needs a non-empty 'name'{where}")
        raw = data.get("fiducials")
        fids: list[Fiducial] = []
        if isinstance(raw, Mapping):
            for k, v in raw.items():
                fids.append(_fiducial(str(k), v, where))
        elif isinstance(raw, list):
            for item in raw:
                if not isinstance(item, Mapping) or "name" not in item:
                    raise AerofidInputError(f"each fiducial in the list needs a 'name', 'x' and 'y'{where}")
                fids.append(_fiducial(str(item["name"]), item, where))
        else:
            raise AerofidInputError(f"'fiducials' must map names to [x_mm, y_mm]{where}")
        pp = data.get("principal_point") or {}
        if not isinstance(pp, Mapping):
            raise AerofidInputError(f"'principal_point' must be an object with 'ppa' and/or 'pbs'{where}")
        ppa = pp.get("ppa", data.get("ppa_mm"))
        pbs = pp.get("pbs", data.get("pbs_mm"))
        return cls(
            name=name.strip(),
            fiducials=tuple(fids),
            focal_length_mm=_opt_number(data.get("focal_length_mm"), "focal_length_mm", where),
            ppa_mm=_opt_pair(ppa, "principal_point.ppa", where),
            pbs_mm=_opt_pair(pbs, "principal_point.pbs", where),
            pixel_size_um=_opt_number(data.get("pixel_size_um"), "pixel_size_um", where),
            y_axis=str(data.get("y_axis", "up")),
            source=source,
        )

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"name": self.name}
        if self.focal_length_mm is not None:
            d["focal_length_mm"] = self.focal_length_mm
        pp = {}
        if self.ppa_mm is not None:
            pp["ppa"] = list(self.ppa_mm)
        if self.pbs_mm is not None:
            pp["pbs"] = list(self.pbs_mm)
        if pp:
            d["principal_point"] = pp
        if self.pixel_size_um is not None:
            d["pixel_size_um"] = self.pixel_size_um
        d["y_axis"] = self.y_axis
        d["fiducials"] = {f.name: ([f.x_mm, f.y_mm] if not f.style else f.to_dict()) for f in self.fiducials}
        return d

# ---------------------------------------------------------------------------------------------------
def _validate(cam: Camera) -> None:
    """Raise an input error naming the problem unless the certificate is plausible."""
    where = f" in {cam.source!r}" if cam.source else ""
    if cam.y_axis not in ("up", "down"):
        raise AerofidInputError(f"'y_axis' must be 'up' or 'down', not {cam.y_axis!r}{where}")
    _validate_fiducials(cam, where)
    if cam.focal_length_mm is not None and not (FOCAL_RANGE_MM[0] <= cam.focal_length_mm <= FOCAL_RANGE_MM[1]):
        raise AerofidInputError(f"focal length {cam.focal_length_mm} mm is implausible{where}")
    if cam.pixel_size_um is not None and not plausible_pixel_size(cam.pixel_size_um / 1000.0):
        raise AerofidInputError(f"pixel size {cam.pixel_size_um} um is implausible{where} (a scan's is at least "
                                f"{1000 * MIN_PIXEL_MM:g} um, {MAX_DPI:g} dpi, and less than "
                                f"{1000 * MAX_GIVEN_MM:g} um)")
    for label, pp in (("ppa", cam.ppa_mm), ("pbs", cam.pbs_mm)):
        if pp is not None and max(abs(pp[0]), abs(pp[1])) > MAX_FIDUCIAL_MM:
            raise AerofidInputError(f"principal point {label} {pp} mm is implausible{where}")


def _validate_fiducials(cam: Camera, where: str) -> None:
    """Unique names, at least 3, plausible coordinates, no two alike, not collinear."""
    names = [f.name for f in cam.fiducials]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise AerofidInputError(f"duplicate fiducial name(s) {', '.join(dup)}{where}")
    if len(cam.fiducials) < 3:
        raise AerofidInputError(
            f"camera {cam.name!r} has {len(cam.fiducials)} fiducial(s); at least 3 are needed{where}")
    for f in cam.fiducials:
        if not all(math.isfinite(v) and abs(v) <= MAX_FIDUCIAL_MM for v in (f.x_mm, f.y_mm)):
            raise AerofidInputError(
                f"fiducial {f.name!r} at ({f.x_mm}, {f.y_mm}) mm is implausible (|x|, |y| <= "
                f"{MAX_FIDUCIAL_MM:g} mm expected){where}")
    xy = np.array([[f.x_mm, f.y_mm] for f in cam.fiducials])
    for i in range(len(xy)):
        for j in range(i + 1, len(xy)):
            if np.hypot(*(xy[i] - xy[j])) < 1e-3:
                raise AerofidInputError(f"fiducials {names[i]!r} and {names[j]!r} have the same coordinates{where}")
    sv = np.linalg.svd(xy - xy.mean(axis=0), compute_uv=False)
    if sv[-1] < 1e-6 * max(sv[0], 1e-12):
        raise AerofidInputError(f"the fiducials of camera {cam.name!r} are collinear{where}")


def _opt_number(v: Any, what: str, where: str) -> float | None:
    return None if v is None else finite_number(v, what, where)


def _opt_pair(v: Any, what: str, where: str) -> tuple[float, float] | None:
    if v is None:
        return None
    if isinstance(v, Mapping):
        v = [v.get("x"), v.get("y")]
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise AerofidInputError(f"{what} must be [x_mm, y_mm]{where}")
    return finite_number(v[0], what, where), finite_number(v[1], what, where)


def _fiducial(name: str, v: Any, where: str) -> Fiducial:
    if not name.strip():
        raise AerofidInputError(f"a fiducial has an empty name{where}")
    style = None
    if isinstance(v, Mapping):
        style = v.get("style")
        if style is not None and not isinstance(style, str):
            raise AerofidInputError(f"fiducial {name!r}: 'style' must be a string{where}")
        v = [v.get("x"), v.get("y")]
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise AerofidInputError(f"fiducial {name!r} must be [x_mm, y_mm] or {{x, y}}, not {v!r}{where}")
    return Fiducial(name.strip(), finite_number(v[0], f"fiducial {name!r} x", where),
                    finite_number(v[1], f"fiducial {name!r} y", where), style)
