"""A JPEG's top rows before its whole decode: libjpeg decodes a baseline or progressive JPEG's rows in order and can
stop after any of them (issue 10: a JPEG is not decoded whole for one box where the codec allows less).

A :class:`~aerofid.io.raster.Raster` of an 8-bit JPEG starts its whole decode in the background when it is opened
(:func:`aerofid.io.jpeg.decoding`). Until that decode is done, a window whose rows end within :data:`TOP_SHARE` of the
image is read from a decode of the rows above it (and :data:`TOP_MARGIN` more) in the reading thread, on the other
core: one box near the top of a frame waits for the decode of the rows down to it, not of the whole image. A raster
opened for its top rows alone (``open_raster(path, rows=...)``: :func:`aerofid.locate` of one box near the top)
decodes those rows and never the whole image unless a read reaches below them. The rows
are decoded by Pillow's libjpeg-turbo, the library and inverse DCT of OpenCV's whole decode, to the same samples
(tests compare them on 4:2:0, 4:4:4, progressive and grey JPEGs and on the real RC20 frame); where Pillow cannot
decode them, or cannot tell that it decoded every one of them (a corrupt or truncated file), the whole decode answers
(and the read waits for it, as without this).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from pathlib import Path
from typing import Any

import numpy as np

from aerofid.io.jpeg import Decoding, ImageHeader, decode_budget, decoded, jpeg_structure
from aerofid.kept import Kept

TOP_SHARE = 0.4
"""A window whose rows end within this share of the image's height is read from a decode of the top rows alone
(the whole decode, where it was started, runs meanwhile on the other core; a decode of more of the image gains too
little on it)."""
TOP_MARGIN = 1024
"""Rows decoded below such a window, for the next windows of the same search (a search reads up to 64 px of context
around its region and measures marks on windows of at most 641 px, :mod:`aerofid.find`)."""
MIN_DECODED_BYTES = 8_000_000
"""A smaller image (under a few milliseconds of decode) is read from its whole decode only."""
CHUNK = 1 << 20
"""Bytes of the file given to the decoder at a time."""
TOPS_KEPT = 2
"""The latest top rows decoded (of as many files) kept by the file's identity, for the next raster of the same file
(``aerofid.locate(path, box)`` called box after box)."""
_TOPS: Kept[np.ndarray] = Kept(TOPS_KEPT)
SENTINEL: dict[str, int | tuple[int, int, int]] = {"L": 7, "RGB": (7, 250, 7)}
"""The value the rows are filled with before the decode, by Pillow mode: a last row that still holds it everywhere
was not decoded (or is this colour throughout: then the whole decode answers, only later)."""


def decode_top(path: Path, rows: int, header: ImageHeader) -> np.ndarray | None:
    """The first ``rows`` rows of the JPEG at ``path`` as ``(rows, columns, samples)`` uint8 (``header``'s size and
    samples), or None where Pillow cannot decode them or cannot tell that it decoded them all.

    Pillow's decoder is given the file a :data:`CHUNK` at a time and an image of ``rows`` rows: it stops once they
    are decoded (libjpeg then reports the scanlines it was not asked for as an error, which is how every decode of
    the top rows ends). The image is a numpy array Pillow decodes into (:func:`_shared_image`: no copy out of
    Pillow); its last row is filled with :data:`SENTINEL` first: an error before it, or the end of the file, leaves it
    so, and gives None."""
    from PIL import Image, JpegImagePlugin  # only a window read before the whole decode is done needs it (start-up)

    try:
        # the plugin's class, not Image.open: Pillow's guard against decompression bombs would warn on stderr about
        # a scan of 90 megapixels and refuse one of 180 (the decode budget, checked before, is the guard here)
        with JpegImagePlugin.JpegImageFile(path) as im:
            if im.format != "JPEG" or len(im.tile) != 1 or im.mode not in SENTINEL or im.size != (header.width,
                                                                                                   header.height):
                return None
            tile = im.tile[0]
            samples, top = _shared_image(Image, im.mode, header.width, rows)
            samples[-1] = SENTINEL[im.mode]
            decoder = Image._getdecoder(im.mode, tile[0], tile[3], im.decoderconfig)
            decoder.setimage(top.im, (0, 0, header.width, rows))
            try:
                _feed(decoder, path, tile[2])
            finally:
                decoder.cleanup()
    except Exception:  # noqa: BLE001 (Pillow raises many types for files it cannot read: the whole decode tells)
        return None
    if samples.shape[2] != header.samples or (samples[-1] == np.asarray(SENTINEL[im.mode], np.uint8)).all():
        return None
    return samples


def _shared_image(image_module: Any, mode: str, width: int, rows: int) -> tuple[np.ndarray, Any]:
    """A ``(rows, width, samples)`` uint8 view of a new array and a Pillow image of ``mode`` ("L" or "RGB") that
    shares its memory: Pillow keeps an RGB pixel in 4 bytes, so the array holds RGBX and the view its first three
    (Pillow's ``np.asarray`` of an image copies its rows out twice, two thirds of the time of the rows' decode)."""
    store = "RGBX" if mode == "RGB" else mode
    pixels = np.empty((rows, width, len(store)), np.uint8)
    image = image_module.frombuffer(store, (width, rows), pixels, "raw", store, 0, 1)
    return pixels[:, :, : len(mode)], image


def _feed(decoder: object, path: Path, offset: int) -> None:
    """Give ``decoder`` the file's bytes from ``offset`` until it ends (stops or fails) or the file does."""
    data = b""
    with open(path, "rb") as f:
        f.seek(offset)
        while chunk := f.read(CHUNK):
            data += chunk
            used, _ = decoder.decode(data)  # type: ignore[attr-defined]
            if used < 0:
                return
            data = data[used:]


class BackgroundJpegReader:
    """Windows of a JPEG decoded whole in a thread of its own (:func:`aerofid.io.jpeg.decoding`): from that decode
    once it is done; before, a window in the top :data:`TOP_SHARE` of the image from :func:`decode_top` of the rows
    down to it and :data:`TOP_MARGIN` more (kept, and decoded further for a window below them), where the whole
    decode and those rows fit the decode budget together and the image is not small (:data:`MIN_DECODED_BYTES`).

    Opened for its top ``rows`` (the caller reads no row below them: one box near the top of a scan), the whole
    decode is not started at all while they lie in the top share: those rows are decoded alone, once, and the whole
    decode starts only when a read reaches below them or they cannot be decoded. ``start`` starts the whole decode
    (or gives the one already kept); ``pending`` is None until it is started. ``key``, the file's identity (its
    resolved path, modification time and size, as the whole decodes are kept by), keeps the top rows a reader opened
    for them decoded (:data:`TOPS_KEPT`) for the next such reader of the file (not those of a reader opened for every
    row: a whole frame's windows read before its decode is done, which its whole decode soon serves)."""

    def __init__(self, start: Callable[[], Decoding], header: ImageHeader, path: Path, rows: int | None = None,
                 key: Hashable | None = None):
        self._start, self._header, self._path, self._key = start, header, path, key
        self._rows = rows if rows is not None and self._in_top(rows, min(rows, header.height)) else None
        self.pending: Decoding | None = None if self._rows is not None else start()
        self._whole: np.ndarray | None = None
        self._top: np.ndarray | None = None
        self.served_top = False
        """Whether a window was read from the top rows (then the whole decode's error is still to be told)."""

    def read(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """Samples of the window ``box`` (a view of a decoded array)."""
        x0, y0, x1, y1 = box
        if self._whole is None and (self.pending is None or not self.pending.future.done()):
            top = self._top_rows(y1)
            if top is not None:
                self.served_top = True
                return top[y0:y1, x0:x1]
        return self.whole()[y0:y1, x0:x1]

    def whole(self) -> np.ndarray:
        """The whole decode (started if it was not), waited for (its error raised: :func:`aerofid.io.jpeg.decoded`)."""
        if self._whole is None:
            self._whole = decoded(self._decoding(), self._header, self._path)
            self._top = None
        return self._whole

    def check(self) -> None:
        """Raise the whole decode's error where windows were read from the top rows (:meth:`whole`): a file that cannot
        be decoded whole is an error, as when a window waited for its decode. Where the whole decode was never started,
        a file whose marker walk is complete (:func:`aerofid.io.jpeg.jpeg_structure`: every scan's data ends, an end
        of image follows) is not decoded whole to tell: only a file cut short or malformed is; nor one that can no
        longer be read (removed since): the rows read were decoded whole (:func:`decode_top` checks its last row)."""
        if not self.served_top:
            return
        if self.pending is None:
            try:
                walk = jpeg_structure(self._path)
            except OSError:
                return
            if walk == "complete":
                return
        self.whole()

    def _decoding(self) -> Decoding:
        """The whole decode, started now if it was not."""
        if self.pending is None:
            self.pending = self._start()
        return self.pending

    def _in_top(self, bottom: int, rows: int) -> bool:
        """Whether a window ending at row ``bottom`` is read from a decode of the top ``rows`` (module docstring)."""
        h = self._header
        row_bytes = h.width * (4 if h.samples == 3 else h.samples) * h.itemsize     # as Pillow stores them
        return (bottom <= TOP_SHARE * h.height and h.decoded_bytes >= MIN_DECODED_BYTES
                and h.decoded_bytes + rows * row_bytes <= decode_budget())

    def _top_rows(self, bottom: int) -> np.ndarray | None:
        """The decoded top rows reaching row ``bottom`` (exclusive), decoded now if need be (the rows the reader was
        opened for, else ``bottom`` and :data:`TOP_MARGIN` more, the whole decode started then); None where the window
        is not in the top of the image or the rows are not decoded."""
        if self._top is not None and bottom <= self._top.shape[0]:
            return self._top
        h = self._header
        if self._rows is not None and bottom <= self._rows:
            rows = min(h.height, self._rows)
        else:
            self._decoding()
            rows = min(h.height, bottom + TOP_MARGIN)
        if not self._in_top(bottom, rows):
            return None
        keep = self._key is not None and self._rows is not None    # a box's search, not a whole frame's first rows
        kept = _TOPS.get(self._key) if keep else None
        if kept is not None and kept.shape[0] >= bottom:
            self._top = kept
            return kept
        top = decode_top(self._path, rows, h)
        if top is not None:
            top.setflags(write=False)
            self._top = top
            if keep:
                _TOPS.put(self._key, top)
        return top

    def release(self) -> None:
        """Nothing to release between the strips of a reduced read (the decodes are kept)."""

    def close(self) -> None:
        """Drop the decoded arrays."""
        self._whole = self._top = None
