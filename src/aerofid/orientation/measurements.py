"""Measured fiducial centres of one scan (pixel coordinates: x = column, y = row, the centre of the top-left
pixel is (0, 0)). Files are read and written by :mod:`aerofid.formats.measurements`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError

MAX_PIXEL_COORDINATE = 1e7
"""Largest |coordinate| of a measured point (px): a 23 cm film frame scanned at 1 um is 230 000 px across;
coordinates far beyond any scan (1e300) would only overflow the adjustment's squares."""


@dataclass(frozen=True)
class Measurements:
    """Measured fiducial centres of one scan; validated when made.

    Attributes
    ----------
    xy : numpy.ndarray
        n x 2 pixel coordinates (x = column, y = row), finite; anything array-like is converted.
    names : tuple of str or None
        The fiducial name of each point (unique), or None when the points are unnamed.
    image : str
        The scan's file name (may be empty).

    Examples
    --------
    >>> m = Measurements.from_any({"P1": (167.5, 212.5), "P2": (5215.0, 234.0)}, image="scan.tif")
    >>> m.named, m.names, m.xy.shape
    (True, ('P1', 'P2'), (2, 2))
    >>> Measurements.from_any([[1.0, 2.0], [3.0, 4.0]]).names is None
    True
    """

    xy: np.ndarray = field(compare=False)
    names: tuple[str, ...] | None = None
    image: str = ""

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy, dtype=float).reshape(-1, 2)
        object.__setattr__(self, "xy", xy)
        if not np.all(np.isfinite(xy)):
            raise AerofidInputError("measured coordinates must be finite numbers")
        if xy.size and float(np.abs(xy).max()) > MAX_PIXEL_COORDINATE:
            raise AerofidInputError(f"a measured coordinate is {float(np.abs(xy).max()):.6g} px, beyond any scan "
                                    f"(|x|, |y| <= {MAX_PIXEL_COORDINATE:.0e} px): check the measurements")
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

    def to_dict(self) -> dict:
        if self.names is None:
            pts: Any = [[float(x), float(y)] for x, y in self.xy]
        else:
            pts = {n: [float(x), float(y)] for n, (x, y) in zip(self.names, self.xy)}
        return {"image": self.image, "points": pts}

    @classmethod
    def from_any(cls, obj: Any, image: str = "") -> Measurements:
        """From a Measurements, a mapping name -> (x, y), a JSON-like dict, or an n x 2 array."""
        if isinstance(obj, Measurements):
            return obj
        if isinstance(obj, Mapping):
            if "points" in obj:
                return measurements_from_json(obj, "")
            return measurements_from_json({"image": image, "points": obj}, "")
        arr = np.asarray(obj, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise AerofidInputError("unnamed measurements must be an n x 2 array of (x, y) pixels")
        return cls(arr, None, image)


def finite_number(v: Any, what: str, where: str) -> float:
    """``v`` as a finite float, else an input error naming ``what`` and ``where`` (and ``v``, its first digits if it is
    long).

    >>> finite_number(10**400, "x", "")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: x must be a finite number, not 100000000000000000000...(401 characters)
    """
    shown = _shown(v)
    if isinstance(v, bool):
        raise AerofidInputError(f"{what} must be a number, not {shown}{where}")
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise AerofidInputError(f"{what} must be a number, not {shown}{where}") from None
    except OverflowError:                           # an integer beyond a float's range
        x = math.inf
    if not math.isfinite(x):
        raise AerofidInputError(f"{what} must be a finite number, not {shown}{where}")
    return x


def _shown(v: Any) -> str:
    """``repr(v)``, its first digits where it is long, its size where Python will not write it (an integer of more
    than 4300 digits: YAML reads hexadecimal ones of any length)."""
    try:
        text = repr(v)
    except ValueError:
        return f"an integer of {v.bit_length()} bits"
    return text if len(text) <= 40 else f"{text[:21]}...({len(text)} characters)"


def _pair(v: Any, what: str, where: str) -> tuple[float, float]:
    if isinstance(v, Mapping):
        v = [v.get("x"), v.get("y")]
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise AerofidInputError(f"{what} must be [x, y], not {v!r}{where}")
    return finite_number(v[0], f"{what} x", where), finite_number(v[1], f"{what} y", where)


def measurements_from_json(data: Any, source: str) -> Measurements:
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


__all__ = ["MAX_PIXEL_COORDINATE", "Measurements", "finite_number", "measurements_from_json"]
