"""Threads for the few steps of a whole frame whose work is numpy's or a codec's with the GIL released: the strips
of a reduced read (:mod:`aerofid.io.reduce`), the levels of a whole frame's screening
(:mod:`aerofid.detect.screen`). Each maps a function over independent parts, and the parts' results are
combined in their order, so the numbers are those of one part after another."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

THREADS = max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1))
"""Threads a step uses: the cores this process may run on, at most 4 (the strips of a whole 11000^2 frame, its
screening's levels)."""


def map_in_threads(fn: Callable[[T], R], parts: Iterable[T], threads: int = THREADS) -> list[R]:
    """``[fn(p) for p in parts]``, by ``threads`` threads at once (one: in this thread); the first exception is
    raised once the parts begun are done."""
    if threads <= 1:
        return [fn(p) for p in parts]
    with ThreadPoolExecutor(threads) as pool:
        return list(pool.map(fn, parts))


__all__ = ["THREADS", "map_in_threads"]
