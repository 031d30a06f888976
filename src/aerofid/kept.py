"""The latest results of a pure computation by key (a :func:`digest` of what it reads), in bounded number, shared by
threads: what ``hough``'s searches keep of their verifications and window analyses (:mod:`aerofid.detect.hough`),
where the overlapping windows of one box meet the same pixels again. :func:`forget_kept` drops them all: the next
call on a box computes it as the first did (a benchmark times every call so, as a user's first call on a box runs)."""

from __future__ import annotations

import threading
import weakref
from _blake2 import blake2b  # hashlib's own, without hashlib's load of OpenSSL (2.5 ms of the import)
from collections import OrderedDict
from collections.abc import Hashable
from typing import Any, Generic, TypeVar

V = TypeVar("V")

DIGEST_SIZE = 20
"""Bytes of a key's digest (:func:`digest`): BLAKE2b-160, no collision in any number of windows a run meets."""


def digest(*parts: bytes) -> bytes:
    """The BLAKE2b digest of ``parts`` one after another: a key of what a computation reads (its pixels), short
    whatever their size.

    Examples
    --------
    >>> digest(b"ab", b"c") == digest(b"abc"), len(digest(b""))
    (True, 20)
    """
    h = blake2b(digest_size=DIGEST_SIZE)
    for part in parts:
        h.update(part)
    return h.digest()


class Kept(Generic[V]):
    """The latest ``limit`` values by key (the least recently given again dropped first).

    Examples
    --------
    >>> kept = Kept[str](2)
    >>> kept.put("a", "1"); kept.put("b", "2"); kept.get("a"); kept.put("c", "3")
    '1'
    >>> kept.get("b") is None, kept.get("a"), kept.get("c")
    (True, '1', '3')
    """

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._kept: OrderedDict[Hashable, V] = OrderedDict()
        self._lock = threading.Lock()
        with _EVERY_LOCK:
            _EVERY.add(self)

    def get(self, key: Hashable) -> V | None:
        """The value kept for ``key`` (now the most recent), or None."""
        with self._lock:
            got = self._kept.get(key)
            if got is not None:
                self._kept.move_to_end(key)
            return got

    def put(self, key: Hashable, value: V) -> None:
        """Keep ``value`` for ``key``, dropping the least recent beyond ``limit``."""
        with self._lock:
            self._kept[key] = value
            self._kept.move_to_end(key)
            while len(self._kept) > self.limit:
                self._kept.popitem(last=False)

    def clear(self) -> None:
        """Drop every value kept."""
        with self._lock:
            self._kept.clear()


_EVERY: weakref.WeakSet[Kept[Any]] = weakref.WeakSet()
"""Every :class:`Kept` made (and not yet collected)."""
_EVERY_LOCK = threading.Lock()
"""Held while :data:`_EVERY` grows or is listed (a thread may make a :class:`Kept`, importing a module, meanwhile)."""


def forget_kept() -> None:
    """Drop what every :class:`Kept` keeps."""
    with _EVERY_LOCK:
        every = list(_EVERY)
    for kept in every:
        kept.clear()
