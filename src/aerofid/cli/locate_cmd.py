"""``aerofid locate``: the operator's box-in tool on the command line, one mark or several per call.

The scan is opened once for all the boxes. Every box and output is checked before any mark is searched
for, and nothing is written unless every mark has been searched for: a run that ends with exit status 2
writes nothing.

The JSON object (``--json``, ``-o FILE.json``) is what ``aerofid orient --measurements`` reads::

    {"image": "scan.tif", "path": "scans/scan.tif", "status": "found" | "not_found",
     "found": ["P1", ...], "not_found": ["P5", ...],
     "points": [{"name": "P1", "status": "found", "x": ..., "y": ..., "sigma": ..., "score": ...,
                 "method": ..., "mark": ..., "polarity": ..., "box": [...], "requested_box": [...],
                 "clipped": false, "reason": ""}, ...]}

``status`` is ``found`` when every mark was found. A mark not found has ``x``, ``y`` null and a ``reason``;
``orient`` leaves it out and names it. With one box, the object also carries that mark's fields at its top
level (as it did when locate took one box).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeAlias

import click

from aerofid.cli.boxes import NamedBox, collect_boxes
from aerofid.cli.output import EXIT_FOUND, EXIT_NOT_FOUND, flush_stdout
from aerofid.conventions import FOUND, MARKS, METHOD_NAMES, NOT_FOUND, POLARITY_CHOICES
from aerofid.errors import AerofidInputError
from aerofid.io.atomic import Staging
from aerofid.io.colour import COLOUR_POLICIES
from aerofid.io.raster import Raster, clip_box, open_raster
from aerofid.windows import rows_read

if TYPE_CHECKING:
    from aerofid.locate import Location

NAME_FIELD = "{name}"
"""In an ``--overlay`` or ``--plot`` path, replaced by each mark's name (one file per mark)."""

Located: TypeAlias = "list[tuple[NamedBox, Location]]"

OPTION_NAMES = ("mark", "method", "polarity", "colour")
"""Names given by options of their own (``--mark``...), never by ``--param``."""


def parse_params(items: Sequence[str]) -> dict[str, Any]:
    """NAME=VALUE pairs -> dict with int, float, bool or string values.

    Examples
    --------
    >>> parse_params(["window_size=24", "rho_step=0.5", "verify=false"])
    {'window_size': 24, 'rho_step': 0.5, 'verify': False}
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise AerofidInputError(f"--param {item!r} must look like NAME=VALUE, e.g. window_size=24")
        if key.strip() in OPTION_NAMES:
            raise AerofidInputError(f"--param {item!r}: {key.strip()} is an option of its own; give --{key.strip()} "
                                    f"{value.strip() or 'VALUE'}")
        v = value.strip()
        if v.lower() in ("true", "false"):
            out[key.strip()] = v.lower() == "true"
            continue
        for cast in (int, float):
            try:
                out[key.strip()] = cast(v)
                break
            except ValueError:
                continue
        else:
            out[key.strip()] = v
    return out


@dataclass(frozen=True)
class Outputs:
    """The files one call writes: the JSON object, overlays (each showing some marks), diagnostic figures."""

    json: Path | None
    overlays: tuple[tuple[Path, tuple[str, ...]], ...]
    plots: tuple[tuple[Path, str], ...]

    def paths(self) -> list[Path]:
        """Every file to be written."""
        return ([self.json] if self.json else []) + [p for p, _ in self.overlays] + [p for p, _ in self.plots]


def _expand(template: str, names: Sequence[str]) -> list[tuple[Path, tuple[str, ...]]]:
    """``template`` with ``{name}`` -> one path per mark; without -> one path for all the marks."""
    if NAME_FIELD in template:
        return [(Path(template.replace(NAME_FIELD, n)), (n,)) for n in names]
    return [(Path(template), tuple(names))]


def plan_outputs(names: Sequence[str], overlay: str | None, plot: str | None, output: str | None,
                 staging: Staging) -> Outputs:
    """The files to write, each checked before any work by ``staging`` (folders exist, no file twice, none an
    input or a special file), ``{name}`` in ``--plot`` when there are several marks, ``--output`` ends in
    ``.json``."""
    for option, value in (("--output", output), ("--overlay", overlay), ("--plot", plot)):
        if value is not None and not value.strip():
            raise AerofidInputError(f"{option} is empty; give a file name, e.g. {option} mark.png")
    if output is not None and Path(output).suffix.lower() != ".json":
        raise AerofidInputError(f"--output {output!r} must end in .json (the measurements aerofid orient reads)")
    if plot is not None and len(names) > 1 and NAME_FIELD not in plot:
        raise AerofidInputError(f"--plot {plot!r} makes one figure per mark: put {NAME_FIELD} in it, "
                                f"e.g. --plot 'diag_{NAME_FIELD}.png'")
    plots = tuple((p, ns[0]) for p, ns in _expand(plot, names)) if plot is not None else ()
    outputs = Outputs(staging.plan(output, "--output") if output is not None else None,
                      tuple(_expand(overlay, names)) if overlay is not None else (), plots)
    for path, _ in outputs.overlays:
        staging.plan(path, "--overlay")
    for path, _ in outputs.plots:
        staging.plan(path, "--plot")
    return outputs


def _check_box(b: NamedBox, raster: Raster) -> None:
    """An input error naming the box when it lies wholly outside the scan."""
    try:
        clip_box(b.box, raster.width, raster.height)
    except AerofidInputError as e:
        raise AerofidInputError(f"{b.source}: {e}") from None


def locate_all(image: str, boxes: Sequence[NamedBox], **options: Any) -> Located:
    """Every box's :class:`~aerofid.locate.Location`, the scan opened once, for the rows the boxes' searches read
    (:func:`~aerofid.windows.rows_read`: a JPEG whose boxes lie near its top is not decoded whole). Every box is
    checked against the scan before any mark is searched for, and the options and parameters by the first search,
    before it reads a pixel. The detection modules are imported once the scan is open: a JPEG whose boxes need its
    whole decode is decoded meanwhile, in the thread the raster starts (the RC20 frame's corner BL, a fresh
    ``aerofid locate``: 457 -> 431 ms median, paired 0.96 over 12 runs; docs/benchmarks_peers.md, session 40)."""
    bottoms = [rows_read(b.box) for b in boxes]
    rows = None if None in bottoms else max((r for r in bottoms if r is not None), default=None)
    with open_raster(image, rows) as raster:
        for b in boxes:
            _check_box(b, raster)
        from aerofid.locate import locate as locate_mark  # after the open (docstring)

        return [(b, locate_mark(raster, b.box, **options)) for b in boxes]


def located_document(image: str, located: Located) -> dict[str, Any]:
    """The JSON object of a call (module docstring): every mark with its name, readable by ``orient``."""
    points = []
    for b, loc in located:
        d = loc.to_dict()
        d.pop("image", None)
        points.append({"name": b.name, **d})
    found = [p["name"] for p in points if p["status"] == FOUND]
    not_found = [p["name"] for p in points if p["status"] != FOUND]
    doc: dict[str, Any] = {"image": Path(image).name, "path": str(image),
                           "status": NOT_FOUND if not_found else FOUND, "found": found, "not_found": not_found}
    if len(points) == 1:
        doc.update({k: v for k, v in points[0].items() if k not in doc})
    doc["points"] = points
    return doc


def _label(b: NamedBox, located: Located) -> str | None:
    """The name to show for ``b``: none for one unnamed box."""
    return b.name if b.named or len(located) > 1 else None


def render_outputs(located: Located, outputs: Outputs) -> dict[Path, bytes]:
    """The overlay and diagnostic PNGs, in memory (nothing is written here)."""
    from aerofid.render import diagnostic_png, overlay_png, overlay_sheet_png

    by_name = {b.name: (b, loc) for b, loc in located}
    files: dict[Path, bytes] = {}
    for path, names in outputs.overlays:
        if len(names) == 1:
            b, loc = by_name[names[0]]
            files[path] = overlay_png(loc, _label(b, located))
        else:
            files[path] = overlay_sheet_png([(n, by_name[n][1]) for n in names])
    for path, name in outputs.plots:
        b, loc = by_name[name]
        files[path] = diagnostic_png(loc, _label(b, located))
    return files


def _json_text(doc: dict[str, Any], indent: int | None = None) -> str:
    """``doc`` as JSON text; json imported only for a JSON answer (the plain one needs none: 1.5 ms of start-up)."""
    import json

    return json.dumps(doc, indent=indent)


def _echo_text(located: Located) -> None:
    """One line per mark on stdout (and a summary when there are several); clipped boxes noted on stderr."""
    width = max(len(b.name) for b, _ in located)
    for b, loc in located:
        label = _label(b, located)
        head = f"{label:<{width}}  " if label else ""
        if loc.found:
            click.echo(f"{head}found  x={loc.x:.3f}  y={loc.y:.3f}  sigma={loc.sigma:.3f} px  "
                       f"score={loc.score:.2f}  method={loc.method}")
        else:
            click.echo(f"{head}not found: {loc.reason}")
    for b, loc in located:
        if loc.clipped:
            who = f"box {b.name}" if _label(b, located) else "the box"
            click.echo(f"note: {who} was clipped to the image: {','.join(map(str, loc.box))}", err=True)
    if len(located) > 1:
        missing = [b.name for b, loc in located if not loc.found]
        click.echo(f"found {len(located) - len(missing)} of {len(located)}"
                   + (f"; not found: {', '.join(missing)}" if missing else ""))


@click.command(name="locate")
@click.argument("image", type=click.Path(dir_okay=True, path_type=str))
@click.option("--box", "box_texts", multiple=True, metavar="[NAME=]X0,Y0,X1,Y1",
              help="Search box in full-image pixels (x = column, y = row, x1/y1 exclusive), named NAME "
                   "(unnamed: its position, 1, 2, ...). Repeatable: one mark per box.")
@click.option("--boxes", "boxes_file", metavar="FILE",
              help="CSV of boxes, one 'name,x0,y0,x1,y1' a line (header optional; '#' comments).")
@click.option("--mark", type=click.Choice(MARKS), default="auto", show_default=True,
              help="external = film fiducial, panel = cloth ground panel.")
@click.option("--method", type=click.Choice(METHOD_NAMES), default="auto", show_default=True)
@click.option("--polarity", type=click.Choice(POLARITY_CHOICES), default="bright", show_default=True,
              help="Mark brighter (bright) or darker (dark) than its ground, or try both (auto).")
@click.option("--colour", type=click.Choice(COLOUR_POLICIES), default="auto", show_default=True,
              help="How RGB becomes grey: auto takes the channel mix that shows the mark best (luminance, the "
                   "one full-resolution plane of a 4:2:0 JPEG, wherever the mark shows in it).")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE",
              help="A method parameter, e.g. window_size=24 or rho_step=0.5 (repeatable; with --method auto "
                   "each goes to the methods that take it).")
@click.option("--json", "as_json", is_flag=True,
              help="Print one JSON object with every mark (aerofid orient --measurements reads it).")
@click.option("-o", "--output", metavar="FILE.json", help="Write that JSON object to FILE.json.")
@click.option("--overlay", metavar="PNG",
              help="Write the delineation overlay: one PNG showing every box, or one per mark with {name} "
                   "in the path (e.g. ov_{name}.png).")
@click.option("--plot", metavar="PNG",
              help="Write the diagnostic figure (with several boxes put {name} in the path).")
def locate_cmd(image: str, box_texts: tuple[str, ...], boxes_file: str | None, mark: str, method: str,
               polarity: str, colour: str, params: tuple[str, ...], as_json: bool, output: str | None,
               overlay: str | None, plot: str | None) -> int:
    """Locate the fiducial marks or ground panels inside boxes of IMAGE.

    Exit status 0 when every mark is found, 1 when any is not found (all are still reported and written),
    2 on bad input (one line 'error: ...', nothing written).
    """
    inputs = [image] + ([boxes_file] if boxes_file is not None else [])
    with Staging(inputs) as staging:
        boxes = collect_boxes(box_texts, boxes_file)
        values = parse_params(params)
        outputs = plan_outputs([b.name for b in boxes], overlay, plot, output, staging)
        located = locate_all(image, boxes, mark=mark, method=method, polarity=polarity, colour=colour, **values)
        doc = located_document(image, located)
        if outputs.json is not None:
            staging.put(outputs.json, _json_text(doc, indent=2) + "\n")
        for path, data in render_outputs(located, outputs).items():
            staging.put(path, data)
        if as_json:
            click.echo(_json_text(doc))
        else:
            _echo_text(located)
        flush_stdout()
        staging.commit()
    return EXIT_FOUND if all(loc.found for _, loc in located) else EXIT_NOT_FOUND


locate = locate_cmd
