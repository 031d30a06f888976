"""``aerofid.locate``: the operator's box in, the mark's sub-pixel centre (or an explicit "not found") out.

The box is clipped to the image, only its window is read (tiled TIFFs decode only the tiles it touches),
colour is reduced to grey by a policy that keeps the mark's contrast, dark marks are inverted so every
detector sees a bright mark, and the chosen method (:mod:`aerofid.detect.registry`) runs on the window.
Coordinates everywhere: x = column, y = row, the centre of the top-left pixel is (0, 0); boxes (x0, y0, x1,
y1) with x1, y1 exclusive.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from aerofid.conventions import FOUND, MARKS, POLARITY_CHOICES, Box, Polarity
from aerofid.detect import auto
from aerofid.detect.params import MethodParams
from aerofid.detect.registry import METHODS, route_params
from aerofid.detect.result import Detection
from aerofid.errors import AerofidInputError
from aerofid.io.colour import to_grey
from aerofid.io.raster import Raster, check_window_size, clip_box, open_raster


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
        Standard deviation of the centre per axis (px).
    method, mark, polarity : str
        The method whose centre is returned, the kind of mark asked for, the polarity that answered.
    box : tuple of int
        The box actually searched (clipped to the image; ``clipped`` says whether it had to be).
    requested_box : tuple of float
        The box as given.
    detection : Detection
        The method's full typed answer (in window pixels; the window's top-left pixel is ``box[:2]``).
    window : ndarray
        The grey window the detector saw (mark bright).
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
    detection: Detection | None = field(default=None, repr=False, compare=False)
    window: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def found(self) -> bool:
        """True when a mark was located."""
        return self.status == FOUND

    def to_dict(self) -> dict[str, Any]:
        """Scalars only, ready for JSON (NaN becomes None)."""
        def num(v: float) -> float | None:
            return None if v is None or not np.isfinite(v) else float(v)

        return {
            "status": self.status, "x": num(self.x), "y": num(self.y), "score": num(self.score),
            "sigma": num(self.sigma), "method": self.method, "mark": self.mark, "polarity": self.polarity,
            "box": list(self.box), "requested_box": list(self.requested_box), "clipped": self.clipped,
            "reason": self.reason, "image": self.image,
        }


def _as_array(image: np.ndarray) -> np.ndarray:
    a = np.asarray(image)
    if a.ndim == 3 and a.shape[2] == 4:
        a = a[:, :, :3]
    if not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] == 3)):
        raise AerofidInputError(f"image array has shape {a.shape}; give a 2-D grey or (h, w, 3) RGB array")
    if a.size == 0:
        raise AerofidInputError("image array is empty")
    if not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)) or a.dtype == bool:
        raise AerofidInputError(f"image array has dtype {a.dtype}; give unsigned integers or floats")
    return a


def read_box(image: str | os.PathLike[str] | np.ndarray | Raster,
             box: Sequence[float]) -> tuple[np.ndarray, Box, bool, str | None]:
    """The window of ``image`` under ``box`` (clipped to the image): (window, clipped box, was clipped, path).
    ``image`` may be an open :class:`~aerofid.io.raster.Raster` (several boxes, one opening)."""
    if isinstance(image, Raster):
        clipped, was = clip_box(box, image.width, image.height)
        check_window_size(clipped, image.bands, image.dtype.itemsize)
        return image.read_window(clipped), clipped, was, str(image.path)
    if isinstance(image, str | os.PathLike):
        with open_raster(image) as r:
            clipped, was = clip_box(box, r.width, r.height)
            check_window_size(clipped, r.bands, r.dtype.itemsize)
            return r.read_window(clipped), clipped, was, str(Path(image))
    a = _as_array(image)
    clipped, was = clip_box(box, a.shape[1], a.shape[0])
    x0, y0, x1, y1 = clipped
    return a[y0:y1, x0:x1], clipped, was, None


Detector = Callable[[np.ndarray], Detection]
"""One configured method: grey window (mark bright) -> its answer."""


METHOD_NAMES = ("auto", *METHODS)
"""What ``method`` may be: ``auto`` or one of the seeds' methods (:data:`aerofid.detect.registry.METHODS`)."""


def make_detector(method_name: str, mark: str, params: Mapping[str, Any]) -> Detector:
    """The configured method ``method_name`` for ``mark`` with the user's ``params`` (checked now, before
    any pixel is read: unknown names and bad values are one-line input errors naming the valid ones).
    ``auto`` routes each parameter to the methods that take it (:func:`~aerofid.detect.registry.route_params`)."""
    _check_choice(method_name, METHOD_NAMES, "method")
    if method_name == "auto":
        types: dict[str, type[MethodParams]] = {"auto": auto.AutoParams}
        types.update({m: METHODS[m].params_type for m in METHODS})
        routed = route_params({"mark": mark, **params}, types)
        auto_params = routed.pop("auto")
        assert isinstance(auto_params, auto.AutoParams)
        return lambda grey: auto.detect(grey, auto_params, methods=routed)
    m = METHODS[method_name]
    values = dict(params)
    if "mark" in m.params_type.names():
        values["mark"] = mark
    p = m.params_type.from_mapping(values, method_name)
    return lambda grey: m.detect(grey, p)


def _check_choice(value: str, choices: Sequence[str], what: str) -> None:
    if value not in choices:
        raise AerofidInputError(f"unknown {what} {value!r}; use one of {', '.join(choices)}")


def locate(image: str | os.PathLike[str] | np.ndarray | Raster, box: Sequence[float], mark: str = "auto",
           method: str = "auto", polarity: str = "bright", colour: str = "auto", **params: Any) -> Location:
    """Locate the mark inside ``box`` of ``image``.

    Parameters
    ----------
    image : path or ndarray
        A path (TIFF/BigTIFF/GeoTIFF, JPEG, PNG), a 2-D grey / (h, w, 3) RGB numpy array, or a scan opened
        once with :func:`aerofid.io.raster.open_raster` for several boxes.
    box : (x0, y0, x1, y1)
        Full-image pixels, x1 and y1 exclusive; a box partly outside the image is clipped
        (``Location.clipped``), one wholly outside is an error.
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
        "not found" is a status, never an exception.

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
    _check_choice(mark, MARKS, "mark")
    _check_choice(polarity, POLARITY_CHOICES, "polarity")
    detector = make_detector(method, mark, params)
    window, clipped, was_clipped, path = read_box(image, _box_tuple(box))
    polarities: tuple[Polarity, ...] = ("bright", "dark") if polarity == "auto" else (polarity,)  # type: ignore[assignment]
    best: tuple[Detection, Polarity, np.ndarray] | None = None
    for pol in polarities:
        grey = to_grey(window, colour, pol)
        if pol == "dark":
            grey = 1.0 - grey
        det = detector(grey)
        if best is None or _better(det, best[0]):
            best = (det, pol, grey)
    assert best is not None
    det, chosen, grey = best
    x0, y0 = clipped[0], clipped[1]
    return Location(status=det.status, x=det.x + x0, y=det.y + y0, score=det.score, sigma=det.sigma,
                    method=det.method, mark=mark, polarity=chosen, box=clipped,
                    requested_box=tuple(float(v) for v in _box_tuple(box)),  # type: ignore[arg-type]
                    clipped=was_clipped, reason=det.reason, image=path, detection=det, window=grey)


def _better(a: Detection, b: Detection) -> bool:
    """Is ``a`` a more reliable answer than ``b``? Found beats not found, then the higher score."""
    if a.found != b.found:
        return a.found
    return a.score > b.score


def _box_tuple(box: Sequence[float]) -> tuple[float, ...]:
    try:
        t = tuple(box)
    except TypeError:
        raise AerofidInputError(f"box {box!r} is not four numbers; give (x0, y0, x1, y1) in pixels") from None
    return t


__all__ = ["METHOD_NAMES", "Location", "locate", "make_detector", "read_box"]
