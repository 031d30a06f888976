"""`aerofid resample`: a scan resampled into its camera's fiducial (film mm) frame, like MicMac ReSampFid
(docs/resample.md).

Exit status: 0 written; 2 on bad input or a failed output (one line ``error: ...`` on stderr; nothing written:
the resampled frame, its sidecar and the exports are written together once all have been made).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import click

from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.exports import FORMATS, asp_tsai, check_format, fiducials_csv, opencv_yaml, orientation_json
from aerofid.formats.orientation import StoredOrientation, read_orientation
from aerofid.resample import DEFAULT_KERNEL, KERNELS, Resampled, output_name, resample_frame, sidecar_path


@click.command()
@click.argument("image")
@click.option("--orientation", "orientation_path", required=True, metavar="IO",
              help="the scan's interior orientation: the JSON 'aerofid orient ... -o IO.json' writes (whole frame "
                   "or measurements) or a MicMac AffinePlane px2mm XML")
@click.option("--pixel-size", type=float, required=True, metavar="MM", help="output pixel size in film mm")
@click.option("--extent", type=float, nargs=4, metavar="XMIN YMIN XMAX YMAX",
              help="output extent in film mm (default: the fiducials' bounding box, as MicMac ReSampFid)")
@click.option("--kernel", type=click.Choice(list(KERNELS)), default=DEFAULT_KERNEL, show_default=True,
              help="interpolation kernel")
@click.option("--y-axis", type=click.Choice(["up", "down"]), default=None,
              help="the camera's film y axis (default: from the orientation; for an AffinePlane the one aerofid "
                   "notes in it, else down, MicMac's): "
                   "rows run along -y for up, +y for down, so the output is never mirrored")
@click.option("--micmac-name", is_flag=True, help="name the output OIS-Reech_<IMAGE's file name> in the folder -o")
@click.option("--export", "exports", multiple=True, metavar="FORMAT=PATH",
              help=f"also write the orientation for another tool: {', '.join(FORMATS)} (repeatable)")
@click.option("--camera", "camera_path", metavar="CAMERA",
              help="camera file, for the asp export (focal length and principal point)")
@click.option("-o", "--output", required=True, metavar="OUT.tif",
              help="the resampled frame (a tiled TIFF); with --micmac-name, the folder it goes to")
def resample(image, orientation_path, pixel_size, extent, kernel, y_axis, micmac_name, exports, camera_path,
             output) -> int:
    """Resample IMAGE into its camera's fiducial frame (film mm): a tiled, compressed TIFF with overviews, the
    scan's bit depth and bands kept, and its own pixel -> mm in OUT.px2mm.json."""
    if micmac_name:
        if not Path(output).is_dir():
            raise AerofidInputError(f"with --micmac-name, -o names the folder the output goes to; {output!r} is "
                                    "not a folder")
        output = str(output_name(image, output))
    wanted = _parse_exports(exports)
    stored = read_orientation(orientation_path)
    makers: dict[str | os.PathLike[str], Callable[[Resampled], str]] = {
        path: _maker(fmt, stored, camera_path) for fmt, path in wanted}
    res = resample_frame(image, stored, output, pixel_size_mm=pixel_size, extent_mm=extent or None, kernel=kernel,
                         y_axis=y_axis, extra_outputs=makers)
    g = res.grid
    also = ", ".join([str(sidecar_path(output))] + [p for _, p in wanted])
    click.echo(f"wrote {output}: {g.width} x {g.height} px of {g.pixel_size_mm:g} mm, film x {g.extent_mm[0]:g}.."
               f"{g.extent_mm[2]:g} mm, y {g.extent_mm[1]:g}..{g.extent_mm[3]:g} mm (y {g.y_axis}), {kernel}; "
               f"also {also}")
    return 0


def _parse_exports(exports: tuple[str, ...]) -> list[tuple[str, str]]:
    out = []
    for text in exports:
        fmt, sep, path = text.partition("=")
        if not sep or not path:
            raise AerofidInputError(f"--export {text!r} must be FORMAT=PATH, e.g. csv=fiducials.csv")
        check_format(fmt, resampled=True)
        out.append((fmt, path))
    return out


def _maker(fmt: str, stored: StoredOrientation, camera_path: str | None) -> Callable[[Resampled], str]:
    """The function that makes an export's text from the resampled frame."""
    if fmt == "asp":
        if camera_path is None:
            raise AerofidInputError("--export asp=... needs --camera CAMERA (its focal length and principal point)")
        cam = read_camera(camera_path)
        return lambda r: asp_tsai(r.grid, cam.focal_length_mm, cam.principal_point_mm[0])
    make = {"csv": fiducials_csv, "json": orientation_json, "opencv": opencv_yaml}[fmt]

    def text(r: Resampled) -> str:
        return make(stored, r.grid)
    return text
