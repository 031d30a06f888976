"""What the command line prints and how it ends: standard output checked (a closed pipe, a full disk), the chatter
of libraries (numpy warnings, tifffile's log, libjpeg/libpng messages written straight to file descriptor 2)
kept off the user's terminal, and every way a command can end mapped to its exit status (0 found, 1 not found,
2 bad input or failed output, 3 a bug in aerofid)."""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import sys
import traceback
import warnings
from collections.abc import Iterator

import click

from aerofid.errors import AerofidInputError

EXIT_FOUND, EXIT_NOT_FOUND, EXIT_BAD_INPUT, EXIT_BUG = 0, 1, 2, 3
"""Exit statuses (README, docs/errors.md)."""

TRACEBACK_ENV = "AEROFID_TRACEBACK"
"""Set to 1 to see the traceback of an internal error (a bug) as well as its one line."""

_STREAM_ERRNOS = frozenset({errno.EPIPE, errno.ENOSPC, errno.EIO, errno.EDQUOT, errno.EFBIG, errno.EBADF})


def is_stream_error(e: OSError) -> bool:
    """Whether ``e`` is a failed write to a stream (no file name: standard output), not a file's error."""
    return e.filename is None and e.errno in _STREAM_ERRNOS


def _silence_stdout() -> None:
    """Point standard output at the null device, so that the interpreter's last flush cannot fail again."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)


def stdout_error(e: OSError) -> AerofidInputError:
    """The one line for a failed write to standard output (a pipe closed early, a full disk)."""
    _silence_stdout()
    return AerofidInputError(f"cannot write to standard output: {e.strerror or e}")


def flush_stdout() -> None:
    """Flush standard output now (before the outputs are committed), so that its failure fails the command."""
    try:
        sys.stdout.flush()
    except OSError as e:
        raise stdout_error(e) from None


@contextlib.contextmanager
def quiet_libraries() -> Iterator[None]:
    """Keep warnings, library logs and C libraries' messages off stderr while a command runs.

    Python's warnings and the ``logging`` records of libraries (tifffile) are switched off; file descriptor 2,
    where libjpeg, libpng and OpenCV write directly, goes to the null device, while ``sys.stderr`` (aerofid's own
    ``error:`` and ``note:`` lines, and the interpreter's) keeps the real stderr.
    """
    disabled = logging.root.manager.disable
    with warnings.catch_warnings(), contextlib.ExitStack() as restore:
        warnings.simplefilter("ignore")
        logging.disable(logging.CRITICAL)
        restore.callback(logging.disable, disabled)
        try:
            fd = sys.stderr.fileno()
        except (AttributeError, OSError, ValueError):
            fd = -1
        if fd != 2:
            yield
            return
        sys.stderr.flush()
        saved = os.dup(2)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.close(devnull)
        real = sys.stderr
        sys.stderr = open(saved, "w", buffering=1, encoding=real.encoding, errors="backslashreplace", closefd=False)
        try:
            yield
        finally:
            with contextlib.suppress(OSError):
                sys.stderr.flush()
            sys.stderr = real
            os.dup2(saved, 2)
            os.close(saved)


def error_line(e: BaseException) -> tuple[str, int]:
    """The ``error:`` line and exit status for an exception that ended a command."""
    if isinstance(e, AerofidInputError):
        return f"error: {e}", EXIT_BAD_INPUT
    if isinstance(e, MemoryError):
        return ("error: out of memory; give a smaller box or region, or a smaller image (the memory budget is set "
                "with the environment variable AEROFID_MEMORY_BUDGET_GB)", EXIT_BAD_INPUT)
    if isinstance(e, RecursionError):
        return "error: an input is nested too deeply; check the files given", EXIT_BAD_INPUT
    if isinstance(e, OSError) and is_stream_error(e):
        return f"error: {stdout_error(e)}", EXIT_BAD_INPUT
    if os.environ.get(TRACEBACK_ENV) == "1":
        traceback.print_exception(e)
    one = " ".join(str(e).split())
    return (f"error: internal error, a bug in aerofid ({type(e).__name__}: {one}); please report it with the "
            f"command (set {TRACEBACK_ENV}=1 for the traceback)", EXIT_BUG)


def echo_error(line: str) -> None:
    """Print an ``error:`` line on stderr (never failing)."""
    with contextlib.suppress(OSError, ValueError):
        click.echo(line, err=True)


__all__ = ["EXIT_BAD_INPUT", "EXIT_BUG", "EXIT_FOUND", "EXIT_NOT_FOUND", "echo_error", "error_line",
           "flush_stdout", "is_stream_error", "quiet_libraries", "stdout_error"]
