"""JPEG and PNG: the declared size from the header, a whole decode (cached) when it fits the memory budget, and
libjpeg's reduced decode for a JPEG that does not.

OpenCV cannot decode a window of a JPEG or PNG, so :class:`~aerofid.io.raster.Raster` decodes one whole, once,
when its decoded samples fit the decode budget (:func:`decode_budget`). The size is read from the header first (the JPEG
start-of-frame segment, the PNG ``IHDR`` chunk), so nothing is decoded to learn it. The decode runs in a thread of
its own (:func:`decoding`). The raster waits for it on opening a PNG or an unusual JPEG; an 8-bit DCT JPEG opens at
once, its first window waits for the decode (:func:`decoded`) unless it lies near the top (:mod:`aerofid.io.jpeg_top`:
a raster opened for its top rows alone starts the decode only when a read needs it), and a whole frame's first look
(``Raster.read_overview``) is taken from libjpeg's reduced decode meanwhile, on the other core; closing the raster
waits for the decode to end (:func:`finish`), and a corrupt file is an error when a window is read or
``Raster.check_decoded`` asks. A larger JPEG is never decoded whole: :class:`HugeJpegReader` answers
``read_reduced`` with libjpeg's decode at 1/2, 1/4 or 1/8 scale (``cv2.IMREAD_REDUCED_*``) followed by block means of
the rest of the factor, and refuses full-resolution windows. A larger PNG is refused (PNG has no reduced decode).

libjpeg's reduced decode is not an exact block mean: it scales the inverse DCT of each 8 x 8 block (at 1/8 it
keeps only the DC coefficient, the block's mean before colour conversion and chroma upsampling), so it
differs from the mean of the full decode by a few grey levels near edges; blocks that straddle the 8 x 8 grid
are weighed by area from the reduced pixels.
"""

from __future__ import annotations

import os
import re
import threading
from collections import OrderedDict
from collections.abc import Iterator
from concurrent.futures import Future, wait
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import BinaryIO, NamedTuple

import cv2
import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.io.budget import memory_budget
from aerofid.io.reduce import reduce_in_strips

__all__ = [
    "DECODED_CACHE",
    "DECODE_BUDGET_BYTES",
    "HugeJpegReader",
    "IMREAD_INTO",
    "ImageHeader",
    "decode_whole",
    "decode_budget",
    "Decoding",
    "decoded",
    "decodes_in_background",
    "decodes_whole",
    "decoding",
    "finish",
    "forget_decodes",
    "kept_decoding",
    "header_segments",
    "jpeg_structure",
    "read_header",
]

#: Most bytes of decoded samples for which a JPEG or PNG is decoded whole (and a JPEG's reduced decode); None:
#: the memory budget (:func:`aerofid.io.budget.memory_budget`, 1 GB unless ``AEROFID_MEMORY_BUDGET_GB`` says).
DECODE_BUDGET_BYTES: int | None = None


def decode_budget() -> int:
    """The bytes a decode may take: :data:`DECODE_BUDGET_BYTES` when set, else the memory budget."""
    return DECODE_BUDGET_BYTES if DECODE_BUDGET_BYTES is not None else memory_budget()
#: How many decoded JPEG/PNG files stay in memory between calls.
DECODED_CACHE = 2

_SOF_MARKERS = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}  # start of frame: not DHT, JPG, DAC
_LOSSLESS_MARKERS = frozenset({0xC3, 0xC7, 0xCB, 0xCF})  # lossless frames: libjpeg decodes them at full size only
_DQT = 0xDB  # define quantisation tables
_STANDALONE = frozenset({0x01, *range(0xD0, 0xD8)})  # TEM and RSTn carry no length
_PNG_SAMPLES = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}  # colour type -> decoded samples per pixel (palette -> RGB)
_REDUCED_FLAGS = {
    (1, 2): cv2.IMREAD_REDUCED_GRAYSCALE_2, (1, 4): cv2.IMREAD_REDUCED_GRAYSCALE_4,
    (1, 8): cv2.IMREAD_REDUCED_GRAYSCALE_8, (3, 2): cv2.IMREAD_REDUCED_COLOR_2,
    (3, 4): cv2.IMREAD_REDUCED_COLOR_4, (3, 8): cv2.IMREAD_REDUCED_COLOR_8,
}


class ImageHeader(NamedTuple):
    """What a JPEG or PNG header declares: size, samples per pixel and bytes per sample once decoded."""

    width: int
    height: int
    samples: int
    itemsize: int
    scalable: bool = True
    """Whether libjpeg can decode it reduced (a DCT JPEG; not a lossless one, nor a PNG)."""
    chroma_subsampled: bool = False
    """Whether a colour JPEG stores its second and third components (the chroma, Cb and Cr) at a lower resolution
    than its first (the luma, Y): 4:2:0 or 4:2:2 (:func:`subsampled_components`)."""
    luma_step: float | None = None
    """The quantisation step of the first component's lowest frequencies, as a share of the samples' range
    (:func:`luma_quantisation`); None where the header does not say it before the frame."""

    @property
    def decoded_bytes(self) -> int:
        """Bytes of the whole decoded image."""
        return self.width * self.height * self.samples * self.itemsize


def _one_line(exc: BaseException) -> str:
    """A library exception's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__


def header_segments(file: BinaryIO) -> Iterator[tuple[int, bytes]]:
    """A JPEG's marker segments ``(marker, body)`` after its start of image, up to and including the first start
    of frame, read as libjpeg reads them (stray and fill bytes skipped, standalone markers passed over).

    Raises
    ------
    ValueError
        The file ends, or its image or scan starts, before a frame; or a segment's length is corrupt.
    """
    file.seek(2)
    while True:
        byte = file.read(1)
        if not byte:
            raise ValueError("no start of frame")
        if byte != b"\xff":  # stray bytes between segments, which libjpeg skips too
            continue
        marker = file.read(1)
        while marker == b"\xff":  # fill bytes
            marker = file.read(1)
        if not marker or marker[0] in (0xD9, 0xDA):  # end of image or start of scan before any frame
            raise ValueError("no start of frame")
        if marker[0] in _STANDALONE:
            continue
        length_bytes = file.read(2)
        if len(length_bytes) < 2 or int.from_bytes(length_bytes, "big") < 2:
            raise ValueError("corrupt segment length")
        yield marker[0], file.read(int.from_bytes(length_bytes, "big") - 2)
        if marker[0] in _SOF_MARKERS:
            return


def _jpeg_header(file: BinaryIO, path: Path) -> ImageHeader:
    """Read the frame's size from a JPEG's first start-of-frame segment (:func:`header_segments`)."""
    bad = AerofidInputError(f"cannot decode {path}: its JPEG header is corrupt or truncated; re-export the scan")
    tables: list[bytes] = []                          # the quantisation tables defined before the frame
    try:
        for marker, body in header_segments(file):      # ends at the first start of frame, or raises
            if marker == _DQT:
                tables.append(body)
    except ValueError:
        raise bad from None
    if len(body) < 6:
        raise bad
    precision, components = body[0], body[5]
    height, width = int.from_bytes(body[1:3], "big"), int.from_bytes(body[3:5], "big")
    if width == 0 or height == 0:
        raise AerofidInputError(f"{path} declares a {width} x {height} JPEG; re-export the scan")
    return ImageHeader(width, height, 3 if components >= 3 else components, 1 if precision <= 8 else 2,
                       scalable=marker not in _LOSSLESS_MARKERS, chroma_subsampled=subsampled_components(body),
                       luma_step=luma_quantisation(tables, body))


LOW_FREQUENCIES = 10
"""The first so many coefficients of a quantisation table in its zigzag order (the DC term and the lowest
frequencies) whose mean step :func:`luma_quantisation` gives: those that carry a mark's edges of a few pixels."""


def luma_quantisation(tables: list[bytes], frame: bytes) -> float | None:
    """The mean quantisation step of the :data:`LOW_FREQUENCIES` lowest frequencies of the table the frame's first
    component (the luma, Y) uses, divided by the largest sample (255 for 8 bits): from the define-quantisation-table
    segments' bodies ``tables`` (ITU-T T.81 B.2.4.1: per table a byte of precision and id, then 64 steps of 1 or 2
    bytes in zigzag order) and the start of frame's body ``frame``. None where no such table precedes the frame or a
    segment is truncated. libjpeg's quality 75 gives 6.7 / 255, 40 gives 16.7, 20 gives 33.1, 15 gives 44.0.

    >>> frame = bytes([8, 0, 8, 0, 8, 3, 1, 0x22, 0, 2, 0x11, 1, 3, 0x11, 1])
    >>> round(luma_quantisation([bytes([0]) + bytes(range(1, 65))], frame) * 255, 2)
    5.5
    """
    if len(frame) < 9:
        return None
    wanted, precision = frame[8], frame[0]
    for body in tables:
        i = 0
        while i < len(body):
            size, table = 2 if body[i] >> 4 else 1, body[i] & 15
            steps = body[i + 1:i + 1 + 64 * size]
            if len(steps) < 64 * size:
                return None
            if table == wanted:
                low = [int.from_bytes(steps[k * size:(k + 1) * size], "big") for k in range(LOW_FREQUENCIES)]
                return sum(low) / LOW_FREQUENCIES / float(2 ** precision - 1)
            i += 1 + 64 * size
    return None


def subsampled_components(frame: bytes) -> bool:
    """Whether a start-of-frame segment's body (ITU-T T.81 B.2.2: precision, height, width, the number of
    components, then 3 bytes per component: its id, its horizontal and vertical sampling factors in one byte, its
    quantisation table) samples a later component more coarsely than the first, in either direction: a colour
    JPEG's chroma subsampled (4:2:0, 4:2:2). A truncated list of components reads as not subsampled."""
    count = frame[5] if len(frame) > 5 else 0
    factors = [(b >> 4, b & 15) for b in frame[7:6 + 3 * count:3]]
    if count < 3 or len(factors) < count:
        return False
    (h0, v0), rest = factors[0], factors[1:]
    return any(h < h0 or v < v0 for h, v in rest)


def _png_header(file: BinaryIO, path: Path) -> ImageHeader:
    """Read a PNG's size, samples and bit depth from its ``IHDR`` chunk."""
    file.seek(8)
    chunk = file.read(8 + 13)
    if len(chunk) < 21 or chunk[4:8] != b"IHDR" or chunk[17] not in _PNG_SAMPLES:
        raise AerofidInputError(f"cannot decode {path}: its PNG header is corrupt or truncated; re-export the scan")
    width, height = int.from_bytes(chunk[8:12], "big"), int.from_bytes(chunk[12:16], "big")
    return ImageHeader(width, height, _PNG_SAMPLES[chunk[17]], 2 if chunk[16] == 16 else 1, scalable=False)


def read_header(path: Path, kind: str) -> ImageHeader:
    """The size a JPEG or PNG declares, read from its header without decoding any pixel.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    kind : str
        ``"jpeg"`` or ``"png"`` (from the file's first bytes).

    Returns
    -------
    ImageHeader
        Width, height, decoded samples per pixel (a JPEG's 4 CMYK components decode to 3) and bytes per sample.

    Raises
    ------
    AerofidInputError
        The header is missing or corrupt, or the file cannot be read.
    """
    try:
        with path.open("rb") as file:
            return _jpeg_header(file, path) if kind == "jpeg" else _png_header(file, path)
    except OSError as exc:
        raise AerofidInputError(f"cannot read {path}: {_one_line(exc)}; check its permissions") from exc


def decodes_whole(header: ImageHeader) -> bool:
    """Whether the whole decoded image fits the decode budget (:func:`decode_budget`)."""
    return header.decoded_bytes <= decode_budget()


def _decode_with_cv2(path: Path) -> np.ndarray:
    """Decode a whole JPEG or PNG file into a (rows, columns, samples) array, colour in RGB(A) order."""
    try:
        image = cv2.imdecode(np.fromfile(path, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    except (OSError, cv2.error) as exc:
        raise AerofidInputError(f"cannot decode {path}: {_one_line(exc)}; re-export the scan") from exc
    if image is None:
        raise AerofidInputError(f"cannot decode {path}: the file is corrupt or truncated; re-export the scan")
    if image.ndim == 2:
        return image[:, :, None]
    if image.shape[2] == 3:  # BGR -> RGB: a view with the samples reversed (no pass over a large image)
        return image[:, :, ::-1]
    if image.shape[2] == 4:  # BGRA -> RGBA in place (no view reorders 4 samples so): no second copy of the image
        cv2.cvtColor(image, cv2.COLOR_BGRA2RGBA, dst=image)
    return image


#: Whether this OpenCV decodes a file into an array given to it (``cv2.imread(filename, dst, flags)``, with
#: ``IMREAD_COLOR_RGB``; OpenCV 5): without it OpenCV's decode of a large JPEG holds the image twice at its peak
#: (a 17000 x 17000 RGB JPEG: 1.7 GB for its 0.87 GB of samples, 0.87 GB into an array given).
IMREAD_INTO = hasattr(cv2, "IMREAD_COLOR_RGB") and "imread(filename[, dst" in (cv2.imread.__doc__ or "")


def _decode_in_place(path: Path, header: ImageHeader) -> np.ndarray | None:
    """An 8-bit JPEG of 1 or 3 samples (:func:`decodes_in_background`) decoded by libjpeg into an array made for
    it from its header, as ``(rows, columns, samples)`` in RGB order: the samples :func:`_decode_with_cv2` gives (the
    same libjpeg decode, its EXIF orientation ignored as ``IMREAD_UNCHANGED`` does, RGB from libjpeg instead of BGR
    reversed), without OpenCV's second copy. Only a shortcut: None, and OpenCV's own decode decides, wherever this
    one could differ from it or cannot tell - OpenCV without the destination (:data:`IMREAD_INTO`), a name that is
    not valid UTF-8, a file that does not end its scans (:func:`_ends_its_scans`: ``cv2.imread`` makes up a truncated
    file's missing end, which the decode from bytes refuses), a decode that failed or wrote nothing (``imread`` into
    an array leaves it as it was when libjpeg refuses the header, or the file is gone: a pattern in its last row
    tells), or one of another size."""
    name = str(path)
    if not IMREAD_INTO or not decodes_in_background(header, "jpeg") or not _utf8(name) or not _ends_its_scans(path):
        return None
    grey = header.samples == 1
    dst = np.empty((header.height, header.width) if grey else (header.height, header.width, 3), np.uint8)
    pattern = ((np.arange(dst[-1].size) * 7 + 3) % 251).astype(np.uint8).reshape(dst[-1].shape)
    dst[-1] = pattern                           # libjpeg writes the rows in order: the last one last
    flags = (cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR_RGB) | cv2.IMREAD_IGNORE_ORIENTATION
    try:
        image = cv2.imread(name, dst, flags)
    except cv2.error:
        return None
    if image is None or image is not dst or np.array_equal(dst[-1], pattern):
        return None
    return image[:, :, None] if grey else image


_SCAN_DATA_END = re.compile(rb"\xff[^\x00\xd0-\xd7\xff]")
"""The marker that ends a scan's entropy-coded data: an FF byte not followed by a stuffed 0, a restart marker or a
fill byte."""
_CHUNK = 1 << 22
"""Bytes read at a time when the marker walk looks for the end of a scan's data."""


def jpeg_structure(path: Path) -> str:
    """How a JPEG's marker segments end, walked as libjpeg reads them (each segment's length skipped, so that an EXIF
    thumbnail's or a comment's bytes do not count; a scan's entropy-coded data up to the marker that ends it, read in
    chunks): ``"complete"`` (an end-of-image marker after a scan), ``"truncated"`` (the file ends inside a segment or a
    scan's data, before its end of image: libjpeg then makes up the rest, grey) or ``"unexpected"`` (anything the walk
    does not expect: no start of image, bytes between segments, a corrupt length, an end before any scan).

    Raises
    ------
    OSError
        The file cannot be read.
    """
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        if f.read(2) != b"\xff\xd8":
            return "unexpected"
        scanned = False
        while True:
            marker = _next_segment(f, size)
            if isinstance(marker, str):
                return marker
            if marker == 0xD9:
                return "complete" if scanned else "unexpected"
            if marker == 0xDA:                               # a start of scan: its entropy-coded data follows
                scanned = True
                end = _scan_data_end(f)
                if end is None:
                    return "truncated"
                f.seek(end)


def _next_segment(f: BinaryIO, size: int) -> int | str:
    """The next marker at ``f``'s position (fill bytes skipped), its segment's body skipped; or how the walk ends
    there (:func:`jpeg_structure`'s ``"truncated"`` or ``"unexpected"``)."""
    byte = f.read(1)
    if not byte:
        return "truncated"
    if byte != b"\xff":
        return "unexpected"
    marker = f.read(1)
    while marker == b"\xff":
        marker = f.read(1)
    if not marker:
        return "truncated"
    if marker[0] == 0xD9 or marker[0] in _STANDALONE:
        return marker[0]
    length_bytes = f.read(2)
    if len(length_bytes) < 2:
        return "truncated"
    length = int.from_bytes(length_bytes, "big")
    if length < 2:
        return "unexpected"
    if f.tell() + length - 2 > size:
        return "truncated"
    f.seek(length - 2, os.SEEK_CUR)
    return marker[0]


def _scan_data_end(f: BinaryIO) -> int | None:
    """The offset of the marker that ends the entropy-coded data starting at ``f``'s position, None if the file ends
    first (an FF at the end of a chunk is carried into the next, with its fill bytes)."""
    start, carry = f.tell(), b""
    while True:
        chunk = f.read(_CHUNK)
        if not chunk:
            return None
        data = carry + chunk
        found = _SCAN_DATA_END.search(data)
        if found is not None:
            return start - len(carry) + found.start()
        carry = b"\xff" if data.endswith(b"\xff") else b""
        start += len(chunk)


def _ends_its_scans(path: Path) -> bool:
    """Whether the JPEG's marker walk is ``"complete"`` (:func:`jpeg_structure`); False when it cannot be read."""
    try:
        return jpeg_structure(path) == "complete"
    except OSError:
        return False


def decodes_in_background(header: ImageHeader, kind: str) -> bool:
    """Whether :class:`~aerofid.io.raster.Raster` decodes the file in the background and takes its first look from
    libjpeg's reduced decode meanwhile: an 8-bit DCT JPEG (grey, or 3 or 4 components, which OpenCV decodes to RGB:
    the header's samples); a PNG's decoded samples are learnt from the decode itself."""
    return kind == "jpeg" and header.itemsize == 1 and header.samples in (1, 3) and header.scalable


@dataclass(eq=False)
class Decoding:
    """A whole decode running in its own thread (:func:`decoding`), started by process ``pid``; ``traceback`` is
    where it failed, if it did."""

    path: Path
    future: Future[np.ndarray]
    pid: int
    header: ImageHeader | None = None
    traceback: TracebackType | None = None


#: The decodes started or done, newest last, by (path, modification time, size); at most DECODED_CACHE.
_DECODES: OrderedDict[tuple[str, int, int], Decoding] = OrderedDict()
_DECODES_LOCK = threading.Lock()


def _read_only(path: Path, header: ImageHeader | None = None) -> np.ndarray:
    """The whole decode, read-only: into an array made from the ``header`` where OpenCV can
    (:func:`_decode_in_place`), else OpenCV's own."""
    image = _decode_in_place(path, header) if header is not None else None
    if image is None:
        image = _decode_with_cv2(path)
    image.setflags(write=False)
    return image


def _decode_into(key: tuple[str, int, int], pending: Decoding) -> None:
    try:
        image = _read_only(pending.path, pending.header)
    except BaseException as exc:  # noqa: BLE001 (handed to the thread that waits for it)
        with _DECODES_LOCK:                     # a failure is not kept: the next open of the file decodes again
            if _DECODES.get(key) is pending:
                del _DECODES[key]
        pending.traceback = exc.__traceback__
        pending.future.set_exception(exc)
    else:
        pending.future.set_result(image)


def decoding(path: str, mtime_ns: int, size: int, header: ImageHeader | None = None) -> Decoding:
    """The whole decode of a JPEG or PNG as ``(rows, columns, samples)`` in RGB(A) order, read-only, started in a
    thread of its own (cv2 releases the GIL while it decodes; the thread ends with the decode) and kept by path,
    modification time and size (the last :data:`DECODED_CACHE`), so that locating several marks in one file, or
    opening it from two threads at once, decodes it once. :func:`decoded` waits for it. With the file's ``header``
    an 8-bit JPEG is decoded into an array made for it (:func:`_decode_in_place`)."""
    key = (path, mtime_ns, size)
    with _DECODES_LOCK:
        pending = _DECODES.get(key)
        if pending is not None:
            _DECODES.move_to_end(key)
            return pending
        pending = _DECODES[key] = Decoding(Path(path), Future(), os.getpid(), header)
        while len(_DECODES) > DECODED_CACHE:
            _DECODES.popitem(last=False)
    threading.Thread(target=_decode_into, args=(key, pending), name="aerofid-decode").start()
    return pending


def kept_decoding(path: str, mtime_ns: int, size: int) -> Decoding | None:
    """The whole decode of :func:`decoding` already started (running or done) for this file, if one is kept."""
    with _DECODES_LOCK:
        return _DECODES.get((path, mtime_ns, size))


def forget_decodes() -> None:
    """Drop the kept decodes (those running end for whoever waits for them)."""
    with _DECODES_LOCK:
        _DECODES.clear()


def _after_fork_in_child() -> None:
    """A forked child has none of its parent's decoding threads, and perhaps a lock one of them held."""
    global _DECODES_LOCK
    _DECODES_LOCK = threading.Lock()
    _DECODES.clear()


os.register_at_fork(after_in_child=_after_fork_in_child)


def _result(pending: Decoding) -> np.ndarray:
    """The decoded image: waited for; decoded here in a process forked while its parent's thread decoded it. A
    failure is raised (:class:`AerofidInputError` for a file that cannot be decoded) with the decode's own
    traceback."""
    if pending.pid != os.getpid() and not pending.future.done():
        return _read_only(pending.path, pending.header)
    exc = pending.future.exception()
    if exc is not None:
        raise exc.with_traceback(pending.traceback)
    return pending.future.result()


def finish(pending: Decoding) -> None:
    """Wait until ``pending`` (started by this process) has ended, whatever its outcome: no decode is left running,
    or writing libjpeg's warnings to stderr, once its raster is closed."""
    if pending.pid == os.getpid():
        wait([pending.future])


def decode_whole(path: str, mtime_ns: int, size: int) -> np.ndarray:
    """The whole decode of :func:`decoding`, waited for."""
    return _result(decoding(path, mtime_ns, size))


def decoded(pending: Decoding, header: ImageHeader, path: Path) -> np.ndarray:
    """The whole decode ``pending`` of the file at ``path`` (:func:`_result`); it must have the size and samples
    ``header`` declared (the raster was opened with them)."""
    image = _result(pending)
    if image.shape != (header.height, header.width, header.samples):
        raise AerofidInputError(
            f"cannot decode {path}: its header declares {header.width} x {header.height} px of {header.samples} "
            f"samples but it decodes to {image.shape[1]} x {image.shape[0]} px of {image.shape[2]}; re-export the scan"
        )
    return image


def _imread(path: Path, flags: int) -> np.ndarray | None:
    """``cv2.imread``: libjpeg reads the file, no copy of its bytes is held beside the decode; from the file's bytes
    (``cv2.imdecode``) for a name that is not valid UTF-8, which OpenCV's ``imread`` cannot take (it crashes)."""
    name = str(path)
    if not _utf8(name):
        return cv2.imdecode(np.fromfile(path, dtype=np.uint8), flags)
    return cv2.imread(name, flags)


def _utf8(name: str) -> bool:
    """Whether OpenCV's ``imread`` can take the file name (it crashes on one that is not valid UTF-8)."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


class HugeJpegReader:
    """A JPEG too large to decode whole: reduced reads through libjpeg's 1/2, 1/4, 1/8 decode, no windows.

    The last reduced decode is kept (one per reader) so that several boxes reduced by the same factor decode
    the file once. With ``checks_truncation`` a reduced decode first checks that the file is not truncated
    (:func:`jpeg_structure`): libjpeg makes up a truncated file's missing rows, grey. Not for the first look at a JPEG
    also decoded whole, whose whole decode refuses such a file.
    """

    def __init__(self, path: Path, header: ImageHeader, bands: int, checks_truncation: bool = True):
        self.path = path
        self.header = header
        self.bands = bands
        self.checks_truncation = checks_truncation
        self._kept: tuple[int, np.ndarray] | None = None
        self._walked = False                    # the truncation check is made once, at the first reduced decode

    def _too_large(self) -> str:
        h = self.header
        return (f"{self.path} is a {h.width} x {h.height} JPEG, too large to decode whole "
                f"({h.decoded_bytes / 1e9:.1f} GB, more than the {decode_budget() / 1e9:.1f} GB budget)")

    def read(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """Refuse: a full-resolution window would need the whole decode."""
        raise AerofidInputError(
            f"{self._too_large()}; convert it to a tiled TIFF (e.g. gdal_translate -co TILED=YES) to read windows"
        )

    def scale_for(self, factor: int) -> int:
        """The largest libjpeg scale (8, 4, 2) that divides ``factor`` and whose decode fits the budget."""
        h = self.header
        if not h.scalable:
            raise AerofidInputError(f"{self._too_large()}, and a lossless JPEG cannot be decoded reduced; convert it "
                                    "to a tiled TIFF (e.g. gdal_translate -co TILED=YES)")
        for scale in (8, 4, 2):
            reduced = -(-h.width // scale) * -(-h.height // scale) * self.bands * h.itemsize
            if factor % scale == 0 and reduced <= decode_budget():
                return scale
        raise AerofidInputError(
            f"{self._too_large()}, and reducing by {factor} cannot use libjpeg's 1/2, 1/4 or 1/8 decode within "
            "the budget; give an even factor (a multiple of 8 needs least memory) or convert the JPEG to a tiled TIFF"
        )

    def _decoded(self, scale: int) -> np.ndarray:
        """The whole image decoded at ``1 / scale`` as ``(rows, columns, bands)`` RGB or grey, kept."""
        if self._kept is not None and self._kept[0] == scale:
            return self._kept[1]
        self._kept = None
        flags = _REDUCED_FLAGS[(self.bands, scale)] | cv2.IMREAD_IGNORE_ORIENTATION
        try:
            if self.checks_truncation and not self._walked and jpeg_structure(self.path) == "truncated":
                raise AerofidInputError(f"cannot decode {self.path}: the file is truncated (its data ends before its "
                                        "end of image); re-export the scan")
            self._walked = True
            image = _imread(self.path, flags)
        except (OSError, cv2.error) as exc:
            raise AerofidInputError(f"cannot decode {self.path}: {_one_line(exc)}; re-export the scan") from exc
        expected = (-(-self.header.height // scale), -(-self.header.width // scale))
        if image is None or image.shape[:2] != expected:
            raise AerofidInputError(f"cannot decode {self.path}: the file is corrupt or truncated; re-export the scan")
        if image.ndim == 2:
            image = image[:, :, None]
        else:
            cv2.cvtColor(image, cv2.COLOR_BGR2RGB, dst=image)
        self._kept = (scale, image)
        return image

    def read_reduced(self, box: tuple[int, int, int, int], factor: int) -> np.ndarray:
        """Window ``box`` reduced by ``factor`` from libjpeg's reduced decode; ``(rows, cols, bands)`` float32."""
        scale = self.scale_for(factor)
        image = self._decoded(scale)
        c0, c1 = box[0] // scale, -(-box[2] // scale)
        return reduce_in_strips(lambda r0, r1: image[r0:r1, c0:c1], box, factor, self.bands,
                                itemsize=1, scale=scale)

    def close(self) -> None:
        """Drop the kept reduced decode."""
        self._kept = None
