"""``ImageSource``: what a window search reads, an open raster, an array presented as one, or a reduced view of
either (:class:`aerofid.io.reduce.ReducedView`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

__all__ = ["ImageSource"]


class ImageSource(Protocol):
    """What the search reads: an open :class:`~aerofid.io.raster.Raster` or an array presented as one."""

    @property
    def width(self) -> int: ...

    @property
    def height(self) -> int: ...

    @property
    def dtype(self) -> np.dtype: ...

    @property
    def path(self) -> Any: ...

    @property
    def chroma_subsampled(self) -> bool: ...

    @property
    def luma_step(self) -> float | None: ...

    def read_window(self, box: Sequence[int]) -> np.ndarray: ...

    def read_reduced(self, box: Sequence[int], factor: int) -> np.ndarray: ...
