"""`aerofid orient IMAGE --camera CAMERA` without measurements: the whole frame (issue 12).

Exit status: 0 when the frame is ok; 1 when it is doubtful or failed (the reasons on stderr and in the
outputs); 2 on bad input or a failed output (nothing written).
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from aerofid.cli.orient_outputs import check_outputs, metashape_text, micmac_files, micmac_texts
from aerofid.cli.output import flush_stdout
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.measurements import read_measurements
from aerofid.frame.nominal import DEFAULT_FORMAT, nominal_camera
from aerofid.frame.orient import orient_frame
from aerofid.frame.profile import learn_profile, read_profile
from aerofid.frame.report import frame_html, frame_text
from aerofid.frame.verdict import adjusted_pixel_mm
from aerofid.io.atomic import Staging
from aerofid.orientation.correspondence import lie_of
from aerofid.orientation.interior import orient


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


def run_frame(image: str, camera_path: str | None, *, pixel_size: float | None, lie: str | None, model: str,
              as_json: bool, output: str | None, micmac_dir: str | None, profile_path: str | None = None,
              metashape: str | None = None) -> int:
    """Orient the whole frame ``image``; print, write the report, MicMac files and Metashape script; the exit
    status. Without ``camera_path``: the :data:`~aerofid.frame.nominal.DEFAULT_FORMAT` format, uncalibrated."""
    check_outputs(output, micmac_dir, metashape)
    the_lie = parse_lie(lie)
    given = camera_path
    camera_path = camera_path or DEFAULT_FORMAT
    nominal = nominal_camera(camera_path)
    if nominal is not None and (micmac_dir is not None or profile_path is not None or metashape is not None):
        what = f"--camera {given!r} names a format, not a calibration" if given else "no --camera given"
        raise AerofidInputError(f"{what}: --micmac, --metashape and --profile need the camera file")
    with Staging([p for p in (image, None if nominal else camera_path, profile_path) if p]) as staging:
        if output is not None:
            staging.plan(output, "report")
        name = Path(image).name
        micmac = micmac_files(Path(micmac_dir), name, model, staging) if micmac_dir is not None else None
        if metashape is not None:
            staging.plan(metashape, "--metashape")
        cam = None if nominal is not None else read_camera(camera_path)     # a format: orient_frame knows it by name
        profile = read_profile(profile_path) if profile_path is not None else None
        res = orient_frame(image, camera_path if cam is None else cam, pixel_size_mm=pixel_size, model=model,
                           lie=the_lie, profile=profile)
        if output is not None:
            suffix = Path(output).suffix.lower()
            staging.put(output, json.dumps(res.to_dict(), indent=2) + "\n" if suffix == ".json"
                        else frame_text(res) if suffix == ".txt" else frame_html(res, image))
        if micmac is not None and cam is not None and res.orientation is not None:
            for path, text in zip(micmac, micmac_texts(cam, res.orientation), strict=True):
                staging.put(path, text)
        if metashape is not None and cam is not None and res.orientation is not None:
            staging.put(metashape, metashape_text(cam, res.orientation))
        click.echo(json.dumps(res.to_dict()) if as_json else frame_text(res), nl=as_json)
        flush_stdout()
        staging.commit()
    for r in res.reasons:
        click.echo(f"note: {res.status}: {r}", err=True)
    return 0 if res.ok else 1


@click.command()
@click.argument("frame")
@click.option("--camera", "camera_path", required=True, metavar="CAMERA",
              help="camera file: JSON/YAML certificate or MicMac MeasuresCamera.xml")
@click.option("-o", "--output", required=True, metavar="ROLL", help="the roll profile to write (.json)")
@click.option("--pixel-size", type=float, metavar="MM",
              help="the scan's pixel size in mm (default: the file's resolution tags, the camera file)")
@click.option("--lie", metavar="ROT[m]", help="the film's lie when the fiducials cannot tell it (e.g. 0, 90m)")
@click.option("--measurements", "-m", "meas_path", metavar="FILE",
              help="the frame's fiducials measured by hand (JSON, CSV or MicMac MeasuresIm, named as in the camera "
                   "file): they give the lie and the pixel size, and the marks found must agree with them")
def learn(frame, camera_path, output, pixel_size, lie, meas_path) -> int:
    """Learn a roll's profile from one of its frames: the marks' style (the method that measures them), size and
    polarity, the film's lie and the pixel size, for 'aerofid orient --profile' on the roll's other frames. The
    frame must orient ok (exit 1 with the reasons, nothing written, if not)."""
    if Path(output).suffix.lower() != ".json":
        raise AerofidInputError(f"roll profile {output!r} must end in .json")
    if meas_path is not None and (lie is not None or pixel_size is not None):
        raise AerofidInputError("--measurements give the lie and the pixel size: leave out --lie and --pixel-size")
    with Staging([p for p in (frame, camera_path, meas_path) if p]) as staging:
        staging.plan(output, "roll profile")
        cam = read_camera(camera_path)
        the_lie, measured = parse_lie(lie), None
        if meas_path is not None:
            meas = read_measurements(meas_path)
            if meas.names is None:
                raise AerofidInputError(f"{meas_path}: the measurements must name the camera file's fiducials")
            io = orient(cam, meas, correspondence="names")
            the_lie, pixel_size = lie_of(io.pixel_to_mm, cam.y_axis), adjusted_pixel_mm(io)
            measured = dict(zip(meas.names, meas.xy.tolist(), strict=True))
        res = orient_frame(frame, cam, pixel_size_mm=pixel_size, lie=the_lie)
        if not res.ok:
            click.echo(f"error: cannot learn from {Path(frame).name}: it is {res.status}: " + "; ".join(res.reasons),
                       err=True)
            return 1
        profile = learn_profile(res, measured)
        staging.put(output, json.dumps(profile.to_dict(), indent=2) + "\n")
        click.echo(f"{Path(frame).name}: {len(res.found)} marks, {profile.method}, {profile.polarity}, radius "
                   f"{profile.mark_radius_mm:.3f} mm, lie {profile.rotation_deg}{'m' if profile.mirrored else ''}, "
                   f"pixel {profile.pixel_size_mm * 1000:.3f} um -> {output}")
        flush_stdout()
        staging.commit()
    return 0
