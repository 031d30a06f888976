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
3. **Marks**: each fiducial is measured at full resolution on a window around its feature or prediction
   (:class:`aerofid.find.Measurer`); where that fails, its predicted area is searched like a region
   (:func:`aerofid.find.search`) and the mark nearest the prediction is taken.
4. **Adjustment** (:func:`aerofid.orient`): the film's lie decided by the 8 arrangements' F test, blunders
   rejected by data snooping; then the verdict per fiducial and per frame (:func:`verdict`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from aerofid.conventions import MM_PER_INCH, Box, Polarity, opposite
from aerofid.detect.auto import AutoResult
from aerofid.detect.screen import Candidate, screen
from aerofid.errors import AerofidInputError
from aerofid.find import (
    RECENTRED_WINDOW,
    SETTLED,
    ImageSource,
    Located,
    Measurer,
    colour_again,
    configure,
    in_box,
    recentred_half,
    reduction_for,
    screen_region,
    search,
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
from aerofid.frame.nominal import (
    DEFAULT_FORMAT,
    UNCALIBRATED,
    extra_marks,
    format_name,
    nominal_camera,
    nominal_sizes,
)
from aerofid.frame.profile import METHODS, Patches, RollProfile, disagreements, lie_by_templates, read_profile
from aerofid.frame.result import (
    DOUBTFUL,
    FAILED,
    FOUND_MARK,
    MISSING_MARK,
    OK,
    ROLL_AREAS,
    WHOLE_FRAME,
    FiducialFinding,
    FrameOrientation,
)
from aerofid.frame.roll_areas import roll_layout
from aerofid.frame.templates import MarkTemplate, match_template, reduction_keeping
from aerofid.frame.verdict import LIE_UNTOLD, adjusted_pixel_mm, verdict
from aerofid.io.array import open_image
from aerofid.io.raster import clip_box
from aerofid.io.reduce import ReducedView, read_reduced_levels
from aerofid.io.resolution import checked_pixel_size, pixel_size_from_tags
from aerofid.orientation.camera import Camera
from aerofid.orientation.correspondence import ARRANGEMENTS, FILM_TURN_DEG
from aerofid.robust import median

FRAME_PIXELS = 1_000_000
"""Most pixels of the reduced whole frame that is screened (a power-of-two reduction: a 5908 x 5408 scan at 8,
an 11000^2 one at 16). Fiducial marks 2-5 mm across are 6-30 reduced px at 21-42 um."""
FEATURES = 512
"""Mark-like features kept for the layout search: the fiducials rank anywhere among the frame's strongest (the
real RC20 frame: 1st to 90th, behind the scanner's edge, the data strip and the image's texture; synthetic
frames with dense aerial texture: 90th to 330th)."""
POSITION_ERROR = 3.0
"""How far (in reduced pixels) a screened feature's centre may lie from the mark's."""
AREA_MARGIN = 2.0
"""A predicted fiducial area reaches this many mark radii beyond the layout's tolerance."""
AREA_CANDIDATES = 8
"""Candidates measured in a predicted fiducial area."""
MIN_REFIT = 3
"""Marks found before the others are predicted from them (an affine transformation)."""
AREA_PROBES = 2
"""Fiducial areas searched in vain, before :data:`MIN_REFIT` marks are found, after which a layout's other areas
are not searched (:func:`measure_marks`): the features it matched are not the frame's marks, and each area searched
around a prediction that wrong costs seconds of failed searches. On 120 perturbed synthetic frames (session 25's
review: marks erased, displaced, covered, clutter painted on them, bright borders, noise; scratch, session 26), none
of the 140 areas searched before 3 marks were found held one, and the 15 frames that then failed took 7-124 s, 72 %
of it in those areas."""
VAIN_STARTS = 4
"""Fiducials that held no mark at their predicted places, while none is found, after which a layout's other
fiducials are not sought there and no area is searched (:func:`measure_marks`; not on a roll's layout, whose film may
have moved): its features are not the frame's marks. Of 92 layouts that found 3 marks or more (session 47: the 25
benchmark frames, the RC20 frame and its 8 lies, 60 random frames turned up to 10 degrees), 90 found their first mark
at the first fiducial sought and 2 (marks painted over) at the second; the chance layouts of noisy frames that fail
sought every fiducial at its place, 0.3 s each, and (session 47) one area, 2.2 s. The '+' marks of the demo frame
(``orient_frame``'s example), once found in their areas only, are found at their features since their refusal as cut
by a feature's window is measured again (:func:`_in_a_larger_box`, session 48)."""
UNSOUGHT = "not sought"
"""How the reason of a fiducial that :func:`measure_marks` did not seek at its predicted place begins."""
REFINED_TOLERANCE_MM = 1.0
"""How far (film mm) a mark may lie from its prediction by the found marks (a camera file's nominal values,
the film's deformation)."""
ESTIMATED_HINT = ("the scan declares no pixel size (no resolution tags, or a screen's default 72 or 96 dpi), so the "
                  "layout was sought at every size it allows: give it (--pixel-size, or pixel_size_um in the camera "
                  "file)")
"""Appended to the reasons of a frame that is not ok when nothing declared the pixel size."""
DECLARED_HINT = ("the layout was sought at the pixel size {size:.5f} mm ({source}), to within 3 %: if that is not the "
                 "scan's, give it (--pixel-size)")
"""Appended to the reasons of a frame that failed at a pixel size given or declared."""
MIN_TOLERANCE_PX = 8.0
"""Least tolerance (px) of a prediction by the found marks."""
FRAME_METHOD_TOLERANCE_MM = 0.3
"""How far (film mm) a mark measured by the frame's own method alone may lie from its prediction by the found
marks: the scanner's affinity across an edge a similarity cannot follow, 0.1 % of the frame."""
ALONE_WINDOWS = ((1.0, 8.0), (1.5, 8.0))
"""The windows (half-size: times the marks' radius, plus px) a mark is measured on by the frame's method alone, in
turn: the mark and little else, then a little of its ground; both tighter than a box's re-centred window
(:data:`aerofid.find.RECENTRED_WINDOW`, 2.5 times), whose ground around the mark is there for ``auto`` to see a
second mark. The marks' radius is that of the marks found so far, which may be of another, larger kind (the Wild
cameras' corner marks beside their midside crosses): a wider window then reaches the mark's surroundings (the film's
edge, the data strip), where symmetry may refuse it. On the 23 synthetic 11000^2 frames of
``benchmarks/bench_frames.py`` (session 22, against the 1.5 times alone): error RMS per axis 0.0086 px against
0.011, the same share of errors within 3 sigma, a fifth less time per frame (the cost of symmetry falls with the
area). The real RC20 frame's marks are mostly refused on the first (a busy border) and measured on the second as
before; where neither takes them, the re-centred window (corner P3 there lies 0.27 px from its centre on the second
and from the person's click)."""
COARSE_RADIUS = 16.0
"""The first mark's ``auto`` runs on the scan reduced (by a power of two) so that the marks' radius stays at least
this many px (:func:`_coarse_first`): ``auto`` tries every method, and its cost grows with the window's area."""
EXTRA_TOLERANCE_MM = 2.0
"""How far (film mm) a mark the camera file does not list may lie from where the orientation puts its nominal
position (:func:`measure_extra_marks`; the 23 cm layout's marks lie within a few tenths of a mm of it on the
Wild cameras: the real RC20 frame's midside marks 0.1-0.2 mm)."""
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
until session 48, when a chance layout came to cost 4 places and no area (:data:`VAIN_STARTS`): seed 1021 of
``benchmarks/bench_sweep.py`` (noisy), whose true layout ranks seventh, failed with 6."""
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
        frame = _Frame(source, cam, Measurer(source, detector, polarities, colour), model, size, size_source, lie,
                       profile, nominal is not None, size_range)
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
    (:func:`aerofid.find.colour_again`) and finished, where that stands better (:func:`_standing`)."""
    again = colour_again(frame.measurer)
    if best.status == FAILED and again is not None:
        other_frame = replace(frame, measurer=again)
        other = other_frame.search(extras, declared)
        if _standing(other) > _standing(best):
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
        stands better than ``failed`` (:func:`_standing`); else None."""
        again = replace(self, size=size, size_source=size_source).answer(extras, (size, size_source))
        return again if again.orientation is not None and _standing(again) > _standing(failed) else None

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
        """The best frame (:func:`_standing`; of equals the first, but for a layout that its search ended on with all
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
            res = _second_look(self.measurer, layout, fid_mm, located, judged(layout, located), judged)
            if best is None or _standing(res) > _standing(best) or (_standing(res) == _standing(best)
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
    """The better (:func:`_standing`) of two answers (None: no answer), the first of a tie."""
    if first is None or (second is not None and _standing(second) > _standing(first)):
        return second
    return first


def _standing(res: FrameOrientation) -> tuple[int, int]:
    """How good a frame's answer is: ok, doubtful, failed; then the more fiducials found."""
    return (res.ok + (res.status != FAILED), len(res.found))


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


def measure_marks(measurer: Measurer, layout: LayoutMatch, fiducials_mm: np.ndarray,
                  features: tuple[Candidate, ...], profile: RollProfile | None = None,
                  follow: bool = False, radii: Sequence[float] | None = None,
                  templates: Sequence[MarkTemplate | None] = ()) -> list[tuple[Located | None, str]]:
    """Step 3: each fiducial's mark (None if not found) and, if not found, why. Fiducials with a feature go first,
    strongest first. The first mark is measured by ``auto`` (on the reduced scan, :func:`_coarse_first`, else at full
    resolution, :func:`measure_fiducial`) and fixes the polarity tried first for the rest. Each later mark is measured
    first by the method that found most of the marks so far, alone (:func:`_by_method`; on its first window only while
    no mark of its kind is found), on a window sized by their extent, from its coarse answer (:func:`_coarse`) until
    :data:`MIN_REFIT` marks are found, then from the refined prediction (within 3 px of the mark on the benchmark's
    synthetic frames, where the method's first window settles: :func:`_alone`); if that fails, like the first: within
    the layout's tolerance until :data:`MIN_REFIT` marks are found, then at the prediction of a transformation fitted to
    them (:meth:`LayoutMatch.predict_from`; to a few px, :data:`REFINED_TOLERANCE_MM`), on a window sized by its own
    screening feature where it has one, or by the features of the marks of its kind found where those are smaller, never
    below the marks' extent (:func:`_fallback_start`; one of a kind none of whose marks is found yet, with a feature,
    waits once until the others of its kind have been sought). A mark not found there either is sought in its area
    (:func:`measure_fiducial`), but before :data:`MIN_REFIT` marks are found only after the fiducials that follow it
    have been measured (then sought again first where the others put it, by ``auto`` as the first marks are, in their
    polarity first: not by the frame's method alone, which lacks ``auto``'s checks and took a square of clutter left
    where a mark was erased; unless none of them was found): a feature that is no mark (an erased or hidden corner's
    clutter) is the strongest one on some frames, and its area, searched in both polarities within the layout's
    tolerance, took seconds that the refined prediction and tolerance save. Before :data:`MIN_REFIT` marks are found,
    areas are searched until :data:`AREA_PROBES` of them held no mark, the others not; while none is found, fiducials
    are sought at their places until :data:`VAIN_STARTS` held none, the others not, nor areas (:func:`_given_up`). The
    adjustment's blunder tests check them all. A roll ``profile`` gives the polarity, the method and the marks' size
    from the first mark on. With ``follow`` (a roll's layout, whose film may have moved: no features), the predictions
    before :data:`MIN_REFIT` marks are moved by the found marks' mean shift from theirs, and each is sought first where
    its learnt template correlates best within the layout's tolerance (``templates``, per fiducial:
    :mod:`aerofid.frame.templates`); ``radii`` (px, per fiducial: a roll's learnt sizes) size each mark's window."""
    n = len(fiducials_mm)
    strength = [0.0 if m is None else features[m].strength for m in layout.matched]
    order = sorted(range(n), key=lambda k: (layout.matched[k] is None, -strength[k]))
    out: list[tuple[Located | None, str]] = [(None, "")] * n
    other: Polarity | None = None               # the polarity tried when the frame's (fixed by its first mark) fails
    if profile is not None and len(measurer.polarities) > 1:
        measurer = replace(measurer, polarities=(profile.polarity,))
        other = opposite(profile.polarity)
    later: dict[int, tuple[int, Candidate, str]] = {}   # an area search put off: the marks found then, start, why
    vain: list[int] = []                        # fiducials whose areas held no mark before MIN_REFIT were found
    waiting: set[int] = set()                   # put off from MIN_REFIT on until the others of their kind are sought
    kinds = fiducial_kinds(fiducials_mm)
    for i, k in enumerate(order):               # (a put-off fiducial is appended to ``order``)
        done = [j for j in range(n) if out[j][0] is not None]
        at, start, tolerance, alone_tolerance, name = _sought(k, out, done, layout, fiducials_mm, features, profile,
                                                              follow, radii)
        if outside := _outside(measurer, at):
            out[k] = (None, outside)
            continue
        if k in later and later[k][0] == len(done):  # no mark found since: the same measurements would fail again
            out[k] = _probed_area(measurer, later[k][1], at, tolerance, later[k][2], len(done), vain, k, follow,
                                  len(later))
            continue
        reach = tolerance if follow and len(done) < MIN_REFIT else 0.0          # a roll's film may have moved
        quick, why = None, ""
        if name is not None and len(measurer.polarities) == 1 and k not in later:
            template = templates[k] if templates and reach > 0 else None
            near = start if len(done) >= MIN_REFIT else _coarse(measurer, name, start, reach, template)
            alike = profile is not None or any(kinds[j] == kinds[k] for j in done)
            quick = _by_method(measurer, name, near, at, alone_tolerance, windows=None if alike else 1)
        if quick is None and radii is None and profile is None:
            if k not in waiting and _waits(k, done, order[i + 1:], kinds, layout):
                waiting.add(k)                  # sought again once the others of its kind are (_fallback_start)
                order.append(k)
                continue
            start = _fallback_start(start, k, done, layout, kinds, features)
        if quick is None and not (unsought := _vain_starts(k, done, later, follow)):
            quick = _coarse_first(measurer, start, at, tolerance)
        if quick is None:
            quick, why = (None, unsought) if unsought else _at_start(measurer, start, at, tolerance, other)
            if quick is None and len(done) < MIN_REFIT and k not in later and k != order[-1]:
                later[k] = (len(done), start, why)  # sought in its area after the others (:data:`MIN_REFIT`)
                order.append(k)
                continue
        out[k] = (quick, "") if quick is not None else _probed_area(measurer, start, at, tolerance, why, len(done),
                                                                     vain, k, follow, len(later))
        if out[k][0] is not None and len(measurer.polarities) > 1:
            polarity = out[k][0].polarity  # type: ignore[union-attr]
            measurer = replace(measurer, polarities=(polarity,))
            other = opposite(polarity)
    return out


class _Sought(NamedTuple):
    """Where and how :func:`measure_marks` seeks a fiducial: the prediction, the window's centre and size, the
    tolerances (px) of any method and of the frame's method alone, and that method (None: not known yet)."""

    at: tuple[float, float]
    start: Candidate
    tolerance: float
    alone_tolerance: float
    name: str | None


def _sought(k: int, out: list[tuple[Located | None, str]], done: list[int], layout: LayoutMatch,
            fiducials_mm: np.ndarray, features: tuple[Candidate, ...], profile: RollProfile | None, follow: bool,
            radii: Sequence[float] | None) -> _Sought:
    """:func:`measure_marks`' :class:`_Sought` for fiducial ``k`` once the marks ``done`` are found (``out``)."""
    name = profile.method if profile is not None else None
    if len(done) >= MIN_REFIT:
        found = np.array([_xy(out[j][0]) for j in done])
        p = layout.predict_from(fiducials_mm, done, found)[k]
        at = (float(p[0]), float(p[1]))
        start = Candidate(at[0], at[1], radii[k] if radii is not None else _median_extent(out, done), 0.0)
        return _Sought(at, start, max(REFINED_TOLERANCE_MM / layout.pixel_size_mm, MIN_TOLERANCE_PX),
                       max(FRAME_METHOD_TOLERANCE_MM / layout.pixel_size_mm, MIN_TOLERANCE_PX),
                       name or _frame_method(out, done))
    moved = [np.subtract(_xy(out[j][0]), layout.predicted[j]) for j in done] if follow else []
    shift = np.mean(moved, axis=0) if moved else np.zeros(2)
    at = (float(layout.predicted[k][0] + shift[0]), float(layout.predicted[k][1] + shift[1]))
    m = layout.matched[k]
    start = (Candidate(at[0], at[1], radii[k], 0.0) if radii is not None
             else Candidate(at[0], at[1], profile.mark_radius_px(layout.pixel_size_mm), 0.0)
             if profile is not None
             else Candidate(at[0], at[1], _median_extent(out, done), 0.0) if done
             else _first_window(features[m]) if m is not None
             else Candidate(at[0], at[1], _median_radius(layout, features), 0.0))
    return _Sought(at, start, layout.tolerance_px, layout.tolerance_px,
                   name or (_frame_method(out, done) if done else None))


def measure_extra_marks(measurer: Measurer, res: FrameOrientation,
                        extras: dict[str, tuple[float, float]]) -> tuple[FiducialFinding, ...]:
    """The marks of the film's format that the camera file does not list (``extras``: name -> nominal film mm,
    :func:`aerofid.frame.nominal.extra_marks`), each measured like a later fiducial of :func:`measure_marks`
    (:func:`_sought_where_oriented`) from where the frame's orientation puts its nominal position, within
    :data:`EXTRA_TOLERANCE_MM` of it. They are not used in the adjustment (their positions are not calibrated): a
    finding's ``predicted_x, predicted_y`` is the nominal position, ``residual_px`` the mark's distance from it."""
    assert res.orientation is not None
    tolerance = max(EXTRA_TOLERANCE_MM / adjusted_pixel_mm(res.orientation), MIN_TOLERANCE_PX)
    out = []
    for mark, p in zip(extras, res.orientation.to_pixel(list(extras.values())), strict=True):
        at = (float(p[0]), float(p[1]))
        got, why = _sought_where_oriented(measurer, res, at, tolerance)
        if got is None:
            out.append(FiducialFinding(mark, MISSING_MARK, None, None, None, None, *at, reason=why))
            continue
        d = got.detection
        out.append(FiducialFinding(mark, FOUND_MARK, got.x, got.y, d.sigma_x, d.sigma_y, *at,
                                   residual_px=math.hypot(got.x - at[0], got.y - at[1]), method=d.method,
                                   located=got))
    return tuple(out)


def _sought_where_oriented(measurer: Measurer, res: FrameOrientation, at: tuple[float, float],
                           tolerance: float) -> tuple[Located | None, str]:
    """A mark sought at ``at``, where the frame's orientation ``res`` puts it, like a later fiducial of
    :func:`measure_marks`: sized like the frame's found marks, in their polarity first, by the frame's method alone
    from its coarse answer, else :func:`measure_fiducial` within ``tolerance`` px; and why not where it is not
    found."""
    marks: list[tuple[Located | None, str]] = [(f.located, "") for f in res.fiducials
                                               if f.status == FOUND_MARK and f.located is not None]
    if not marks:
        return None, "no mark of the frame found to measure it like"
    done = list(range(len(marks)))
    name = _frame_method(marks, done)
    other: Polarity | None = None
    if len(measurer.polarities) > 1:
        polarity = marks[0][0].polarity  # type: ignore[union-attr]
        measurer, other = replace(measurer, polarities=(polarity,)), opposite(polarity)
    start = Candidate(at[0], at[1], _median_extent(marks, done), 0.0)
    got = (None if name is None or _outside(measurer, at)
           else _by_method(measurer, name, _coarse(measurer, name, start), at, tolerance))
    return (got, "") if got is not None else measure_fiducial(measurer, start, at, tolerance, other)


def _second_look(measurer: Measurer, layout: LayoutMatch, fiducials_mm: np.ndarray,
                 located: list[tuple[Located | None, str]], res: FrameOrientation,
                 judged: Callable[[LayoutMatch, list[tuple[Located | None, str]]], FrameOrientation]
                 ) -> FrameOrientation:
    """``res`` (the frame judged on ``layout``'s marks ``located`` of ``fiducials_mm``) or the frame judged again with
    the fiducials it left unfound sought where its orientation puts them (:func:`_sought_where_oriented`, within the
    refined tolerance), wherever that is further than the refined tolerance from where :func:`measure_marks` may have
    sought them (:func:`_sought_places`): the layout's lie is a hypothesis that the adjustment's F test may overturn,
    and its fit to coarse features, or the marks of a wrong lie refitted, may put a fiducial beyond the tolerance of
    its mark, which is then not found, although the orientation of the others puts it plainly elsewhere (a camera file
    with one fiducial 2 mm off: two marks 11 and 19 px from where they were sought, within 0.05 px of where the
    orientation put them). A new mark goes to the layout's fiducial nearest it (of the camera's: ``res``'s fiducials
    come first in a layout with the format's other marks), whose prediction becomes the orientation's; the adjustment
    names the marks again and its blunder tests check the new one with the others. The new frame is kept only where
    it stands as well (:func:`_standing`) and has more marks found and used (a mark the blunder tests reject is not
    one)."""
    if res.orientation is None:
        return res
    tolerance = max(REFINED_TOLERANCE_MM / adjusted_pixel_mm(res.orientation), MIN_TOLERANCE_PX)
    marks, predicted, added = list(located), layout.predicted.copy(), False
    places = _sought_places(layout, fiducials_mm, located)
    n = len(res.fiducials)
    for f in res.fiducials:
        if f.status != MISSING_MARK:
            continue
        at = (f.predicted_x, f.predicted_y)
        k = int(np.argmin(np.hypot(*(layout.predicted[:n] - at).T)))
        if marks[k][0] is not None or all(math.hypot(*(p[k] - at)) <= tolerance for p in places):
            continue                                            # sought there already, or its place is taken
        got, _ = _sought_where_oriented(measurer, res, at, tolerance)
        if got is not None:
            marks[k], predicted[k], added = (got, ""), at, True
    if not added:
        return res
    second = judged(replace(layout, predicted=predicted), marks)
    used = sum(f.status == FOUND_MARK for f in second.fiducials) > sum(f.status == FOUND_MARK for f in res.fiducials)
    return second if used and _standing(second) >= _standing(res) else res


def _sought_places(layout: LayoutMatch, fiducials_mm: np.ndarray,
                   located: list[tuple[Located | None, str]]) -> list[np.ndarray]:
    """Where :func:`measure_marks` sought ``layout``'s fiducials (n x 2 px each): at the layout's predictions, and from
    :data:`MIN_REFIT` marks found on, at those of the layout's lie refitted to the marks found then (here: to all the
    marks ``located``, which the later fiducials' refits approach)."""
    done = [j for j, (m, _) in enumerate(located) if m is not None]
    if len(done) < MIN_REFIT:
        return [layout.predicted]
    return [layout.predicted, layout.predict_from(fiducials_mm, done, np.array([_xy(located[j][0]) for j in done]))]


def _xy(m: Located | None) -> tuple[float, float]:
    assert m is not None
    return m.x, m.y


def _median_extent(out: list[tuple[Located | None, str]], done: list[int]) -> float:
    return float(median(np.array([out[j][0].extent for j in done])))  # type: ignore[union-attr]


def _waits(k: int, done: list[int], pending: list[int], kinds: Sequence[int], layout: LayoutMatch) -> bool:
    """Whether :func:`measure_marks` puts off fiducial ``k``, which the frame's method alone missed: from
    :data:`MIN_REFIT` marks on (``done``), where it has a feature, no mark of its kind is found yet and another of its
    kind is still to be sought (``pending``), by whose feature :func:`_fallback_start` will size its search."""
    return (len(done) >= MIN_REFIT and layout.matched[k] is not None and all(kinds[j] != kinds[k] for j in done)
            and any(kinds[j] == kinds[k] and j != k for j in pending))


def _fallback_start(start: Candidate, k: int, done: list[int], layout: LayoutMatch, kinds: Sequence[int],
                    features: tuple[Candidate, ...]) -> Candidate:
    """Where and how large :func:`measure_marks` seeks fiducial ``k`` by ``auto`` once the frame's method alone has
    not found it (``start``: its prediction, sized like the marks found, ``done``): as large as its own screening
    feature, but from :data:`MIN_REFIT` marks on (the prediction within a few px) no larger than the features of the
    marks of its kind found (``kinds``, :func:`fiducial_kinds`: corners or midsides; their median), and never smaller
    than ``start`` (the marks' extent so far can be another style's: a '+' that ``hough`` measured on a ring and
    cross gives its arms' half length, a third of the ring's radius that a ring and X in the corners has). A
    camera's marks of one kind are alike, and the feature the layout matched there may be something else (a blot
    painted over the mark, 2.4-2.9 times the marks' radius on the damaged frames of ``benchmarks/bench_frames.py``,
    whose windows and areas of that size took seconds of failed searches)."""
    m = layout.matched[k]
    if not done or m is None:
        return start
    size = _first_window(features[m]).radius
    alike = [j for j in done if kinds[j] == kinds[k]]
    if len(done) >= MIN_REFIT and any(layout.matched[j] is not None for j in alike):
        size = min(size, _median_radius(layout, features, alike))
    return replace(start, radius=max(start.radius, size))


def fiducial_kinds(fiducials_mm: np.ndarray) -> list[int]:
    """Each fiducial's kind by its direction on the film from the middle of the layout (the centre of the fiducials'
    bounding box: a certificate's origin may be a corner): 1 a corner (nearer a diagonal), 0 a midside (nearer an
    axis). A camera's marks of one kind are alike (the Wild cameras' corner rings with an X and a dot, their
    midside rings with a '+'; a film that lies turned by 90 degrees in the scanner turns one axis's midsides into
    the other's).

    Examples
    --------
    >>> fiducial_kinds(np.array([[-106.0, -106.0], [0.0, -110.0], [110.0, 0.5], [106.0, 106.0], [-110.0, 0.0]]))
    [1, 0, 0, 1, 0]
    >>> fiducial_kinds(np.array([[10.0, 10.0], [116.0, 10.0], [222.0, 10.0], [222.0, 116.0], [222.0, 222.0]]))
    [1, 0, 1, 0, 1]
    """
    xy = np.asarray(fiducials_mm, float)
    d = xy - (xy.min(axis=0) + xy.max(axis=0)) / 2.0
    angle = np.degrees(np.arctan2(np.abs(d[:, 1]), np.abs(d[:, 0])))
    return (np.abs(angle - 45.0) < 22.5).astype(int).tolist()


def _frame_method(out: list[tuple[Located | None, str]], done: list[int]) -> str | None:
    """The seed method that found most of the marks ``done``, of a tie the one of the first fiducial (not a set's
    order, which follows the process's string hashing); None if ``auto``'s own answers: none."""
    methods = [out[j][0].detection.method for j in done]  # type: ignore[union-attr]
    name = max(methods, key=methods.count)
    return name if name in METHODS else None


def _by_method(measurer: Measurer, name: str, start: Candidate, at: tuple[float, float],
               tolerance: float, windows: int | None = None) -> Located | None:
    """A mark measured by the method ``name`` alone (the marks of one frame, or of one roll, are alike), on the
    window the marks' extent (``start.radius``) sizes at ``start`` (the prediction, or a coarse answer):
    :data:`ALONE_WINDOWS` in turn, else a box's re-centred window (:data:`aerofid.find.RECENTRED_WINDOW`: the real
    RC20 frame's marks, on a busy border, are refused on some of the tight ones); re-centred and with
    its window term (:meth:`aerofid.find.Measurer.recentre`); kept only when it lies within ``tolerance`` px of the
    prediction ``at``, else None (then ``auto`` measures it). The geometry of the marks found (or the layout) is what
    replaces ``auto``'s cross-checks and uniqueness pass here, three quarters of its time on a ring and cross.
    ``windows``: only the first so many of these (None: all); :func:`measure_marks` asks for one on a fiducial of a kind
    (:func:`fiducial_kinds`) none of whose marks is found yet: ``hough``, which measured a midside's ring and '+',
    spent 0.4-1.4 s per window failing on a corner's ring and X on a frame of ``benchmarks/bench_frames.py``'s roll."""
    alone = measurer.alone(name)
    for window in (*ALONE_WINDOWS, RECENTRED_WINDOW)[:windows]:
        got = _alone(alone, start, at, tolerance, window)
        if got is not None:
            return got
    return None


def _alone(alone: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
           window: tuple[float, float]) -> Located | None:
    """:func:`_by_method` on one window law. A first answer on the pixel its window is centred on, whose extent
    sizes the window within :data:`aerofid.find.SETTLED`, is already the re-centred answer (the round is not
    repeated); so is one that the method's remeasure on the re-centred window gives back
    (:meth:`aerofid.find.Measurer.confirms`: within 3 px of the mark, as the refined predictions are, the first
    window gives the centre the re-centred one does)."""
    half = recentred_half(start.radius, window)
    got = alone.at(start.x, start.y, half, start)
    if not got.found or math.hypot(got.x - at[0], got.y - at[1]) > tolerance:
        return None
    own = recentred_half(got.extent, window)
    settled = (round(got.x), round(got.y)) == (round(start.x), round(start.y)) and abs(own - half) <= SETTLED * half
    if not settled and alone.confirms(got, own):
        settled, half = True, own
    got = alone.window_term(got, half) if settled else alone.recentre(got, start, window)
    return got if got.found and math.hypot(got.x - at[0], got.y - at[1]) <= tolerance else None


def _coarse_first(measurer: Measurer, start: Candidate, at: tuple[float, float],
                  tolerance: float) -> Located | None:
    """The first mark, and a later one the frame's method alone did not find: ``auto`` (every method, the
    measurer's polarities) on the scan reduced by :func:`_coarse_factor`, then the method and polarity it chose
    measure the mark alone at full resolution (:func:`_by_method`) from its coarse centre. None when the marks are
    too small to reduce, or either stage finds nothing (then ``auto`` measures it at full resolution). A mark ``auto``
    refuses only for another mark-like feature in its window is measured again in tighter boxes about it
    (:func:`_in_a_tighter_box`)."""
    f = _coarse_factor(start.radius)
    if f == 1:
        return None
    view = ReducedView(measurer.source, f)
    reduced = replace(measurer, source=view)
    coarse = reduced.candidate(_reduced(start, view), settle=False)
    if not coarse.found:
        coarse = _in_a_tighter_box(reduced, coarse, view.from_full(*at))
    if not coarse.found or coarse.detection.method not in METHODS:
        return None
    return _by_method(replace(measurer, polarities=(coarse.polarity,)), coarse.detection.method, _full(coarse, view),
                      at, tolerance)


RIVAL_SHARE = 0.5
""":func:`_in_a_tighter_box` measures again a mark ``auto`` refused for the features beside it only when the mark lies
at most this share of each one's distance from the prediction: the prediction, not the box, picks the fiducial."""


def _in_a_tighter_box(measurer: Measurer, refused: Located, at: tuple[float, float]) -> Located:
    """A mark that ``auto`` verified but refused for a second mark-like feature in its window
    (:attr:`~aerofid.detect.auto.AutoResult.ambiguous_at`), measured again, as the refusal asks of a person, in tighter
    boxes centred on it (the candidate's windows, :meth:`aerofid.find.Measurer.candidate`, from the one refused down to
    the mark's extent, until one finds it), where the prediction ``at`` (the measurer's pixels) picks it: it lies at
    most :data:`RIVAL_SHARE` of the distance of every rival feature (:attr:`~aerofid.detect.auto.AutoResult.rivals`)
    from ``at``. Else, and when nothing was refused so, ``refused`` itself. Before :data:`MIN_REFIT` marks are found the
    layout's tolerance can exceed the distance between a mark and a like feature beside it: a review's frame with a copy
    of each mark 108-125 px beside it had a copy taken within the tolerance for a second fiducial (its mark nearer the
    prediction), and the frame was doubtful instead of ok. The real RC20 frame in two of its 8 lies (turned three
    quarters, or flipped top to bottom): the strongest feature, a corner mark merged with its number dots at the
    screening's scale, 46 px from the mark and 200-270 px from the dots, made a first window that held both, and the
    fiducial's search at full resolution then took 0.25 s to fail (``tests/test_frame.py``)."""
    d = refused.detection
    if not isinstance(d, AutoResult) or d.ambiguous_at is None or not math.isfinite(d.mark_extent):
        return refused
    x, y = d.origin[0] + d.ambiguous_at[0], d.origin[1] + d.ambiguous_at[1]
    near = math.hypot(x - at[0], y - at[1])
    if any(near > RIVAL_SHARE * math.hypot(d.origin[0] + rx - at[0], d.origin[1] + ry - at[1]) for rx, ry in d.rivals):
        return refused
    c = refused.candidate
    assert c is not None
    return measurer.candidate(replace(c, x=x, y=y, inner=min(c.inner, d.mark_extent)), settle=False)


def _coarse(measurer: Measurer, name: str, start: Candidate, reach: float = 0.0,
            template: MarkTemplate | None = None) -> Candidate:
    """Where a later mark is measured at full resolution: ``start`` (its prediction, sized like the marks) moved
    to the centre and extent the method ``name`` finds there on the scan reduced by :func:`_coarse_factor`, so
    that the full-resolution window is the re-centred one at once (:func:`_by_method`); ``start`` when the marks
    are too small to reduce or the coarse measurement finds nothing. The reduced window is the first of
    :data:`ALONE_WINDOWS` (the mark and little else; 1.5 times the radius before session 22, whose change of both
    is measured in docs/benchmarks_frames.md). ``reach``: how far (px) the mark may lie from
    ``start``, added to the window's half-size (then marks too small to reduce are sought so too, unreduced); there
    the mark's learnt ``template`` is tried first (:func:`_matched`)."""
    matched = _matched(measurer, template, start, reach) if template is not None else None
    if matched is not None:
        return matched
    f = _coarse_factor(start.radius)
    if f == 1 and reach <= 0:
        return start
    view = ReducedView(measurer.source, f)
    small = _reduced(start, view)
    half = recentred_half(small.radius, ALONE_WINDOWS[0]) + reach / view.factor
    coarse = replace(measurer.alone(name), source=view).at(small.x, small.y, half, small)
    return _full(coarse, view) if coarse.found else start


def _matched(measurer: Measurer, template: MarkTemplate, start: Candidate, reach: float) -> Candidate | None:
    """``start`` moved to where the mark's ``template`` correlates best within ``reach`` px of it, on the scan
    reduced by the template's factor, in the measurer's (first) polarity
    (:func:`aerofid.frame.templates.match_template`); None where nothing there correlates enough."""
    view = ReducedView(measurer.source, template.factor)
    small = _reduced(start, view)
    half = max(template.shape) / 2 + reach / view.factor
    box, grey = replace(measurer, source=view).grey(small.x, small.y, half, measurer.polarities[0])
    found = match_template(grey, template)
    if found is None:
        return None
    x, y = view.to_full(box[0] + found[0], box[1] + found[1])
    return Candidate(x, y, start.radius, 0.0)


def _coarse_factor(radius: float) -> int:
    """The power of two that reduces marks of ``radius`` px to at least :data:`COARSE_RADIUS` px (1: none)."""
    return reduction_keeping(radius, COARSE_RADIUS)


def _reduced(c: Candidate, view: ReducedView) -> Candidate:
    x, y = view.from_full(c.x, c.y)
    return replace(c, x=x, y=y, radius=c.radius / view.factor, inner=c.inner / view.factor)


def _full(coarse: Located, view: ReducedView) -> Candidate:
    x, y = view.to_full(coarse.x, coarse.y)
    return Candidate(x, y, coarse.extent * view.factor, 0.0)


def _first_window(c: Candidate) -> Candidate:
    """A screened feature sized for its first window: the geometric mean of its largest radius (coarse levels
    see the mark's surroundings too) and its smallest (the real RC20 marks: 80-96 and 12 px; the marks are about
    40 px in radius)."""
    return replace(c, radius=math.sqrt(c.radius * c.inner))


def _median_radius(layout: LayoutMatch, features: tuple[Candidate, ...], among: Sequence[int] | None = None) -> float:
    """The median first-window radius (:func:`_first_window`) of the features matched to the fiducials ``among``
    (default: all of them)."""
    matched = layout.matched if among is None else [layout.matched[j] for j in among]
    return float(median(np.array([_first_window(features[m]).radius for m in matched if m is not None])))


def measure_fiducial(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
                     other_polarity: Polarity | None = None) -> tuple[Located | None, str]:
    """One fiducial: the mark measured from ``start`` (a feature, or the prediction sized like the marks), else in
    ``other_polarity`` (a ring and cross on film is a mark in both: each loses some windows), else the mark
    nearest the prediction ``at`` in its area searched like a region, within ``tolerance`` px."""
    outside = _outside(measurer, at)
    if outside:
        return None, outside
    got, why = _at_start(measurer, start, at, tolerance, other_polarity)
    return (got, "") if got is not None else _in_area(measurer, start, at, tolerance, why)


def _at_start(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
              other_polarity: Polarity | None) -> tuple[Located | None, str]:
    """:func:`measure_fiducial`'s measurements from ``start`` (in the measurer's polarities, then in
    ``other_polarity``): the mark found within ``tolerance`` px of ``at``, else None and why not there (where the
    first measurement found a mark, how far off; else its reason, with the box of the window it speaks of:
    :meth:`aerofid.find.Located.reason_in_window`)."""
    others = () if other_polarity is None else (replace(measurer, polarities=(other_polarity,)),)
    first: Located | None = None
    for m in (measurer, *others):
        got = _in_a_larger_box(m, m.candidate(start), at, tolerance)
        first = first or got
        if got.found and math.hypot(got.x - at[0], got.y - at[1]) <= tolerance:
            return got, ""
    assert first is not None
    if first.found:
        return None, (f"the mark found there, at ({first.x:.1f}, {first.y:.1f}), lies "
                      f"{math.hypot(first.x - at[0], first.y - at[1]):.0f} px from the prediction")
    return None, first.reason_in_window(measurer.source.width, measurer.source.height)


def _in_a_larger_box(measurer: Measurer, refused: Located, at: tuple[float, float], tolerance: float) -> Located:
    """A mark that ``auto`` found but refused as cut by its window's edge
    (:attr:`~aerofid.detect.auto.AutoResult.cut_at`), measured again, as the refusal asks of a person, on windows
    centred on it and sized by its extent (:meth:`aerofid.find.Measurer.candidate`), where it lies within
    ``tolerance`` px of the prediction ``at`` and the scan holds its extent about it (not a mark cut by the scan's
    edge); else ``refused`` itself. The screening gives a thin '+' the radius of its crossing (3 px on the 40 px '+'
    marks of ``synth.demo_frame``, the doctest of :func:`orient_frame`): its first window holds the crossing, and
    the mark (radius 21 px) was refused there and found only by its area's search."""
    d = refused.detection
    if not isinstance(d, AutoResult) or d.cut_at is None or not math.isfinite(d.mark_extent):
        return refused
    x, y = d.origin[0] + d.cut_at[0], d.origin[1] + d.cut_at[1]
    room = min(x, y, measurer.source.width - 1 - x, measurer.source.height - 1 - y)   # a mark cut by the scan's edge
    if math.hypot(x - at[0], y - at[1]) > tolerance or room < d.mark_extent:
        return refused
    return measurer.candidate(Candidate(x, y, d.mark_extent, 0.0))


def _in_area(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float,
             why: str) -> tuple[Located | None, str]:
    """:func:`measure_fiducial`'s area search: the mark nearest ``at`` within ``tolerance`` px in the area around
    it, else None and why not (``why``: why not at ``start``)."""
    half = tolerance + AREA_MARGIN * start.radius
    area, _ = clip_box((at[0] - half, at[1] - half, at[0] + half + 1, at[1] + half + 1), measurer.source.width,
                       measurer.source.height)
    nearest = _nearest_mark(measurer, area, at, tolerance, start.radius)
    if nearest is not None:
        return nearest, ""
    return None, (f"no mark within {tolerance:.0f} px of the predicted ({at[0]:.0f}, {at[1]:.0f}) in the area "
                  f"{area[0]},{area[1]},{area[2]},{area[3]} (at the prediction: {why})")


def _probed_area(measurer: Measurer, start: Candidate, at: tuple[float, float], tolerance: float, why: str,
                 found: int, vain: list[int], k: int, follow: bool, put_off: int) -> tuple[Located | None, str]:
    """:func:`_in_area` for fiducial ``k`` of :func:`measure_marks` once ``found`` marks are found: before
    :data:`MIN_REFIT`, only until :data:`AREA_PROBES` fiducials' areas have held no mark (``vain``: ``k`` is appended
    when its area holds none); while no mark is found, one, and none once :data:`VAIN_STARTS` fiducials held no mark at
    their predicted places (``put_off``: the fiducials put off so far); not so on a roll's layout (``follow``), whose
    film may have moved. Then not searched, and why. With no mark found, a fiducial reaches its area only once the
    others were sought at their places (or :data:`VAIN_STARTS` of them) and none held one: a scan with no fiducials in
    it, or a camera file that is not the scan's, spent 1.2-1.7 s of each layout it tried in two areas; a noisy frame
    that fails (seed 5009 of ``benchmarks/bench_sweep.py``) 2.2 s of each of its 24 chance layouts in one (118 s in
    all, 54 s without them, session 48)."""
    if found >= MIN_REFIT:
        return _in_area(measurer, start, at, tolerance, why)
    if _given_up(found, put_off, follow):
        place = f"the predicted ({at[0]:.0f}, {at[1]:.0f})"
        there = (f"{UNSOUGHT} at {place} nor in its area" if why.startswith(UNSOUGHT)
                 else f"no mark at {place} ({why}); its area was not searched")
        return None, (f"{there}: {VAIN_STARTS} fiducials held no mark at their predicted places and none was found "
                      "(the features the layout matched are probably not the frame's marks)")
    if len(vain) >= (1 if found == 0 and not follow else AREA_PROBES):
        return None, (f"no mark at the predicted ({at[0]:.0f}, {at[1]:.0f}) ({why}); its area was not searched: "
                      f"the areas of {len(vain)} fiducials held none and {found} marks were found, too few to "
                      "predict the others (the features the layout matched are probably not the frame's marks)")
    got = _in_area(measurer, start, at, tolerance, why)
    if got[0] is None:
        vain.append(k)
    return got


def _vain_starts(k: int, done: list[int], later: dict[int, tuple[int, Candidate, str]], follow: bool) -> str:
    """Why :func:`measure_marks` does not seek fiducial ``k`` at its predicted place: none is found (``done``) and
    :data:`VAIN_STARTS` fiducials held none at theirs (``later``: those put off), but on a roll's layout (``follow``);
    "" when it seeks it there."""
    if k in later or not _given_up(len(done), len(later), follow):
        return ""
    return f"{UNSOUGHT}: {VAIN_STARTS} fiducials held no mark at their predicted places"


def _given_up(found: int, put_off: int, follow: bool) -> bool:
    """Whether :func:`measure_marks` gives a layout up, seeking no more fiducials at their places nor in their areas:
    none is ``found`` and :data:`VAIN_STARTS` fiducials held none at their places (``put_off``), but on a roll's
    layout (``follow``)."""
    return not found and not follow and put_off >= VAIN_STARTS


def _outside(measurer: Measurer, at: tuple[float, float]) -> str:
    """Why no mark is sought at ``at``: it lies outside the scan; "" when it lies inside."""
    if in_box(at[0], at[1], (0, 0, measurer.source.width, measurer.source.height)):
        return ""
    return f"the predicted ({at[0]:.0f}, {at[1]:.0f}) lies outside the scan"


def _nearest_mark(measurer: Measurer, area: Box, at: tuple[float, float], tolerance: float,
                  radius: float) -> Located | None:
    """The predicted area searched like a region: the found mark nearest ``at`` within ``tolerance``."""
    cands, f = screen_region(measurer.source, area, measurer.colour, measurer.polarities[0], 2.0,
                             max(4.0 * radius, 8.0), AREA_CANDIDATES)
    marks = [m for m in search(measurer, area, cands, f).marks if math.hypot(m.x - at[0], m.y - at[1]) <= tolerance]
    return min(marks, key=lambda m: math.hypot(m.x - at[0], m.y - at[1]), default=None)


__all__ = ["FEATURES", "FRAME_PIXELS", "frame_features", "measure_fiducial", "measure_marks", "orient_frame",
           "scan_pixel_size"]
