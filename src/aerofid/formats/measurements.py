"""Fiducial pixel measurements: JSON, CSV and MicMac MeasuresIm XML.

* JSON: ``{"image": "scan.tif", "points": {"P1": [x, y], ...}}``; unnamed points as a list
  ``"points": [[x, y], ...]``; a list of ``{"name", "x", "y"}`` objects is accepted too. This is what
  ``aerofid locate --json`` writes: a point whose ``"status"`` is not ``"found"`` (a mark locate did not
  find) is left out, and :func:`read_measurements_and_not_found` names it.
* CSV: ``name,x,y`` (a header line is optional; ``#`` starts a comment); ``x,y`` for unnamed points.
  Commas, semicolons, tabs or blanks separate the fields.
* XML: MicMac ``MeasuresIm-<image>.xml`` (``SetOfMesureAppuisFlottants`` / ``MesureAppuiFlottant1Im`` /
  ``NameIm`` / ``OneMesureAF1I`` / ``NamePt`` / ``PtIm``), see :mod:`aerofid.formats.micmac`.

Pixel coordinates: x = column, y = row, the centre of the top-left pixel is (0, 0).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.micmac import number_text, read_measures_im, write_measures_im
from aerofid.formats.text import is_header, load_json, table_rows
from aerofid.io.atomic import write_text_atomic
from aerofid.io.files import input_file, read_text_input
from aerofid.orientation.measurements import (
    Measurements,
    finite_number,
    measurements_from_json,
)


def read_measurements(path: str | Path, image: str | None = None) -> Measurements:
    """Read measurements from ``.json``, ``.csv``/``.txt``/``.tsv`` or MicMac ``.xml`` (by extension).

    Parameters
    ----------
    path : str or Path
        The file (formats: module docstring).
    image : str or None
        MicMac: which image's measures to take when the file holds several; CSV: the image's name (default:
        from a ``MeasuresIm-<image>.csv`` file name, else empty).

    Returns
    -------
    Measurements
        The measured points; points marked not found (JSON ``"status"``) are left out.

    Raises
    ------
    AerofidInputError
        Missing or unreadable file, unknown extension, bad numbers, duplicate or missing names.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "MeasuresIm-scan.tif.csv"
    >>> _ = path.write_text("name,x,y\\nP1,167.5,212.5\\nP2,5215,234\\nP3,148.5,5259.5\\n")
    >>> m = read_measurements(path)
    >>> m.names, m.image, m.xy[1].tolist()
    (('P1', 'P2', 'P3'), 'scan.tif', [5215.0, 234.0])
    """
    return read_measurements_and_not_found(path, image)[0]


def read_measurements_and_not_found(path: str | Path,
                                    image: str | None = None) -> tuple[Measurements, tuple[str, ...]]:
    """Like :func:`read_measurements`, and the names of the points the file marks as not found.

    A JSON file written by ``aerofid locate --json`` lists every mark it searched for, each with a
    ``"status"``; the marks it did not find have no coordinates and are left out of the measurements.

    Returns
    -------
    measurements : Measurements
        The found points.
    not_found : tuple of str
        The names of the points left out, in file order (empty for CSV and MicMac files).

    Raises
    ------
    AerofidInputError
        As :func:`read_measurements`; also when no point of the file was found.

    Examples
    --------
    >>> import json, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "located.json"
    >>> _ = path.write_text(json.dumps({"image": "scan.tif", "points": [
    ...     {"name": "P1", "status": "found", "x": 167.5, "y": 212.5},
    ...     {"name": "P2", "status": "not_found", "x": None, "y": None},
    ...     {"name": "P3", "status": "found", "x": 148.5, "y": 5259.5}]}))
    >>> m, not_found = read_measurements_and_not_found(path)
    >>> m.names, not_found
    (('P1', 'P3'), ('P2',))
    """
    path = input_file(path, "measurements file")
    suffix = path.suffix.lower()
    if suffix == ".xml":
        return read_measures_im(path, image=image), ()
    if suffix not in (".json", ".csv", ".txt", ".tsv"):
        raise AerofidInputError(f"unknown measurements format {suffix!r}: use .json, .csv or MicMac .xml")
    path, text = read_text_input(path, "measurements file")
    if suffix == ".json":
        data = load_json(text, f"measurements file {str(path)!r}")
        data, not_found = _without_not_found(data, str(path))
        return measurements_from_json(data, str(path)), not_found
    return _from_csv_text(text, str(path), image or _image_from_name(path)), ()


def write_measurements(path: str | Path, m: Measurements) -> None:
    """Write measurements as ``.json``, ``.csv``/``.txt`` or MicMac ``.xml`` (by extension), atomically.

    Numbers are written in full (the shortest text that reads back to the same float), so a round trip
    is exact. MicMac files need named points.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> m = Measurements(np.array([[167.5, 212.5], [5215.0, 234.0]]), ("P1", "P2"), "scan.tif")
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "m.json"
    >>> write_measurements(path, m)
    >>> back = read_measurements(path)
    >>> back.names == m.names and bool((back.xy == m.xy).all())
    True
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".xml":
        write_measures_im(path, m)
    elif suffix == ".json":
        write_text_atomic(path, json.dumps(m.to_dict(), indent=2) + "\n")
    elif suffix in (".csv", ".txt"):
        lines = ["name,x,y"] if m.names is not None else ["x,y"]
        for i, (x, y) in enumerate(m.xy):
            row = f"{number_text(x)},{number_text(y)}"
            lines.append(f"{m.names[i]},{row}" if m.names is not None else row)
        write_text_atomic(path, "\n".join(lines) + "\n")
    else:
        raise AerofidInputError(f"unknown measurements format {suffix!r}: use .json, .csv or MicMac .xml")


def _is_not_found(point: Any) -> bool:
    return isinstance(point, Mapping) and "status" in point and point["status"] != "found"


def _without_not_found(data: Any, source: str) -> tuple[Any, tuple[str, ...]]:
    """``data`` without the points whose ``"status"`` is not ``"found"``, and their names."""
    if not isinstance(data, Mapping) or "points" not in data:
        return data, ()
    pts = data["points"]
    if isinstance(pts, Mapping):
        gone = tuple(str(k) for k, v in pts.items() if _is_not_found(v))
        kept: Any = {k: v for k, v in pts.items() if not _is_not_found(v)}
    elif isinstance(pts, list):
        gone = tuple(str(p.get("name", f"point {i + 1}")) for i, p in enumerate(pts) if _is_not_found(p))
        kept = [p for p in pts if not _is_not_found(p)]
    else:
        return data, ()
    if gone and not kept:
        raise AerofidInputError(f"no point of {source!r} was found (not found: {', '.join(gone)})")
    return {**data, "points": kept}, gone


def _image_from_name(path: Path) -> str:
    m = re.match(r"MeasuresIm-(.+)\.\w+$", path.name)
    return m.group(1) if m else ""


def _from_csv_text(text: str, source: str, image: str) -> Measurements:
    where = f" in {source!r}"
    numbered = table_rows(text)
    if numbered and is_header(numbered[0][1], 2):
        numbered = numbered[1:]
    rows = [fields for _, fields in numbered]
    if not rows:
        raise AerofidInputError(f"no measured points{where}")
    widths = {len(r) for r in rows}
    if widths == {2}:
        xy = [(finite_number(r[0], f"line {i + 1} x", where), finite_number(r[1], f"line {i + 1} y", where))
              for i, r in enumerate(rows)]
        return Measurements(np.array(xy), None, image)
    if widths == {3}:
        names = tuple(r[0] for r in rows)
        if any(not n for n in names):
            raise AerofidInputError(f"a point has an empty name{where}")
        xy = [(finite_number(r[1], f"point {r[0]!r} x", where), finite_number(r[2], f"point {r[0]!r} y", where))
              for r in rows]
        return Measurements(np.array(xy), names, image)
    raise AerofidInputError(f"each line must be 'name,x,y' (or 'x,y' for unnamed points){where}")
