"""``aerofid.locate``: the operator's box in, the mark's sub-pixel centre (or an explicit "not found") out.

The box says where the centre may be, not which pixels may be read: :func:`locate` is the search of
:mod:`aerofid.find` on the box (screening for candidates, each measured on a window of its own size read
around it, clipped only by the image, then re-centred on its answer) plus the one-mark rule: exactly one mark
(its accessories apart: index dots, digits) must have its centre in the box; several are "not found" with
their positions. Colour is reduced to grey by a policy that keeps the mark's contrast, dark marks are
inverted so every detector sees a bright mark. Coordinates everywhere: x = column, y = row, the centre of
the top-left pixel is (0, 0); boxes (x0, y0, x1, y1) with x1, y1 exclusive.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from aerofid.conventions import FOUND, NOT_FOUND, Box, finite_or_none
from aerofid.detect.auto import TWIN_MARGIN, TWIN_SCALES, AutoResult, blank_disc, seed_params, twin_panels
from aerofid.detect.hough.params import HoughParams
from aerofid.detect.noise import laplacian_noise_sigma
from aerofid.detect.result import Detection
from aerofid.detect.screen import Candidate
from aerofid.errors import AerofidInputError
from aerofid.find import (
    ACCESSORY_RATIO,
    MAX_MARK_RADIUS,
    WEAK_CANDIDATE,
    Located,
    MarkSearch,
    Measurer,
    configure,
    in_box,
    rows_read,
    screen_region,
    search,
    window_ladder,
    with_white,
)
from aerofid.io.array import open_image
from aerofid.io.raster import Raster, clip_box
from aerofid.methods import METHOD_NAMES, AutoDetector

LOCATE_CANDIDATES = (8, 32)
"""At most this many screening candidates are measured in one box: the first for boxes up to
:data:`CANDIDATE_AREA` px, more in proportion to the area beyond, up to the second."""
CANDIDATE_AREA = 512 * 512
"""Box area (px) per :data:`LOCATE_CANDIDATES`[0] candidates."""


@dataclass(frozen=True)
class Location:
    """The answer of :func:`locate`, in full-image pixels.

    Attributes
    ----------
    status : str
        ``"found"`` or ``"not_found"``.
    x, y : float
        The centre (NaN when not found).
    score : float
        The detector's confidence in [0, 1] (for ``hough``: the similarity metric of seed 001).
    sigma : float
        Standard deviation of the centre per axis (px): sqrt((sigma_x^2 + sigma_y^2) / 2).
    sigma_x, sigma_y, cov_xy : float
        The centre's covariance matrix [[sigma_x^2, cov_xy], [cov_xy, sigma_y^2]] (px^2).
    method, mark, polarity : str
        The method whose centre is returned, the kind of mark asked for, the polarity that answered.
    box : tuple of int
        The box the centre was sought in (clipped to the image; ``clipped`` says whether it had to be).
    requested_box : tuple of float
        The box as given.
    detection : Detection
        The method's full typed answer, moved to full-image pixels (its ``origin`` is the top-left pixel of
        the window it saw, ``window_box``).
    window : ndarray
        The grey window the detector saw (mark bright).
    window_box : tuple of int
        Where that window lies in the image.
    search : MarkSearch
        How the box was searched: screening candidates, every measurement, marks and accessories.
    """

    status: str
    x: float
    y: float
    score: float
    sigma: float
    method: str
    mark: str
    polarity: str
    box: Box
    requested_box: tuple[float, float, float, float]
    clipped: bool
    reason: str = ""
    image: str | None = None
    sigma_x: float = float("nan")
    sigma_y: float = float("nan")
    cov_xy: float = float("nan")
    window_box: Box | None = None
    detection: Detection | None = field(default=None, repr=False, compare=False)
    window: np.ndarray | None = field(default=None, repr=False, compare=False)
    search: MarkSearch | None = field(default=None, repr=False, compare=False)

    @property
    def found(self) -> bool:
        """True when a mark was located."""
        return self.status == FOUND

    @property
    def covariance(self) -> np.ndarray:
        """The centre's 2 x 2 covariance matrix (px^2; NaN when unknown)."""
        return np.array([[self.sigma_x ** 2, self.cov_xy], [self.cov_xy, self.sigma_y ** 2]])

    def to_dict(self) -> dict[str, Any]:
        """Scalars only, ready for JSON (NaN becomes None)."""
        n = finite_or_none
        out: dict[str, Any] = {"status": self.status, "x": n(self.x), "y": n(self.y), "score": n(self.score),
                               "sigma": n(self.sigma), "sigma_x": n(self.sigma_x), "sigma_y": n(self.sigma_y),
                               "cov_xy": n(self.cov_xy), "method": self.method, "mark": self.mark,
                               "polarity": self.polarity, "box": list(self.box),
                               "requested_box": list(self.requested_box), "clipped": self.clipped,
                               "reason": self.reason, "image": self.image}
        if self.search is not None:
            out["candidates"] = [c.to_dict() for c in self.search.candidates]
        return out


def locate(image: str | os.PathLike[str] | np.ndarray | Raster, box: Sequence[float], mark: str = "auto",
           method: str = "auto", polarity: str = "bright", colour: str = "auto", **params: Any) -> Location:
    """Locate the mark inside ``box`` of ``image``.

    Parameters
    ----------
    image : path or ndarray
        A path (TIFF/BigTIFF/GeoTIFF, JPEG, PNG), a 2-D grey / (h, w, 3) RGB numpy array, or a scan opened
        once with :func:`aerofid.io.raster.open_raster` for several boxes.
    box : (x0, y0, x1, y1)
        Where the mark's centre lies: full-image pixels, x1 and y1 exclusive, from tight (the mark plus a
        few px) to many times the mark's size. Pixels around it are read as context. A box partly outside the
        image is clipped (``Location.clipped``), one wholly outside is an error.
    mark : {"auto", "external", "panel"}
        A film fiducial, a cloth ground panel, or let the detector decide.
    method : {"auto", "hough", "symmetry", "circles", "lines"}
        ``"hough"`` (Hunt, Ryan & Gifford), ``"symmetry"`` (Cho & Kim), ``"circles"`` (Seedahmed),
        ``"lines"`` (Sohn et al.) runs that one detector; ``"auto"`` runs the detectors that apply,
        cross-checks them and answers only with a corroborated, verified centre (:mod:`aerofid.detect.auto`;
        ``method`` then names the detector whose centre is returned).
    polarity : {"bright", "dark", "auto"}
        Mark brighter than its ground (the seeds' case), darker, or try both (the more confident answer wins).
    colour : str
        How RGB becomes grey: "auto" (the channel mix with the most mark contrast), "luminance", "red",
        "green", "blue" or "max".
    **params
        Parameters of the method (``aerofid.detect.hough.HoughParams``, ``...symmetry.SymmetryParams``,
        ``...circles.CirclesParams``, ``...lines.LinesParams``, ``...auto.AutoParams``), e.g.
        ``window_size=24``, ``max_asymmetry=0.2``; with ``method="auto"`` each goes to the methods that take it.

    Returns
    -------
    Location
        "not found" is a status, never an exception: also when the box holds several marks (the reason
        names how many and where; accessories such as index dots beside a mark do not count).

    Raises
    ------
    AerofidInputError
        Bad input (missing/corrupt file, box outside the image, unknown option or parameter...).

    Examples
    --------
    >>> import numpy as np, aerofid
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("cross", size=30, window=80, rng=np.random.default_rng(0))
    >>> truth = scene.marks[0]
    >>> r = aerofid.locate(scene.image, (10, 10, 70, 70), mark="external")
    >>> r.found, bool(np.hypot(r.x - truth.x, r.y - truth.y) < 0.1)
    (True, True)
    """
    detector, polarities = configure(method, mark, polarity, colour, params)
    requested = _box_tuple(box)
    with open_image(image, rows_read(requested)) as source:
        region, was_clipped = clip_box(requested, source.width, source.height)
        found = search_box(Measurer(source, detector, polarities, colour), region)
    return one_mark(found, mark, requested, was_clipped)


def search_box(measurer: Measurer, region: Box) -> MarkSearch:
    """The search of :func:`aerofid.find.find_marks` on one box, with the box's centre as a last candidate
    (a tight box: the mark fills it); a cloth panel's box is first measured whole (:func:`panel_box`)."""
    measurer = with_white(measurer, region)
    w, h = region[2] - region[0], region[3] - region[1]
    centre = Candidate(x=region[0] + (w - 1) / 2.0, y=region[1] + (h - 1) / 2.0,
                       radius=min(w / 2.0, h / 2.0, MAX_MARK_RADIUS), strength=0.0, inner=2.0)
    candidates, f = screened = screen_box(measurer, region)
    whole, measured = panel_box(measurer, region, centre, screened)
    if whole is None:
        found = search(measurer, region, candidates, f, last=() if measured else (centre,), measured=measured)
        if len(found.marks) != 1:
            return found
        whole = replace(found, marks=found.marks + tuple(confirmed_rivals(measurer, region, found.attempts,
                                                                          found.marks[0])))
    if len(whole.marks) != 1:
        return whole
    twin = box_twin(measurer, region, whole.marks[0])
    return whole if twin is None else replace(whole, marks=(*whole.marks, twin))


def panel_box(measurer: Measurer, region: Box, centre: Candidate,
              screened: tuple[tuple[Candidate, ...], int]) -> tuple[MarkSearch | None, tuple[Located, ...]]:
    """A cloth panel's box (``auto`` with ``mark="panel"``) measured whole first: ``auto`` on the first window of the
    box's ``centre`` candidate (:func:`~aerofid.find.window_ladder`: the box and 1.5 times its half-size + 8 px
    around it, so that a panel with its centre in the box lies whole in it, unless the image's edge cuts it). Where
    that window holds the box, ``auto``'s uniqueness pass has looked there for a second panel (the panel's own image,
    turned, matched and fitted: :func:`aerofid.detect.auto.panel_twins`) and for a second answer of ``symmetry``:

    - a panel found in the box, re-centred (:meth:`~aerofid.find.Measurer.recentre`), is the answer, unless
      ``hough`` alone finds another '+' in the box on the first window of one of its ``screened`` candidates
      (:func:`another_cross`; a '+' of another shape is no twin of the panel);
    - a panel refused for a second one beside it: the two measured each on its own (:func:`two_panels`).

    Returns that answer (else None), and the panel the box's search by candidates (with ``auto`` on each one's window
    ladder) is then to count with the marks it finds, in place of the box's centre candidate, whose measurement it is
    (where ``hough`` found another '+': the search named only that '+', a bright one 2-3 times as thick as the panel,
    in one of 8 scratch boxes, without measuring the centre after it: it skips a candidate weaker than a mark found,
    and the centre has no strength). The panel's thin strips screen weaker than aerial clutter: on bench_peers.py's
    boxes the clutter's candidates came first, each at the cost of ``auto``'s failed searches on every window of its
    ladder."""
    det = measurer.detector
    if not (isinstance(det, AutoDetector) and det.params.mark == "panel"):
        return None, ()
    half = window_ladder(centre.radius, centre.inner)[0]
    x0, y0, x1, y1 = measurer.window_box(centre.x, centre.y, half)
    if not (x0 <= region[0] and y0 <= region[1] and x1 >= region[2] and y1 >= region[3]):
        return None, ()
    got = measurer.at(centre.x, centre.y, half, centre)
    if not got.found:
        return two_panels(measurer, region, got, screened), ()
    if not in_box(got.x, got.y, region):
        return None, ()
    final = measurer.recentre(got, centre)
    if not (final.found and in_box(final.x, final.y, region)):
        return None, ()
    if another_cross(measurer, region, final, screened[0]):
        return None, (final,)
    return _measured(measurer, region, (final,), (final,), screened), ()


BOX_TWIN_SLACK = 1.0
""":func:`box_twin`'s second panel passes ``hough``'s verification as a lone answer must (no ``twin_slack``): matched at
other sizes over a whole box, a dark ring with a bright halo and blurred texture beside bench_peers.py's panels were
fitted as a '+' with a centre sigma of 0.17-0.18 px, within the twins' slack (0.3 px); the second panels of a review's
boxes, 0.03-0.05 px."""


def box_twin(measurer: Measurer, region: Box, panel: Located) -> Located | None:
    """A second cloth panel in the box besides the one found (``auto`` with ``mark="panel"``): the panel's own image,
    turned and scaled, matched over the whole box and fitted (:func:`aerofid.detect.auto.twin_panels`), on a window
    that holds the box and a twin of twice the panel's size whose centre lies in it, the panel blanked out. ``auto``'s
    own check of the panel looked only on the window it measured the panel on, which the box's search sizes by the
    candidate (a review's boxes with two panels: of 191 answered as one before session 54, 89 still were, the second
    panel without a screening candidate in 79 of them: the screen keeps the box's strongest few, and a panel's thin
    strips screen weaker than aerial clutter; 21 with this check). Returns the twin (its ``hough`` fit) or None."""
    det, auto = panel.detection, measurer.detector
    member = det.member if isinstance(det, AutoResult) else None
    if not (isinstance(auto, AutoDetector) and auto.params.mark == "panel" and member is not None
            and member.method == "hough"):
        return None
    params = auto.params
    hough = seed_params(params, auto.methods)["hough"]
    assert isinstance(hough, HoughParams)
    extent = panel.extent
    reach = params.second_size * (extent + TWIN_MARGIN) * math.sqrt(2.0) + params.edge_margin + 2.0
    x0, y0, x1, y1 = region
    half = max(x1 - x0, y1 - y0) / 2.0 + reach
    box, grey = measurer.grey((x0 + x1 - 1) / 2.0, (y0 + y1 - 1) / 2.0, half, panel.polarity)
    px, py = panel.x - box[0], panel.y - box[1]
    at = replace(member, x=px, y=py)
    blanked = blank_disc(grey, px, py, extent + params.edge_margin, laplacian_noise_sigma(grey))
    twins = twin_panels(grey, blanked, at, extent, params, hough,
                        inside=lambda x, y: in_box(x + box[0], y + box[1], region), scales=TWIN_SCALES,
                        slack=BOX_TWIN_SLACK)
    if not twins:
        return None
    return Located(twins[0].shifted(box[0], box[1]), panel.polarity, box, grey)


def screen_box(measurer: Measurer, region: Box) -> tuple[tuple[Candidate, ...], int]:
    """The box's screening candidates (at most :data:`LOCATE_CANDIDATES`, by its area) and the screen's reduction."""
    w, h = region[2] - region[0], region[3] - region[1]
    n = int(min(max(LOCATE_CANDIDATES[0] * w * h / CANDIDATE_AREA, LOCATE_CANDIDATES[0]), LOCATE_CANDIDATES[1]))
    return screen_region(measurer.source, region, measurer.colour, measurer.polarities[0], min_radius=2.0,
                         max_radius=min(max(w, h) / 2.0 + 2.0, MAX_MARK_RADIUS), max_candidates=n,
                         white=measurer.white)


def another_cross(measurer: Measurer, region: Box, panel: Located, screened: tuple[Candidate, ...]) -> bool:
    """Whether the box may hold a '+' besides ``panel``: ``hough`` alone (as ``auto`` runs it) answers one with its
    centre in the box, beyond the panel's extent, on the first window of a ``screened`` candidate of the box
    (:func:`screen_box`). The candidates are taken as the box's search by candidates takes them (strongest first; one
    whose answer was found makes those weaker than :data:`~aerofid.find.WEAK_CANDIDATE` times its strength not worth
    a look; the panel's own, within its extent, counts as found), and that search measures them with ``auto``, whose
    panel is ``hough``'s '+', and names two marks where two of them answer one. ``auto``'s uniqueness on the whole
    window seeks only a second panel of this one's shape: a review's bright '+' 2-3 times as thick as a panel beside
    it was answered, 45-118 px from the panel, in 5 of 845 boxes. ``hough`` searches as ``auto`` runs it on those
    windows (up to 8 refused candidates): giving up after 2, as when ``auto`` re-examines a place, took a panel box
    from 0.40 to 0.21 s but let 2 of those 5 bright '+' through (the spiral starts at the candidate, which is
    clutter, and the panel lies elsewhere in its window)."""
    hough = measurer.alone("hough")
    strongest = 0.0
    for c in screened:
        if c.strength < WEAK_CANDIDATE * strongest:
            continue
        if float(np.hypot(c.x - panel.x, c.y - panel.y)) <= panel.extent:
            strongest = max(strongest, c.strength)
            continue
        got = hough.at(c.x, c.y, window_ladder(c.radius, c.inner)[0], c)
        if not got.found:
            continue
        if in_box(got.x, got.y, region) and float(np.hypot(got.x - panel.x, got.y - panel.y)) > panel.extent:
            return True
        strongest = max(strongest, c.strength)
    return False


def two_panels(measurer: Measurer, region: Box, whole: Located,
               screened: tuple[tuple[Candidate, ...], int]) -> MarkSearch | None:
    """The box's marks where ``auto`` on its ``whole`` window refused a panel for a second answer beside it: both
    places measured as candidates of their own (:meth:`~aerofid.find.Measurer.candidate`, of the refused panel's
    extent); both found in the box, apart: these two marks (:func:`one_mark` then names both). Else None. The
    search candidate by candidate could miss one of them: of 4 scratch boxes with two 9 px panels 47 px apart, it
    found one panel in one box and answered it."""
    det = whole.detection
    if not (isinstance(det, AutoResult) and det.ambiguous_at is not None and det.second_marks):
        return None
    wx, wy = whole.box[:2]
    other = det.second_marks[0]
    marks: list[Located] = []
    for x, y in (det.ambiguous_at, (other.x, other.y)):
        got = measurer.candidate(Candidate(x=x + wx, y=y + wy, radius=det.mark_extent, strength=0.0, inner=2.0))
        if not (got.found and in_box(got.x, got.y, region)):
            return None
        marks.append(got)
    a, b = marks
    if float(np.hypot(a.x - b.x, a.y - b.y)) <= max(a.extent, b.extent):
        return None
    return _measured(measurer, region, (a, b), (whole, a, b), screened)


def _measured(measurer: Measurer, region: Box, marks: tuple[Located, ...], attempts: tuple[Located, ...],
              screened: tuple[tuple[Candidate, ...], int]) -> MarkSearch:
    """The box's search where its ``screened`` candidates (and the screen's reduction) were not measured: ``marks``
    found by ``attempts``."""
    source = measurer.source
    return MarkSearch(region, marks, (), attempts, *screened, source.width, source.height,
                      None if source.path is None else str(source.path))


def one_mark(search: MarkSearch, mark: str, requested: tuple[float, ...], was_clipped: bool) -> Location:
    """The one-mark rule: exactly one mark in the box is the answer; none or several is "not found". Accessories
    of a mark (:func:`aerofid.find.one_per_mark`) do not count, nor does a mark both smaller (extent below
    :data:`~aerofid.find.ACCESSORY_RATIO` of the largest's) and less confident (lower score) than the largest
    (a dust speck on the film border beside a fiducial); one that is smaller but more confident does (the
    fiducials of a whole frame against a dial of its data strip)."""
    if len(search.marks) > 1:
        top = max(search.marks, key=lambda m: m.extent)
        minor = tuple(m for m in search.marks if m.extent < ACCESSORY_RATIO * top.extent
                      and m.detection.score < top.detection.score)
        search = replace(search, marks=tuple(m for m in search.marks if m not in minor),
                         accessories=search.accessories + minor)
    if len(search.marks) == 1:
        return _location(search.marks[0], search, mark, requested, was_clipped, FOUND, "")
    if search.marks:
        where = ", ".join(f"({m.x:.1f}, {m.y:.1f})" for m in search.marks)
        reason = f"{len(search.marks)} marks in the box, at {where}: draw the box round one of them"
        return _location(search.marks[0], search, mark, requested, was_clipped, NOT_FOUND, reason)
    if not search.attempts:
        return _location(None, search, mark, requested, was_clipped, NOT_FOUND,
                         "nothing in the box stands out of its ground as a mark")
    first = search.attempts[0]
    return _location(first, search, mark, requested, was_clipped, NOT_FOUND,
                     first.reason_in_window(search.width, search.height))


RIVAL_SCALE = 2.0
"""A refused candidate rivals the mark when its screening radius is within this factor of the mark's..."""
RIVAL_STRENGTH = 0.5
"""... and its screening strength at least this fraction of the mark's."""


def confirmed_rivals(measurer: Measurer, region: Box, attempts: tuple[Located, ...],
                     found: Located) -> list[Located]:
    """Second marks that the found one spoils: candidates in the box, beyond its extent, screened at about its
    scale and strength (:data:`RIVAL_SCALE`, :data:`RIVAL_STRENGTH`) but refused, measured again with the found
    mark blanked out (:func:`aerofid.detect.auto.blank_disc`); those found then are marks too (two dots side by
    side: each one's window holds the other), one per mark (a second '+' screened twice was listed twice: a helper's
    audit), whose centres lie in the box (a candidate in the box was measured on a panel beyond its edge, and the box
    refused for "2 marks in the box" with that panel's centre outside it). A notch corner or an arm's end refused for
    what it is stays refused."""
    own = found.candidate
    if own is None or own.strength <= 0:
        return []
    rivals: list[Located] = []
    for a in attempts:
        c = a.candidate
        if a.found or c is None or c is own or c.strength < RIVAL_STRENGTH * own.strength:
            continue
        inside = in_box(c.x, c.y, region)
        apart = all(float(np.hypot(c.x - m.x, c.y - m.y)) > m.extent for m in (found, *rivals))
        if inside and apart and 1 / RIVAL_SCALE <= c.radius / own.radius <= RIVAL_SCALE:
            again = measurer.candidate(c, blank=(found.x, found.y, found.extent + 2.0))
            beyond = again.found and in_box(again.x, again.y, region) \
                and float(np.hypot(again.x - found.x, again.y - found.y)) > found.extent
            if beyond and all(float(np.hypot(again.x - m.x, again.y - m.y)) > max(m.extent, again.extent)
                              for m in rivals):
                rivals.append(again)
    return rivals


def _location(got: Located | None, search: MarkSearch, mark: str, requested: tuple[float, ...],
              was_clipped: bool, status: str, reason: str) -> Location:
    nan = float("nan")
    det = got.detection if got is not None else None
    ok = status == FOUND and det is not None
    return Location(
        status=status, x=det.x if ok else nan, y=det.y if ok else nan,  # type: ignore[union-attr]
        score=det.score if det is not None else 0.0, sigma=det.sigma if ok else nan,  # type: ignore[union-attr]
        sigma_x=det.sigma_x if ok else nan, sigma_y=det.sigma_y if ok else nan,  # type: ignore[union-attr]
        cov_xy=det.cov_xy if ok else nan, method=det.method if det is not None else "",  # type: ignore[union-attr]
        mark=mark, polarity=got.polarity if got is not None else "bright", box=search.region,
        requested_box=tuple(float(v) for v in requested),  # type: ignore[arg-type]
        clipped=was_clipped, reason=reason, image=search.path, window_box=got.box if got is not None else None,
        detection=det, window=got.window if got is not None else None, search=search)


def _box_tuple(box: Sequence[float]) -> tuple[float, ...]:
    try:
        t = tuple(box)
    except TypeError:
        raise AerofidInputError(f"box {box!r} is not four numbers; give (x0, y0, x1, y1) in pixels") from None
    return t


__all__ = ["METHOD_NAMES", "Location", "another_cross", "box_twin", "locate", "one_mark", "panel_box", "screen_box",
           "search_box", "two_panels"]
