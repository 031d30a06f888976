"""Outputs written whole or not at all, and never over an input or a special file.

A command's outputs go through one :class:`Staging`: each output path is checked when the command starts
(:meth:`Staging.plan`: its folder exists and is writable; the path is not a folder, FIFO, device, socket or
symbolic link, not read-only, and not one of the command's inputs by path or inode), its bytes are written to a
hidden temporary file beside it (:meth:`Staging.put`), and only :meth:`Staging.commit`, called once the whole
command has succeeded, renames every temporary file into place. A command that fails (or is interrupted)
leaves no output: :meth:`Staging.discard` (also on leaving the ``with`` block without committing) removes the
temporary files. A run killed with SIGKILL cannot clean up; its temporary files carry its process id
(``.NAME.aerofid-PID-XXXX.tmp``) and the next run that writes NAME in that folder removes those whose process is
gone.

:func:`write_bytes_atomic` and :func:`write_text_atomic` stage and commit one file.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path

from aerofid.errors import AerofidInputError
from aerofid.io.files import file_kind

__all__ = ["Staging", "check_output", "write_bytes_atomic", "write_text_atomic"]

TEMP_TAG = ".aerofid-"
"""Marks aerofid's temporary files: ``.NAME.aerofid-PID-XXXX.tmp``."""

_Identity = tuple[int, int]


def _identity(path: Path) -> _Identity | None:
    """(device, inode) of the file ``path`` names (symbolic links followed), or None if there is none."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def temporary_beside(path: Path) -> tuple[int, str]:
    """A new temporary file beside ``path`` (open descriptor, name), named so that :func:`sweep_stale` knows it, with
    the permissions a file created in place would have (``mkstemp``'s are the owner's alone, and a rename keeps
    them); an input error where it cannot be made."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}{TEMP_TAG}{os.getpid()}-", suffix=".tmp", dir=_folder(path))
    except OSError as e:
        raise AerofidInputError(f"cannot write {str(path)!r}: {e.strerror}") from None
    with contextlib.suppress(OSError):                  # a file system without modes (FAT, some shares) keeps its own
        os.fchmod(fd, 0o666 & ~_UMASK)
    return fd, tmp


_UMASK = os.umask(0)
os.umask(_UMASK)
"""The process's umask, read once as the module loads (reading it sets it, which threads must not race)."""


def check_output(path: str | os.PathLike[str], what: str = "output", inputs: Iterable[str | os.PathLike[str]] = ()
                 ) -> Path:
    """``path`` as a Path once it is safe to replace: an input error otherwise.

    Parameters
    ----------
    path : str or os.PathLike
        The output file.
    what : str
        What it is, for the message (``"--overlay"``, ``"report"``...).
    inputs : iterable of paths
        The command's input files: the output may name none of them (same resolved path or same inode, so a
        hard link or a symbolic link to an input is refused too).

    Raises
    ------
    AerofidInputError
        An empty path; a folder that does not exist or is not writable; a path naming a folder, FIFO, device,
        socket or symbolic link, a read-only file, or an input.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> scan = folder / "scan.tif"
    >>> _ = scan.write_bytes(b"II*\\x00")
    >>> check_output(folder / "overlay.png", "--overlay", [scan]).name
    'overlay.png'
    >>> check_output(scan, "--overlay", [scan])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: --overlay '...scan.tif' is an input of this command; give another name
    """
    text = os.fspath(path)
    if not text:
        raise AerofidInputError(f"{what} is an empty path; give a file name")
    p = Path(text)
    name = f"{what} {text!r}"
    try:
        st = p.lstat()
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise AerofidInputError(f"cannot write {name}: {e.strerror}") from None
    if st is not None:
        if stat.S_ISLNK(st.st_mode):
            target = _identity(p)
            if target is not None and target in {_identity(Path(i)) for i in inputs}:
                raise AerofidInputError(f"{name} is a symbolic link to an input of this command; give another name")
            raise AerofidInputError(f"{name} is a symbolic link, which writing would replace; give the path of the "
                                    "file itself or another name")
        if not stat.S_ISREG(st.st_mode):
            raise AerofidInputError(f"{name} is {file_kind(st.st_mode)}; give the name of a regular file")
        if (st.st_dev, st.st_ino) in {_identity(Path(i)) for i in inputs}:
            raise AerofidInputError(f"{name} is an input of this command; give another name")
        if not st.st_mode & 0o222 or not os.access(p, os.W_OK):
            raise AerofidInputError(f"{name} is read-only; give another name or make it writable")
    folder = _folder(p)
    if not folder.is_dir():
        raise AerofidInputError(f"cannot write {name}: folder {str(folder)!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise AerofidInputError(f"cannot write {name}: folder {str(folder)!r} is not writable")
    return p


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


def sweep_stale(path: Path) -> None:
    """Remove temporary files of ``path`` left by aerofid runs that were killed (their process is gone)."""
    pattern = re.compile(re.escape(f".{path.name}{TEMP_TAG}") + r"(\d+)-\w+\.tmp")
    try:
        entries = list(os.scandir(_folder(path)))
    except OSError:
        return
    for entry in entries:
        m = pattern.fullmatch(entry.name)
        if m and int(m.group(1)) != os.getpid() and not _alive(int(m.group(1))):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)


def _unlink(path: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)


class Staging:
    """The outputs of one command, committed together once it has succeeded (module docstring).

    Parameters
    ----------
    inputs : iterable of paths
        The command's input files (none of them may be an output); more with :meth:`add_input`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with Staging() as out:
    ...     a = out.plan(folder / "a.json", "-o")
    ...     out.put(a, '{"x": 1}')
    ...     out.put(folder / "b.txt", "done")
    ...     out.commit()
    >>> sorted(p.name for p in folder.iterdir())
    ['a.json', 'b.txt']
    >>> with Staging() as out:
    ...     out.put(folder / "c.txt", "never")   # no commit(): the command failed, nothing is written
    >>> sorted(p.name for p in folder.iterdir())
    ['a.json', 'b.txt']
    """

    def __init__(self, inputs: Iterable[str | os.PathLike[str]] = ()):
        self._inputs: list[Path] = [Path(os.fspath(p)) for p in inputs]
        self._planned: dict[Path, str] = {}
        self._staged: dict[Path, str] = {}

    def add_input(self, path: str | os.PathLike[str]) -> None:
        """Another input of the command: no output may name it."""
        self._inputs.append(Path(os.fspath(path)))

    def plan(self, path: str | os.PathLike[str], what: str = "output") -> Path:
        """Check an output before any work (:func:`check_output`; no two outputs share a path) and return it."""
        p = check_output(path, what, self._inputs)
        key = Path(os.path.abspath(p))
        if key in {Path(os.path.abspath(q)) for q in self._planned}:
            raise AerofidInputError(f"two outputs would be written to {str(p)!r}; give each its own name")
        self._planned[p] = what
        return p

    def put(self, path: str | os.PathLike[str], data: bytes | str) -> None:
        """Write ``data`` (text as UTF-8) to a temporary file beside ``path`` (planned now if it was not)."""
        p = Path(os.fspath(path))
        if p not in self._planned:
            self.plan(p)
        sweep_stale(p)
        payload = data.encode("utf-8") if isinstance(data, str) else data
        fd, tmp = temporary_beside(p)
        self._staged[p] = tmp
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(payload)
                f.flush()
                os.fsync(f.fileno())
        except OSError as e:
            self.discard()
            raise AerofidInputError(f"cannot write {str(p)!r}: {e.strerror}") from None

    def commit(self) -> None:
        """Rename every staged file into place, each path checked again first; on a failure the files not yet
        renamed are removed and the error names what was written."""
        done: list[str] = []
        try:
            for p, tmp in list(self._staged.items()):
                check_output(p, self._planned.get(p, "output"), self._inputs)
                try:
                    os.replace(tmp, p)
                except OSError as e:
                    raise AerofidInputError(f"cannot write {str(p)!r}: {e.strerror}") from None
                del self._staged[p]
                done.append(str(p))
        except AerofidInputError as e:
            self.discard()
            written = f" (written before it: {', '.join(done)})" if done else " (nothing was written)"
            raise AerofidInputError(f"{e}{written}") from None

    def discard(self) -> None:
        """Remove every staged temporary file: nothing is written."""
        for tmp in self._staged.values():
            _unlink(tmp)
        self._staged.clear()

    def __enter__(self) -> Staging:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.discard()


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` whole or not at all (one :class:`Staging`, committed at once).

    Raises
    ------
    AerofidInputError
        As :func:`check_output`, or the write itself failed.
    """
    with Staging() as out:
        out.put(path, data)
        out.commit()


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write UTF-8 ``text`` atomically (see :func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"))
