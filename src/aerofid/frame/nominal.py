"""Frames without a calibration certificate: the nominal layout of a film format stands in for the camera file.

Seeds 002-004 orient a frame from its calibrated fiducials. Archives often hold rolls whose certificate is
lost; their marks can still be found and reported in pixels, with the fiducial centre, the pixel size and the
frame's rotation in the scanner estimated from a nominal layout, and the frame flagged as uncalibrated.
"""

from __future__ import annotations

from aerofid.orientation.camera import Camera

NOMINAL_LAYOUTS = {
    "23cm": {"corner_1": (-106.0, 106.0), "corner_2": (106.0, 106.0), "corner_3": (106.0, -106.0),
             "corner_4": (-106.0, -106.0), "midside_top": (0.0, 110.0), "midside_right": (110.0, 0.0),
             "midside_bottom": (0.0, -110.0), "midside_left": (-110.0, 0.0)},
}
"""The nominal fiducials (film mm, y up) of a format: 23 cm (9 in) aerial film with corner marks about 106 mm
and midside marks about 110 mm from the centre (Wild RC8 to RC30 and most 23 cm cameras within a few mm; the
layout search allows 3 % of scale and 2 mm, and a camera whose marks lie elsewhere gets those it finds)."""
FORMAT_ALIASES = {"23cm": "23cm", "23": "23cm", "230mm": "23cm", "9in": "23cm", "9x9": "23cm"}
"""How a format may be named on the command line (spaces and case ignored)."""
UNCALIBRATED = ("uncalibrated: no calibration certificate, only the {fmt} format: the marks are found in pixels "
                "and the fiducial centre, pixel size and rotation are estimated from the format's nominal "
                "layout; give the camera file for an interior orientation")
"""The reason every uncalibrated frame carries."""


def nominal_camera(name: str) -> Camera | None:
    """The nominal camera of a film format named ``name`` (e.g. ``"23cm"``, ``"9 in"``), None if it names none.

    >>> nominal_camera("23 cm").name, len(nominal_camera("23 cm").fiducials)
    ('nominal 23cm format (uncalibrated)', 8)
    >>> nominal_camera("camera.json") is None
    True
    """
    key = FORMAT_ALIASES.get(str(name).replace(" ", "").lower())
    if key is None:
        return None
    return Camera.from_dict({"name": f"nominal {key} format (uncalibrated)",
                             "fiducials": {k: list(v) for k, v in NOMINAL_LAYOUTS[key].items()}})


__all__ = ["NOMINAL_LAYOUTS", "UNCALIBRATED", "nominal_camera"]
