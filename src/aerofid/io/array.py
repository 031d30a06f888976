"""A numpy array read like a scan: :class:`ArrayRaster` has :class:`~aerofid.io.raster.Raster`'s interface, and
:func:`open_image` opens a path, an array or an already open raster alike (closing only what it opened)."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Sequence
from contextlib import AbstractContextManager
from typing import Any

import numpy as np

from aerofid.errors import AerofidInputError
from aerofid.io.raster import WINDOW_LIMIT_BYTES, Raster, _window_box, check_window_size, open_raster
from aerofid.io.reduce import check_factor, check_reduced_size, reduce_in_strips

__all__ = ["ArrayRaster", "RasterLike", "as_image_array", "open_image"]


INTEGER_RANGES = (np.uint8, np.uint16, np.uint32)
"""Signed integers, and unsigned ones wider than 16 bits, are read as the smallest of these whose range holds them:
an ``int64`` or ``uint32`` array of 0-255 is an 8-bit image, not 0.000000003 % of its type's range (a ``uint32``
array was divided by its type's maximum, and its marks lost: a helper's audit)."""
FLOAT_SCALES = (1.0, 255.0, 65535.0)
"""Float samples are grey levels on [0, 1], or on 0-255 or 0-65535 (then divided by it): the first scale at least
half the largest sample is taken (noise may carry a [0, 1] image a little beyond 1 or below 0)."""


def _sample_range(a: np.ndarray) -> np.ndarray:
    """``a`` with samples on aerofid's scale: 8- and 16-bit unsigned integers as they are, other integers as the
    smallest unsigned type that holds them (:data:`INTEGER_RANGES`), floats by :data:`FLOAT_SCALES`. Negative
    integers, non-finite floats and samples beyond every scale are an input error."""
    if (a.dtype.kind == "u" and a.dtype.itemsize <= 2) or a.size == 0:
        return a
    lo, hi = float(np.min(a)), float(np.max(a))
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise AerofidInputError("image array holds NaN or infinite samples; give finite grey levels")
    if a.dtype.kind in "ui":
        if lo < 0:
            raise AerofidInputError(f"image array holds negative integers (down to {lo:g}); give grey levels >= 0 "
                                    "(unsigned integers, or floats on [0, 1])")
        for kind in INTEGER_RANGES:
            if hi <= np.iinfo(kind).max:
                return a.astype(kind)
    for scale in FLOAT_SCALES:
        if a.dtype.kind == "f" and hi <= 2 * scale:
            return a if scale == 1.0 else (a / np.float32(scale)).astype(np.float32)
    raise AerofidInputError(f"image array holds samples up to {hi:g}, beyond 32-bit integer or 0-65535 grey levels; "
                            "rescale it to [0, 1] or to unsigned integers")


def as_image_array(a: Any) -> np.ndarray:
    """Check an image given as an array and return it as one (RGBA loses its alpha band).

    Parameters
    ----------
    a : array_like
        ``(h, w)`` grey or ``(h, w, 3)`` RGB (``(h, w, 4)`` RGBA: alpha dropped), integers or floats. Floats are
        grey levels on [0, 1], or on 0-255 / 0-65535 (then divided by 255 / 65535: :data:`FLOAT_SCALES`); signed
        integers, and unsigned ones wider than 16 bits, are read as 8-, 16- or 32-bit unsigned by their largest
        sample (:data:`INTEGER_RANGES`).

    Returns
    -------
    numpy.ndarray
        ``a`` as an array (a view, not a copy, where numpy allows and no rescaling is needed).

    Raises
    ------
    AerofidInputError
        Another shape, no pixel, samples that are not integers or floats (booleans included), negative integers,
        non-finite floats, samples beyond every scale.

    Examples
    --------
    >>> as_image_array(np.zeros((4, 5, 4), np.uint8)).shape
    (4, 5, 3)
    >>> as_image_array(np.array([[0, 255]])).dtype, float(as_image_array(np.array([[0.0, 255.0]])).max())
    (dtype('uint8'), 1.0)
    """
    a = np.asarray(a)
    if a.ndim == 3 and a.shape[2] == 4:
        a = a[:, :, :3]
    if not (a.ndim == 2 or (a.ndim == 3 and a.shape[2] == 3)):
        raise AerofidInputError(f"image array has shape {a.shape}; give a 2-D grey or (h, w, 3) RGB array")
    if a.size == 0:
        raise AerofidInputError(f"image array is empty (shape {a.shape}); give an image of at least one pixel")
    if not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)) or a.dtype == bool:
        raise AerofidInputError(f"image array has dtype {a.dtype}; give unsigned integers or floats")
    return _sample_range(a)


class ArrayRaster:
    """A numpy image with :class:`~aerofid.io.raster.Raster`'s interface (the array is kept, not copied).

    Parameters
    ----------
    array : array_like
        ``(h, w)`` grey or ``(h, w, 3)`` RGB (RGBA: alpha dropped), integers or floats (:func:`as_image_array`).
    chroma_subsampled : bool, optional
        Whether the array was decoded from a file that stores its chroma subsampled (a 4:2:0 JPEG: the file's
        :attr:`Raster.chroma_subsampled <aerofid.io.raster.Raster>`): the colour policy then prefers luminance as it
        does on the file (:data:`~aerofid.io.colour.LUMA_SHARE`). An array keeps no trace of its file: default False.

    Attributes
    ----------
    path : None
        An array has no file.
    format : str
        ``"array"``.
    width, height : int
        Image size in pixels.
    bands : int
        1 (grey) or 3 (RGB).
    dtype : numpy.dtype
        The array's dtype (native byte order), that :meth:`read_window` returns.
    tiled : bool
        False.
    chroma_subsampled : bool
        As given.
    luma_step : None
        An array's quantisation is not known.

    Examples
    --------
    >>> image = np.arange(12, dtype=np.uint8).reshape(3, 4)
    >>> with ArrayRaster(image) as raster:
    ...     print(raster.width, raster.height, raster.read_window((1, 0, 3, 2)).tolist())
    ...     print(raster.read_reduced((0, 0, 4, 3), 2).tolist())
    4 3 [[1, 2], [5, 6]]
    [[2.5, 4.5], [8.5, 10.5]]
    """

    path: None = None
    format = "array"
    tiled = False
    luma_step = None

    def __init__(self, array: Any, *, chroma_subsampled: bool = False):
        a = as_image_array(array)
        self.chroma_subsampled = bool(chroma_subsampled) and a.ndim == 3
        self.height, self.width = a.shape[:2]
        self.bands = 1 if a.ndim == 2 else 3
        self.dtype = a.dtype.newbyteorder("=")
        self._array: np.ndarray | None = a[:, :, None] if a.ndim == 2 else a

    def _open_array(self) -> np.ndarray:
        """The kept ``(h, w, bands)`` array, or raise if closed."""
        if self._array is None:
            raise AerofidInputError("the image array is closed; make a new ArrayRaster")
        return self._array

    def read_window(self, box: Sequence[int]) -> np.ndarray:
        """Read a window (a copy), as :meth:`aerofid.io.raster.Raster.read_window` does.

        Parameters
        ----------
        box : sequence of int
            ``(x0, y0, x1, y1)`` integers inside the image, x1 and y1 exclusive.

        Returns
        -------
        numpy.ndarray
            A new ``(h, w)`` or ``(h, w, 3)`` array of :attr:`dtype`.

        Raises
        ------
        AerofidInputError
            Closed; the box is not a window inside the image; the window would need more than about 1 GB.
        """
        a = self._open_array()
        x0, y0, x1, y1 = _window_box(box, self.width, self.height)
        check_window_size((x0, y0, x1, y1), self.bands, self.dtype.itemsize, WINDOW_LIMIT_BYTES)
        window = np.array(a[y0:y1, x0:x1], dtype=self.dtype)
        return window[:, :, 0] if self.bands == 1 else window

    def read_reduced(self, box: Sequence[int], factor: int) -> np.ndarray:
        """Read a window reduced by block means, as :meth:`aerofid.io.raster.Raster.read_reduced` does.

        Parameters
        ----------
        box : sequence of int
            ``(x0, y0, x1, y1)`` integers inside the image, x1 and y1 exclusive.
        factor : int
            Side of the square blocks averaged (>= 1).

        Returns
        -------
        numpy.ndarray
            float32 ``(ceil(h / factor), ceil(w / factor))`` or ``(..., ..., 3)``; edge blocks are the means of
            the pixels they have.

        Raises
        ------
        AerofidInputError
            Closed; the box is not a window inside the image; the factor is not an integer >= 1; the reduced
            window would need more than about 1 GB.
        """
        a = self._open_array()
        window_box = _window_box(box, self.width, self.height)
        factor = check_factor(factor)
        check_reduced_size(window_box, factor, self.bands, WINDOW_LIMIT_BYTES)
        x0, x1 = window_box[0], window_box[2]
        out = reduce_in_strips(lambda r0, r1: a[r0:r1, x0:x1], window_box, factor, self.bands,
                               itemsize=a.dtype.itemsize)
        return out[:, :, 0] if self.bands == 1 else out

    def close(self) -> None:
        """Drop the array; later reads raise :class:`AerofidInputError`."""
        self._array = None

    def __enter__(self) -> ArrayRaster:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._array is None else "open"
        return f"<ArrayRaster {self.width}x{self.height} bands={self.bands} dtype={self.dtype} {state}>"


RasterLike = Raster | ArrayRaster
"""What :func:`open_image` gives: a scan file or an array, read through one interface."""


def open_image(
    image: str | bytes | os.PathLike[str] | np.ndarray | Raster | ArrayRaster, rows: int | None = None,
) -> AbstractContextManager[RasterLike]:
    """Open an image given as a path, an array or an open raster, for use in a ``with`` statement.

    Parameters
    ----------
    image : str, bytes, os.PathLike, numpy.ndarray, Raster or ArrayRaster
        A path (bytes too) is opened with :func:`~aerofid.io.raster.open_raster` and closed on leaving the ``with``; an
        array becomes an :class:`ArrayRaster`; an open :class:`~aerofid.io.raster.Raster` or
        :class:`ArrayRaster` is used as it is and left open (it belongs to the caller).
    rows : int, optional
        A file's rows the caller reads lie above this one (:func:`~aerofid.io.raster.open_raster`).

    Returns
    -------
    contextlib.AbstractContextManager
        Entering it gives the :class:`~aerofid.io.raster.Raster` or :class:`ArrayRaster`; leaving it closes
        only what this call opened.

    Raises
    ------
    AerofidInputError
        The file cannot be opened (:func:`~aerofid.io.raster.open_raster`) or the array is not an image
        (:func:`as_image_array`); ``image`` is none of these.

    Examples
    --------
    >>> with open_image(np.zeros((20, 30), np.uint16)) as image:
    ...     print(image.format, image.width, image.height, image.read_window((0, 0, 2, 1)).tolist())
    array 30 20 [[0, 0]]
    """
    if isinstance(image, Raster | ArrayRaster):
        return contextlib.nullcontext(image)
    if isinstance(image, str | bytes | os.PathLike):
        return open_raster(os.fsdecode(image), rows)
    if not (isinstance(image, list | tuple) or hasattr(image, "__array__")):
        raise AerofidInputError(
            f"image is a {type(image).__name__}; give a file path, a numpy array or an open Raster"
        )
    return ArrayRaster(image)
