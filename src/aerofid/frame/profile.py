"""A roll's profile: what one frame's marks look like, learnt once and used on every frame of the roll.

The frames of one roll come from one camera and one scanner set-up: the marks' style, size and polarity, the
method that measures them, the film's lie and the pixel size are the same on every frame. ``aerofid learn``
stores them from one frame oriented ok (:func:`learn_profile`); ``aerofid orient --profile`` then

- takes the pixel size and the lie from it (a symmetric layout's lie is no longer open),
- measures every mark by the learnt method alone from the first one on, on the window the learnt size gives
  (the frame's geometry checks it; ``auto`` is the fallback), and
- searches the areas around where the learnt frame had its fiducials first (``positions_px``,
  :mod:`aerofid.frame.roll_areas`; the first marks where their learnt templates correlate best,
  :mod:`aerofid.frame.templates`), the whole frame too unless that finds every fiducial and an ok frame, and
- flags a frame that disagrees with it for review (:func:`disagreements`): another lie, another pixel size,
  marks of another size or polarity, or marks the learnt method did not find; and, where the marks' own looks tell
  the film's lie (the RC20's number dots) and it is not the frame's, that (:func:`lie_by_templates`).
"""

from __future__ import annotations

import math
import os
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerofid.conventions import POLARITIES, Polarity, opposite
from aerofid.errors import AerofidInputError
from aerofid.formats.text import load_json
from aerofid.frame.result import FOUND_MARK, FrameOrientation
from aerofid.frame.templates import MarkTemplate, agreement, cut_template
from aerofid.frame.verdict import adjusted_pixel_mm
from aerofid.io.files import read_text_input
from aerofid.orientation.correspondence import ARRANGEMENTS, arrangement_matrix
from aerofid.robust import median

PROFILE_FORMAT = "aerofid-roll-profile"
"""The ``format`` entry that names a profile file."""
PROFILE_VERSION = 1
"""The version of the profile file this code writes and reads."""
SIZE_AGREEMENT = 0.25
"""Largest relative difference between a frame's mark radius and the profile's before the frame is flagged: the
radius a method reports varies by a few per cent between frames; another mark style differs by more."""
PIXEL_AGREEMENT = 0.01
"""Largest relative difference between a frame's adjusted pixel size and the profile's: one scanner set-up
gives the same size to a few tenths of a per cent."""
MEASURED_AGREEMENT_PX = 3.0
"""How far (px) a mark found may lie from a person's measurement of it when a profile is learnt from measured
marks: a person's clicks are off by up to a pixel or two (the RC20 frame: 0.8 px RMS)."""
MIN_MEASURED = 3
"""Fewest marks found that the measurements name, to learn from measured marks."""
METHODS = ("hough", "symmetry", "circles", "lines")
"""The seed methods a roll's marks can be measured by alone."""


@dataclass(frozen=True)
class RollProfile:
    """What the marks of a roll look like (see the module docstring).

    Attributes
    ----------
    camera : str
        The camera file's name: a profile is used with the camera it was learnt with.
    pixel_size_mm : float
        The learnt frame's adjusted pixel size.
    rotation_deg, mirrored : int, bool
        The film's lie in the scanner (:data:`aerofid.orientation.correspondence.ARRANGEMENTS`).
    polarity : str
        ``"bright"`` or ``"dark"``: the polarity the marks were measured in (a symmetric mark, a bright ring and
        cross on dark film, can be measured in either: the one that gave the better answers on the learnt frame).
    method : str
        The seed method that measured most of the learnt frame's marks.
    mark_radius_mm : float
        The marks' median radius by that method's model (film mm).
    image : str
        The frame it was learnt from.
    positions_px : tuple of (name, dx, dy)
        Each fiducial's pixel position on the learnt scan, from the scan's centre ``((width - 1) / 2,
        (height - 1) / 2)``: the mark found, else where the frame's orientation (or layout) put it. Empty in a profile
        written without them (by an earlier aerofid): the whole frame is then searched.
    mark_radii_mm : tuple of (name, radius)
        Each found mark's radius (film mm) by its method's model: a camera's marks differ (the Wild cameras' corner
        and midside marks), and each is measured on the window its own size gives in the roll's areas.
    mark_templates : tuple of (name, MarkTemplate)
        Each found mark as the learnt frame showed it, reduced (:mod:`aerofid.frame.templates`): where the first
        marks are sought in the roll's areas. Empty in a profile written without them.
    """

    camera: str
    pixel_size_mm: float
    rotation_deg: int
    mirrored: bool
    polarity: Polarity
    method: str
    mark_radius_mm: float
    image: str = ""
    positions_px: tuple[tuple[str, float, float], ...] = ()
    mark_radii_mm: tuple[tuple[str, float], ...] = ()
    mark_templates: tuple[tuple[str, MarkTemplate], ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        if (self.rotation_deg, self.mirrored) not in ARRANGEMENTS:
            raise AerofidInputError(f"profile: lie ({self.rotation_deg}, {self.mirrored}) is not one of the 8 lies")
        if self.polarity not in POLARITIES:
            raise AerofidInputError(f"profile: polarity {self.polarity!r} must be bright or dark")
        if self.method not in METHODS:
            raise AerofidInputError(f"profile: method {self.method!r} must be one of {', '.join(METHODS)}")
        for what, v in (("pixel_size_mm", self.pixel_size_mm), ("mark_radius_mm", self.mark_radius_mm)):
            if not (math.isfinite(v) and 0 < v < 50):
                raise AerofidInputError(f"profile: {what} {v!r} must be a positive size in mm")
        if not all(math.isfinite(dx) and math.isfinite(dy) for _, dx, dy in self.positions_px):
            raise AerofidInputError("profile: positions_px must be finite pixel offsets")
        if not all(math.isfinite(r) and 0 < r < 50 for _, r in self.mark_radii_mm):
            raise AerofidInputError("profile: mark_radii_mm must be positive sizes in mm")

    def mark_radius_px(self, pixel_size_mm: float) -> float:
        return self.mark_radius_mm / pixel_size_mm

    def radii_px(self, names: Sequence[str], pixel_size_mm: float) -> list[float]:
        """Each fiducial's learnt mark radius (px), the marks' median where the learnt frame did not find it."""
        own = dict(self.mark_radii_mm)
        return [own.get(n, self.mark_radius_mm) / pixel_size_mm for n in names]

    def templates_for(self, names: Sequence[str]) -> list[MarkTemplate | None]:
        """Each fiducial's learnt template (None where the learnt frame gave none)."""
        own = dict(self.mark_templates)
        return [own.get(n) for n in names]

    def check_camera(self, camera_name: str) -> None:
        """Refuse (one line) a camera other than the one the profile was learnt with."""
        if self.camera != camera_name:
            raise AerofidInputError(f"the roll profile was learnt with camera {self.camera!r}, not {camera_name!r}: "
                                    "give its camera file or learn the profile again")

    def to_dict(self) -> dict[str, Any]:
        return {"format": PROFILE_FORMAT, "version": PROFILE_VERSION, "camera": self.camera,
                "pixel_size_mm": self.pixel_size_mm, "lie": {"rotation_deg": self.rotation_deg,
                                                             "mirrored": self.mirrored},
                "polarity": self.polarity, "method": self.method, "mark_radius_mm": self.mark_radius_mm,
                "image": self.image, "positions_px": {k: [dx, dy] for k, dx, dy in self.positions_px},
                "mark_radii_mm": dict(self.mark_radii_mm),
                "mark_templates": {k: t.to_dict() for k, t in self.mark_templates}}

    @classmethod
    def from_dict(cls, d: Any, source: str = "profile") -> RollProfile:
        """The profile :meth:`to_dict` wrote; anything else is one line saying what is wrong."""
        if not isinstance(d, dict) or d.get("format") != PROFILE_FORMAT:
            raise AerofidInputError(f"{source}: not a roll profile (make one with 'aerofid learn FRAME --camera C "
                                    "-o roll.json')")
        if d.get("version") != PROFILE_VERSION:
            raise AerofidInputError(f"{source}: profile version {d.get('version')!r}; this aerofid reads version "
                                    f"{PROFILE_VERSION}: learn it again")
        try:
            lie = d["lie"]
            return cls(camera=str(d["camera"]), pixel_size_mm=_number(d["pixel_size_mm"]),
                       rotation_deg=int(lie["rotation_deg"]), mirrored=_flag(lie["mirrored"]),
                       polarity=d["polarity"], method=str(d["method"]), mark_radius_mm=_number(d["mark_radius_mm"]),
                       image=str(d.get("image", "")), positions_px=_positions(d.get("positions_px", {})),
                       mark_radii_mm=_radii(d.get("mark_radii_mm", {})),
                       mark_templates=_templates(d.get("mark_templates", {})))
        except (KeyError, TypeError) as e:
            raise AerofidInputError(f"{source}: the profile lacks or mistypes {e}: learn it again") from None
        except AerofidInputError as e:
            raise AerofidInputError(f"{source}: {e}") from None


def _number(v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise TypeError(repr(v))
    return float(v)


def _positions(d: Any) -> tuple[tuple[str, float, float], ...]:
    """``positions_px`` as :meth:`RollProfile.to_dict` writes it: name -> [dx, dy]."""
    if not isinstance(d, dict) or not all(isinstance(v, list) and len(v) == 2 for v in d.values()):
        raise TypeError("positions_px")
    return tuple((str(k), _number(v[0]), _number(v[1])) for k, v in d.items())


def _radii(d: Any) -> tuple[tuple[str, float], ...]:
    """``mark_radii_mm`` as :meth:`RollProfile.to_dict` writes it: name -> radius."""
    if not isinstance(d, dict):
        raise TypeError("mark_radii_mm")
    return tuple((str(k), _number(v)) for k, v in d.items())


def _templates(d: Any) -> tuple[tuple[str, MarkTemplate], ...]:
    """``mark_templates`` as :meth:`RollProfile.to_dict` writes it: name -> template."""
    if not isinstance(d, dict):
        raise TypeError("mark_templates")
    return tuple((str(k), MarkTemplate.from_dict(v)) for k, v in d.items())


def _flag(v: Any) -> bool:
    if not isinstance(v, bool):
        raise TypeError(repr(v))
    return v


def read_profile(path: str | os.PathLike[str]) -> RollProfile:
    """A roll profile file (JSON, as ``aerofid learn`` writes it)."""
    p, text = read_text_input(path, "roll profile")
    return RollProfile.from_dict(load_json(text, str(p)), str(p))


def learn_profile(res: FrameOrientation, measured: Mapping[str, Sequence[float]] | None = None) -> RollProfile:
    """The profile of the roll ``res`` belongs to, learnt from its found marks; the frame must be ok (else the
    one line says why and what to do). ``measured``: the same frame's fiducials measured by hand (name -> x, y),
    which every mark found must agree with to :data:`MEASURED_AGREEMENT_PX`."""
    if not res.ok:
        raise AerofidInputError(f"cannot learn from a frame that is {res.status}: " + "; ".join(res.reasons)
                                + " (give --lie or --pixel-size, or learn from another frame of the roll)")
    if measured is not None:
        _check_measured(res, measured)
    found = [f.located for f in res.fiducials if f.status == FOUND_MARK and f.located is not None]
    methods = [m.detection.method for m in found if m.detection.method in METHODS]
    if not methods or res.rotation_deg is None or res.mirrored is None or res.orientation is None:
        raise AerofidInputError("cannot learn from this frame: its marks were not found by a seed method alone")
    size = _pixel_mm(res)
    cx, cy = (res.width - 1) / 2, (res.height - 1) / 2
    positions = []
    for f in res.fiducials:
        x, y = f.predicted_x, f.predicted_y
        if f.status == FOUND_MARK and f.x is not None and f.y is not None:
            x, y = f.x, f.y
        positions.append((f.name, x - cx, y - cy))
    polarity = Counter(m.polarity for m in found).most_common(1)[0][0]
    return RollProfile(camera=res.camera, pixel_size_mm=size, rotation_deg=res.rotation_deg,
                       mirrored=res.mirrored, polarity=polarity,
                       method=Counter(methods).most_common(1)[0][0],
                       mark_radius_mm=float(median(np.array([m.extent for m in found]))) * size, image=res.image,
                       positions_px=tuple(positions),
                       mark_radii_mm=tuple((f.name, f.located.extent * size) for f in res.fiducials
                                           if f.status == FOUND_MARK and f.located is not None),
                       mark_templates=_learnt_templates(res, polarity))


def _learnt_templates(res: FrameOrientation, polarity: Polarity) -> tuple[tuple[str, MarkTemplate], ...]:
    """The templates of the frame's marks found in the roll's ``polarity`` (the one they are sought in), cut from
    the windows they were measured on."""
    out = []
    for f in res.fiducials:
        m = f.located
        if f.status == FOUND_MARK and m is not None and m.polarity == polarity:
            t = cut_template(m.window, m.box, m.x, m.y, m.extent)
            if t is not None:
                out.append((f.name, t))
    return tuple(out)


def _check_measured(res: FrameOrientation, measured: Mapping[str, Sequence[float]]) -> None:
    """Every found mark of ``res`` that was measured by hand lies within :data:`MEASURED_AGREEMENT_PX` of the
    measurement, and at least :data:`MIN_MEASURED` were."""
    far = []
    common = 0
    for f in res.fiducials:
        if f.status != FOUND_MARK or f.x is None or f.y is None or f.name not in measured:
            continue
        common += 1
        d = math.hypot(f.x - float(measured[f.name][0]), f.y - float(measured[f.name][1]))
        if d > MEASURED_AGREEMENT_PX:
            far.append(f"{f.name} {d:.1f} px")
    if far:
        raise AerofidInputError(f"the marks found disagree with the measurements ({', '.join(far)} apart, more than "
                                f"{MEASURED_AGREEMENT_PX:g} px): check the measurements' names and the camera file")
    if common < MIN_MEASURED:
        raise AerofidInputError(f"only {common} of the marks found were measured (by name): the measurements must "
                                "name the camera file's fiducials")


def _pixel_mm(res: FrameOrientation) -> float:
    """The frame's adjusted mean pixel size (mm), else the one its search assumed."""
    return adjusted_pixel_mm(res.orientation) if res.orientation is not None else float(res.pixel_size_mm or math.nan)


def disagreements(profile: RollProfile, res: FrameOrientation) -> list[str]:
    """Why a frame oriented with ``profile`` should be reviewed: it disagrees with the roll (none: it agrees)."""
    out = []
    if res.rotation_deg is not None and (res.rotation_deg, res.mirrored) != (profile.rotation_deg, profile.mirrored):
        out.append(f"the film lies rotated {res.rotation_deg} deg{' mirrored' if res.mirrored else ''}, the roll "
                   f"profile's {profile.rotation_deg} deg{' mirrored' if profile.mirrored else ''}")
    size = _pixel_mm(res)
    if math.isfinite(size) and abs(size / profile.pixel_size_mm - 1) > PIXEL_AGREEMENT:
        out.append(f"the adjusted pixel size {size:.5f} mm differs from the roll profile's "
                   f"{profile.pixel_size_mm:.5f} mm")
    found = [f for f in res.fiducials if f.status == FOUND_MARK and f.located is not None]
    if found:
        radius = float(median(np.array([f.located.extent for f in found]))) * size  # type: ignore[union-attr]
        if abs(radius / profile.mark_radius_mm - 1) > SIZE_AGREEMENT:
            out.append(f"the marks' radius {radius:.3f} mm differs from the roll profile's "
                       f"{profile.mark_radius_mm:.3f} mm")
        flipped = [f.name for f in found if f.located.polarity != profile.polarity]  # type: ignore[union-attr]
        if 2 * len(flipped) > len(found):
            out.append(f"marks {', '.join(flipped)} were measured {opposite(profile.polarity)}, the roll's "
                       f"{profile.polarity}")
    return out


NAMING_MM = 3.0
"""How far (film mm) a mark may lie from a fiducial under another lie (:func:`lie_by_templates`) and be named by it: a
layout symmetric to the certificate's few hundredths of a mm names every mark under each of its lies; another lie
of an asymmetric layout names some of them by no fiducial, and is not weighed."""
LIE_MARGIN = 0.03
"""How much more alike (mean normalised cross-correlation over the same marks, :func:`lie_by_templates`) the marks
must be to the roll's templates under another lie than under the frame's for the frame to be flagged: the real RC20
frame turned or flipped, each corner with its 1-4 number dots, correlates 0.92-1.00 under its true lie and 0.81-0.93
under the roll's; marks alike in every lie (a ring, a '+') differ by less than a hundredth."""
MIN_TEMPLATES = 3
"""Fewest found marks with a template for :func:`lie_by_templates` to weigh the lies."""

Patches = Mapping[tuple[str, int], tuple[np.ndarray, tuple[float, float]]]
"""Each found mark's pixels by (fiducial name, reduction): the grey levels about it (the mark bright) reduced by that
factor, and its centre (x, y) in them."""


def lie_by_templates(profile: RollProfile, res: FrameOrientation, fiducials_mm: np.ndarray, names: Sequence[str],
                     y_axis: str, read_patches: Callable[[], Patches]) -> list[str]:
    """Why a frame oriented with ``profile`` should be reviewed for its lie: its found marks look more like the roll's
    templates (``profile.mark_templates``) named and turned as another lie of the film would name and turn them than
    as its own lie does (none: they do not, or cannot tell, or the fiducials told the lie: its correspondence is
    unique). A layout symmetric under the lies (the RC20's 4 corners) cannot tell the film's lie, so the roll's is
    taken (issue 12's promise: a frame that lies otherwise is flagged); a frame scanned turned or mirrored is then
    named wrongly, and only its marks' own looks (the RC20's number dots) can tell. Marks alike in every lie tell
    nothing, but the frames' small turns in the scanner do: the synthetic frames' rings with an X or a '+' correlated
    up to 0.02 better under another lie (a frame turned a few tenths of a degree the other way), below
    :data:`LIE_MARGIN`; where the fiducials tell the lie they are not weighed. ``read_patches``: each found mark's
    pixels (:data:`Patches`) at every reduction the templates use, read only where the lies are weighed. Each lie
    names each mark by the fiducial nearest its film position under that lie, turned about the layout's centre
    (within :data:`NAMING_MM`), and turns each template by the lie's arrangement relative to the roll's; it is
    weighed against the frame's own lie by the marks' mean correlation (:func:`~aerofid.frame.templates.agreement`)
    over the marks both can score."""
    own = dict(profile.mark_templates)
    io = res.orientation
    found = [f for f in res.fiducials if f.status == FOUND_MARK and f.located is not None]
    if io is None or res.rotation_deg is None or len(found) < MIN_TEMPLATES or not own:
        return []
    if io.correspondence is not None and io.correspondence.status == "unique":
        return []                                         # the fiducials told the lie
    patches = read_patches()
    frame_lie = (res.rotation_deg, bool(res.mirrored))
    g_frame = arrangement_matrix(*frame_lie, y_axis)
    g_roll = arrangement_matrix(profile.rotation_deg, profile.mirrored, y_axis)
    centre = fiducials_mm.mean(axis=0)                    # a layout's lies turn it about its centre
    at_mm = io.to_mm([(f.located.x, f.located.y) for f in found if f.located is not None]) - centre
    alike: dict[tuple[int, bool], list[float]] = {}       # per lie, each mark's correlation (nan: none)
    for lie in ARRANGEMENTS:
        g = arrangement_matrix(*lie, y_axis)
        film = centre + at_mm @ (g @ g_frame.T).T         # the marks' film mm had the film lain so
        gap = np.hypot(*(film[:, None, :] - fiducials_mm[None, :, :]).transpose(2, 0, 1))
        named = [names[j] if gap[i, j] <= NAMING_MM else None for i, j in enumerate(np.argmin(gap, axis=1))]
        if None not in named:
            alike[lie] = [agreement(*_patch(patches, f.name, own[n]), g.T @ g_roll)
                          if n in own and (f.name, own[n].factor) in patches else math.nan
                          for f, n in zip(found, named, strict=True)]
    if frame_lie not in alike:
        return []
    told = []                                             # (gain, lie, its score, the frame's), on the same marks
    for lie, values in alike.items():
        both = [(a, b) for a, b in zip(values, alike[frame_lie], strict=True) if math.isfinite(a) and math.isfinite(b)]
        if lie != frame_lie and len(both) >= MIN_TEMPLATES:
            score, own_score = (float(np.mean(v)) for v in zip(*both, strict=True))
            told.append((score - own_score, lie, score, own_score))
    if not told or max(told)[0] < LIE_MARGIN:
        return []
    _, best, score, own_score = max(told)
    return [f"the marks look like the roll's with the film lying rotated {best[0]} deg{' mirrored' if best[1] else ''} "
            f"(template correlation {score:.2f} against {own_score:.2f}): check its lie, or give it (--lie)"]


def _patch(patches: Patches, name: str, template: MarkTemplate) -> tuple[np.ndarray, MarkTemplate, tuple[float, float]]:
    """:func:`~aerofid.frame.templates.agreement`'s first three arguments: the found mark ``name``'s pixels at the
    template's reduction, the template, the mark's centre in them."""
    patch, centre = patches[(name, template.factor)]
    return patch, template, centre


__all__ = ["LIE_MARGIN", "PROFILE_FORMAT", "Patches", "RollProfile", "disagreements", "learn_profile",
           "lie_by_templates", "read_profile"]
