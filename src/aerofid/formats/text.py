"""Reading the text files aerofid takes (camera, measurements, boxes) without trusting them: JSON with duplicate
keys refused and nesting limited, XML with nesting limited, and the rows of a delimited table with a header
recognised only by its column names (YAML, read only for camera files: :mod:`aerofid.formats.yaml_text`).

Every refusal is one :class:`~aerofid.errors.AerofidInputError` line naming the file.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from aerofid.errors import AerofidInputError

if TYPE_CHECKING:
    import xml.etree.ElementTree as ET

__all__ = ["MAX_DEPTH", "is_header", "load_json", "parse_xml", "table_rows", "too_deep"]

MAX_DEPTH = 32
"""Deepest nesting of JSON arrays/objects, YAML collections or XML elements accepted: the deepest file aerofid
reads (locate's JSON, a MicMac file) nests 4 levels; a limit far above that refuses a hostile file before the
parser's recursion or memory does."""

_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)
_COORDINATE_NAME = re.compile(r"(x|y|col|column|row|line|sample|i|j|u|v)\d?([ _\-(\[].*)?", re.IGNORECASE)
"""A column name a table's header may give a coordinate: x, y, x0, y1, x_px, "x (px)", column, row..."""


def too_deep(source: str) -> AerofidInputError:
    return AerofidInputError(f"{source} nests deeper than {MAX_DEPTH} levels; it is not a file aerofid writes or "
                             "reads: check that it is the right file")


def too_long(source: str) -> AerofidInputError:
    """The error of a number with more digits than Python converts (4300: an integer of thousands of digits)."""
    return AerofidInputError(f"{source} holds a number of thousands of digits; it is not a file aerofid writes or "
                             "reads: check that it is the right file")


def _json_depth(text: str) -> int:
    """Deepest nesting of ``[``/``{`` outside strings (a cheap scan before the recursive parser runs)."""
    codes = np.frombuffer(_JSON_STRING.sub('""', text).encode("utf-8", "replace"), np.uint8)
    if codes.size == 0:
        return 0
    steps = np.isin(codes, (ord("["), ord("{"))).astype(np.int64) - np.isin(codes, (ord("]"), ord("}")))
    return int(np.cumsum(steps).max())


def _unique_pairs(source: str):
    def hook(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        keys = [k for k, _ in pairs]
        dup = sorted({k for k in keys if keys.count(k) > 1})
        if dup:
            raise AerofidInputError(f"duplicate key(s) {', '.join(dup)} in {source}; each key once")
        return dict(pairs)

    return hook


def load_json(text: str, source: str) -> Any:
    """Parse JSON ``text`` (from ``source``, e.g. ``"camera file 'c.json'"``): duplicate keys and nesting deeper
    than :data:`MAX_DEPTH` refused.

    Examples
    --------
    >>> load_json('{"a": [1, 2]}', "x.json")
    {'a': [1, 2]}
    >>> load_json('{"a": 1, "a": 2}', "x.json")
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: duplicate key(s) a in x.json; each key once
    """
    import json  # only when JSON is read: not on a box given on the command line

    if _json_depth(text) > MAX_DEPTH:
        raise too_deep(source)
    try:
        return json.loads(text, object_pairs_hook=_unique_pairs(source))
    except json.JSONDecodeError as e:
        raise AerofidInputError(f"{source} is not valid JSON: {e}") from None
    except AerofidInputError:                       # the file's own refusals (a ValueError too)
        raise
    except ValueError as e:                         # an integer of more digits than Python converts, or a bad value
        raise (too_long(source) if "digits" in str(e) else AerofidInputError(f"{source} is not valid JSON: {e}")
               ) from None
    except RecursionError:
        raise too_deep(source) from None


def parse_xml(text: str, source: str) -> ET.Element:
    """Parse XML ``text``: its root element; nesting deeper than :data:`MAX_DEPTH` refused (expat itself refuses
    entity expansion bombs).

    Examples
    --------
    >>> parse_xml("<a><b>1</b></a>", "x.xml").find("b").text
    '1'
    """
    import xml.etree.ElementTree as ET  # only when XML is read: not on a box given on the command line

    parser: ET.XMLPullParser = ET.XMLPullParser(events=("start", "end"))
    depth = 0
    root: ET.Element | None = None
    try:
        parser.feed(text)
        parser.close()
        for event, element in parser.read_events():  # type: ignore[misc]
            depth += 1 if event == "start" else -1
            if depth > MAX_DEPTH:
                raise too_deep(source)
            if root is None and isinstance(element, ET.Element):
                root = element
    except ET.ParseError as e:
        raise AerofidInputError(f"{source} is not valid XML: {e}") from None
    if root is None:
        raise AerofidInputError(f"{source} is not valid XML: no element found")
    return root


def table_rows(text: str) -> list[tuple[int, list[str]]]:
    """The non-empty rows of a delimited table as (line number, fields): ``#`` starts a comment; commas,
    semicolons or tabs separate the fields, else blanks.

    Examples
    --------
    >>> table_rows("name,x,y  # header\\n\\nP1; 1.5; 2\\nP2 3 4\\n")
    [(1, ['name', 'x', 'y']), (3, ['P1', '1.5', '2']), (4, ['P2', '3', '4'])]
    """
    rows = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if line:
            sep = r"[,;\t]" if re.search(r"[,;\t]", line) else r"\s+"
            rows.append((number, [f.strip() for f in re.split(sep, line)]))
    return rows


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def is_header(fields: Sequence[str], coordinates: int) -> bool:
    """Whether a table's first row is a header: its last ``coordinates`` fields are column names of coordinates
    (x, y, x0, y1, x_px, column, row...), not numbers. A row such as ``P1,a,b`` is data (with bad numbers),
    not a header.

    Examples
    --------
    >>> is_header(["name", "x", "y"], 2), is_header(["P1", "a", "b"], 2), is_header(["P1", "1", "2"], 2)
    (True, False, False)
    """
    names = fields[-coordinates:]
    return len(fields) >= coordinates and all(_COORDINATE_NAME.fullmatch(f) and not _is_number(f) for f in names)
