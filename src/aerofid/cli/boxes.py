"""The boxes of ``aerofid locate``: ``--box [NAME=]X0,Y0,X1,Y1`` (repeatable) and ``--boxes FILE``.

A boxes file is CSV: one box a line as ``name,x0,y0,x1,y1``; a header line is optional, ``#`` starts a
comment, blank lines are skipped; commas, semicolons, tabs or blanks separate the fields. Boxes are in
full-image pixels (x = column, y = row, x1 and y1 exclusive). A ``--box`` without a name is named by its
position among all the boxes (``1``, ``2``, ...). Names are unique and are letters, digits, ``_``, ``.``,
``+`` or ``-`` (starting with a letter, digit or ``_``), so that they can go into file names and MicMac files.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from aerofid.errors import AerofidInputError
from aerofid.formats.text import is_header, table_rows
from aerofid.io.files import read_text_input

NAME_PATTERN = re.compile(r"\w[\w.+-]*")
"""What a box name may be."""

COORDINATES = ("x0", "y0", "x1", "y1")


@dataclass(frozen=True)
class NamedBox:
    """A search box with its mark's name and where it was given (for error messages).

    Attributes
    ----------
    name : str
        The mark's name (unique among the boxes of one call).
    box : tuple of float
        (x0, y0, x1, y1) in full-image pixels, finite, x1 > x0 and y1 > y0.
    source : str
        Where the box came from, e.g. ``--box 'P1=10,10,90,90'`` or ``line 3 of 'boxes.csv'``.
    named : bool
        Whether the user gave the name (an unnamed ``--box`` is named by its position).
    """

    name: str
    box: tuple[float, float, float, float]
    source: str
    named: bool = True


def check_name(name: str, source: str) -> str:
    """``name`` stripped, or an input error when it is not a valid box name."""
    name = name.strip()
    if not NAME_PATTERN.fullmatch(name):
        raise AerofidInputError(f"{source}: box name {name!r} must be letters, digits, '_', '.', '+' or '-' "
                                "(starting with a letter, digit or '_'), e.g. P1")
    return name


def _coordinates(fields: Sequence[str], source: str) -> tuple[float, float, float, float]:
    """Four numbers x0, y0, x1, y1 of a non-empty box, or an input error naming ``source``."""
    values = []
    for what, text in zip(COORDINATES, fields):
        try:
            v = float(text)
        except ValueError:
            raise AerofidInputError(f"{source}: {what} {text.strip()!r} is not a number; give X0,Y0,X1,Y1 "
                                    "such as 100,200,220,320") from None
        if not math.isfinite(v):
            raise AerofidInputError(f"{source}: {what} {text.strip()!r} is not a finite number")
        values.append(v)
    x0, y0, x1, y1 = values
    if x1 <= x0 or y1 <= y0:
        raise AerofidInputError(f"{source}: the box is empty; give X0,Y0,X1,Y1 with x1 > x0 and y1 > y0 "
                                "(pixels, x1/y1 exclusive)")
    return x0, y0, x1, y1


def parse_box(text: str, position: int = 1) -> NamedBox:
    """One ``--box``: ``NAME=X0,Y0,X1,Y1`` or ``X0,Y0,X1,Y1`` (then named ``str(position)``).

    Examples
    --------
    >>> parse_box("P1=10,20,130,140")
    NamedBox(name='P1', box=(10.0, 20.0, 130.0, 140.0), source="--box 'P1=10,20,130,140'", named=True)
    >>> parse_box("10,20,130,140", 2).name
    '2'
    """
    source = f"--box {text!r}"
    name, sep, coords = text.rpartition("=")
    name = check_name(name, source) if sep else str(position)
    parts = coords.split(",")
    if len(parts) != 4:
        raise AerofidInputError(f"{source} needs four numbers X0,Y0,X1,Y1 (pixels, x1/y1 exclusive), "
                                "optionally named: NAME=X0,Y0,X1,Y1")
    return NamedBox(name, _coordinates(parts, source), source, bool(sep))


def parse_boxes_text(text: str, source: str) -> list[NamedBox]:
    """The boxes of a boxes file's ``text`` (format: module docstring); ``source`` names the file in errors.

    Examples
    --------
    >>> [b.name for b in parse_boxes_text("name,x0,y0,x1,y1\\nUL,0,0,100,100\\nUR,900,0,1000,100\\n", "b.csv")]
    ['UL', 'UR']
    """
    out: list[NamedBox] = []
    rows = table_rows(text)
    if rows and len(rows[0][1]) == 5 and is_header(rows[0][1], 4):
        rows = rows[1:]
    for number, fields in rows:
        where = f"line {number} of {source!r}"
        if len(fields) != 5:
            raise AerofidInputError(f"{where}: expected name,x0,y0,x1,y1 (5 fields), got {len(fields)}")
        out.append(NamedBox(check_name(fields[0], where), _coordinates(fields[1:], where), where))
    if not out:
        raise AerofidInputError(f"no boxes in {source!r}; give one name,x0,y0,x1,y1 a line")
    return out


def read_boxes_file(path: str | Path) -> list[NamedBox]:
    """The boxes of the boxes file at ``path`` (format: module docstring)."""
    path, text = read_text_input(path, "boxes file")
    return parse_boxes_text(text, str(path))


def collect_boxes(box_texts: Sequence[str], boxes_file: str | Path | None) -> list[NamedBox]:
    """Every box of one call: the ``--box`` options in order, then the rows of ``--boxes``; names unique."""
    boxes = [parse_box(t, i) for i, t in enumerate(box_texts, start=1)]
    if boxes_file is not None:
        boxes += read_boxes_file(boxes_file)
    if not boxes:
        raise AerofidInputError("give a box: --box X0,Y0,X1,Y1 or --box NAME=X0,Y0,X1,Y1 (repeatable), "
                                "or --boxes FILE")
    seen: dict[str, NamedBox] = {}
    for b in boxes:
        if b.name in seen:
            raise AerofidInputError(f"box name {b.name!r} is given twice ({seen[b.name].source} and {b.source}); "
                                    "each mark needs its own name")
        seen[b.name] = b
    return boxes


__all__ = ["NAME_PATTERN", "NamedBox", "check_name", "collect_boxes", "parse_box", "parse_boxes_text",
           "read_boxes_file"]
