"""Grey levels from scan windows: normalisation to [0, 1] and the colour policy (which channel mix turns an
RGB window into grey, chosen per window by the contrast it gives the mark). Pure functions on arrays; reading
windows lives in :mod:`aerofid.io.raster`."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aerofid.conventions import POLARITIES, Polarity
from aerofid.errors import AerofidInputError
from aerofid.robust import difference_noise_sigma, percentiles

__all__ = [
    "BRIGHT_SHARE",
    "COLOUR_POLICIES",
    "LEAST_SIGNIFICANT_BITS",
    "MIX_WEIGHTS",
    "channel_mix",
    "choose_channel_mix",
    "first_look_white",
    "luminance_first",
    "mark_contrast",
    "normalise",
    "saturated",
    "to_grey",
]

COLOUR_POLICIES = ("auto", "luminance", "red", "green", "blue", "max")

#: Weights of the channel mixes that ``to_grey(policy="auto")`` chooses among. Luminance uses the
#: ITU-R BT.601 luma weights, as OpenCV and Pillow do.
MIX_WEIGHTS = {
    "luminance": (0.299, 0.587, 0.114),
    "red": (1.0, 0.0, 0.0),
    "green": (0.0, 1.0, 0.0),
    "blue": (0.0, 0.0, 1.0),
}
#: Noise floor (grey levels in [0, 1]) for float windows, which have no quantisation step.
FLOAT_NOISE_FLOOR = 1e-6




def normalise(window: np.ndarray, white: float | None = None) -> np.ndarray:
    """Return ``window`` as float32 grey levels, on [0, 1] for a scan's samples up to ``white``.

    Integer samples are divided by ``white``, the full scale a search reads its scan at (:func:`first_look_white`),
    by default the largest value of their dtype (255 for uint8, 65535 for uint16); one above a ``white`` below that
    is read as 1, as a scan of the full range saturates (a hot pixel would otherwise outshine every mark). Float
    samples are returned unchanged, as float32.
    """
    array = np.asarray(window)
    if array.dtype.kind in "ui":
        top = np.iinfo(array.dtype).max
        return saturated(array.astype(np.float32) / np.float32(white or top), white, top)
    if array.dtype.kind == "f":
        return array.astype(np.float32, copy=False)
    raise AerofidInputError(
        f"cannot use samples of type {array.dtype} as grey levels; give integer or float samples"
    )


def saturated(grey: np.ndarray, white: float | None, top: int) -> np.ndarray:
    """``grey`` (float32 levels of integer samples of largest value ``top`` read at full scale ``white``) with the
    levels above 1 set to 1 where ``white`` lies below ``top``, in place: a scan of fewer bits than its dtype's
    saturates at its white as one of the full range does at ``top``."""
    if white and white < top:
        np.minimum(grey, np.float32(1.0), out=grey)
    return grey


def _noise_floor(dtype: np.dtype, white: float | None = None) -> float:
    """Smallest noise level worth believing for samples of ``dtype`` read at full scale ``white`` (:func:`normalise`),
    in grey levels."""
    if dtype.kind in "ui":
        return 1.0 / float(white or np.iinfo(dtype).max)
    return FLOAT_NOISE_FLOOR


LEAST_SIGNIFICANT_BITS = 12
"""Integer samples wider than 8 bits whose first look (:func:`first_look_white`) uses fewer than this many bits are
read at the scale of the bits they use: a 16-bit file that holds a 10-bit scan, or an 8-bit scan widened without
scaling, spans 1.6 % or 0.4 % of 65535, under the detectors' least grey range (2 %: a homogeneous window), and none
of its marks was found (session 58). From 12 bits on (3 % of 65535 or more) the dtype's scale, as always."""
BRIGHT_SHARE = 1e-4
"""Share of a first look's samples, the brightest, that :func:`first_look_white` passes over, one at least (a hot
pixel, a speck of dust against the light: a 60 px box of a 10-bit scan with one was still read on 65535's scale)."""


def first_look_white(levels: np.ndarray, dtype: np.dtype) -> float | None:
    """The full scale (a sample value) a search reads a scan of ``dtype`` at, from the grey levels of its first look
    (its region, or a whole frame, read reduced on the dtype's scale): None (the dtype's largest) but for integers
    wider than 8 bits whose brightest levels, a :data:`BRIGHT_SHARE` of them passed over, use fewer than
    :data:`LEAST_SIGNIFICANT_BITS` bits; then ``2^(b + 1) - 1`` for the ``b`` bits they use (at least 8): one bit above,
    for the marks' pixels brighter than the blocks of a reduced look. A sample above it is read as 1.

    >>> looks = [np.full((100, 100), v / 65535.0) for v in (230.0, 920.0, 3000.0)]
    >>> [first_look_white(a, np.dtype(np.uint16)) for a in looks]
    [511.0, 2047.0, None]
    >>> hot = looks[1].copy(); hot[0, 0] = 1.0
    >>> first_look_white(hot, np.dtype(np.uint16)), first_look_white(looks[0], np.dtype(np.uint8))
    (2047.0, None)
    """
    if dtype.kind not in "ui" or np.iinfo(dtype).max <= 255 or levels.size == 0:
        return None
    flat = np.asarray(levels, np.float64).ravel()
    rank = max(flat.size - 1 - max(1, int(flat.size * BRIGHT_SHARE)), 0)
    bright = float(np.partition(flat, rank)[rank]) * float(np.iinfo(dtype).max)
    bits = max(8, round(max(bright, 0.0)).bit_length())
    return None if bits >= LEAST_SIGNIFICANT_BITS else float(2 ** (bits + 1) - 1)


def mark_contrast(grey: np.ndarray, polarity: Polarity = "bright", *, noise_floor: float) -> float:
    """Contrast of a mark in a grey window relative to the window's noise.

    For ``polarity="bright"`` the signal is the 99th percentile minus the median; for ``"dark"`` it is the
    median minus the 1st percentile. The noise is the pixel noise from the first differences
    (:func:`~aerofid.robust.difference_noise_sigma`), floored at ``noise_floor`` so that a flat background does not
    divide by 0. The spread of the grey levels themselves (their MAD) is no measure of the noise where the mark fills
    much of the window: a Wild RC20 ring 45 px across in the middle half of its box spreads the red channel's levels
    3 times as wide as its noise, and with noise of 10 grey levels in every channel the channel without the mark
    then scored highest.
    """
    _check_choice(polarity, POLARITIES, "polarity")
    low, middle, high = (np.float64(v) for v in percentiles(grey, (1.0, 50.0, 99.0)))   # as np.percentile's
    signal = high - middle if polarity == "bright" else middle - low
    return float(signal) / max(difference_noise_sigma(grey), noise_floor)


def channel_mix(rgb: np.ndarray, mix: str) -> np.ndarray:
    """Mix an ``(h, w, 3)`` float window to grey: ``"max"`` of the channels, or a weighted sum from
    :data:`MIX_WEIGHTS` (``"luminance"``, ``"red"``, ``"green"``, ``"blue"``)."""
    if mix == "max":
        return rgb.max(axis=-1)
    return rgb @ np.asarray(MIX_WEIGHTS[mix], dtype=np.float32)


MIX_CENTRE_MIN = 32
"""Windows at least this many px across judge the channel mixes on their central half (below: the whole)."""

LUMA_SHARE = 0.4
"""Where the file stores its chroma subsampled (a 4:2:0 JPEG), luminance is taken whenever it gives the mark at
least this share of the best mix's contrast (:func:`mark_contrast`). Luminance is then the one mix at the file's full
resolution (the BT.601 weights of :data:`MIX_WEIGHTS` are the JPEG's own Y); the red, green and blue channels carry
the chroma planes, sampled on a grid of 2 x 2 px by the encoder and interpolated back by the decoder, each after its
own convention of where a chroma sample sits. On the real Wild RC20 JPEG (4:2:0) the red marks' centres in the red
channel lie 0.16-0.33 px left of their centres in luminance at all 8 marks (in y 0.01-0.08 px), and in the Cr plane
0.3-0.5 px left; the affine fit of its 4 corners to their calibration leaves 0.46 px (RMS of the vectors' lengths) in
luminance against 0.48 in red (docs/benchmarks_frames.md). Luminance had 0.66-0.98 of red's contrast there; a red
ring on black through libjpeg's 4:2:0 at quality 90 has 0.53-0.59, a blue one 0.31-0.33 (blue's weight in
luminance is 0.114): that one is still measured in blue. Luminance is quantised like the rest (:data:`LUMA_STEP_MAX`),
and a frame whose search fails in it is searched again by the mix that shows each mark best
(:func:`aerofid.find.colour_again`)."""

LUMA_STEP_MAX = 20.0 / 255.0
"""Luminance goes first only in a file whose luminance is quantised finely enough to keep a coloured mark: the mean step
of its lowest frequencies (:func:`aerofid.io.jpeg.luma_quantisation`) at most this share of the samples' range
(libjpeg's quality 33 or better). The RC20's red rings stand 28-48 grey levels above the border in luminance; at
quality 40 (a step of 16.7 levels) luminance found all 4 corners as at 75 (6.7), at 20 (33.1) all 4 but 3 times as
slowly, at 15 (44.0) 2 (a helper's audit, session 57), where red found them: there the mix that shows the mark best
goes first."""


def luminance_first(chroma_subsampled: bool, luma_step: float | None) -> bool:
    """Whether ``to_grey(..., "auto")`` takes luminance first (``luma_first``) for a file: its chroma subsampled
    (:data:`LUMA_SHARE`) and its luminance quantised no more coarsely than :data:`LUMA_STEP_MAX` (None: not known,
    taken as fine).

    >>> luminance_first(True, 6.7 / 255), luminance_first(True, 44 / 255), luminance_first(False, None)
    (True, False, False)
    """
    return chroma_subsampled and (luma_step is None or luma_step <= LUMA_STEP_MAX)


def _best_mix(rgb: np.ndarray, polarity: Polarity, noise_floor: float, luma_first: bool = False) -> str:
    """Name of the mix in :data:`MIX_WEIGHTS` whose grey window gives the mark the most contrast, judged on
    the window's central half (each side a quarter in) when it is at least :data:`MIX_CENTRE_MIN` px across:
    the user boxes the mark, and the box's margins may hold the bright aerial image area beside a notch,
    which is brightest in whichever channel its colour favours (a red RC20 midside mark next to cyan water
    picked blue on the whole box). With ``luma_first``, luminance wherever it has :data:`LUMA_SHARE` of the best
    contrast."""
    h, w = rgb.shape[:2]
    if min(h, w) >= MIX_CENTRE_MIN:
        rgb = rgb[h // 4:h - h // 4, w // 4:w - w // 4]
    scores = [
        mark_contrast(channel_mix(rgb, mix), polarity, noise_floor=noise_floor) for mix in MIX_WEIGHTS
    ]
    mixes = list(MIX_WEIGHTS)
    if luma_first and scores[mixes.index("luminance")] >= LUMA_SHARE * max(scores):
        return "luminance"
    return mixes[int(np.argmax(scores))]


def _rgb_window(window: np.ndarray) -> np.ndarray:
    """Return ``window`` if it is a non-empty ``(h, w)`` or ``(h, w, 3)`` array, else raise."""
    array = np.asarray(window)
    if array.size == 0 or not (array.ndim == 2 or (array.ndim == 3 and array.shape[2] == 3)):
        raise AerofidInputError(
            f"window of shape {array.shape} is not a non-empty grey (h, w) or RGB (h, w, 3) array; "
            "read it with Raster.read_window()"
        )
    return array


def choose_channel_mix(window: np.ndarray, polarity: Polarity = "bright", *, luma_first: bool = False) -> str:
    """The channel mix (``"luminance"``, ``"red"``, ``"green"`` or ``"blue"``) that ``to_grey(window,
    "auto", polarity, luma_first=...)`` uses for an RGB window: the one with the largest :func:`mark_contrast`, the
    noise floored at one quantisation step of the window's dtype (ties go to luminance); with ``luma_first``
    luminance wherever it has :data:`LUMA_SHARE` of the largest."""
    _check_choice(polarity, POLARITIES, "polarity")
    array = _rgb_window(window)
    if array.ndim == 2:
        raise AerofidInputError("window is grey; a channel mix needs an RGB (h, w, 3) window")
    return _best_mix(normalise(array), polarity, _noise_floor(array.dtype), luma_first)


def to_grey(window: np.ndarray, policy: str = "auto", polarity: Polarity = "bright", *,
            luma_first: bool = False, white: float | None = None) -> np.ndarray:
    """Turn a window into float32 grey levels in [0, 1] by a colour policy.

    Args:
        window: ``(h, w)`` grey or ``(h, w, 3)`` RGB samples, as :meth:`Raster.read_window` returns them.
        policy: one of :data:`COLOUR_POLICIES`. ``"auto"`` picks, per window, the mix among luminance,
            red, green and blue that gives the mark the most contrast (:func:`choose_channel_mix`): colour
            scans often print the marks in red on a black film border, where luminance loses most of the
            contrast. ``"max"`` takes the brightest channel of each pixel. Grey windows ignore the policy.
        polarity: ``"bright"`` (mark brighter than its surround, most fiducials) or ``"dark"``; only
            ``"auto"`` uses it.
        luma_first: whether the window comes from a file whose luminance alone has its full resolution and keeps the
            mark (:func:`luminance_first`: a 4:2:0 JPEG of a fair quality); ``"auto"`` then takes luminance wherever
            it shows the mark with :data:`LUMA_SHARE` of the best mix's contrast.
        white: integer samples' full scale (:func:`normalise`; default: their dtype's largest value).
    """
    _check_choice(policy, COLOUR_POLICIES, "colour policy")
    _check_choice(polarity, POLARITIES, "polarity")
    array = _rgb_window(window)
    grey = normalise(array, white)
    if array.ndim == 2:
        return grey
    mix = _best_mix(grey, polarity, _noise_floor(array.dtype, white), luma_first) if policy == "auto" else policy
    return channel_mix(grey, mix)


def _check_choice(value: str, choices: Sequence[str], what: str) -> None:
    """Raise :class:`AerofidInputError` unless ``value`` is one of ``choices``."""
    if value not in choices:
        raise AerofidInputError(f"unknown {what} {value!r}; use one of {', '.join(choices)}")
