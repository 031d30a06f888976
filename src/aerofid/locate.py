"""``aerofid.locate``: the operator's box in, the mark's sub-pixel centre (or an explicit "not found") out.

The box is clipped to the image, only its window is read (tiled TIFFs decode only the tiles it touches),
colour is reduced to grey by a policy that keeps the mark's contrast, dark marks are inverted so every
detector sees a bright mark, and the chosen method's detector runs on the window. Coordinates everywhere:
x = column, y = row, the centre of the top-left pixel is (0, 0); boxes (x0, y0, x1, y1) with x1, y1
exclusive.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from aerofid.detect import METHODS, available_methods, detector
from aerofid.detect.result import FOUND, NOT_FOUND, Detection
from aerofid.errors import AerofidInputError
from aerofid.io.raster import check_window_size, clip_box, open_raster, to_grey

MARKS = ("auto", "external", "panel")
"""Kinds of mark: an external (film) fiducial, a cloth ground panel, or let the detector decide."""
POLARITIES = ("bright", "dark", "auto")
"""The mark is brighter than its ground (most fiducials), darker (negatives, some panels), or either."""

AUTO_METHODS = ("circles", "symmetry", "hough", "lines")
"""The detectors ``method="auto"`` may use; which of them run, how they are cross-checked and which answer
is trusted is the rule of :mod:`aerofid.detect.auto`."""


@dataclass(frozen=True)
class Location:
    """The answer of :func:`locate`, in full-image pixels.

    ``status`` is "found" or "not_found"; ``x``, ``y`` the centre (NaN when not found); ``score`` the
    detector's confidence in [0, 1] (for ``hough``: the similarity metric of seed 001); ``sigma`` the
    standard deviation of the centre per axis in px; ``box`` the box actually searched (clipped to the
    image; ``clipped`` says whether it had to be); ``detection`` the detector's full answer with its
    diagnostics (in window pixels; the window's top-left pixel is ``box[:2]``); ``window`` the grey
    window the detector saw.
    """

    status: str
    x: float
    y: float
    score: float
    sigma: float
    method: str
    mark: str
    polarity: str
    box: tuple[int, int, int, int]
    requested_box: tuple[float, float, float, float]
    clipped: bool
    reason: str = ""
    image: str | None = None
    detection: Detection | None = field(default=None, repr=False, compare=False)
    window: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def found(self) -> bool:
        return self.status == FOUND

    def to_dict(self) -> dict[str, Any]:
        """Scalars only, ready for JSON (NaN becomes None)."""
        def num(v):
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


def read_box(image: str | os.PathLike | np.ndarray, box) -> tuple[np.ndarray, tuple[int, int, int, int], bool, str | None]:
    """The window of ``image`` under ``box`` (clipped to the image): (window, clipped box, was clipped, path)."""
    if isinstance(image, (str, os.PathLike)):
        with open_raster(image) as r:
            clipped, was = clip_box(box, r.width, r.height)
            check_window_size(clipped, r.bands, r.dtype.itemsize)
            return r.read_window(clipped), clipped, was, str(Path(image))
    a = _as_array(image)
    clipped, was = clip_box(box, a.shape[1], a.shape[0])
    x0, y0, x1, y1 = clipped
    return a[y0:y1, x0:x1], clipped, was, None


def _check_auto_params(params: dict) -> None:
    """``method="auto"`` passes the user's parameters to ``hough``: check them before anything runs."""
    from aerofid.detect.hough.analysis import HoughParams
    from aerofid.detect.hough.search import SearchParams

    extra = {"verify", "min_arm_balance", "min_arm_snr"}
    hk, sk = set(HoughParams.__dataclass_fields__), set(SearchParams.__dataclass_fields__)
    unknown = set(params) - hk - sk - extra
    if unknown:
        raise AerofidInputError(f"unknown parameter(s) for method 'auto' (which passes them to 'hough'): "
                                f"{', '.join(sorted(unknown))}")
    try:
        HoughParams(**{k: v for k, v in params.items() if k in hk})
        SearchParams(**{k: v for k, v in params.items() if k in sk})
    except (TypeError, ValueError) as e:
        raise AerofidInputError(f"bad parameter for method 'auto': {e}") from None


def _run(method: str, grey: np.ndarray, mark: str, params: dict) -> Detection:
    if method == "auto":
        from aerofid.detect.auto import detect_auto, make_runner

        have = available_methods()
        return detect_auto(grey, mark, run=make_runner(mark, params),
                           methods=[m for m in AUTO_METHODS if m in have])
    fn = detector(method)
    kwargs = dict(params)
    if method == "hough":
        kwargs["mark"] = mark
    try:
        return fn(grey, **kwargs)
    except (TypeError, ValueError) as e:
        raise AerofidInputError(f"bad parameter for method {method!r}: {e}") from None


def locate(image: str | os.PathLike | np.ndarray, box, mark: str = "auto", method: str = "auto",
           polarity: str = "bright", colour: str = "auto", **params) -> Location:
    """Locate the mark inside ``box`` of ``image``.

    Args:
        image: a path (TIFF/BigTIFF/GeoTIFF, JPEG, PNG) or a 2-D grey / (h, w, 3) RGB numpy array.
        box: (x0, y0, x1, y1) in full-image pixels, x1 and y1 exclusive; a box partly outside the image is
            clipped (``Location.clipped``), one wholly outside is an error.
        mark: "external" (film fiducial), "panel" (cloth ground panel) or "auto".
        method: "hough" (Hunt, Ryan & Gifford), "symmetry" (Cho & Kim), "circles" (Seedahmed), "lines"
            (Sohn et al.) runs that one detector; "auto" runs the detectors that apply, cross-checks them and
            answers only with a corroborated, verified centre (:mod:`aerofid.detect.auto`; ``score`` is then
            comparable across methods and ``method`` names the detector whose centre is returned).
        polarity: "bright" marks on darker ground (the seed's case), "dark" marks on brighter ground, or
            "auto" (both are tried; the more confident answer wins).
        colour: how RGB becomes grey: "auto" (the channel mix with the most mark contrast), "luminance",
            "red", "green", "blue" or "max".
        **params: the method's parameters (e.g. ``window_size=24``, ``rho_step=0.5``, ``theta_step=5``,
            ``hough_threshold=0.3``); see :class:`aerofid.detect.hough.analysis.HoughParams` and
            :class:`aerofid.detect.hough.search.SearchParams`.

    Returns:
        :class:`Location`; "not found" is a status, never an exception.

    Raises:
        AerofidInputError: bad input (missing/corrupt file, box outside the image, unknown option...).
    """
    if mark not in MARKS:
        raise AerofidInputError(f"unknown mark {mark!r}; use one of {', '.join(MARKS)}")
    if polarity not in POLARITIES:
        raise AerofidInputError(f"unknown polarity {polarity!r}; use one of {', '.join(POLARITIES)}")
    known = ("auto", *METHODS)
    if method not in known:
        raise AerofidInputError(f"unknown method {method!r}; use one of {', '.join(known)}")
    have = available_methods()
    if method != "auto" and method not in have:
        raise AerofidInputError(f"method {method!r} is not available in this installation; use one of {', '.join(have)}")
    window, clipped, was_clipped, path = read_box(image, _box_tuple(box))
    requested = tuple(float(v) for v in _box_tuple(box))
    if method == "auto":
        _check_auto_params(params)
    methods = [method]
    polarities = ("bright", "dark") if polarity == "auto" else (polarity,)
    best: tuple[Detection, str, np.ndarray] | None = None
    for pol in polarities:
        grey = to_grey(window, colour, pol)
        if pol == "dark":
            grey = 1.0 - grey
        for m in methods:
            det = _run(m, grey, mark, params)
            if best is None or _better(det, best[0]):
                best = (det, pol, grey)
    det, pol, grey = best
    x0, y0 = clipped[0], clipped[1]
    return Location(status=det.status, x=det.x + x0, y=det.y + y0, score=det.score, sigma=det.sigma,
                    method=det.method, mark=mark, polarity=pol, box=clipped, requested_box=requested,
                    clipped=was_clipped, reason=det.reason, image=path, detection=det, window=grey)


def _better(a: Detection, b: Detection) -> bool:
    """Is ``a`` a more reliable answer than ``b``? Found beats not found, then the higher score."""
    if a.found != b.found:
        return a.found
    return a.score > b.score


def _box_tuple(box) -> tuple:
    try:
        t = tuple(box)
    except TypeError:
        raise AerofidInputError(f"box {box!r} is not four numbers; give (x0, y0, x1, y1) in pixels") from None
    return t


__all__ = ["Location", "MARKS", "NOT_FOUND", "POLARITIES", "locate", "read_box"]
