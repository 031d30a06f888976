"""Block means of a window, read strip by strip so that memory stays bounded (``read_reduced``).

A window of ``h`` x ``w`` pixels reduced by a factor ``f`` has ``ceil(h / f)`` x ``ceil(w / f)`` pixels, each the
mean of an ``f`` x ``f`` block of the window (blocks at the right and bottom edges are means of the pixels they
have). The window is read in horizontal strips of at most :data:`STRIP_BYTES` of samples (whole tile rows of a
tiled TIFF) and each strip is folded into the output in chunks of :data:`CHUNK_SAMPLES`, so peak memory is the
output plus one strip plus one chunk, whatever the window (where several threads read strips at once,
:func:`reduce_in_strips`, their strips together hold at most :data:`STRIP_BYTES`, plus a chunk each).

A source at the image's own scale is summed block by block (rows and columns grouped by reshapes, in
integers for integer samples; :func:`_fold_blocks`). The reduction is linear: ``out = Wy @
window @ Wx.T`` with banded weight matrices (:func:`block_weights`: a block meets a few source pixels), which
reduce a source that is itself stored reduced by ``scale`` (libjpeg's reduced JPEG decode): each source pixel then
stands for ``scale`` x ``scale`` pixels of the image, and a block's mean weighs each source pixel by the area it
shares with the block.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerofid.conventions import LEAST_GREY_STEP
from aerofid.errors import AerofidInputError
from aerofid.io.colour import saturated
from aerofid.io.source import ImageSource
from aerofid.parallel import map_in_threads

__all__ = [
    "CHUNK_SAMPLES",
    "STRIP_BYTES",
    "THREADED_BYTES",
    "BlockWeights",
    "ReducedView",
    "block_weights",
    "check_factor",
    "check_reduced_size",
    "read_reduced_levels",
    "reduce_in_strips",
    "reduced_shape",
]

#: Most bytes of samples read at once by ``read_reduced`` (one strip; a tile row may be more).
STRIP_BYTES = 64 * 2**20
#: Least bytes of samples in a window whose strips several threads read (:func:`reduce_in_strips`): starting them costs
#: about a millisecond, the time one thread reads and folds 2 MB of an array in memory.
THREADED_BYTES = 16 * 2**20
#: Most samples of a strip folded into the output at once (block sums, or float64 for the weights of a reduced source).
CHUNK_SAMPLES = 2**21

RowReader = Callable[[int, int], np.ndarray]
"""``read_rows(r0, r1)``: source rows ``[r0, r1)`` under the window's columns, ``(rows, cols, bands)``."""


def check_factor(factor: int) -> int:
    """Return ``factor`` as an int, or raise :class:`AerofidInputError` if it is not an integer >= 1.

    Parameters
    ----------
    factor : int
        The reduction factor: the side of the square blocks that are averaged.

    Returns
    -------
    int
        ``factor``.
    """
    try:
        value = operator.index(factor)
    except TypeError as exc:
        raise AerofidInputError(f"reduction factor {factor!r} is not an integer; give an integer >= 1") from exc
    if isinstance(factor, bool) or value < 1:
        raise AerofidInputError(f"reduction factor {factor!r} is not an integer >= 1; give an integer >= 1")
    return value


def reduced_shape(box: Sequence[int], factor: int) -> tuple[int, int]:
    """``(rows, columns)`` of window ``box`` = ``(x0, y0, x1, y1)`` reduced by ``factor`` (partial blocks count).

    Parameters
    ----------
    box : sequence of int
        ``(x0, y0, x1, y1)``, x1 and y1 exclusive.
    factor : int
        Side of the averaged blocks.

    Returns
    -------
    tuple of int
        ``(ceil((y1 - y0) / factor), ceil((x1 - x0) / factor))``.
    """
    x0, y0, x1, y1 = box
    return -(-(y1 - y0) // factor), -(-(x1 - x0) // factor)


def check_reduced_size(box: Sequence[int], factor: int, bands: int, limit_bytes: int) -> None:
    """Raise :class:`AerofidInputError` if the float32 reduced window would need more than ``limit_bytes``.

    Parameters
    ----------
    box : sequence of int
        ``(x0, y0, x1, y1)`` window.
    factor : int
        Side of the averaged blocks.
    bands : int
        1 (grey) or 3 (RGB).
    limit_bytes : int
        The most bytes the output may take.
    """
    rows, cols = reduced_shape(box, factor)
    nbytes = rows * cols * bands * 4
    if nbytes > limit_bytes:
        raise AerofidInputError(
            f"window {tuple(box)} reduced by {factor} would need {nbytes / 1e9:.1f} GB, more than the "
            f"{limit_bytes / 1e9:.1f} GB limit; give a larger factor or a smaller box"
        )


@dataclass(frozen=True, eq=False)
class BlockWeights:
    """The weights that average the pixels of a window along one axis in blocks, from a source whose pixel ``i``
    covers image pixels ``[i scale, (i + 1) scale)``: block ``j``'s mean is the sum over ``m`` of ``weight[j, m]``
    times source pixel ``first[j] + m`` (counted from the window's first source pixel), a weight 0 where that source
    pixel shares nothing with the block. A banded matrix: (blocks, sources), ``taps`` source pixels per block."""

    first: np.ndarray
    """(blocks,) int: each block's first source pixel (it covers the block's first image pixel: its weight is not 0)."""
    last: np.ndarray
    """(blocks,) int: each block's last source pixel of a weight that is not 0."""
    weight: np.ndarray
    """(blocks, taps) float64: the share of the block's length each of its source pixels covers (rows sum to 1)."""
    sources: int
    """The source pixels along the axis under the window."""

    def dense(self) -> np.ndarray:
        """The (blocks, sources) matrix."""
        out = np.zeros((len(self.first), self.sources))
        for m in range(self.weight.shape[1]):
            on = self.weight[:, m] > 0
            out[np.flatnonzero(on), self.first[on] + m] = self.weight[on, m]
        return out


def block_weights(start: int, stop: int, factor: int, scale: int = 1) -> BlockWeights:
    """Weights that average the pixels ``[start, stop)`` of one axis in blocks of ``factor``.

    Parameters
    ----------
    start, stop : int
        The window along the axis, in image pixels (stop exclusive).
    factor : int
        Block length in image pixels; the last block is cut at ``stop``.
    scale : int, optional
        Source pixel ``i`` covers image pixels ``[i * scale, (i + 1) * scale)`` (1: the source is the image).

    Returns
    -------
    BlockWeights
        Source pixel 0 is ``start // scale``. Block ``j``'s weights are the share of its length that each source
        pixel covers, so that they sum to 1.

    Examples
    --------
    >>> block_weights(2, 9, 4, 2).dense().tolist()      # blocks 2-5 and 6-8 of source pixels 1-4 (2 px each)
    [[0.5, 0.5, 0.0, 0.0], [0.0, 0.0, 0.6666666666666666, 0.3333333333333333]]
    """
    n = -(-(stop - start) // factor)
    b0 = start + np.arange(n) * factor
    b1 = np.minimum(b0 + factor, stop)
    taps = -(-factor // scale) + 1                       # the source pixels a block can touch
    weight = np.zeros((n, taps))
    for m in range(taps):
        source = b0 // scale + m
        overlap = np.minimum((source + 1) * scale, b1) - np.maximum(source * scale, b0)
        keep = overlap > 0
        weight[keep, m] = overlap[keep] / (b1 - b0)[keep]
    first = b0 // scale - start // scale
    return BlockWeights(first, (b1 - 1) // scale - start // scale, weight, -(-stop // scale) - start // scale)


def _strips(start: int, stop: int, step: int) -> Iterator[tuple[int, int]]:
    """``[r0, r1)`` ranges covering ``[start, stop)`` with inner boundaries at multiples of ``step``."""
    r0 = start
    while r0 < stop:
        r1 = min((r0 // step + 1) * step, stop)
        yield r0, r1
        r0 = r1


def _fold(out: np.ndarray, strip: np.ndarray, first: int, wy: BlockWeights, wx: BlockWeights, bands: int) -> None:
    """Add the contribution of ``strip`` (``(rows, cols, bands)`` source rows from ``first`` on, relative to the
    window) to ``out``, a chunk of :data:`CHUNK_SAMPLES` at a time: ``wy``'s rows of the chunk's source rows, then
    ``wx``'s columns, each output a sum of its weighted source pixels in their order from 0 (float64), the
    numbers of a sparse matrix product (``out[k0:k1] += Wy[k0:k1, rows] @ samples @ Wx.T``)."""
    chunk = max(1, CHUNK_SAMPLES // max(strip[0].size, 1))
    on = wy.weight > 0
    for c0 in range(0, strip.shape[0], chunk):
        c1 = min(c0 + chunk, strip.shape[0])
        touched = np.flatnonzero((wy.first < first + c1) & (wy.last >= first + c0))
        if touched.size == 0:
            continue
        k0, k1 = int(touched[0]), int(touched[-1]) + 1
        samples = strip[c0:c1].astype(np.float64).reshape(c1 - c0, -1)
        rows = np.zeros((k1 - k0, samples.shape[1]))
        for m in range(wy.weight.shape[1]):
            source = wy.first[k0:k1] + m - (first + c0)
            take = on[k0:k1, m] & (source >= 0) & (source < c1 - c0)
            rows[take] += wy.weight[k0:k1, m][take, None] * samples[source[take]]
        rows3 = rows.reshape(k1 - k0, wx.sources, bands)
        blocks = np.zeros((k1 - k0, len(wx.first), bands))
        for m in range(wx.weight.shape[1]):
            take = np.flatnonzero(wx.weight[:, m] > 0)
            blocks[:, take] += wx.weight[take, m][None, :, None] * rows3[:, wx.first[take] + m]
        out[k0:k1] += blocks.reshape(k1 - k0, -1)


def _sum_type(dtype: np.dtype, factor: int) -> type:
    """The type block sums of ``factor`` x ``factor`` samples of ``dtype`` are exact in."""
    if dtype.kind in "ui" and dtype.itemsize <= 2 and factor * factor * 2 ** (8 * dtype.itemsize) < 2**32:
        return np.uint32 if dtype.kind == "u" else np.int32
    return np.int64 if dtype.kind in "ui" else np.float64


def _row_sum_type(dtype: np.dtype, factor: int) -> type:
    """The narrowest type sums of ``factor`` samples of ``dtype`` are exact in (a block's rows are summed first, in
    it: half the memory traffic of the block's type for 8-bit samples)."""
    if dtype.kind == "u" and dtype.itemsize == 1 and factor * 255 < 2**16:
        return np.uint16
    return _sum_type(dtype, factor)


def _fold_blocks(out: np.ndarray, strip: np.ndarray, first: int, factor: int, height: int) -> None:
    """Add the block means of ``strip`` (``(rows, cols, bands)`` rows of the window from ``first`` on, at the
    image's scale) to ``out`` (``(blocks, cols, bands)``; a block cut by the strip's edge gets its share), for a
    window ``height`` rows high: block sums by reshapes (exact: integers for integer samples), at most
    :data:`CHUNK_SAMPLES` samples at a time."""
    n, w, bands = strip.shape
    acc, narrow = _sum_type(strip.dtype, factor), _row_sum_type(strip.dtype, factor)
    head = min(n, -first % factor)                      # rows that end a block begun in the strip before
    full = (n - head) // factor * factor                # whole blocks; then the rows of one block left
    for r0, r1 in ((0, head), (head + full, n)):         # a part of one block
        if r1 > r0:
            _add_block_means(out, strip[r0:r1].sum(axis=0, dtype=narrow)[None], (first + r0) // factor, factor, height,
                             acc)
    step = max(1, CHUNK_SAMPLES // (factor * w * bands)) * factor
    for r0 in range(head, head + full, step):            # whole blocks, a chunk at a time
        r1 = min(r0 + step, head + full)
        rows = strip[r0:r1].reshape((r1 - r0) // factor, factor, w, bands).sum(axis=1, dtype=narrow)
        _add_block_means(out, rows, (first + r0) // factor, factor, height, acc)


def _add_block_means(out: np.ndarray, rows: np.ndarray, block: int, factor: int, height: int, acc: type) -> None:
    """Add ``rows`` (sums over the rows of blocks ``block``, ``block + 1``, ...: ``(k, cols, bands)``), summed over
    the columns of each block (in ``acc``) and divided by its size, to ``out``'s rows ``block ..``."""
    k, w, bands = rows.shape
    whole = w // factor * factor
    sums = np.empty((k, -(-w // factor), bands), np.float64)
    # the block's columns added one by one: a reshape's sum over its last, short axis is slower
    columns: np.ndarray = rows[:, 0:whole:factor].astype(acc)
    for j in range(1, factor):
        columns += rows[:, j:whole:factor]
    sums[:, : whole // factor] = columns
    if whole < w:
        sums[:, -1] = rows[:, whole:].sum(axis=1, dtype=acc)
    widths = np.full(sums.shape[1], float(factor))
    widths[-1] = w - (sums.shape[1] - 1) * factor
    blocks = block + np.arange(k)
    tall = np.minimum(blocks * factor + factor, height) - blocks * factor
    out[block : block + k] += (sums / (tall[:, None, None] * widths[None, :, None])).astype(out.dtype)


def reduce_in_strips(read_rows: RowReader, box: Sequence[int], factor: int, bands: int, *, itemsize: int,
                     scale: int = 1, row_step: int = 1, threads: int = 1) -> np.ndarray:
    """Block means of window ``box`` reduced by ``factor``, read strip by strip.

    Parameters
    ----------
    read_rows : callable
        ``read_rows(r0, r1)`` returns source rows ``[r0, r1)`` under the window's source columns
        ``[x0 // scale, ceil(x1 / scale))`` as a ``(rows, cols, bands)`` array.
    box : sequence of int
        ``(x0, y0, x1, y1)`` window in image pixels, inside the image.
    factor : int
        Side of the averaged blocks, in image pixels (>= 1, a multiple of ``scale``).
    bands : int
        1 or 3.
    itemsize : int
        Bytes per source sample (sizes the strips).
    scale : int, optional
        Each source pixel stands for ``scale`` x ``scale`` image pixels (1: the source is the image).
    row_step : int, optional
        Strip boundaries fall on multiples of this many source rows (a TIFF's tile length or rows per strip), and
        of ``factor`` too where the window's blocks begin on one (a window from row 0) and a strip can hold that
        many rows: each block is then summed from one strip.
    threads : int, optional
        Strips read and folded at once, by that many threads, where ``read_rows`` may be called from several
        (:data:`aerofid.parallel.THREADS`: a TIFF's tiles are decoded, and a memory map's pages read, with the GIL
        released): where the window holds :data:`THREADED_BYTES` or more and ``threads`` strips of
        whole blocks (above) fit in :data:`STRIP_BYTES` together, two per thread where the window has the rows
        (the same numbers as one strip after another); else one strip after another.

    Returns
    -------
    numpy.ndarray
        ``(ceil(h / factor), ceil(w / factor), bands)`` float32 in the source's sample units.
    """
    x0, y0, x1, y1 = box
    rows, cols = reduced_shape(box, factor)
    out = np.zeros((rows, cols * bands), np.float32)
    src_cols = -(-x1 // scale) - x0 // scale
    src0, src1 = y0 // scale, -(-y1 // scale)
    row_bytes = max(src_cols * bands * itemsize, 1)
    step = row_step * max(1, STRIP_BYTES // (row_step * row_bytes))
    weights = None
    if scale > 1:                                        # a reduced source: the area-weighted banded matrices
        weights = (block_weights(y0, y1, factor, scale), block_weights(x0, x1, factor, scale), bands)

    def add(strip_rows: tuple[int, int]) -> None:
        r0, r1 = strip_rows
        strip = read_rows(r0, r1)
        if factor == 1:
            out.reshape(rows, cols, bands)[r0 - src0 : r1 - src0] = strip
        elif weights is None:
            _fold_blocks(out.reshape(rows, cols, bands), strip, r0 - src0, factor, y1 - y0)
        else:
            _fold(out, strip, r0 - src0, *weights)
        del strip  # a memory-mapped strip is unmapped before the next is read

    unit = math.lcm(row_step, factor)                   # strips of whole blocks and whole tile rows
    whole_blocks = weights is None and src0 % factor == 0
    if whole_blocks and unit <= step:
        step = step // unit * unit
    each = min(STRIP_BYTES // (threads * row_bytes), -(-(src1 - src0) // (2 * threads))) // unit * unit
    if not (threads > 1 and whole_blocks and each > 0 and src1 - src0 > each
            and (src1 - src0) * row_bytes >= THREADED_BYTES):
        threads, each = 1, step
    map_in_threads(add, _strips(src0, src1, each), threads)
    return out.reshape(rows, cols, bands)


@dataclass(frozen=True)
class ReducedView:
    """An image seen reduced by ``factor`` (block means, :meth:`~aerofid.io.raster.Raster.read_reduced`), as grey
    levels on [0, 1] (integer samples divided by ``white``, by default their type's maximum): a source that a window
    search reads like the image itself, at a coarser scale. Reduced pixel ``i`` is the mean of full pixels
    ``f i .. f i + f - 1``, so its centre is full pixel ``f i + (f - 1) / 2`` (:meth:`to_full`)."""

    source: ImageSource
    factor: int
    white: float | None = None
    """The search's full scale of the source's integer samples (:func:`read_reduced_levels`; None: their type's
    maximum)."""
    width: int = field(init=False)
    height: int = field(init=False)
    dtype: np.dtype = field(init=False)
    path: Any = field(init=False)
    chroma_subsampled: bool = field(init=False)
    luma_step: float | None = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "width", math.ceil(self.source.width / self.factor))
        object.__setattr__(self, "height", math.ceil(self.source.height / self.factor))
        object.__setattr__(self, "dtype", np.dtype(np.float32))
        object.__setattr__(self, "path", self.source.path)
        # a 4:2:0 file's chroma has one sample per 2 x 2 px: reduced by 2 or more, the view has it at its own resolution
        object.__setattr__(self, "chroma_subsampled", self.source.chroma_subsampled and self.factor < 2)
        object.__setattr__(self, "luma_step", self.source.luma_step if self.factor < 2 else None)

    def read_window(self, box: Sequence[int]) -> np.ndarray:
        """The reduced window ``box`` (reduced pixels, x1 and y1 exclusive), float32 on [0, 1]."""
        return self.read_reduced(box, 1)

    def read_reduced(self, box: Sequence[int], factor: int) -> np.ndarray:
        """The reduced window ``box`` reduced again by ``factor``, float32 on [0, 1]."""
        f = self.factor
        x0, y0, x1, y1 = (int(v) for v in box)
        full = (x0 * f, y0 * f, min(x1 * f, self.source.width), min(y1 * f, self.source.height))
        return read_reduced_levels(self.source, full, f * factor, white=self.white)[0]

    def to_full(self, x: float, y: float) -> tuple[float, float]:
        """Full-image pixel coordinates of the reduced point (x, y)."""
        f = self.factor
        return f * x + (f - 1) / 2, f * y + (f - 1) / 2

    def from_full(self, x: float, y: float) -> tuple[float, float]:
        """Reduced pixel coordinates of the full-image point (x, y)."""
        f = self.factor
        return (x - (f - 1) / 2) / f, (y - (f - 1) / 2) / f


def read_reduced_levels(source: ImageSource, box: Sequence[int], f: int,
                        overview: bool = False, white: float | None = None) -> tuple[np.ndarray, float]:
    """``box`` of ``source`` reduced by ``f`` as float32 grey levels on [0, 1] (integer samples divided by ``white``,
    the search's full scale, :func:`~aerofid.io.colour.first_look_white`; default: their type's maximum), and one
    quantisation step of the samples on that scale, at least
    :data:`~aerofid.conventions.LEAST_GREY_STEP` (float
    samples: that). With ``overview``, read by the source's ``read_overview`` where it has one (a JPEG's reduced
    decode: :meth:`aerofid.io.raster.Raster.read_overview`)."""
    read = getattr(source, "read_overview", source.read_reduced) if overview else source.read_reduced
    reduced = read(box, f)
    if source.dtype.kind not in "ui":
        return reduced.astype(np.float32), LEAST_GREY_STEP
    top = np.iinfo(source.dtype).max
    step = 1.0 / float(white or top)
    return saturated((reduced * np.float32(step)).astype(np.float32), white, top), max(step, LEAST_GREY_STEP)

