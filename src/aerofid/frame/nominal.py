"""Frames without a calibration certificate: the nominal layout of a film format stands in for the camera file.

Seeds 002-004 orient a frame from its calibrated fiducials. Archives often hold rolls whose certificate is
lost; their marks can still be found and reported in pixels, with the fiducial centre, the pixel size and the
frame's rotation in the scanner estimated from a nominal layout, and the frame flagged as uncalibrated.
"""

from __future__ import annotations

import numpy as np

from aerofid.orientation.camera import Camera

NOMINAL_LAYOUTS = {
    "23cm": {"corner_1": (-106.0, 106.0), "corner_2": (106.0, 106.0), "corner_3": (106.0, -106.0),
             "corner_4": (-106.0, -106.0), "midside_top": (0.0, 110.0), "midside_right": (110.0, 0.0),
             "midside_bottom": (0.0, -110.0), "midside_left": (-110.0, 0.0)},
}
"""The nominal fiducials (film mm, y up) of a format: 23 cm (9 in) aerial film with corner marks about 106 mm
and midside marks about 110 mm from the centre (Wild RC8 to RC30 and most 23 cm cameras within a few mm; the
layout search allows 3 % of scale and 2 mm, and a camera whose marks lie elsewhere gets those it finds)."""
SCALE_SPREAD = 1.05
"""How far in scale (a ratio) a camera's marks may lie from its format's nominal layout: a scan whose pixel size is
declared (given, its resolution tags) is searched for the layout at pixel sizes within this ratio of it either way
(:func:`nominal_sizes`). The Jena LMK of certificate OSL/1785 has its corner marks 110 mm from the centre, 3.8 % beyond
the nominal 106 mm; the real Wild RC20 frame's, 106 mm."""
FORMAT_ALIASES = {"23cm": "23cm", "23": "23cm", "230mm": "23cm", "9in": "23cm", "9x9": "23cm"}
"""How a format may be named on the command line (spaces and case ignored)."""
DEFAULT_FORMAT = "23cm"
"""The format a scan is oriented on when no camera file is given (the aerial film format of nearly every mapping
camera: Wild RC, Zeiss RMK, Fairchild)."""
FORMAT_MATCH_MM = 3.0
"""How far (film mm) each of a camera file's fiducials may lie from a mark of a format's nominal layout (placed
by the translation that fits them best) for the file to be read as that format (:func:`extra_marks`)."""
UNCALIBRATED = ("uncalibrated: no calibration certificate, only the {fmt} format: the marks are found in pixels "
                "and the fiducial centre, pixel size and rotation are estimated from the format's nominal "
                "layout; give the camera file for an interior orientation")
"""The reason every uncalibrated frame carries."""


def format_name(name: str) -> str | None:
    """The film format that ``name`` names, as :data:`NOMINAL_LAYOUTS` keys it (``"9 in"`` -> ``"23cm"``); None
    if it names none."""
    return FORMAT_ALIASES.get(str(name).replace(" ", "").lower())


def nominal_camera(name: str) -> Camera | None:
    """The nominal camera of a film format named ``name`` (e.g. ``"23cm"``, ``"9 in"``), None if it names none.

    >>> nominal_camera("23 cm").name, len(nominal_camera("23 cm").fiducials)
    ('nominal 23cm format (uncalibrated)', 8)
    >>> nominal_camera("camera.json") is None
    True
    """
    key = format_name(name)
    if key is None:
        return None
    return Camera.from_dict({"name": f"nominal {key} format (uncalibrated)",
                             "fiducials": {k: list(v) for k, v in NOMINAL_LAYOUTS[key].items()}})


def nominal_sizes(pixel_size_mm: float) -> tuple[float, float]:
    """The pixel sizes (mm) at which a format's nominal layout is sought in a scan of declared ``pixel_size_mm``: the
    camera's marks lie within :data:`SCALE_SPREAD` of the nominal ones in scale.

    >>> [round(s, 4) for s in nominal_sizes(0.021)]
    [0.02, 0.0221]
    """
    return pixel_size_mm / SCALE_SPREAD, pixel_size_mm * SCALE_SPREAD


def extra_marks(camera: Camera) -> dict[str, tuple[float, float]]:
    """The marks of the camera's film format that its file does not list, at their nominal positions in the
    file's film coordinates (mm): a certificate often calibrates only the 4 corner marks of a camera that has 8
    (the real Wild RC20 frame's ``MeasuresCamera.xml``). The format is the nominal layout
    (:data:`NOMINAL_LAYOUTS`) on which every fiducial of the file lies within :data:`FORMAT_MATCH_MM` of a mark of
    its own, the layout moved by the translation that fits them best (the file's origin may be a corner; its y
    axis up or down) and not turned (certificates are drawn square to the film's edges); {} when no layout holds
    them all, or it has no other marks. A mark whose nominal name the file gives to another fiducial is named
    ``"<name> (format)"``.

    >>> cam = Camera.from_dict({"name": "RC20", "fiducials": {"P1": [106.0, -106.0], "P2": [-106.0, -106.0],
    ...                                                       "P3": [-106.0, 106.0], "P4": [106.0, 106.0]}})
    >>> extra_marks(cam)["midside_top"]
    (0.0, 110.0)
    """
    xy = camera.xy_mm
    flip = np.array([1.0, 1.0 if camera.y_axis == "up" else -1.0])
    for layout in NOMINAL_LAYOUTS.values():
        nominal = np.array(list(layout.values())) * flip
        fit = _layout_fit(xy, nominal)
        if fit is not None:
            shift, matched = fit
            return {(n if n not in camera.names else f"{n} (format)"): (float(p[0]), float(p[1]))
                    for k, (n, p) in enumerate(zip(layout, nominal + shift, strict=True)) if k not in matched}
    return {}


def _layout_fit(xy: np.ndarray, nominal: np.ndarray) -> tuple[np.ndarray, set[int]] | None:
    """The translation that puts each point of ``xy`` within :data:`FORMAT_MATCH_MM` of its own mark of
    ``nominal`` with the least sum of squares (tried from every pairing of the first point with a mark, each
    point then taking its nearest mark), and the marks taken; None if there is none."""
    if len(xy) > len(nominal):
        return None
    best: tuple[float, np.ndarray, set[int]] | None = None
    for k in range(len(nominal)):
        shift = xy[0] - nominal[k]
        d = np.hypot(*(xy[:, None, :] - (nominal + shift)[None, :, :]).transpose(2, 0, 1))
        nearest = d.argmin(axis=1)
        if len(set(nearest.tolist())) < len(xy):
            continue
        shift = shift + (xy - (nominal[nearest] + shift)).mean(axis=0)
        d = np.hypot(*(xy - (nominal[nearest] + shift)).T)
        if d.max() <= FORMAT_MATCH_MM and (best is None or float(d @ d) < best[0]):
            best = (float(d @ d), shift, set(nearest.tolist()))
    return None if best is None else best[1:]


__all__ = ["FORMAT_MATCH_MM", "NOMINAL_LAYOUTS", "SCALE_SPREAD", "UNCALIBRATED", "extra_marks", "nominal_camera",
           "nominal_sizes"]
