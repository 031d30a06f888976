"""``aerofid locate``: the operator's box-in tool on the command line."""

from __future__ import annotations

import json

import click

from aerofid.conventions import MARKS, POLARITY_CHOICES
from aerofid.errors import AerofidInputError
from aerofid.locate import METHOD_NAMES
from aerofid.locate import locate as locate_mark


def parse_box(text: str) -> tuple[float, float, float, float]:
    """'X0,Y0,X1,Y1' -> four floats."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 4:
        raise AerofidInputError(f"--box {text!r} needs four numbers X0,Y0,X1,Y1 (pixels, x1/y1 exclusive)")
    try:
        return tuple(float(p) for p in parts)  # type: ignore[return-value]
    except ValueError:
        raise AerofidInputError(f"--box {text!r} has a malformed number; "
                                "give X0,Y0,X1,Y1 such as 100,200,220,320") from None


def parse_params(items: tuple[str, ...]) -> dict:
    """KEY=VALUE pairs -> dict with int, float, bool or string values."""
    out: dict = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise AerofidInputError(f"--param {item!r} must look like NAME=VALUE, e.g. window_size=24")
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


@click.command(name="locate")
@click.argument("image", type=click.Path(dir_okay=True, path_type=str))
@click.option("--box", "box_text", required=True, metavar="X0,Y0,X1,Y1",
              help="Search box in full-image pixels (x = column, y = row, x1/y1 exclusive).")
@click.option("--mark", type=click.Choice(MARKS), default="auto", show_default=True,
              help="external = film fiducial, panel = cloth ground panel.")
@click.option("--method", type=click.Choice(METHOD_NAMES), default="auto", show_default=True)
@click.option("--polarity", type=click.Choice(POLARITY_CHOICES), default="bright", show_default=True,
              help="Mark brighter (bright) or darker (dark) than its ground, or try both (auto).")
@click.option("--colour", default="auto", show_default=True,
              help="RGB to grey: auto, luminance, red, green, blue or max.")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE",
              help="A method parameter, e.g. window_size=24 or rho_step=0.5 (repeatable).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
@click.option("--overlay", type=click.Path(dir_okay=False, path_type=str), help="Write the delineation overlay PNG.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=str), help="Write the diagnostic figure PNG.")
def locate_cmd(image, box_text, mark, method, polarity, colour, params, as_json, overlay, plot) -> int:
    """Locate the fiducial mark or ground panel inside a box of IMAGE.

    Exit status 0 when found, 1 when not found, 2 on bad input.
    """
    from aerofid.io.atomic import write_bytes_atomic
    from aerofid.render import diagnostic_png, overlay_png

    result = locate_mark(image, parse_box(box_text), mark=mark, method=method, polarity=polarity, colour=colour,
                    **parse_params(params))
    if overlay:
        write_bytes_atomic(overlay, overlay_png(result))
    if plot:
        write_bytes_atomic(plot, diagnostic_png(result))
    if as_json:
        click.echo(json.dumps(result.to_dict()))
    elif result.found:
        click.echo(f"found  x={result.x:.3f}  y={result.y:.3f}  sigma={result.sigma:.3f} px  "
                   f"score={result.score:.2f}  method={result.method}")
    else:
        click.echo(f"not found: {result.reason}")
    if result.clipped and not as_json:
        click.echo(f"note: the box was clipped to the image: {','.join(map(str, result.box))}", err=True)
    return 0 if result.found else 1


locate = locate_cmd
