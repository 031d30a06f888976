"""Fiducial pixel measurements: JSON, CSV and MicMac MeasuresIm XML.

* JSON: ``{"image": "scan.tif", "points": {"P1": [x, y], ...}}``; unnamed points as a list
  ``"points": [[x, y], ...]``; a list of ``{"name", "x", "y"}`` objects is accepted too.
* CSV: ``name,x,y`` (a header line is optional; ``#`` starts a comment); ``x,y`` for unnamed points.
  Commas, semicolons, tabs or blanks separate the fields.
* XML: MicMac ``MeasuresIm-<image>.xml`` (``SetOfMesureAppuisFlottants`` / ``MesureAppuiFlottant1Im`` /
  ``NameIm`` / ``OneMesureAF1I`` / ``NamePt`` / ``PtIm``), see :mod:`aerofid.formats.micmac`.

Pixel coordinates: x = column, y = row, the centre of the top-left pixel is (0, 0).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.atomic import write_text_atomic


@dataclass(frozen=True)
class Measurements:
    """Measured fiducial centres of one scan.

    Attributes:
        xy: n x 2 pixel coordinates (x = column, y = row).
        names: the fiducial name of each point, or None when the points are unnamed.
        image: the scan's file name (may be empty).
    """

    xy: np.ndarray = field(compare=False)
    names: tuple[str, ...] | None = None
    image: str = ""

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy, dtype=float).reshape(-1, 2)
        object.__setattr__(self, "xy", xy)
        if not np.all(np.isfinite(xy)):
            raise AerofidInputError("measured coordinates must be finite numbers")
        if self.names is not None:
            if len(self.names) != len(xy):
                raise AerofidInputError("each measured point needs one name")
            dup = sorted({n for n in self.names if self.names.count(n) > 1})
            if dup:
                raise AerofidInputError(f"duplicate measured point name(s) {', '.join(dup)}")
        if len(xy) == 0:
            raise AerofidInputError("no measured points")

    @property
    def named(self) -> bool:
        return self.names is not None

    def as_dict(self) -> dict[str, tuple[float, float]]:
        if self.names is None:
            raise AerofidInputError("the measured points have no names")
        return {n: (float(x), float(y)) for n, (x, y) in zip(self.names, self.xy)}

    def to_dict(self) -> dict:
        if self.names is None:
            pts: Any = [[float(x), float(y)] for x, y in self.xy]
        else:
            pts = {n: [float(x), float(y)] for n, (x, y) in zip(self.names, self.xy)}
        return {"image": self.image, "points": pts}

    @classmethod
    def from_any(cls, obj: Any, image: str = "") -> "Measurements":
        """From a Measurements, a path, a mapping name -> (x, y), a JSON-like dict, or an n x 2 array."""
        if isinstance(obj, Measurements):
            return obj
        if isinstance(obj, (str, Path)):
            return read_measurements(obj)
        if isinstance(obj, Mapping):
            if "points" in obj:
                return _from_json_obj(obj, "")
            return _from_json_obj({"image": image, "points": obj}, "")
        arr = np.asarray(obj, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise AerofidInputError("unnamed measurements must be an n x 2 array of (x, y) pixels")
        return cls(arr, None, image)


def read_measurements(path: str | Path, image: str | None = None) -> Measurements:
    """Read measurements from ``.json``, ``.csv``/``.txt`` or MicMac ``.xml`` (by extension)."""
    path = Path(path)
    if not path.is_file():
        raise AerofidInputError(f"measurements file {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".xml":
        from aerofid.formats.micmac import read_measures_im

        return read_measures_im(path, image=image)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise AerofidInputError(f"cannot read measurements file {str(path)!r}: {e}") from None
    if suffix == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as e:
            raise AerofidInputError(f"measurements file {str(path)!r} is not valid JSON: {e}") from None
        return _from_json_obj(data, str(path))
    if suffix in (".csv", ".txt", ".tsv"):
        return _from_csv_text(text, str(path), image or _image_from_name(path))
    raise AerofidInputError(f"unknown measurements format {suffix!r}: use .json, .csv or MicMac .xml")


def write_measurements(path: str | Path, m: Measurements) -> None:
    """Write measurements as ``.json``, ``.csv`` or MicMac ``.xml`` (by extension), atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".xml":
        from aerofid.formats.micmac import write_measures_im

        write_measures_im(path, m)
    elif suffix == ".json":
        write_text_atomic(path, json.dumps(m.to_dict(), indent=2) + "\n")
    elif suffix in (".csv", ".txt"):
        lines = ["name,x,y"] if m.names is not None else ["x,y"]
        for i, (x, y) in enumerate(m.xy):
            row = f"{_fmt(x)},{_fmt(y)}"
            lines.append(f"{m.names[i]},{row}" if m.names is not None else row)
        write_text_atomic(path, "\n".join(lines) + "\n")
    else:
        raise AerofidInputError(f"unknown measurements format {suffix!r}: use .json, .csv or MicMac .xml")


def _fmt(v: float) -> str:
    return repr(float(v))


def _image_from_name(path: Path) -> str:
    m = re.match(r"MeasuresIm-(.+)\.\w+$", path.name)
    return m.group(1) if m else ""


def _num(v: Any, what: str, where: str) -> float:
    if isinstance(v, bool):
        raise AerofidInputError(f"{what} must be a number, not {v!r}{where}")
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise AerofidInputError(f"{what} must be a number, not {v!r}{where}") from None
    if not math.isfinite(x):
        raise AerofidInputError(f"{what} must be a finite number, not {v!r}{where}")
    return x


def _pair(v: Any, what: str, where: str) -> tuple[float, float]:
    if isinstance(v, Mapping):
        v = [v.get("x"), v.get("y")]
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise AerofidInputError(f"{what} must be [x, y], not {v!r}{where}")
    return _num(v[0], f"{what} x", where), _num(v[1], f"{what} y", where)


def _from_json_obj(data: Any, source: str) -> Measurements:
    where = f" in {source!r}" if source else ""
    if not isinstance(data, Mapping) or "points" not in data:
        raise AerofidInputError(f"measurements must be {{\"image\": ..., \"points\": {{name: [x, y]}}}}{where}")
    image = data.get("image") or ""
    if not isinstance(image, str):
        raise AerofidInputError(f"'image' must be a file name{where}")
    pts = data["points"]
    if isinstance(pts, Mapping):
        names = tuple(str(k) for k in pts)
        xy = [_pair(v, f"point {k!r}", where) for k, v in pts.items()]
    elif isinstance(pts, list):
        if pts and all(isinstance(p, Mapping) and "name" in p for p in pts):
            names = tuple(str(p["name"]) for p in pts)
            xy = [_pair(p, f"point {p['name']!r}", where) for p in pts]
        else:
            names = None
            xy = [_pair(p, f"point {i + 1}", where) for i, p in enumerate(pts)]
    else:
        raise AerofidInputError(f"'points' must map names to [x, y] or list [x, y] pairs{where}")
    if not xy:
        raise AerofidInputError(f"no measured points{where}")
    return Measurements(np.array(xy, dtype=float), names, image)


def _from_csv_text(text: str, source: str, image: str) -> Measurements:
    where = f" in {source!r}"
    rows: list[list[str]] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        fields = [f.strip() for f in re.split(r"[,;\t]" if re.search(r"[,;\t]", line) else r"\s+", line)]
        rows.append(fields)
    if rows and _is_header(rows[0]):
        rows = rows[1:]
    if not rows:
        raise AerofidInputError(f"no measured points{where}")
    widths = {len(r) for r in rows}
    if widths == {2}:
        xy = [(_num(r[0], f"line {i + 1} x", where), _num(r[1], f"line {i + 1} y", where))
              for i, r in enumerate(rows)]
        return Measurements(np.array(xy), None, image)
    if widths == {3}:
        names = tuple(r[0] for r in rows)
        if any(not n for n in names):
            raise AerofidInputError(f"a point has an empty name{where}")
        xy = [(_num(r[1], f"point {r[0]!r} x", where), _num(r[2], f"point {r[0]!r} y", where)) for r in rows]
        return Measurements(np.array(xy), names, image)
    raise AerofidInputError(f"each line must be 'name,x,y' (or 'x,y' for unnamed points){where}")


def _is_header(fields: Sequence[str]) -> bool:
    try:
        float(fields[-1])
        return False
    except ValueError:
        return True
