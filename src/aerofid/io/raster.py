"""Open scanned aerial photographs lazily and read windows of them (grey levels: :mod:`aerofid.io.colour`).

Formats: TIFF and BigTIFF (a GeoTIFF is a TIFF), tiled or striped, any compression that tifffile with
imagecodecs decodes (none, LZW, deflate, JPEG, PackBits, ...); JPEG; PNG. The format is recognised from
the file's first bytes, not from its name. Samples: unsigned integers (8, 16 or 32-bit) or floats, grey or
RGB; the alpha band of RGBA is dropped.

How :meth:`Raster.read_window` reads a window, cheapest first:

* a TIFF page stored uncompressed and contiguously is memory-mapped, so only the window's bytes are read;
* any other TIFF page is read tile by tile (or strip by strip): only the segments that intersect the window
  are read from the file and decoded, with tifffile's ``TiffPage.decode`` on the bytes at
  ``page.dataoffsets`` / ``page.databytecounts``;
* a TIFF layout that cannot be windowed (segments that do not tile the image as the tags say, NDPI-style
  JPEG) is decoded whole on the first read and kept in memory;
* a JPEG or PNG is decoded whole (OpenCV cannot read a window of it) and kept in memory, if its decoded size (read
  from the header first) fits the decode budget (:func:`aerofid.io.jpeg.decode_budget`): a PNG, a lossless or a
  12-bit JPEG when opened, an 8-bit DCT JPEG in the background from the moment it is opened (its windows wait for it,
  :meth:`Raster.read_overview` takes libjpeg's reduced decode meanwhile; a window near its top is read from a decode
  of its top rows, and a raster opened for its top rows alone decodes only those, :mod:`aerofid.io.jpeg_top`); a
  larger JPEG is never decoded whole
  (only :meth:`Raster.read_reduced` reads it, through libjpeg's reduced decode), a larger PNG is refused.

:meth:`Raster.read_reduced` reads a window reduced by block means in horizontal strips (whole tile rows of a
tiled TIFF), so its memory stays bounded whatever the box (:mod:`aerofid.io.reduce`); a TIFF's strips of a large
window by several threads at once (:data:`aerofid.parallel.THREADS`: tiles are decoded, and a memory map's pages
read, while the GIL is released). A numpy array is read
through the same interface by :class:`aerofid.io.array.ArrayRaster`; :func:`aerofid.io.array.open_image` opens a
path, an array or an open raster alike.

Pixel conventions: x = column, y = row, boxes are ``(x0, y0, x1, y1)`` with x1, y1
exclusive. Every bad input raises :class:`aerofid.errors.AerofidInputError` with a one-line message.
"""

from __future__ import annotations

import math
import operator
import os
import reprlib
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.io import jpeg
from aerofid.io.budget import check_budget
from aerofid.io.files import input_file
from aerofid.io.jpeg_top import BackgroundJpegReader
from aerofid.io.reduce import check_factor, check_reduced_size, reduce_in_strips
from aerofid.parallel import THREADS

if TYPE_CHECKING:
    import tifffile

__all__ = [
    "WINDOW_LIMIT_BYTES",
    "Raster",
    "check_window_size",
    "image_size",
    "part_inside",
    "clip_box",
    "open_raster",
    "segment_indices",
]

SUPPORTED_FORMATS = "TIFF/BigTIFF/GeoTIFF, JPEG or PNG"
WINDOW_LIMIT_BYTES = 1_000_000_000

_TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")
_JPEG_MAGIC = b"\xff\xd8\xff"
_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
_JPEG_COMPRESSIONS = frozenset({6, 7, 33007, 34892})
_MINISWHITE, _MINISBLACK, _RGB, _YCBCR = 0, 1, 2, 6
"""TIFF 6.0's PhotometricInterpretation values read (tifffile's ``PHOTOMETRIC`` enumeration compares equal to them)."""


# --------------------------------------------------------------------------------------------------
# Boxes
# --------------------------------------------------------------------------------------------------


def _box_numbers(box: Sequence[float]) -> tuple[float, float, float, float]:
    """Return the four numbers of a box as floats, or raise if it is not four finite numbers."""
    try:
        if isinstance(box, str | bytes) or any(isinstance(v, str | bytes) for v in box):
            raise TypeError("text")
        numbers = tuple(float(v) for v in box)
    except (TypeError, ValueError, OverflowError) as exc:
        raise AerofidInputError(
            f"box {reprlib.repr(box)} is not four numbers; give (x0, y0, x1, y1) in pixels"
        ) from exc
    if len(numbers) != 4:
        raise AerofidInputError(f"box {reprlib.repr(box)} has {len(numbers)} numbers; give (x0, y0, x1, y1) in pixels")
    if not all(math.isfinite(v) for v in numbers):
        raise AerofidInputError(f"box {reprlib.repr(box)} has a non-finite number; give finite pixel coordinates")
    return numbers


def part_inside(box: Sequence[int], width: int, height: int) -> tuple[int, int, int, int] | None:
    """The part of a box of whole pixels inside an image of ``width`` x ``height`` pixels, None where it has none (a
    drawing of a mark predicted off the scan draws no pixel; :func:`clip_box` refuses such a box)."""
    inside = (max(box[0], 0), max(box[1], 0), min(box[2], width), min(box[3], height))
    return inside if inside[2] > inside[0] and inside[3] > inside[1] else None


def clip_box(
    box: Sequence[float], width: int, height: int
) -> tuple[tuple[int, int, int, int], bool]:
    """Clip a box to an image of ``width`` x ``height`` pixels.

    The box is first widened to whole pixels (x0, y0 rounded down; x1, y1 rounded up), then cut to the
    image. Returns ``(clipped_box, was_clipped)``; ``was_clipped`` says whether the whole-pixel box reached
    outside the image.

    Raises:
        AerofidInputError: the box is not four finite numbers, is empty (x1 <= x0 or y1 <= y0), or lies
            wholly outside the image.
    """
    x0, y0, x1, y1 = _box_numbers(box)
    if x1 <= x0 or y1 <= y0:
        raise AerofidInputError(
            f"box {tuple(box)} is empty; give (x0, y0, x1, y1) with x1 > x0 and y1 > y0"
        )
    rounded = (math.floor(x0), math.floor(y0), math.ceil(x1), math.ceil(y1))
    clipped = part_inside(rounded, width, height)
    if clipped is None:
        raise AerofidInputError(
            f"box {tuple(box)} lies outside the {width} x {height} image; "
            "give a box that overlaps the image"
        )
    return clipped, clipped != rounded


def _window_box(box: Sequence[int], width: int, height: int) -> tuple[int, int, int, int]:
    """Return ``box`` as four ints after checking that it is a non-empty window inside the image."""
    try:
        x0, y0, x1, y1 = (operator.index(v) for v in box)
    except (TypeError, ValueError) as exc:
        raise AerofidInputError(
            f"window box {box!r} is not four integers; round it with clip_box() first"
        ) from exc
    if x1 <= x0 or y1 <= y0:
        raise AerofidInputError(f"window box {tuple(box)} is empty; give x1 > x0 and y1 > y0")
    if x0 < 0 or y0 < 0 or x1 > width or y1 > height:
        raise AerofidInputError(
            f"window box {tuple(box)} reaches outside the {width} x {height} image; "
            "clip it with clip_box() first"
        )
    return x0, y0, x1, y1


def check_window_size(
    box: Sequence[int], bands: int, itemsize: int, limit_bytes: int = WINDOW_LIMIT_BYTES
) -> None:
    """Raise :class:`AerofidInputError` if reading ``box`` would need more than ``limit_bytes`` bytes."""
    x0, y0, x1, y1 = box
    nbytes = (x1 - x0) * (y1 - y0) * bands * itemsize
    if nbytes > limit_bytes:
        raise AerofidInputError(
            f"window {tuple(box)} would need {nbytes / 1e9:.1f} GB, more than the "
            f"{limit_bytes / 1e9:.1f} GB limit; give a smaller box"
        )


def segment_indices(
    box: Sequence[int],
    segment_shape: tuple[int, int],
    image_shape: tuple[int, int],
    planes: int = 1,
) -> np.ndarray:
    """Indices of the TIFF tiles or strips that intersect a window, in TIFF segment order.

    Args:
        box: ``(x0, y0, x1, y1)`` window inside the image, x1 and y1 exclusive.
        segment_shape: ``(rows, columns)`` of one tile; for strips ``(rows_per_strip, image_width)``.
        image_shape: ``(height, width)`` of the image.
        planes: number of separately stored sample planes (``PlanarConfiguration`` 2), else 1.

    Returns:
        Sorted int64 array of indices into ``page.dataoffsets``: per plane, segments run row by row.
    """
    x0, y0, x1, y1 = box
    seg_rows, seg_cols = segment_shape
    across = -(-image_shape[1] // seg_cols)
    per_plane = -(-image_shape[0] // seg_rows) * across
    rows = np.arange(y0 // seg_rows, (y1 - 1) // seg_rows + 1)
    cols = np.arange(x0 // seg_cols, (x1 - 1) // seg_cols + 1)
    in_plane = (rows[:, None] * across + cols[None, :]).ravel()
    return (np.arange(planes)[:, None] * per_plane + in_plane[None, :]).ravel()


# --------------------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------------------


def _one_line(exc: BaseException) -> str:
    """A library exception's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__


def _sniff_format(head: bytes) -> str | None:
    """``"tiff"``, ``"jpeg"`` or ``"png"`` from a file's first bytes, or None."""
    if head[:4] in _TIFF_MAGIC:
        return "tiff"
    if head.startswith(_JPEG_MAGIC):
        return "jpeg"
    if head.startswith(_PNG_MAGIC):
        return "png"
    return None


def _file_format(path: Path) -> str:
    """Check that ``path`` is a readable file of a supported format and return the format's name."""
    input_file(path, "image")
    try:
        with path.open("rb") as file:
            head = file.read(8)
    except OSError as exc:
        raise AerofidInputError(f"cannot read {path}: {_one_line(exc)}; check its permissions") from exc
    kind = _sniff_format(head)
    if kind is None:
        what = "an empty file" if not head else "not a supported image format"
        raise AerofidInputError(
            f"{path} is {what}; aerofid reads {SUPPORTED_FORMATS}: convert the scan to one of these"
        )
    return kind


def _bands_for_samples(samples: int, path: Path) -> int:
    """Bands returned for ``samples`` samples per pixel: 1 (grey) or 3 (RGB, alpha dropped)."""
    if samples == 1:
        return 1
    if samples in (3, 4):
        return 3
    raise AerofidInputError(
        f"{path} has {samples} samples per pixel; aerofid reads grey (1), RGB (3) or RGBA (4, alpha "
        "dropped): export the scan as grey or RGB"
    )


def _check_dtype(dtype: np.dtype | None, path: Path) -> np.dtype:
    """Return ``dtype`` in native byte order if aerofid reads it (unsigned integer or float), else raise."""
    if dtype is None or dtype.kind not in "uf":
        raise AerofidInputError(
            f"{path} has {dtype if dtype is not None else 'undecodable'} samples; aerofid reads unsigned "
            "8-, 16- or 32-bit integer or float samples: convert the scan to 8- or 16-bit"
        )
    return dtype.newbyteorder("=")


def _hwc(shaped: np.ndarray) -> np.ndarray:
    """View a tifffile array of normalised shape (planes, depth, rows, columns, contig samples) of one
    depth as (rows, columns, samples)."""
    planes, _, rows, cols, contig = shaped.shape
    return shaped[:, 0].transpose(1, 2, 0, 3).reshape(rows, cols, planes * contig)


class _ArrayReader:
    """Windows of a (rows, columns, samples) array that is made on first need and then kept: a whole
    decoded image, or a memory map of the file (``mapped``), which :meth:`release` unmaps between the strips
    of a reduced read so that the pages it touched do not pile up."""

    def __init__(self, load: Callable[[], np.ndarray], mapped: bool = False):
        self._load = load
        self._array: np.ndarray | None = None
        self._loading = threading.Lock()
        self.mapped = mapped

    def read(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """Samples of the window ``box`` (a view of the kept array); from any thread (one loads the array)."""
        array = self._array
        if array is None:
            with self._loading:
                if self._array is None:
                    self._array = self._load()
                array = self._array
        x0, y0, x1, y1 = box
        return array[y0:y1, x0:x1]

    def release(self) -> None:
        """Forget a memory map (it is unmapped once no window views it; the next read maps it again)."""
        if self.mapped:
            self._array = None

    def close(self) -> None:
        """Drop the array (and with it any memory map)."""
        self._array = None


def _positional_reads(filehandle: tifffile.FileHandle) -> int | None:
    """The file descriptor under a TIFF's file handle, for reads at an offset (``os.pread``) that several threads make
    at once, where the handle is the whole file (its offsets are the file's: not a TIFF embedded in a larger file);
    None where the platform or the handle has none (then reads seek under a lock)."""
    if not hasattr(os, "pread"):
        return None
    try:
        fd = filehandle.fileno()
        return fd if os.fstat(fd).st_size == filehandle.size else None
    except (OSError, ValueError):
        return None


def _pread(fd: int, count: int, offset: int) -> bytes:
    """``count`` bytes of ``fd`` from ``offset``, fewer only where the file ends (as a file's ``read`` gives them)."""
    parts, got = [], 0
    while got < count and (more := os.pread(fd, count - got, offset + got)):
        parts.append(more)
        got += len(more)
    return b"".join(parts)


class _TiffSegmentReader:
    """Windows of a TIFF page, reading and decoding only the tiles or strips that intersect a window."""

    def __init__(self, tif: tifffile.TiffFile, page: tifffile.TiffPage):
        self._filehandle = tif.filehandle
        self._seeking = threading.Lock()        # tifffile's own lock is a no-op unless asked for
        self._positional = _positional_reads(tif.filehandle)
        self._page = page
        if page.is_tiled:
            self.segment_shape = (page.tilelength, page.tilewidth)
        else:
            self.segment_shape = (min(page.rowsperstrip, page.imagelength), page.imagewidth)
        self.planes = page.samplesperpixel if page.planarconfig == 2 else 1
        self._decode_args = (
            {"jpegtables": page.jpegtables} if page.compression in _JPEG_COMPRESSIONS else {}
        )

    def expected_segments(self) -> int:
        """Number of segments this layout needs; a page with another number cannot be windowed."""
        rows, cols = self.segment_shape
        page = self._page
        return self.planes * -(-page.imagelength // rows) * -(-page.imagewidth // cols)

    def _segment_bytes(self, index: int) -> bytes | None:
        """Encoded bytes of one segment, or None for a segment that the file leaves empty."""
        offset, count = self._page.dataoffsets[index], self._page.databytecounts[index]
        if offset == 0 or count == 0:
            return None
        if self._positional is not None:        # os.pread: no shared position, no lock between the threads
            return _pread(self._positional, count, offset)
        with self._seeking:                     # strips are read by several threads (aerofid.io.reduce)
            self._filehandle.seek(offset)
            return self._filehandle.read(count)

    def read(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """Samples of the window ``box``, assembled from the decoded segments it intersects."""
        page = self._page
        x0, y0, x1, y1 = box
        # every pixel of the window lies in one segment of each plane (the layout was checked at open), so the
        # array needs no fill but where a segment is empty
        out = np.empty((y1 - y0, x1 - x0, page.samplesperpixel), dtype=page.dtype)
        indices = segment_indices(box, self.segment_shape, (page.imagelength, page.imagewidth), self.planes)
        for index in indices.tolist():
            segment, (plane, _, top, left, _), shape = page.decode(
                self._segment_bytes(index), index, **self._decode_args
            )
            rows, cols, samples = shape[1:] if segment is None else segment.shape[1:]
            r0, r1 = max(top, y0), min(top + rows, y1)
            c0, c1 = max(left, x0), min(left + cols, x1)
            part = out[r0 - y0 : r1 - y0, c0 - x0 : c1 - x0, plane : plane + samples]
            if segment is None:  # an empty segment: the file's nodata value
                part[...] = page.nodata
            else:
                part[...] = segment[0, r0 - top : r1 - top, c0 - left : c1 - left]
        return out

    def close(self) -> None:
        """Drop the page and file handle (the :class:`Raster` closes the file itself)."""
        del self._page, self._filehandle


_Reader = _ArrayReader | _TiffSegmentReader | jpeg.HugeJpegReader | BackgroundJpegReader
"""What reads a raster's windows."""


class Raster:
    """A scanned photograph opened for windowed reading; use as a context manager or call :meth:`close`.

    Attributes:
        path: the file.
        format: ``"tiff"``, ``"jpeg"`` or ``"png"`` (from the file's first bytes).
        width, height: image size in pixels.
        bands: 1 (grey) or 3 (RGB; an alpha band is dropped).
        dtype: numpy dtype of the samples that :meth:`read_window` returns (native byte order).
        tiled: whether the file stores tiles (only TIFF can).
        chroma_subsampled: whether the file stores a colour image's chroma at a lower resolution than its luma (a
            JPEG's, or a JPEG-compressed TIFF's, 4:2:0 or 4:2:2): only its luminance then has the full resolution.
        luma_step: a JPEG's quantisation step of its luma's lowest frequencies, as a share of the samples' range
            (:func:`aerofid.io.jpeg.luma_quantisation`); None where the file does not say it (TIFF, PNG).
    """

    def __init__(self, path: str | os.PathLike[str], rows: int | None = None):
        self.path = Path(path)
        self.format = _file_format(self.path)
        self._tif: tifffile.TiffFile | None = None
        self._reader: _Reader | None = None
        self._overview: jpeg.HugeJpegReader | None = None
        self._invert = False
        if self.format == "tiff":
            self._open_tiff()
        else:
            self._open_cv2(rows)

    def _open_cv2(self, rows: int | None) -> None:
        """Read a JPEG's or PNG's size from its header; decode it whole if that fits the budget
        (:func:`aerofid.io.jpeg.decode_budget`), else (a JPEG only) keep it for reduced reads. ``rows``: see
        :func:`open_raster`."""
        header = jpeg.read_header(self.path, self.format)
        self.tiled = False
        self.chroma_subsampled = header.chroma_subsampled
        self.luma_step = header.luma_step
        if jpeg.decodes_whole(header):
            st = self.path.stat()
            key = (str(self.path.resolve()), st.st_mtime_ns, st.st_size)
            if jpeg.decodes_in_background(header, self.format):
                self._open_decoding(header, lambda: jpeg.decoding(*key, header),
                                    rows if jpeg.kept_decoding(*key) is None else None, key)
                return
            image = jpeg.decode_whole(*key)
            self.height, self.width, samples = image.shape
            self.bands = _bands_for_samples(samples, self.path)
            self.dtype = _check_dtype(image.dtype, self.path)
            self._reader = _ArrayReader(lambda: image)
            return
        too_large = (
            f"{self.path} is a {header.width} x {header.height} {self.format.upper()} of "
            f"{header.decoded_bytes / 1e9:.1f} GB decoded, more than the {jpeg.decode_budget() / 1e9:.1f} GB "
            "that aerofid decodes whole"
        )
        if self.format != "jpeg" or header.itemsize != 1:
            raise AerofidInputError(f"{too_large}; convert it to a tiled TIFF (e.g. gdal_translate -co TILED=YES)")
        self._reader = self._from_header(header)

    def _from_header(self, header: jpeg.ImageHeader, checks_truncation: bool = True) -> jpeg.HugeJpegReader:
        """Size, bands and type of an 8-bit JPEG from its header, and its reader through libjpeg's reduced decode."""
        self.width, self.height = header.width, header.height
        self.bands = _bands_for_samples(header.samples, self.path)
        self.dtype = np.dtype(np.uint8)
        return jpeg.HugeJpegReader(self.path, header, self.bands, checks_truncation)

    def _open_decoding(self, header: jpeg.ImageHeader, start: Callable[[], jpeg.Decoding], rows: int | None,
                       key: tuple[str, int, int]) -> None:
        """A JPEG decoded whole in the background (``start``: :func:`aerofid.io.jpeg.decoding`; not started while
        only its top ``rows`` are read, :class:`~aerofid.io.jpeg_top.BackgroundJpegReader`): its size from the header,
        windows once the decode is done, and :meth:`read_overview` from libjpeg's reduced decode meanwhile."""
        self._overview = self._from_header(header, checks_truncation=False)   # the whole decode refuses a truncated one
        self._reader = BackgroundJpegReader(start, header, self.path, rows, key)

    def _open_tiff(self) -> None:
        """Open the first page of a TIFF and choose how windows of it are read."""
        import tifffile  # only a TIFF needs it (start-up of a JPEG's one-box locate, issue 10)

        try:
            tif = self._tif = tifffile.TiffFile(self.path)
            page = tif.pages.first
        except Exception as exc:  # tifffile raises many types for corrupt files
            self.close()
            raise AerofidInputError(
                f"cannot read {self.path} as TIFF: {_one_line(exc)}; the file may be corrupt or truncated"
            ) from exc
        try:
            self._describe_tiff_page(page)
            self._reader = self._tiff_reader(tif, page)
        except AerofidInputError:
            self.close()
            raise
        except Exception as exc:  # tags that lie in ways tifffile lets through (a tile 0 px wide, a tuple for a size)
            self.close()
            raise AerofidInputError(
                f"cannot read {self.path} as TIFF: {_one_line(exc)}; the file may be corrupt or truncated"
            ) from exc

    def _describe_tiff_page(self, page: tifffile.TiffPage) -> None:
        """Set size, bands, dtype and inversion from a TIFF page, or raise if aerofid cannot read it."""
        if page.imagedepth != 1 or page.imagewidth == 0 or page.imagelength == 0:
            raise AerofidInputError(
                f"{self.path} has a {page.imagedepth} x {page.imagelength} x {page.imagewidth} image; "
                "aerofid reads non-empty 2-D images: export the scan as a plain 2-D TIFF"
            )
        self.width, self.height = page.imagewidth, page.imagelength
        self.bands = _bands_for_samples(page.samplesperpixel, self.path)
        self.dtype = _check_dtype(page.dtype, self.path)
        self.tiled = bool(page.is_tiled)
        self.chroma_subsampled = self.bands == 3 and bool(page.is_subsampled)
        self.luma_step = None
        photometric = page.photometric
        jpeg = page.compression in _JPEG_COMPRESSIONS
        usable = photometric in (_MINISBLACK, _RGB) or (photometric == _YCBCR and jpeg)
        if photometric == _MINISWHITE and self.bands == 1 and self.dtype.kind == "u":
            self._invert = True
        elif not usable:
            name = getattr(photometric, "name", photometric)
            raise AerofidInputError(
                f"{self.path} stores {name} colour with {page.samplesperpixel} samples of {self.dtype}; "
                "aerofid reads grey or RGB TIFFs: convert the scan to one of these"
            )

    def _tiff_reader(self, tif: tifffile.TiffFile, page: tifffile.TiffPage) -> _ArrayReader | _TiffSegmentReader:
        """The cheapest reader that can window ``page``: memory map, segments, or whole-page decode."""
        if page.is_memmappable:
            file_dtype = np.dtype(tif.byteorder + self.dtype.char)
            return _ArrayReader(
                lambda: _hwc(
                    np.memmap(self.path, file_dtype, "r", offset=page.dataoffsets[0], shape=page.shaped)
                ),
                mapped=True,
            )
        segments = _TiffSegmentReader(tif, page)
        if page.jpegheader is None and len(page.dataoffsets) == segments.expected_segments():
            rows, cols = segments.segment_shape
            check_budget(rows * cols * page.samplesperpixel * self.dtype.itemsize,
                         f"{self.path} stores {rows} x {cols} px tiles or strips: decoding one",
                         "the file may be corrupt; else convert it to a tiled TIFF (e.g. gdal_translate -co TILED=YES)")
            return segments
        check_budget(page.imagewidth * page.imagelength * page.samplesperpixel * self.dtype.itemsize,
                     f"{self.path} declares a {page.imagewidth} x {page.imagelength} image in {len(page.dataoffsets)} "
                     f"segments (its layout needs {segments.expected_segments()}): decoding it whole",
                     "the file may be corrupt; else convert it to a tiled TIFF (e.g. gdal_translate -co TILED=YES)")
        return _ArrayReader(lambda: _hwc(page.asarray(squeeze=False)))

    def _open_reader(self) -> _Reader:
        """The reader, or raise if the raster is closed."""
        if self._reader is None:
            raise AerofidInputError(f"{self.path} is closed; open it again with open_raster()")
        return self._reader

    def _samples(self, box: tuple[int, int, int, int], copy: bool = True) -> np.ndarray:
        """The window's ``(h, w, bands)`` samples of :attr:`dtype`, alpha dropped, MINISWHITE inverted; a view
        of a kept array unless ``copy``."""
        reader = self._open_reader()
        try:
            samples = reader.read(box)
        except (AerofidInputError, MemoryError):  # a background decode's own error, or the memory it lacked
            raise
        except Exception as exc:  # tifffile, imagecodecs and numpy.memmap raise many types
            raise AerofidInputError(
                f"cannot decode window {box} of {self.path}: {_one_line(exc)}; the file may be corrupt or truncated"
            ) from exc
        bands = samples[:, :, : self.bands]
        if not (copy or self._invert):
            return np.asarray(bands, dtype=self.dtype)
        window = np.array(bands, dtype=self.dtype)
        if self._invert:
            np.subtract(np.iinfo(self.dtype).max, window, out=window)
        return window

    def read_window(self, box: Sequence[int]) -> np.ndarray:
        """Read the samples of a window.

        Args:
            box: ``(x0, y0, x1, y1)`` integers in full-image pixels (x = column, y = row), x1 and y1
                exclusive, inside the image (clip a loose box with :func:`clip_box` first).

        Returns:
            A new ``(h, w)`` (grey) or ``(h, w, 3)`` (RGB) array of :attr:`dtype`.

        Raises:
            AerofidInputError: the raster is closed; the box is not four integers, is empty, reaches outside
                the image or would need more than about 1 GB; the file cannot be decoded (or is a JPEG too
                large to decode whole).
        """
        self._open_reader()
        window_box = _window_box(box, self.width, self.height)
        check_window_size(window_box, self.bands, self.dtype.itemsize, WINDOW_LIMIT_BYTES)
        window = self._samples(window_box)
        return window[:, :, 0] if self.bands == 1 else window

    def _strip_rows(self, r0: int, r1: int, columns: tuple[int, int]) -> np.ndarray:
        """Rows ``[r0, r1)`` of the image under ``columns``, for :meth:`read_reduced`; a memory map is then
        released so that each strip's pages are unmapped once the strip is reduced."""
        reader = self._open_reader()
        strip = self._samples((columns[0], r0, columns[1], r1), copy=False)
        if isinstance(reader, _ArrayReader):
            reader.release()
        return strip

    def read_reduced(self, box: Sequence[int], factor: int) -> np.ndarray:
        """Read a window reduced by block means, in bounded memory whatever the box.

        Parameters
        ----------
        box : sequence of int
            ``(x0, y0, x1, y1)`` integers in full-image pixels, x1 and y1 exclusive, inside the image (as
            :meth:`read_window` takes).
        factor : int
            Side of the square blocks averaged (>= 1; 1 gives :meth:`read_window` as float32).

        Returns
        -------
        numpy.ndarray
            float32 in the file's sample units (not normalised), ``(ceil(h / factor), ceil(w / factor))`` for
            grey or ``(..., ..., 3)`` for RGB; blocks at the right and bottom edges are the means of the pixels
            they have. The window is read in strips of at most about 64 MB of samples (whole tile rows of a
            tiled TIFF; :mod:`aerofid.io.reduce`). A JPEG too large to decode whole is reduced from libjpeg's
            1/2, 1/4 or 1/8 decode, which is close to the block mean but not exact (:mod:`aerofid.io.jpeg`).

        Raises
        ------
        AerofidInputError
            The raster is closed; the box is not a window inside the image; the factor is not an integer >= 1;
            the reduced window would need more than about 1 GB; the file cannot be decoded.
        """
        reader = self._open_reader()
        window_box, factor = self._reduced_request(box, factor)
        if isinstance(reader, jpeg.HugeJpegReader):
            out = reader.read_reduced(window_box, factor)
        else:
            step = reader.segment_shape[0] if isinstance(reader, _TiffSegmentReader) else 1
            columns = (window_box[0], window_box[2])
            threads = THREADS if isinstance(reader, _TiffSegmentReader | _ArrayReader) else 1
            out = reduce_in_strips(lambda r0, r1: self._strip_rows(r0, r1, columns), window_box, factor,
                                   self.bands, itemsize=self.dtype.itemsize, row_step=step, threads=threads)
        return out[:, :, 0] if self.bands == 1 else out

    def _reduced_request(self, box: Sequence[int], factor: int) -> tuple[tuple[int, int, int, int], int]:
        """The window and factor of a reduced read, checked (:meth:`read_reduced`'s errors)."""
        window_box = _window_box(box, self.width, self.height)
        factor = check_factor(factor)
        check_reduced_size(window_box, factor, self.bands, WINDOW_LIMIT_BYTES)
        return window_box, factor

    def read_overview(self, box: Sequence[int], factor: int) -> np.ndarray:
        """A window reduced by ``factor`` for a first look at a whole frame: :meth:`read_reduced`, except for a JPEG
        decoded in the background, where an even ``factor`` is read from libjpeg's reduced decode
        (:class:`~aerofid.io.jpeg.HugeJpegReader`: close to the block means of a whole frame, not exact, and
        farther from them at the image's last row and column and on windows not on its 8 x 8 grid) without waiting
        for the whole decode. A corrupt JPEG's reduced decode may succeed: :meth:`check_decoded` tells."""
        if self._overview is None:                  # not such a JPEG, or closed: read_reduced checks and reads
            return self.read_reduced(box, factor)
        window_box, factor = self._reduced_request(box, factor)
        if factor % 2:
            return self.read_reduced(window_box, factor)
        out = self._overview.read_reduced(window_box, factor)
        return out[:, :, 0] if self.bands == 1 else out

    @property
    def decoding(self) -> bool:
        """Whether a whole decode of this JPEG is running in its own thread (then a second core is busy with it)."""
        pending = self._reader.pending if isinstance(self._reader, BackgroundJpegReader) else None
        return pending is not None and not pending.future.done()

    def check_decoded(self) -> None:
        """Wait for a JPEG's background decode (started now if the raster was opened for its top rows and has not
        started it) and raise its error (one line) if it failed; nothing for other rasters. A search that read only
        :meth:`read_overview` calls it: a corrupt file is an error, not an image without marks."""
        reader = self._open_reader()
        if isinstance(reader, BackgroundJpegReader):
            reader.whole()

    def close(self, check: bool = True) -> None:
        """Release the file and any cached image, once a background decode has ended (so that no decode runs, or
        writes libjpeg's warnings to stderr, after the raster is closed); later reads raise
        :class:`AerofidInputError`. Where windows were read from a JPEG's top rows before its whole decode was done
        (:mod:`aerofid.io.jpeg_top`), that decode's error is raised here (``check``; not while leaving a ``with``
        block on another error): a truncated file is an error, as when the window waited for it
        (:meth:`~aerofid.io.jpeg_top.BackgroundJpegReader.check`)."""
        reader = self._reader
        try:
            if isinstance(reader, BackgroundJpegReader):
                if reader.pending is not None:
                    jpeg.finish(reader.pending)
                if check:
                    reader.check()
        finally:
            self._release()

    def _release(self) -> None:
        """Drop the readers, the kept image and the TIFF file (:meth:`close`)."""
        if self._reader is not None:
            self._reader.close()
        self._reader = None
        if self._overview is not None:
            self._overview.close()
            self._overview = None
        if self._tif is not None:
            self._tif.close()
            self._tif = None

    def __enter__(self) -> Raster:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close(check=exc_info[0] is None)

    def __repr__(self) -> str:
        state = "closed" if self._reader is None else "open"
        return (
            f"<Raster {str(self.path)!r} {self.format} {self.width}x{self.height} bands={self.bands} "
            f"dtype={self.dtype} tiled={self.tiled} {state}>"
        )


def image_size(path: str | os.PathLike[str]) -> tuple[int, int]:
    """A scan's (width, height) from its header, no pixel decoded (a TIFF's first page, a JPEG's or PNG's header);
    the errors of :func:`open_raster`."""
    p = Path(os.fspath(path))
    kind = _file_format(p)
    if kind == "tiff":
        with Raster(p) as scan:
            return scan.width, scan.height
    header = jpeg.read_header(p, kind)
    return header.width, header.height


def open_raster(path: str | os.PathLike[str], rows: int | None = None) -> Raster:
    """Open a scan (TIFF/BigTIFF/GeoTIFF, JPEG or PNG) for windowed reading.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its format is recognised from its first bytes.
    rows : int, optional
        The caller reads no row at or below this one (e.g. the boxes near the top of a scan it will search). A JPEG
        whose windows are read while it is decoded whole in the background then decodes those top rows alone, and
        starts its whole decode only if a read reaches below them (:mod:`aerofid.io.jpeg_top`); reads beyond them
        are still right, only slower. None: any row (a JPEG starts its whole decode at once).

    Returns
    -------
    Raster
        Use it as a context manager (or call :meth:`Raster.close`) and read windows with
        :meth:`Raster.read_window`.

    Raises
    ------
    AerofidInputError
        Missing, unreadable, unsupported or corrupt file (one line saying what to do); the corruption of a JPEG
        decoded in the background is told when a window is read, or by :meth:`Raster.check_decoded`.

    Examples
    --------
    A tiled 16-bit TIFF, of which one window is read:

    >>> import tempfile, pathlib, tifffile
    >>> image = np.arange(300 * 200, dtype=np.uint16).reshape(300, 200)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "scan.tif"
    >>> tifffile.imwrite(path, image, tile=(64, 64))
    >>> with open_raster(path) as scan:
    ...     window = scan.read_window((10, 20, 50, 60))         # (x0, y0, x1, y1), x1 and y1 exclusive
    ...     print(scan.width, scan.height, scan.bands, scan.tiled)
    200 300 1 True
    >>> bool((window == image[20:60, 10:50]).all())
    True
    """
    return Raster(path, rows)
