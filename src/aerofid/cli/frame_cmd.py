"""`aerofid orient IMAGE --camera CAMERA` without measurements: the whole frame (issue 12).

Exit status: 0 when the frame is ok; 1 when it is doubtful or failed (the reasons on stderr and in the
outputs); 2 on bad input or a failed output (nothing written).
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from aerofid.cli.orient_outputs import check_outputs, micmac_files, micmac_texts
from aerofid.cli.output import flush_stdout
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.frame.orient import orient_frame
from aerofid.frame.report import frame_html, frame_text
from aerofid.io.atomic import Staging


def parse_lie(text: str | None) -> tuple[int, bool] | None:
    """``--lie``: ``0``, ``90``, ``180``, ``270``, optionally followed by ``m`` (mirrored), e.g. ``90m``."""
    if text is None:
        return None
    t = text.strip().lower()
    mirrored = t.endswith("m")
    digits = t[:-1] if mirrored else t
    if digits not in ("0", "90", "180", "270"):
        raise AerofidInputError(f"--lie {text!r}: give 0, 90, 180 or 270 (degrees), with 'm' if the film is "
                                "mirrored, e.g. --lie 90m")
    return int(digits), mirrored


def run_frame(image: str, camera_path: str, *, pixel_size: float | None, lie: str | None, model: str,
              as_json: bool, output: str | None, micmac_dir: str | None) -> int:
    """Orient the whole frame ``image``; print, write the report and MicMac files; the exit status."""
    check_outputs(output, micmac_dir)
    the_lie = parse_lie(lie)
    with Staging([image, camera_path]) as staging:
        if output is not None:
            staging.plan(output, "report")
        name = Path(image).name
        micmac = micmac_files(Path(micmac_dir), name, model, staging) if micmac_dir is not None else None
        cam = read_camera(camera_path)
        res = orient_frame(image, cam, pixel_size_mm=pixel_size, model=model, lie=the_lie)
        if output is not None:
            suffix = Path(output).suffix.lower()
            staging.put(output, json.dumps(res.to_dict(), indent=2) + "\n" if suffix == ".json"
                        else frame_text(res) if suffix == ".txt" else frame_html(res, image))
        if micmac is not None and res.orientation is not None:
            for path, text in zip(micmac, micmac_texts(cam, res.orientation), strict=True):
                staging.put(path, text)
        click.echo(json.dumps(res.to_dict()) if as_json else frame_text(res), nl=as_json)
        flush_stdout()
        staging.commit()
    for r in res.reasons:
        click.echo(f"note: {res.status}: {r}", err=True)
    return 0 if res.ok else 1
