"""The roll's fiducial areas: a frame oriented with a roll profile is measured first where the profile's frame
had its fiducials (seed 002, section 2: "fiducial areas" predicted before the detection; issue 12: the profile
is used "to search smaller areas"), without screening the whole frame.

The frames of one roll lie in the scanner alike, up to the film's placement: a few mm of shift and a few tenths
of a degree of turn (150 mm from the centre, 1 degree moves a corner mark 2.6 mm). Each fiducial is sought within
:data:`ROLL_SHIFT_MM` of its learnt position (taken from the scan's centre, so that scans cropped to different
sizes around the film agree; scaled by the pixel sizes): the marks are measured as on a layout found by the
screening (:func:`aerofid.frame.marks.measure_marks`: the first ones near their learnt positions, else in their
areas searched like a region; the later ones where the marks found put them), and adjusted and judged alike. A
frame placed farther off, or one that is not ok this way, is searched whole
(:func:`aerofid.frame.orient.orient_frame`).
"""

from __future__ import annotations

import numpy as np

from aerofid.frame.layout import LayoutMatch, layout_at
from aerofid.frame.profile import RollProfile
from aerofid.orientation.camera import Camera

ROLL_SHIFT_MM = 10.0
"""How far (film mm) a fiducial of a frame of the roll may lie from where the profile's frame had it and still be
found in its area (the synthetic frames of the tests: up to 3 mm of shift per axis and 0.5 degree of turn each)."""


LAYOUT_AGREEMENT = 0.05
"""How far (relative) the pixel size of the profile's positions fitted to the camera's layout may differ from the
scan's: positions that do not fit the camera file (edited by hand, or of another camera of the same name) are not
used."""


def roll_layout(profile: RollProfile, camera: Camera, scan_size: tuple[int, int],
                pixel_size_mm: float) -> LayoutMatch | None:
    """The profile's layout on this scan: the ``camera``'s fiducials at the profile's positions from the scan's
    centre, scaled by the profile's pixel size over this scan's, in the profile's lie, each to be found within
    :data:`ROLL_SHIFT_MM`; None when the profile lacks a position for one of them (a profile written without
    positions, or learnt with another camera file's names), or its positions do not fit the camera's layout
    (:data:`LAYOUT_AGREEMENT`)."""
    known = {name: (dx, dy) for name, dx, dy in profile.positions_px}
    names = camera.names
    if not names or any(n not in known for n in names):
        return None
    scale = profile.pixel_size_mm / pixel_size_mm
    centre = np.array([(scan_size[0] - 1) / 2, (scan_size[1] - 1) / 2])
    points = centre + scale * np.array([known[n] for n in names], dtype=float)
    if not np.isfinite(points).all() or np.ptp(points, axis=0).min() <= 0:
        return None
    layout = layout_at(points, camera.xy_mm, profile.rotation_deg, profile.mirrored, camera.y_axis,
                       ROLL_SHIFT_MM / pixel_size_mm)
    return layout if abs(layout.pixel_size_mm / pixel_size_mm - 1) <= LAYOUT_AGREEMENT else None


__all__ = ["LAYOUT_AGREEMENT", "ROLL_SHIFT_MM", "roll_layout"]
