"""Exports of an interior orientation (and of a resampled frame's grid) for other tools (docs/resample.md).

Formats (:data:`FORMATS`):

``csv``
    One row per fiducial: ``name, status, x_px, y_px, x_mm, y_mm, residual_x_mm, residual_y_mm`` (pixels: x =
    column, y = row, the centre of the top-left pixel (0, 0); residuals calibrated minus adjusted), plus
    ``x_out_px, y_out_px`` (the calibrated position in the resampled frame) when there is a grid.
``json``
    The fiducials as above and the 3x3 matrices ``pixel_to_mm``, ``mm_to_pixel`` and, with a grid,
    ``output_pixel_to_mm`` and ``scan_to_output``, row-major, with the convention spelled out.
``opencv``
    The same matrices as an OpenCV FileStorage YAML file (``cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    .getNode("scan_to_output").mat()``). ``scan_to_output`` is ``M`` of ``cv2.warpPerspective(scan, M, (width,
    height))`` (``cv2.warpAffine(scan, M[:2], ...)`` for an affine orientation): ``dst = M src``, pixel centres
    at integer coordinates in both images, as OpenCV's warps use them.
``asp``
    NASA Ames Stereo Pipeline pinhole intrinsics of the resampled frame, a ``.tsai`` file (``VERSION_4``,
    ``PINHOLE``, ``fu fv cu cv`` in mm, ``pitch`` the output pixel size in mm, ``NULL`` distortion), for
    ``cam_gen --sample-file`` (ASP's documentation: docs/pinholemodels.rst "File formats" and "How the pinhole
    model is applied", docs/tools/cam_gen.rst ``--sample-file`` / ``--focal-length`` / ``--optical-center`` /
    ``--pixel-pitch``; https://stereopipeline.readthedocs.io). ``fu = fv`` the calibrated focal length, ``(cu,
    cv)`` the principal point's offset from the upper-left of the image in mm: its output pixel position times
    the pitch (ASP's pixel is ``(fu Q1/Q3 + cu, fv Q2/Q3 + cv) / pitch``). The camera centre ``C`` and rotation
    ``R`` are placeholders (0 and the identity) that ``cam_gen`` replaces.

    ASP's pixel (0, 0) is the centre of the top-left pixel, as ours, so ``cu``, ``cv`` carry no half-pixel
    term. ASP's documentation says only "relative to the upper-left image corner"; the source settles it:
    Vision Workbench's ``PinholeModel::point_to_pixel`` (visionworkbench, src/vw/Camera/PinholeModel.cc) returns
    ``(fu Q1/Q3 + cu, fv Q2/Q3 + cv) / pitch`` with no offset, and ASP compares those pixels with images indexed
    by integers, converting from ISIS pixels (centre of the top-left pixel (1, 1)) by subtracting 1 and from CSM
    pixels (its centre (0.5, 0.5)) by subtracting 0.5 (StereoPipeline, src/asp/Camera/CsmModel.cc,
    ``ASP_TO_CSM_SHIFT``). Checked in the sources; not run against ASP itself.

Agisoft Metashape: :mod:`aerofid.formats.metashape` (a script placing the measured fiducials on the scan, written
by ``aerofid orient --metashape`` and ``aerofid batch --metashape``; docs/exports.md).
"""

from __future__ import annotations

import csv
import io
import json
import math

import cv2
import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.formats.micmac import number_text
from aerofid.formats.orientation import StoredOrientation
from aerofid.orientation.grid import ResampleGrid

FORMATS = ("csv", "json", "opencv", "asp")
"""The export formats, by name."""
CONVENTION = ("pixels: x = column, y = row, the centre of the top-left pixel is (0, 0); matrices 3x3 row-major, "
              "applied to (x, y, 1) column vectors: dst = M src (cv2.warpAffine / cv2.warpPerspective's M)")
_COLUMNS = ("name", "status", "x_px", "y_px", "x_mm", "y_mm", "residual_x_mm", "residual_y_mm")


def matrices(stored: StoredOrientation, grid: ResampleGrid | None = None) -> dict[str, np.ndarray]:
    """The 3x3 matrices of an orientation (and of its resampling onto ``grid``), by name."""
    out = {"pixel_to_mm": stored.transform.matrix, "mm_to_pixel": stored.transform.inverse.matrix}
    if grid is not None:
        out["output_pixel_to_mm"] = grid.pixel_to_mm
        out["scan_to_output"] = grid.scan_to_output(stored.transform)
    return out


def _rows(stored: StoredOrientation, grid: ResampleGrid | None) -> list[dict]:
    rows = []
    for f in stored.fiducials:
        row = {k: getattr(f, k) for k in _COLUMNS}
        if grid is not None:
            row["x_out_px"], row["y_out_px"] = (float(v) for v in grid.to_pixel([(f.x_mm, f.y_mm)])[0])
        rows.append(row)
    return rows


def fiducials_csv(stored: StoredOrientation, grid: ResampleGrid | None = None) -> str:
    """The ``csv`` export (module docstring)."""
    buf = io.StringIO()
    columns = list(_COLUMNS) + (["x_out_px", "y_out_px"] if grid is not None else [])
    w = csv.DictWriter(buf, columns, lineterminator="\n")
    w.writeheader()
    for row in _rows(stored, grid):
        w.writerow({k: v if isinstance(v, str) else number_text(v) for k, v in row.items()})
    return buf.getvalue()


def orientation_json(stored: StoredOrientation, grid: ResampleGrid | None = None) -> str:
    """The ``json`` export (module docstring)."""
    d = {"image": stored.image, "camera": stored.camera, "convention": CONVENTION,
         "fiducials": _rows(stored, grid), **{k: M.tolist() for k, M in matrices(stored, grid).items()}}
    if grid is not None:
        d["grid"] = grid.to_dict()
    return json.dumps(d, indent=2) + "\n"


def opencv_yaml(stored: StoredOrientation, grid: ResampleGrid | None = None) -> str:
    """The ``opencv`` export: an OpenCV FileStorage YAML text of :func:`matrices`."""
    fs = cv2.FileStorage(".yml", cv2.FILE_STORAGE_WRITE | cv2.FILE_STORAGE_MEMORY)
    for name, M in matrices(stored, grid).items():
        fs.write(name, np.asarray(M, dtype=np.float64))
    if grid is not None:
        fs.write("width", grid.width)
        fs.write("height", grid.height)
    return fs.releaseAndGetString()


def asp_tsai(grid: ResampleGrid, focal_length_mm: float | None, principal_point_mm: tuple[float, float]) -> str:
    """The ``asp`` export: ASP pinhole intrinsics (``.tsai``) of the frame resampled onto ``grid``."""
    if focal_length_mm is None or not math.isfinite(focal_length_mm) or focal_length_mm <= 0:
        raise AerofidInputError("the ASP export needs the calibrated focal length: give --camera with a camera file "
                                "that has focal_length_mm")
    col, row = grid.to_pixel([principal_point_mm])[0]
    p = grid.pixel_size_mm
    f = number_text(focal_length_mm)
    return "\n".join(["VERSION_4", "PINHOLE", f"fu = {f}", f"fv = {f}", f"cu = {number_text(col * p)}",
                      f"cv = {number_text(row * p)}", "u_direction = 1 0 0", "v_direction = 0 1 0",
                      "w_direction = 0 0 1", "C = 0 0 0", "R = 1 0 0 0 1 0 0 0 1", f"pitch = {number_text(p)}",
                      "NULL", ""])


def check_format(fmt: str, resampled: bool) -> None:
    """An input error for an unknown format, or for one that describes a resampled frame without one."""
    if fmt == "metashape":
        raise AerofidInputError("Metashape places the fiducials on the original scan, not on a resampled frame: use "
                                "'aerofid orient SCAN --camera CAMERA --metashape SCRIPT.py' (docs/exports.md)")
    if fmt not in FORMATS:
        raise AerofidInputError(f"unknown export format {fmt!r}: choose one of {', '.join(FORMATS)}")
    if fmt == "asp" and not resampled:
        raise AerofidInputError("the ASP export describes a resampled frame: export it from 'aerofid resample'")


__all__ = ["CONVENTION", "FORMATS", "asp_tsai", "check_format", "fiducials_csv", "matrices", "opencv_yaml",
           "orientation_json"]
