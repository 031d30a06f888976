"""A roll's mark templates: each fiducial's mark as the learnt frame showed it, reduced, so that the roll's other
frames find it again fast where the film may have moved (issue 12: the profile stores "what this roll's marks look
like" and is used "to search smaller areas").

The seed methods measure a mark on a window drawn round it. Cho & Kim's symmetry (seed 002) looks for the centre
within such a window and refuses one in which the mark may lie anywhere: on a frame of the roll the first fiducials
may lie up to :data:`aerofid.frame.roll_areas.ROLL_SHIFT_MM` from where the learnt frame had them, five radii of a
Wild mark at 21 um, and on such an area it fails about as often as it finds the mark. Where the learnt frame's mark
correlates best (normalised cross-correlation, :func:`match_template`) over that area of the scan reduced by the
template's factor is where the method measures the mark at full resolution, on its usual window. The template
says only where to look, to a reduced pixel or two; the centre is the method's, as on the learnt frame, and the
frame's geometry checks the marks found. A template that finds nothing as alike as :data:`MIN_CORRELATION` (a
frame of another lie, a mark damaged) leaves the search to the method.
"""

from __future__ import annotations

import base64
import binascii
import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from aerofid.detect.params import is_int, number_in
from aerofid.errors import AerofidInputError

TEMPLATE_RADIUS = 16.0
"""A template is reduced by the power of two that keeps the mark's radius at least this many px
(:func:`reduction_keeping`): the correlation then sees the mark's rings and arms, at a sixteenth of the pixels of an
11000^2 scan's Wild marks (94 px)."""
TEMPLATE_REACH = 1.5
"""A template holds the learnt frame's pixels within this many mark radii of the centre: the mark and a little of
its ground."""
MIN_CORRELATION = 0.5
"""Least correlation at which a template's best place is taken as the mark: the synthetic frames' marks correlate
at 0.9 and more across a roll; aerial texture and the film's edge stay below 0.4."""
MAX_TEMPLATE_SIDE = 256
"""Largest side (px) of a stored template."""
MAX_FACTOR = 64
"""Largest reduction of a stored template (a mark of 1000 px radius at 16)."""


def reduction_keeping(radius: float, least: float) -> int:
    """The largest power of two that reduces marks of ``radius`` px to no fewer than ``least`` px (1: none).

    Examples
    --------
    >>> reduction_keeping(94.0, 16.0), reduction_keeping(40.0, 16.0), reduction_keeping(10.0, 16.0)
    (4, 2, 1)
    """
    return 2 ** max(0, math.floor(math.log2(radius / least))) if radius > 0 else 1


@dataclass(frozen=True)
class MarkTemplate:
    """One fiducial's mark on the learnt frame, reduced by ``factor`` (block means on the grid of
    :class:`aerofid.io.reduce.ReducedView`), the mark bright, as 8-bit levels (``levels``: ``shape`` row-major;
    the correlation does not depend on the levels' scale). ``centre``: the mark's centre in template pixels
    (x = column, y = row)."""

    factor: int
    shape: tuple[int, int]
    centre: tuple[float, float]
    levels: bytes

    def __post_init__(self) -> None:
        if not (is_int(self.factor) and 1 <= self.factor <= MAX_FACTOR and not self.factor & (self.factor - 1)):
            raise AerofidInputError(f"a template's factor must be a power of two up to {MAX_FACTOR}")
        if not (len(self.shape) == 2 and all(is_int(n) and 3 <= n <= MAX_TEMPLATE_SIDE for n in self.shape)):
            raise AerofidInputError(f"template shape {self.shape!r} must be two whole numbers of 3 to "
                                    f"{MAX_TEMPLATE_SIDE} px")
        h, w = self.shape
        if not isinstance(self.levels, bytes) or len(self.levels) != h * w:
            raise AerofidInputError(f"template levels do not fill its shape {self.shape}")
        if len(set(self.levels)) < 2:
            raise AerofidInputError("a template without contrast (one level) finds no mark")
        if not (len(self.centre) == 2 and number_in(self.centre[0], 0, w - 1) and number_in(self.centre[1], 0, h - 1)):
            raise AerofidInputError(f"template centre {self.centre!r} must lie inside its shape {self.shape}")

    @property
    def image(self) -> np.ndarray:
        """The template as float32 grey levels."""
        return np.frombuffer(self.levels, np.uint8).reshape(self.shape).astype(np.float32)

    def to_dict(self) -> dict[str, Any]:
        return {"factor": self.factor, "shape": list(self.shape), "centre": list(self.centre),
                "levels": base64.b64encode(self.levels).decode("ascii")}

    @classmethod
    def from_dict(cls, d: Any) -> MarkTemplate:
        """The template :meth:`to_dict` wrote; anything else is an :class:`AerofidInputError` saying what."""
        if not (isinstance(d, dict) and {"factor", "shape", "centre", "levels"} <= d.keys()):
            raise AerofidInputError("a mark template must hold factor, shape, centre and levels")
        shape, centre, text = d["shape"], d["centre"], d["levels"]
        if not (isinstance(shape, list) and isinstance(centre, list) and isinstance(text, str)):
            raise AerofidInputError("a mark template's shape and centre must be lists, its levels base64 text")
        try:
            levels = base64.b64decode(text.encode("ascii"), validate=True)
        except (binascii.Error, UnicodeEncodeError):
            raise AerofidInputError("a mark template's levels are not base64") from None
        return cls(d["factor"], tuple(shape), tuple(centre), levels)


def cut_template(window: np.ndarray, box: tuple[int, int, int, int], x: float, y: float,
                 radius: float) -> MarkTemplate | None:
    """The template of the mark centred at (x, y) (full px) of ``radius`` px on ``window`` (grey, the mark bright,
    the image's pixels ``box``): the window's pixels within :data:`TEMPLATE_REACH` radii of the centre, reduced by
    :func:`reduction_keeping` in whole blocks of the reduced scan's grid. None where the window does not hold the
    mark's own disc (a mark cut by the scan's edge) or the mark has no contrast."""
    f = reduction_keeping(radius, TEMPLATE_RADIUS)
    reach = TEMPLATE_REACH * radius
    x0, y0 = max(box[0], math.floor(x - reach)), max(box[1], math.floor(y - reach))
    x1, y1 = min(box[2], math.ceil(x + reach) + 1), min(box[3], math.ceil(y + reach) + 1)
    bx0, by0 = -(-x0 // f), -(-y0 // f)                    # whole blocks of the grid within the window
    bx1, by1 = x1 // f, y1 // f
    if min(x - bx0 * f, y - by0 * f, bx1 * f - 1 - x, by1 * f - 1 - y) < radius:
        return None
    part = np.asarray(window, np.float64)[by0 * f - box[1]:by1 * f - box[1], bx0 * f - box[0]:bx1 * f - box[0]]
    reduced = part.reshape(by1 - by0, f, bx1 - bx0, f).mean(axis=(1, 3))
    lo, hi = float(reduced.min()), float(reduced.max())
    if not hi > lo or max(reduced.shape) > MAX_TEMPLATE_SIDE:
        return None
    levels = np.round((reduced - lo) / (hi - lo) * 255).astype(np.uint8)
    centre = ((x - (f - 1) / 2) / f - bx0, (y - (f - 1) / 2) / f - by0)
    return MarkTemplate(f, (int(levels.shape[0]), int(levels.shape[1])), (float(centre[0]), float(centre[1])),
                        levels.tobytes())


def match_template(area: np.ndarray, template: MarkTemplate) -> tuple[float, float, float] | None:
    """Where in ``area`` (grey, the mark bright, reduced by the template's factor) the template's mark lies (x, y in
    ``area``'s pixels: the best correlation's place, to a tenth of a pixel by a parabola through its neighbours)
    and that correlation; None where the area cannot hold the template or nothing correlates
    :data:`MIN_CORRELATION`."""
    img = template.image
    if area.shape[0] < img.shape[0] or area.shape[1] < img.shape[1]:
        return None
    score = cv2.matchTemplate(np.asarray(area, np.float32), img, cv2.TM_CCOEFF_NORMED)
    j, i = np.unravel_index(int(np.argmax(score)), score.shape)
    best = float(score[j, i])
    if not best >= MIN_CORRELATION:
        return None
    dx = _vertex(score[j, i - 1:i + 2]) if 0 < i < score.shape[1] - 1 else 0.0
    dy = _vertex(score[j - 1:j + 2, i]) if 0 < j < score.shape[0] - 1 else 0.0
    return i + dx + template.centre[0], j + dy + template.centre[1], best


def turned(image: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """``image`` as a scan whose pixel axes are ``turn`` (2 x 2, a signed permutation of x and y) of its own shows it:
    ``out[d] = image[turn^-1 d]`` for pixel offsets d = (x, y) from the centre.

    >>> a = np.arange(6).reshape(2, 3)
    >>> turned(a, np.array([[0, -1], [1, 0]])).tolist()     # x' = -y, y' = x: a quarter turn
    [[3, 0], [4, 1], [5, 2]]
    """
    m = np.rint(turn).astype(int)
    swapped = m[0, 0] == 0
    out = image.T if swapped else image
    sx, sy = (m[0, 1], m[1, 0]) if swapped else (m[0, 0], m[1, 1])
    return out[::sy, ::sx]


def agreement(patch: np.ndarray, template: MarkTemplate, centre: tuple[float, float], turn: np.ndarray,
              reach: int = 4) -> float:
    """How alike ``template``'s mark, turned by ``turn`` (:func:`turned`), and the mark at ``centre`` (x, y) of
    ``patch`` (grey, the mark bright, reduced by the template's factor) are: the best normalised cross-correlation with
    the template's centre within ``reach`` px of it; nan where ``patch`` does not hold the template there."""
    img = turned(template.image, turn)
    h0, w0 = template.shape
    d = np.rint(turn).astype(int) @ np.array([template.centre[0] - (w0 - 1) / 2, template.centre[1] - (h0 - 1) / 2])
    h, w = img.shape
    x0 = int(round(centre[0] - (d[0] + (w - 1) / 2))) - reach
    y0 = int(round(centre[1] - (d[1] + (h - 1) / 2))) - reach
    if x0 < 0 or y0 < 0 or y0 + h + 2 * reach > patch.shape[0] or x0 + w + 2 * reach > patch.shape[1]:
        return math.nan
    part = np.ascontiguousarray(patch[y0:y0 + h + 2 * reach, x0:x0 + w + 2 * reach], np.float32)
    return float(cv2.matchTemplate(part, np.ascontiguousarray(img), cv2.TM_CCOEFF_NORMED).max())


def _vertex(three: np.ndarray) -> float:
    """The vertex of the parabola through three samples at -1, 0, 1 (within half a sample of the middle one)."""
    a, b, c = (float(v) for v in three)
    den = a - 2 * b + c
    return float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) if den < 0 else 0.0


__all__ = ["MIN_CORRELATION", "MarkTemplate", "TEMPLATE_RADIUS", "TEMPLATE_REACH", "agreement", "cut_template",
           "match_template", "reduction_keeping", "turned"]
