"""Where else a window holds a mark like the one found (beyond the seeds): the mark's own image, turned, matched.

``auto``'s uniqueness check asks whether a box holds a second mark like the one it answers. For a cloth panel on
aerial ground the seed's own search (Hunt, Ryan & Gifford's Hough spiral over the blanked window) is a weak and
slow judge: its similarity metric scores a second panel in clutter anywhere from 0.03 to 0.9, and it stops after
a few refused candidates, before it has seen the whole window. The found mark itself is the best template of a
second one of the same survey: :func:`turned_matches` correlates it, turned through the mark's own period of
rotation ('+': a quarter turn), with every position of the window (OpenCV's normalised correlation coefficient,
``TM_CCOEFF_NORMED``), and :func:`match_peaks` lists the best places, for a fit to decide.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

TURN_STEP = 10.0
"""Degrees between the turned templates: a half step (5 degrees) moves the end of a 6 px arm by 0.5 px."""
PEAK_SEPARATION = 2
"""Peaks closer than this many px (a 5 x 5 neighbourhood) are one."""


@dataclass(frozen=True, eq=False)
class Matches:
    """Per position of a template's centre pixel in the window (offset ``half`` from the map's origin): the best
    correlation over the turns, and the turn (degrees) that gave it; ``offset``: where in its centre pixel the
    template's mark lies (x, y), so that a match at pixel p puts the mark at p + offset."""

    score: np.ndarray
    turn: np.ndarray
    half: int
    offset: tuple[float, float]


def turned_matches(image: np.ndarray, window: np.ndarray, x: float, y: float, half: int,
                   period: float = 90.0, step: float = TURN_STEP) -> Matches | None:
    """The square of half-size ``half`` around (x, y) in ``image``, turned by 0, ``step``, ... below ``period``
    degrees about (x, y) (bilinear), each matched with ``window`` (same pixel grid as ``image``: e.g. the image
    with the mark blanked out); None when what the turned square needs of ``image`` (``half`` sqrt 2 + 1 px
    around) leaves it, the square is flat, or the window is smaller than the template.

    Examples
    --------
    >>> img = np.zeros((40, 60), np.float32); img[18:23, 10:13] = img[19:22, 9:14] = 1.0
    >>> img[8:13, 45:48] = img[9:12, 44:49] = 1.0            # the same '+' 35 px right, 10 px up
    >>> m = turned_matches(img, img, 11.0, 20.0, 4)
    >>> [(round(s, 2), x, y) for s, x, y, _ in match_peaks(m, 11.0, 20.0, 5.0, 0.5, 1)]
    [(1.0, 46.0, 10.0)]
    """
    big = int(np.ceil(half * np.sqrt(2.0))) + 1
    cx, cy = int(round(x)), int(round(y))
    h, w = image.shape
    if cx - big < 0 or cy - big < 0 or cx + big >= w or cy + big >= h or min(window.shape) < 2 * half + 1:
        return None
    crop = np.ascontiguousarray(image[cy - big:cy + big + 1, cx - big:cx + big + 1], np.float32)
    inner = slice(big - half, big + half + 1)
    if float(crop[inner, inner].std()) < 1e-6:
        return None   # a flat template correlates 1 with everything
    target = np.ascontiguousarray(window, np.float32)
    centre = (x - (cx - big), y - (cy - big))
    angles = np.arange(0.0, period - 1e-9, step)
    maps = []
    for angle in angles:
        m = cv2.getRotationMatrix2D(centre, float(angle), 1.0)
        turned = cv2.warpAffine(crop, m, crop.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        maps.append(cv2.matchTemplate(target, np.ascontiguousarray(turned[inner, inner]), cv2.TM_CCOEFF_NORMED))
    best = np.argmax(maps, axis=0)                    # the first turn of equals
    score = np.take_along_axis(np.asarray(maps), best[None], axis=0)[0]
    turn = angles[best]
    return Matches(score, turn, half, (x - cx, y - cy))


def match_peaks(matches: Matches, x: float, y: float, exclude: float, minimum: float,
                count: int) -> list[tuple[float, float, float, float]]:
    """The ``count`` best local maxima of ``matches`` of at least ``minimum``, further than ``exclude`` px from
    (x, y) (the mark itself), best first: (score, x, y, turn), the mark's place in window pixels (to a pixel)."""
    s = matches.score.astype(np.float32)
    dx, dy = matches.offset
    yy, xx = np.mgrid[0:s.shape[0], 0:s.shape[1]] + matches.half
    s = np.where(np.hypot(xx + dx - x, yy + dy - y) > exclude, s, -1.0).astype(np.float32)
    k = 2 * PEAK_SEPARATION + 1
    top = (s == cv2.dilate(s, np.ones((k, k), np.uint8))) & (s >= minimum)
    rows, cols = np.nonzero(top)
    order = np.argsort(-s[rows, cols], kind="stable")[:count]
    return [(float(s[rows[i], cols[i]]), float(cols[i] + matches.half + dx), float(rows[i] + matches.half + dy),
             float(matches.turn[rows[i], cols[i]])) for i in order]


__all__ = ["PEAK_SEPARATION", "TURN_STEP", "Matches", "match_peaks", "turned_matches"]
