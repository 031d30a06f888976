"""``aerofid.orient_frame``: a scan and its camera's calibration in, the interior orientation out, no boxes.

The automatic interior orientation of seeds 002 (section 2: "fiducial areas" predicted from the calibration),
003 and 004 (section 3: search areas, detection, then the affine adjustment with its statistics), for any camera
and any mark style:

1. **Features** (:func:`frame_features`): the whole frame, read reduced to at most :data:`FRAME_PIXELS`
   (never the full-resolution image of a tiled TIFF; a JPEG's from libjpeg's reduced decode while the whole decode
   runs in the background), is screened for mark-like structure
   (:mod:`aerofid.detect.screen`); the :data:`FEATURES` strongest are kept.
2. **Layout** (:mod:`aerofid.frame.layout`): the camera's fiducial layout is found among them at the scan's
   pixel size (given, from the file's resolution tags, from the camera file, or estimated by the layout itself);
   it predicts every fiducial's position, including those screening missed.
3. **Marks** (:mod:`aerofid.frame.marks`): each fiducial is measured at full resolution on a window around its
   feature or prediction (:class:`aerofid.find.Measurer`); where that fails, its predicted area is searched like a
   region (:func:`aerofid.find.search`) and the mark nearest the prediction is taken.
4. **Adjustment** (:func:`aerofid.orient`): the film's lie decided by the 8 arrangements' F test, blunders
   rejected by data snooping; then the verdict per fiducial and per frame (:func:`verdict`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from aerofid.conventions import MM_PER_INCH
from aerofid.detect.screen import Candidate, screen
from aerofid.errors import AerofidInputError
from aerofid.find import (
    ImageSource,
    Located,
    Measurer,
    colour_again,
    configure,
    reduction_for,
    with_white,
)
from aerofid.formats.camera_file import read_camera
from aerofid.frame.layout import (
    MAX_ROTATION_DEG,
    MIN_MATCHED,
    USUAL_TURNS,
    LayoutMatch,
    can_end_early,
    layout_candidates,
)
from aerofid.frame.marks import measure_extra_marks, measure_marks, second_look
from aerofid.frame.nominal import (
    DEFAULT_FORMAT,
    UNCALIBRATED,
    extra_marks,
    format_name,
    nominal_camera,
    nominal_sizes,
)
from aerofid.frame.profile import Patches, RollProfile, disagreements, lie_by_templates, read_profile
from aerofid.frame.result import (
    DOUBTFUL,
    FAILED,
    FOUND_MARK,
    MISSING_MARK,
    OK,
    ROLL_AREAS,
    WHOLE_FRAME,
    FrameOrientation,
    standing,
)
from aerofid.frame.roll_areas import roll_layout
from aerofid.frame.verdict import LIE_UNTOLD, verdict
from aerofid.io.array import open_image
from aerofid.io.reduce import read_reduced_levels
from aerofid.io.resolution import checked_pixel_size, pixel_size_from_tags
from aerofid.orientation.camera import Camera
from aerofid.orientation.correspondence import ARRANGEMENTS, FILM_TURN_DEG

FRAME_PIXELS = 1_000_000
"""Most pixels of the reduced whole frame that is screened (a power-of-two reduction: a 5908 x 5408 scan at 8,
an 11000^2 one at 16). Fiducial marks 2-5 mm across are 6-30 reduced px at 21-42 um."""
FEATURES = 512
"""Mark-like features kept for the layout search: the fiducials rank anywhere among the frame's strongest (the
real RC20 frame: 1st to 90th, behind the scanner's edge, the data strip and the image's texture; synthetic
frames with dense aerial texture: 90th to 330th)."""
POSITION_ERROR = 3.0
"""How far (in reduced pixels) a screened feature's centre may lie from the mark's."""
ESTIMATED_HINT = ("the scan declares no pixel size (no resolution tags, or a screen's default 72 or 96 dpi), so the "
                  "layout was sought at every size it allows: give it (--pixel-size, or pixel_size_um in the camera "
                  "file)")
"""Appended to the reasons of a frame that is not ok when nothing declared the pixel size."""
DECLARED_HINT = ("the layout was sought at the pixel size {size:.5f} mm ({source}), to within 3 %: if that is not the "
                 "scan's, give it (--pixel-size)")
"""Appended to the reasons of a frame that failed at a pixel size given or declared."""
REVIEW = "review: "
"""How the reasons start that say where a frame disagrees with its roll's profile."""
ASKEW_MARKS = 0.5
"""A frame with fewer than this share of its fiducials found within the layout search's usual turn
(:data:`aerofid.frame.layout.MAX_ROTATION_DEG`) is searched again with the film turned up to
:data:`aerofid.orientation.correspondence.FILM_TURN_DEG` (:meth:`_Frame.on_whole_frame`): a film laid askew on a
flatbed. The wider search costs more and finds more chance layouts, so only such frames pay for it."""
ALTERNATIVES = 8
"""Layouts measured, best first, when the pixel size is not known (:func:`aerofid.frame.layout.layout_candidates`):
the first whose frame is ok is taken. A noisy or faded frame with 4-6 of its 8 marks among the features can rank
chance layouts of as many or more matches at other pixel sizes first: in sweeps of 70 synthetic frames (session 46,
turned up to 10 degrees, half without a pixel size) the true layout was fourth twice and sixth once, and those frames
failed with 3 (tests/test_frame.py; a frame that is ok stops at its layout, so only the others pay for the rest); 6
until session 48, when a chance layout came to cost 4 places and no area
(:data:`~aerofid.frame.marks.VAIN_STARTS`): seed 1021 of ``benchmarks/bench_sweep.py`` (noisy), whose true layout
ranks seventh, failed with 6."""
HOUGH_REJECTIONS = 2
"""``hough``'s ``max_rejections`` (8 for a box) wherever a frame measures a mark (with ``auto``, which runs it on a
window where neither ``circles`` nor ``symmetry`` found a mark): a true '+' is the first candidate it verifies, and
in a frame most such windows hold no mark (a chance layout's places, a noisy frame's misses), where each refusal
costs a least-squares fit. Measured with ``hough``'s searches logged (scratch, session 49: seed 1021 of
``benchmarks/bench_sweep.py``, 3 demo frames, 4 frames of 4-fiducial cameras with thin '+' marks): 86 found a mark,
each with no refusal before it, 96 of the others stopped at 8 refusals. Seeds 1000-1059 and 5000-5059, 36 frames of
4-fiducial cameras, the RC20 frame in its 9 readings and 3 demo frames, oriented with 8 and with 2: every status, lie
and position the same; only the reasons of marks not found say 2 refusals for 8 (docs/benchmarks_frames.md, session
49). With 8, seed 1021 (noisy, ok) spent 12.2 of its 17.1 s (under the profiler) in 132 such searches and 922
refusals; seeds 5000-5059 took 635 -> 478 s, the failing 5009 76 -> 30 s."""


def orient_frame(image: str | os.PathLike[str] | np.ndarray | Any,
                 camera: Camera | str | os.PathLike[str] | Mapping[str, Any] | None = None, *,
                 pixel_size_mm: float | None = None, mark: str = "auto", method: str = "auto",
                 polarity: str = "auto", colour: str = "auto", model: str = "affine",
                 lie: tuple[int, bool] | None = None,
                 profile: RollProfile | str | os.PathLike[str] | None = None) -> FrameOrientation:
    """The fiducials of a whole scanned frame and its interior orientation, from the camera file alone.

    Parameters
    ----------
    image : path, ndarray or open raster
        The scan (any size: it is read reduced for the search and by windows for the marks).
    camera : Camera, path, mapping or format, optional
        The calibration certificate (:func:`aerofid.read_camera` reads JSON, YAML or MicMac XML; a mapping as
        :meth:`~aerofid.orientation.camera.Camera.from_dict` reads it); or the film format alone (``"23cm"``, the
        default: :data:`~aerofid.frame.nominal.DEFAULT_FORMAT`): the marks are then found on its nominal layout
        (:mod:`aerofid.frame.nominal`), the frame is doubtful and flagged uncalibrated, the pixel size, fiducial
        centre (the orientation's ``mm_to_pixel`` of (0, 0)) and rotation are estimates.
    pixel_size_mm : float, optional
        The scan's pixel size; default: the file's resolution tags, else the camera file's ``pixel_size_um``,
        else estimated from the marks' layout. On a format's nominal layout the layout is sought within
        :data:`~aerofid.frame.nominal.SCALE_SPREAD` of a pixel size given or tagged, and that is the one reported.
    mark, method, polarity, colour : str
        As :func:`aerofid.locate` (polarity ``"auto"``: marks bright or dark).
    model : str
        The adjustment's model: ``"affine"`` (seed 004), ``"similarity"`` or ``"projective"``.
    lie : (rotation_deg, mirrored), optional
        The film's lie in the scanner when the fiducials cannot tell it (a symmetric layout); default: the
        profile's, else as the camera file draws the frame (0, False), and the frame is then doubtful.
    profile : RollProfile or path, optional
        What the roll's marks look like (:mod:`aerofid.frame.profile`, ``aerofid learn``; a path is read by
        :func:`~aerofid.frame.profile.read_profile`): its pixel size (unless given), lie, polarity, method and mark
        size are used, and a frame that disagrees with it is doubtful.

    Returns
    -------
    FrameOrientation
        ``status`` ok / doubtful / failed with its reasons, a finding per fiducial, the orientation. A frame that
        fails on the features screened at its reduction (``reduction``) is screened again at half of it: a noisy
        frame's thin marks can vanish in the reduction.

    Examples
    --------
    Eight '+' fiducials of a synthetic 900 px frame at 0.05 mm, the camera file made from their true centres:

    >>> from aerofid import synth
    >>> frame = synth.demo_frame(np.random.default_rng(0), size=900, mark_size=40)
    >>> truth = {m.name: m for m in frame.marks if m.style == "cross"}
    >>> cam = Camera.from_dict({"name": "demo", "fiducials": {
    ...     n: [(m.x - 449.5) * 0.05, (449.5 - m.y) * 0.05] for n, m in truth.items()}})
    >>> res = orient_frame(frame.image, cam, pixel_size_mm=0.05, mark="external")
    >>> res.status, len(res.found), res.rotation_deg, res.mirrored
    ('ok', 8, 0, False)
    >>> bool(max(math.hypot(f.x - truth[f.name].x, f.y - truth[f.name].y) for f in res.fiducials) < 0.1)
    True
    """
    camera = DEFAULT_FORMAT if camera is None else camera
    fmt = format_name(camera) if isinstance(camera, str) else None
    nominal = None if fmt is None else nominal_camera(fmt)
    cam = nominal or _camera(camera)
    profile = read_profile(profile) if isinstance(profile, str | os.PathLike) else profile
    pixel_size_mm = None if pixel_size_mm is None else checked_pixel_size(pixel_size_mm)
    lie = _checked_options(cam, lie, profile)
    detector, polarities = configure(method, mark, polarity, colour,
                                     {"max_rejections": HOUGH_REJECTIONS} if method in ("auto", "hough") else {})
    with open_image(image) as source:
        declared = scan_pixel_size(source, cam, pixel_size_mm, profile)
        # a nominal layout's scale is not the scan's: the layout search finds it, near a pixel size the scan declares
        size, size_source = (None, "estimated") if nominal is not None else declared
        size_range = nominal_sizes(declared[0]) if nominal is not None and declared[0] is not None else None
        measurer = with_white(Measurer(source, detector, polarities, colour), (0, 0, source.width, source.height))
        frame = _Frame(source, cam, measurer, model, size, size_source, lie, profile, nominal is not None, size_range)
        extras = {} if nominal is not None else extra_marks(cam)
        best = frame.search(extras, declared)
        if not best.fiducials:                  # no layout among the features: its reasons say all (_no_layout)
            return best
        best = _finished_in_its_colour(frame, best, extras, declared)
    if nominal is not None:
        return _uncalibrated(best, str(fmt), *declared)
    return _hinted(best, size, size_source)


def _finished_in_its_colour(frame: _Frame, best: FrameOrientation, extras: dict[str, tuple[float, float]],
                            declared: tuple[float | None, str]) -> FrameOrientation:
    """``frame``'s answer ``best`` finished (:meth:`_Frame.finished`), or where that failed on a file whose marks were
    measured in luminance first, the frame searched again by the mix that shows each mark best
    (:func:`aerofid.find.colour_again`) and finished, where that stands better (:func:`standing`)."""
    again = colour_again(frame.measurer)
    if best.status == FAILED and again is not None:
        other_frame = replace(frame, measurer=again)
        other = other_frame.search(extras, declared)
        if standing(other) > standing(best):
            return other_frame.finished(other, extras)
    return frame.finished(best, extras)


def _hinted(res: FrameOrientation, size: float | None, size_source: str) -> FrameOrientation:
    """``res`` with what to do where its pixel size was searched (:data:`ESTIMATED_HINT`: the frame is not ok) or
    declared as ``size`` from ``size_source`` (:data:`DECLARED_HINT`: the frame failed)."""
    if res.status != OK and size_source == "estimated":
        return replace(res, reasons=(*res.reasons, ESTIMATED_HINT))
    if res.status == FAILED and size is not None:
        return replace(res, reasons=(*res.reasons, DECLARED_HINT.format(size=size, source=size_source)))
    return res


def _without_the_tags(frame: _Frame, extras: dict[str, tuple[float, float]], failed: FrameOrientation
                      ) -> FrameOrientation:
    """``failed`` (the frame sought at the pixel size its resolution tags declare), or, where it found too few marks to
    orient (:data:`~aerofid.frame.layout.MIN_MATCHED`) and the frame sought with the pixel size unknown (estimated
    from the marks) is oriented and stands better, that one, doubtful: a scan's tags can be wrong (software that
    rewrote the file, a scanner's default), and the layout is sought within 3 % of a declared size. A frame that
    fails with three or more marks found at the tags' size was sought at its size, and one whose features hold no
    layout whole (:attr:`~aerofid.frame.layout.LayoutMatch.decisive`) at any size is no frame whose tags are wrong:
    neither is sought again (a tagged frame without marks, a leader or a blank, pays for the layout search only)."""
    if frame.size is None or len(failed.found) >= MIN_MATCHED:
        return failed
    features, f = frame.features()
    cam = frame.cam
    layouts = _layouts(frame.source, features, f, cam.xy_mm, cam.y_axis, None, first_complete=True)
    if not (layouts and layouts[0].decisive):
        return failed                                   # no layout the features hold whole at another size
    again = frame.better_at(None, "estimated", extras, failed)
    if again is None:
        return failed
    why = (f"the scan's resolution tags declare {MM_PER_INCH / frame.size:.1f} dpi ({frame.size:.5f} mm), its marks "
           f"{again.pixel_size_mm:.5f} mm: the tags are wrong; give the pixel size (--pixel-size)")
    return replace(again, status=DOUBTFUL if again.ok else again.status, reasons=(*again.reasons, why))


def _at_the_tags_size(frame: _Frame, extras: dict[str, tuple[float, float]], failed: FrameOrientation
                      ) -> FrameOrientation:
    """``failed`` (the frame sought at its roll profile's pixel size), or, where it found too few marks to orient and
    the scan's resolution tags declare another size, the frame sought at that one where it is oriented and stands
    better (doubtful for review: its pixel size is not the roll's): a frame of the roll scanned at another resolution
    failed, told to give ``--pixel-size``, which a batch gives every frame (a helper's audit)."""
    tagged = _tagged_size(frame.source)
    if tagged is None or frame.size is None or len(failed.found) >= MIN_MATCHED or math.isclose(tagged, frame.size,
                                                                                                 rel_tol=0.03):
        return failed
    return frame.better_at(tagged, "tags", extras, failed) or failed


@dataclass(frozen=True)
class _Frame:
    """One scan, its camera and the options: the frame oriented on a set of features (:meth:`oriented`)."""

    source: ImageSource
    cam: Camera
    measurer: Measurer
    model: str
    size: float | None
    size_source: str
    lie: tuple[int, bool] | None
    profile: RollProfile | None
    nominal: bool
    size_range: tuple[float, float] | None = None
    """The pixel sizes the layout is sought at when ``size`` is None (default: those the scan's size allows)."""
    screens: dict[int | None, tuple[tuple[Candidate, ...], int]] = field(default_factory=dict, compare=False,
                                                                        repr=False)
    """The whole frame's screens by reduction (:meth:`features`), shared with the frame sought again at another pixel
    size (``dataclasses.replace`` passes the same dict): they do not depend on the size."""

    def features(self, f: int | None = None) -> tuple[tuple[Candidate, ...], int]:
        """:func:`frame_features` of the scan at reduction ``f`` (default: its own), screened once per frame."""
        got = self.screens.get(f)
        if got is None:
            got = frame_features(self.source, f)
            self.screens[f] = self.screens[got[1]] = got
        return got

    def oriented(self, features: tuple[Candidate, ...], f: int, searched: str,
                 extras: dict[str, tuple[float, float]], turns: tuple[float, float] = USUAL_TURNS
                 ) -> FrameOrientation | None:
        """Steps 2-4 on ``features`` screened at reduction ``f`` (``searched``: where), the film turned beyond its
        lie by more than the first of ``turns`` and at most the second, with the format's other marks ``extras`` to
        fall back on (:meth:`_Search.with_format_marks`); None when they hold no layout."""
        cam = self.cam
        fid_mm = cam.xy_mm
        head = self.head(len(features), f, searched)
        search = _Search(self.source, features, f, cam.y_axis, self.size, self.measurer, self.profile, self.nominal,
                         self.size_range, turns)

        def judged(layout: LayoutMatch, located: list[tuple[Located | None, str]]) -> FrameOrientation:
            return _judged(cam, layout, located, self.model, head, self.size, self.size_source, self.lie,
                           self.profile)

        return search.with_format_marks(fid_mm, extras, judged, search.best(fid_mm, judged))

    def on_whole_frame(self, extras: dict[str, tuple[float, float]], best: FrameOrientation | None
                       ) -> tuple[FrameOrientation | None, dict[str, Any]]:
        """The better of ``best`` (the roll areas' answer, or None) and steps 1-4 on the whole frame (:meth:`oriented`
        on :func:`frame_features`), None when neither holds an answer; and the head of the last screen. Where the
        better one fails, the frame is screened again at half the reduction (a noisy frame's thin marks can vanish
        in it); where fewer than :data:`ASKEW_MARKS` of its fiducials are found, its layout is sought again with the
        film turned further (beyond :data:`~aerofid.frame.layout.MAX_ROTATION_DEG`, up to
        :data:`~aerofid.orientation.correspondence.FILM_TURN_DEG`: the layouts measured so far are not met again),
        among the features of each screen, the last first (a noisy frame's marks can be among the first screen's
        features and not the second's, where its noise is stronger)."""
        screens = [self.features()]
        best = _better(best, self.oriented(*screens[0], WHOLE_FRAME, extras))
        if (best is None or best.status == FAILED) and screens[0][1] > 1:
            screens.append(self.features(screens[0][1] // 2))
            best = _better(best, self.oriented(*screens[1], WHOLE_FRAME, extras))
        for features, f in reversed(screens):
            if best is not None and len(best.found) >= ASKEW_MARKS * len(self.cam.fiducials):
                break
            best = _better(best, self.oriented(features, f, WHOLE_FRAME, extras, (MAX_ROTATION_DEG, FILM_TURN_DEG)))
        _check_decoded(self.source)
        features, f = screens[-1]
        return best, self.head(len(features), f, WHOLE_FRAME)

    def search(self, extras: dict[str, tuple[float, float]], declared: tuple[float | None, str]) -> FrameOrientation:
        """:meth:`answer`, and where that fails at a pixel size the scan's tags or the roll's profile declare, the
        frame sought at another (:func:`_without_the_tags`, :func:`_at_the_tags_size`)."""
        best = self.answer(extras, declared)
        if best.status == FAILED and self.size_source == "tags":
            return _without_the_tags(self, extras, best)
        if best.status == FAILED and self.size_source == "profile":
            return _at_the_tags_size(self, extras, best)
        return best

    def better_at(self, size: float | None, size_source: str, extras: dict[str, tuple[float, float]],
                  failed: FrameOrientation) -> FrameOrientation | None:
        """The frame sought again at pixel size ``size`` (None: unknown) from ``size_source``, where it is oriented and
        stands better than ``failed`` (:func:`standing`); else None."""
        again = replace(self, size=size, size_source=size_source).answer(extras, (size, size_source))
        return again if again.orientation is not None and standing(again) > standing(failed) else None

    def finished(self, best: FrameOrientation, extras: dict[str, tuple[float, float]]) -> FrameOrientation:
        """``best`` with the format's other marks ``extras`` measured where it is oriented, and, with a roll profile's
        templates, flagged for review where its marks look like the roll's under another lie
        (:func:`~aerofid.frame.profile.lie_by_templates`)."""
        if extras and best.orientation is not None:
            best = replace(best, extra_marks=measure_extra_marks(self.measurer, best, extras))
        profile, cam = self.profile, self.cam
        if profile is not None and profile.mark_templates:
            best = _reviewed(best, lie_by_templates(profile, best, cam.xy_mm, cam.names, cam.y_axis,
                                                    lambda: _patches(self.measurer, best, profile)))
        return best

    def answer(self, extras: dict[str, tuple[float, float]], declared: tuple[float | None, str]) -> FrameOrientation:
        """The frame measured in the roll's areas, else (or where that is not settled) searched whole
        (:meth:`on_whole_frame`); failed where no layout is found (``declared``: the pixel size the scan declares,
        and where from)."""
        best = self.in_roll_areas()
        if best is None or not _settled(best):
            best, screened = self.on_whole_frame(extras, best)
            if best is None:
                return _no_layout(screened, len(self.cam.fiducials), *declared)
        return best

    def in_roll_areas(self) -> FrameOrientation | None:
        """The frame measured on the roll profile's layout (:mod:`aerofid.frame.roll_areas`), nothing screened;
        None without a profile's positions or a pixel size."""
        if self.profile is None or self.size is None:
            return None
        layout = roll_layout(self.profile, self.cam, (self.source.width, self.source.height), self.size)
        if layout is None:
            return None
        radii = self.profile.radii_px(self.cam.names, self.size)
        located = measure_marks(self.measurer, layout, self.cam.xy_mm, (), self.profile, follow=True, radii=radii,
                                templates=self.profile.templates_for(self.cam.names))
        return _judged(self.cam, layout, located, self.model, self.head(0, 1, ROLL_AREAS), self.size,
                       self.size_source, self.lie, self.profile)

    def head(self, features: int, reduction: int, searched: str) -> dict[str, Any]:
        """The :class:`FrameOrientation` fields that say what was oriented and how it was searched."""
        source = self.source
        return dict(image="" if source.path is None else os.path.basename(str(source.path)), camera=self.cam.name,
                    width=source.width, height=source.height, features=features, reduction=reduction,
                    searched=searched)


@dataclass(frozen=True)
class _Search:
    """Steps 2-4 on one frame's features (:meth:`best`)."""

    source: ImageSource
    features: tuple[Candidate, ...]
    f: int
    y_axis: str
    size: float | None
    measurer: Measurer
    profile: RollProfile | None
    nominal: bool
    size_range: tuple[float, float] | None = None
    turns: tuple[float, float] = USUAL_TURNS

    def best(self, fid_mm: np.ndarray, judged: Callable[[LayoutMatch, list[tuple[Located | None, str]]],
                                                         FrameOrientation]) -> FrameOrientation | None:
        """The best frame (:func:`standing`; of equals the first, but for a layout that its search ended on with all
        fiducials but one on features, :func:`_ended_nearly`, which gives way to the whole search's) of the layouts of
        ``fid_mm`` measured in turn (:func:`_attempts`) until one is ok, or finds every fiducial with the film's lie its
        one doubt (:func:`_complete_but_the_lie`), or (a nominal layout's) half its marks, each judged by ``judged``;
        None when the features do not hold the layout."""
        layouts = _layouts(self.source, self.features, self.f, fid_mm, self.y_axis, self.size, first_complete=True,
                           size_range=self.size_range, turns=self.turns)
        if not layouts:
            return None
        best: FrameOrientation | None = None
        best_layout = layouts[0]
        for layout in _attempts(self.source, self.features, self.f, fid_mm, self.y_axis, self.size, layouts,
                                self.size_range, self.turns):
            located = measure_marks(self.measurer, layout, fid_mm, self.features, self.profile)
            res = second_look(self.measurer, layout, fid_mm, located, judged(layout, located), judged)
            if best is None or standing(res) > standing(best) or (standing(res) == standing(best)
                                                                     and _ended_nearly(best_layout)):
                best, best_layout = res, layout
            if (res.ok or _complete_but_the_lie(res)
                    or (self.nominal and res.orientation is not None and 2 * len(res.found) >= len(fid_mm))):
                break
        return best

    def with_format_marks(self, fid_mm: np.ndarray, extras: dict[str, tuple[float, float]],
                          judged: Callable[[LayoutMatch, list[tuple[Located | None, str]]], FrameOrientation],
                          best: FrameOrientation | None) -> FrameOrientation | None:
        """``best`` (the frame of the camera file's layout ``fid_mm``) or, when it leaves fiducials unfound, the
        better of it and the frame whose layout has the format's other marks ``extras`` (name -> nominal film mm)
        added, judged on the file's fiducials alone: those marks make the layout distinctive (4 corners alone form a
        square that chance features form too, and a corner whose feature lies off its centre loses to them)."""
        if not extras or (best is not None and len(best.found) >= len(fid_mm)):
            return best
        n = len(fid_mm)
        again = self.best(np.vstack([fid_mm, list(extras.values())]),
                          lambda layout, located: judged(_first(layout, n), located[:n]))
        return _better(best, again)


def _complete_but_the_lie(res: FrameOrientation) -> bool:
    """Whether every fiducial of a frame is found and used, and its one doubt is the film's lie (its marks fit several
    lies equally: a symmetric layout, :data:`~aerofid.frame.verdict.LIE_UNTOLD`): another layout measures these marks
    or others, and cannot tell the lie either. The real RC20 frame (4 corners in its camera file) without its pixel
    size measured all 6 layouts it tried, in 11 s (session 47); it now stops at the fourth, the first to find every
    corner, and turned a quarter at the first."""
    return (bool(res.fiducials) and all(f.status == FOUND_MARK for f in res.fiducials)
            and len(res.reasons) == 1 and res.reasons[0].startswith(LIE_UNTOLD))


def _first(layout: LayoutMatch, n: int) -> LayoutMatch:
    """``layout`` of its first ``n`` fiducials (the camera file's, before the format's other marks)."""
    return replace(layout, predicted=layout.predicted[:n], matched=layout.matched[:n])


def _layouts(source: ImageSource, features: tuple[Candidate, ...], f: int, fid_mm: np.ndarray, y_axis: str,
             size: float | None, first_complete: bool = False, nearly: bool = True,
             size_range: tuple[float, float] | None = None,
             turns: tuple[float, float] = USUAL_TURNS) -> list[LayoutMatch]:
    """Step 2: the camera's layouts among the ``features`` screened at reduction ``f``, best first (with
    ``first_complete``, ``nearly``, the pixel sizes ``size_range`` to try when ``size`` is None and the film's
    ``turns``: :func:`aerofid.frame.layout.layout_candidates`)."""
    return layout_candidates(np.array([[c.x, c.y] for c in features]).reshape(-1, 2), fid_mm, y_axis, size,
                             position_error_px=POSITION_ERROR * f, scan_size=(source.width, source.height),
                             first_complete=first_complete, nearly=nearly, size_range=size_range, turns=turns)


def _attempts(source: ImageSource, features: tuple[Candidate, ...], f: int, fid_mm: np.ndarray, y_axis: str,
              size: float | None, layouts: list[LayoutMatch], size_range: tuple[float, float] | None = None,
              turns: tuple[float, float] = USUAL_TURNS) -> Iterator[LayoutMatch]:
    """The layouts measured in turn until one's frame is ok (:meth:`_Search.best`): the best one when the pixel size is
    known, and where its search ended at all fiducials but one on close features (:func:`_ended_nearly`: a chance layout
    can end it before the complete one is formed), the whole search's best where it lies on other features; else the
    first :data:`ALTERNATIVES` of ``layouts``, and when that search may have ended early
    (:func:`aerofid.frame.layout.can_end_early`) at a decisive layout, the others of the whole search. The whole search
    is made only if it is asked for."""
    first = layouts[0]
    if size is not None:
        yield first
        if _ended_nearly(first):
            taken = set(first.matched) - {None}
            yield from [m for m in _layouts(source, features, f, fid_mm, y_axis, size, nearly=False, turns=turns)
                        if set(m.matched) - {None} != taken][:1]
        return
    yield from layouts[:ALTERNATIVES]
    if len(layouts) == 1 and first.decisive and can_end_early(fid_mm, size):
        same = (first.matched, first.rotation_deg, first.mirrored)
        others = [m for m in _layouts(source, features, f, fid_mm, y_axis, None, nearly=False, size_range=size_range,
                                      turns=turns)
                  if (m.matched, m.rotation_deg, m.mirrored) != same]
        yield from others[:ALTERNATIVES - 1]


def _ended_nearly(layout: LayoutMatch) -> bool:
    """Whether ``layout``'s search ended on it with all its fiducials but one on features
    (:data:`aerofid.frame.layout.NEARLY_COMPLETE`): decisive, not complete."""
    return layout.decisive and not layout.complete


def _judged(cam: Camera, layout: LayoutMatch, located: list[tuple[Located | None, str]], model: str,
            head: dict[str, Any], size: float | None, size_source: str, lie: tuple[int, bool] | None,
            profile: RollProfile | None) -> FrameOrientation:
    """Step 4 for one layout's marks: the verdict (at the layout's pixel size when none was declared), and with
    a roll ``profile`` the frame doubtful for review where it disagrees with it."""
    res = verdict(cam, layout, located, model, head, layout.pixel_size_mm if size is None else size, size_source,
                  lie)
    if profile is not None and res.orientation is not None:
        res = _reviewed(res, disagreements(profile, res))
    return res


def _camera(camera: Any) -> Camera:
    """``orient_frame``'s ``camera`` (not a format's name) as a :class:`Camera`: itself, read from its file, or made
    from its mapping (:meth:`Camera.from_dict`)."""
    if isinstance(camera, Camera):
        return camera
    if isinstance(camera, str | os.PathLike):
        return read_camera(os.fspath(camera))
    if isinstance(camera, Mapping):
        return Camera.from_dict(camera)
    raise AerofidInputError(f"camera {type(camera).__name__}: give a Camera, the path of a camera file, its mapping "
                            "(name, fiducials) or a film format such as '23cm'")


def _checked_options(cam: Camera, lie: tuple[int, bool] | None, profile: RollProfile | None
                     ) -> tuple[int, bool] | None:
    """The options checked (one line each): the lie to assume, the given one or the profile's."""
    lie = lie.tolist() if isinstance(lie, np.ndarray) else lie
    if lie is not None and not (isinstance(lie, Sequence) and len(lie) == 2 and tuple(lie) in ARRANGEMENTS):
        raise AerofidInputError(f"lie {lie!r}: give (rotation, mirrored) with rotation 0, 90, 180 or 270 degrees")
    if profile is not None and not isinstance(profile, RollProfile):
        raise AerofidInputError(f"profile {type(profile).__name__}: give a RollProfile or the path of a roll's profile "
                                "(aerofid learn)")
    lie = None if lie is None else (int(lie[0]), bool(lie[1]))
    if profile is None:
        return lie
    profile.check_camera(cam.name)
    return lie if lie is not None else (profile.rotation_deg, profile.mirrored)


def _patches(measurer: Measurer, res: FrameOrientation, profile: RollProfile) -> Patches:
    """Each found mark's pixels about it (:data:`aerofid.frame.profile.Patches`) at each reduction of the profile's
    templates, wide enough for its largest template turned and :func:`~aerofid.frame.templates.agreement`'s reach:
    the window it was measured on where that holds them in the roll's polarity (its grey levels are those of the mark
    the template was cut from on the learnt frame: a colour scan's channel mix is chosen per window), else one read
    about it in that polarity (the templates' own)."""
    sides: dict[int, int] = {}
    for _, t in profile.mark_templates:
        sides[t.factor] = max(sides.get(t.factor, 0), *t.shape)
    out = {}
    for fid in res.fiducials:
        if fid.status != FOUND_MARK or fid.located is None:
            continue
        m = fid.located
        for f, side in sides.items():
            half = f * (side / 2 + PATCH_MARGIN)
            held = (min(m.x - m.box[0], m.y - m.box[1], m.box[2] - 1 - m.x, m.box[3] - 1 - m.y) >= half
                    and m.polarity == profile.polarity)
            box, grey = (m.box, m.window) if held else measurer.grey(m.x, m.y, half, profile.polarity)
            h, w = grey.shape[0] // f, grey.shape[1] // f
            reduced = grey[:h * f, :w * f].reshape(h, f, w, f).mean(axis=(1, 3))
            out[(fid.name, f)] = (reduced, ((m.x - box[0] - (f - 1) / 2) / f, (m.y - box[1] - (f - 1) / 2) / f))
    return out


PATCH_MARGIN = 8
"""Reduced pixels read beyond half a template's side about a mark (:func:`_patches`): the template's centre may lie
a pixel or two off its middle, and :func:`~aerofid.frame.templates.agreement` reaches 4 px about the mark."""


def _uncalibrated(res: FrameOrientation, fmt: str, size: float | None, size_source: str) -> FrameOrientation:
    """A frame oriented on a format's nominal layout: doubtful (or failed) and flagged uncalibrated; the reasons
    that only a calibration gives a meaning to (the lie, the residuals, the pixel size) dropped; the pixel size the
    scan declares (``size``, from ``size_source``), if it does, in place of the nominal layout's estimate."""
    kept = tuple(r for r in res.reasons if "found" in r or "marks used" in r)
    res = replace(res, status=FAILED if res.status == FAILED else DOUBTFUL,
                  reasons=(UNCALIBRATED.format(fmt=fmt), *kept))
    return res if size is None else replace(res, pixel_size_mm=size, pixel_size_source=size_source)


def _reviewed(res: FrameOrientation, doubts: list[str]) -> FrameOrientation:
    """``res`` doubtful for review when it disagrees with the roll's profile (``doubts``)."""
    if not doubts:
        return res
    return replace(res, status=DOUBTFUL, reasons=(*res.reasons, *(f"{REVIEW}{d}" for d in doubts)))


def _settled(res: FrameOrientation) -> bool:
    """Whether a frame measured in the roll's areas needs no whole-frame search: every fiducial found, and ok but
    for the roll's review (another lie or pixel size, which a second search would not change)."""
    return (all(f.status != MISSING_MARK for f in res.fiducials)
            and (res.ok or (res.orientation is not None and all(r.startswith(REVIEW) for r in res.reasons))))


def _better(first: FrameOrientation | None, second: FrameOrientation | None) -> FrameOrientation | None:
    """The better (:func:`standing`) of two answers (None: no answer), the first of a tie."""
    if first is None or (second is not None and standing(second) > standing(first)):
        return second
    return first


def _no_layout(head: dict[str, Any], n: int, size: float | None, size_source: str) -> FrameOrientation:
    """The failed frame whose features do not hold the camera's layout."""
    reasons = (f"the camera's {n} fiducials were not found among the frame's {head['features']} mark-like "
               "features: check the camera file and the pixel size, or measure the marks with 'aerofid locate'",)
    return FrameOrientation(**head, status=FAILED, reasons=reasons + ((ESTIMATED_HINT,) if size is None else ()),
                            fiducials=(), orientation=None, rotation_deg=None, mirrored=None, pixel_size_mm=size,
                            pixel_size_source=size_source)


def scan_pixel_size(source: ImageSource, cam: Camera, given: float | None,
                    profile: RollProfile | None = None) -> tuple[float | None, str]:
    """The pixel size the search assumes (mm) and where it came from, None when nothing says: the given one, the
    roll profile's, the file's tags, the camera file's."""
    if given is not None:
        return float(given), "given"
    if profile is not None:
        return profile.pixel_size_mm, "profile"
    tagged = _tagged_size(source)
    if tagged is not None:
        return tagged, "tags"
    if cam.pixel_size_um is not None:
        return cam.pixel_size_um / 1000.0, "camera"
    return None, "estimated"


def _tagged_size(source: ImageSource) -> float | None:
    """The pixel size a scan's file declares in its resolution tags (:func:`aerofid.io.resolution.pixel_size_from_tags`;
    None for an array, or a file that declares none)."""
    return pixel_size_from_tags(source.path) if isinstance(source.path, str | os.PathLike) else None


def _check_decoded(source: ImageSource) -> None:
    """Raise if the scan's whole decode failed (``Raster.check_decoded``): a JPEG's first look comes from its reduced
    decode, which may work on a corrupt file, and a frame whose marks were never read would otherwise be reported
    as a frame without marks."""
    check = getattr(source, "check_decoded", None)
    if check is not None:
        check()


def frame_features(source: ImageSource, f: int | None = None) -> tuple[tuple[Candidate, ...], int]:
    """Step 1: the :data:`FEATURES` strongest mark-like features of the whole frame read reduced by ``f`` (default:
    within :data:`FRAME_PIXELS`), and the reduction."""
    f = f or reduction_for(source.width, source.height, FRAME_PIXELS)
    reduced, step = read_reduced_levels(source, (0, 0, source.width, source.height), f, overview=True)
    grey = reduced.mean(axis=2) if reduced.ndim == 3 else reduced
    threads = 1 if getattr(source, "decoding", False) else None      # a JPEG's whole decode has the other core
    return screen(grey, scale=f, min_radius=2.0, max_candidates=FEATURES, noise_floor=step / f, threads=threads), f


__all__ = ["FEATURES", "FRAME_PIXELS", "frame_features", "orient_frame", "scan_pixel_size"]
