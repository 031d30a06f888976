"""Input files checked before any work: a regular, readable file of a bounded size (never a FIFO, which would
block the reader forever, a device, a folder or a symbolic-link loop), and text read from one within a limit.

Every refusal is one :class:`~aerofid.errors.AerofidInputError` line naming the file and what to give instead.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from aerofid.errors import AerofidInputError

__all__ = ["MAX_TEXT_BYTES", "file_kind", "input_file", "read_text_input"]

MAX_TEXT_BYTES = 64_000_000
"""Largest camera, measurements or boxes file read (bytes): a certificate or a frame's fiducials take a few kB,
a boxes file for thousands of frames a few MB; anything larger is not one of these."""


def file_kind(mode: int) -> str:
    """What a non-regular file is, in words (for error messages)."""
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    return "not a regular file"


def input_file(path: str | os.PathLike[str] | bytes, what: str) -> Path:
    """``path`` as a :class:`~pathlib.Path` once it is known to name a regular file (symbolic links followed).

    Parameters
    ----------
    path : str, os.PathLike or bytes
        The file.
    what : str
        What it is, for the message (``"camera file"``, ``"image"``, ...).

    Raises
    ------
    AerofidInputError
        Missing, a symbolic-link loop, a folder, a FIFO, a device or a socket (nothing is opened: a FIFO would
        block the reader).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> input_file(folder, "camera file")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: camera file '...' is a folder; give the path of a file
    """
    p = Path(os.fsdecode(path))
    if not str(path):
        raise AerofidInputError(f"the {what}'s path is empty; give the path of a file")
    try:
        st = p.stat()
    except OSError as e:
        if e.errno == errno.ELOOP:
            raise AerofidInputError(f"{what} {str(p)!r} is a symbolic-link loop; give the path of a file") from None
        if e.errno in (errno.ENOENT, errno.ENOTDIR):
            raise AerofidInputError(f"{what} {str(p)!r} does not exist; check the path") from None
        raise AerofidInputError(f"cannot read {what} {str(p)!r}: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise AerofidInputError(f"{what} {str(p)!r} is {file_kind(st.st_mode)}; give the path of a file")
    return p


def read_text_input(path: str | os.PathLike[str], what: str, limit: int = MAX_TEXT_BYTES) -> tuple[Path, str]:
    """The checked path (:func:`input_file`) and its UTF-8 text (a byte-order mark dropped), at most ``limit``
    bytes; an input error when it is larger, unreadable or not UTF-8."""
    p = input_file(path, what)
    try:
        with p.open("rb") as f:
            data = f.read(limit + 1)
    except OSError as e:
        raise AerofidInputError(f"cannot read {what} {str(p)!r}: {e.strerror}") from None
    if len(data) > limit:
        raise AerofidInputError(f"{what} {str(p)!r} is larger than {limit / 1e6:.0f} MB; is it the right file?")
    try:
        return p, data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise AerofidInputError(f"cannot read {what} {str(p)!r}: it is not UTF-8 text ({e.reason} at byte "
                                f"{e.start})") from None
