"""A batch's frames: the INPUTS of ``aerofid batch`` (files, folders, globs) expanded to scan files, and the name
each frame's outputs carry in the output folder.

Pure bookkeeping on paths: nothing here reads an image.
"""

from __future__ import annotations

import glob
import os
from collections.abc import Iterable, Sequence
from pathlib import Path

from aerofid.errors import AerofidInputError

SCAN_SUFFIXES = (".tif", ".tiff", ".jpg", ".jpeg", ".png")
"""The file endings a folder or a glob contributes (case-insensitive): the formats :mod:`aerofid.io` reads."""
GLOB_CHARACTERS = "*?["
"""An input holding one of these is a pattern (``roll1/*.tif``, ``archive/**/*.tif``: ``**`` goes into
subfolders)."""
KEY_SEPARATOR = "__"
"""Joins the folders and the file name of a frame whose file name another frame of the batch shares."""


def is_scan(path: Path) -> bool:
    """Whether ``path``'s ending is one of :data:`SCAN_SUFFIXES`."""
    return path.suffix.lower() in SCAN_SUFFIXES


def _expand_one(item: str) -> list[Path]:
    """The scan files one input names: itself (a file), the scans in it (a folder, not its subfolders), or the
    scans a glob matches (folders it matches give their scans). Hidden files (``.x.tif``: a system's or a
    killed run's temporary files) come only when named directly."""
    if any(c in item for c in GLOB_CHARACTERS) and not os.path.lexists(item):
        found: list[Path] = []
        for m in glob.glob(item, recursive=True):
            found += _expand_one(m) if os.path.isdir(m) else [Path(m)] if is_scan(Path(m)) else []
        return found
    p = Path(item)
    if p.is_dir():
        return [c for c in p.iterdir() if is_scan(c) and not c.name.startswith(".") and not c.is_dir()]
    return [p] if os.path.lexists(item) else []


def _inside(path: Path, folder: str) -> bool:
    return os.path.commonpath([os.path.realpath(path), folder]) == folder


def expand_inputs(inputs: Iterable[str], exclude: Sequence[str | os.PathLike[str]] = ()) -> tuple[Path, ...]:
    """The scan files that ``inputs`` name, sorted and each once (the same file named twice, by another path
    or a symbolic link, counts once), none of them inside the folders ``exclude`` (the batch's own outputs: its mark
    crops, which are PNG files, and its resampled frames, which are TIFFs, when the scans share its folder).

    A file named directly is taken whatever its ending (a corrupt or mis-named file is a frame that fails, not
    a reason to stop); folders and globs contribute only files ending in :data:`SCAN_SUFFIXES`.

    Raises
    ------
    AerofidInputError
        No inputs, or an input that names no scan (a missing file, an empty folder, a glob matching nothing):
        one error naming every such input, before any work.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for n in ("b.TIF", "a.jpg", "notes.txt"):
    ...     _ = (d / n).write_bytes(b"")
    >>> [p.name for p in expand_inputs([str(d), str(d / "*.jpg")])]
    ['a.jpg', 'b.TIF']
    >>> expand_inputs([str(d / "*.png")])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: no scan (.tif, .tiff, .jpg, .jpeg, .png) in ...*.png...
    """
    items = list(inputs)
    if not items:
        raise AerofidInputError("give the scans to process: files, folders or globs (e.g. 'roll1/*.tif')")
    seen: dict[str, Path] = {}
    empty: list[str] = []
    skip = [os.path.realpath(folder) for folder in exclude]
    for item in items:
        found = [p for p in _expand_one(item) if not any(_inside(p, folder) for folder in skip)]
        if not found:
            empty.append(item)
        for p in found:
            seen.setdefault(os.path.realpath(p), p)
    if empty:
        raise AerofidInputError(f"no scan ({', '.join(SCAN_SUFFIXES)}) in {', '.join(map(repr, empty))}; check "
                                "the paths (a folder gives the scans directly in it, a glob like 'a/**/*.tif' "
                                "goes into subfolders)")
    return tuple(sorted(seen.values(), key=str))


def frame_keys(paths: Sequence[Path]) -> tuple[str, ...]:
    """The name each frame's outputs carry: the scan's file name (``x.tif``: ``x.tif.json``,
    ``MeasuresIm-x.tif.xml``), or, for frames whose file names are the same (case-insensitively), their path
    below the folder they have in common with the folders joined by :data:`KEY_SEPARATOR`
    (``roll1__x.tif``, ``roll2__x.tif``), so that no two frames share an output.

    Raises
    ------
    AerofidInputError
        Two frames would still share a name (folder names that themselves hold the separator).

    Examples
    --------
    >>> from pathlib import Path
    >>> frame_keys([Path("a/roll1/x.tif"), Path("a/roll2/x.tif"), Path("a/roll2/y.tif")])
    ('roll1__x.tif', 'roll2__x.tif', 'y.tif')
    """
    full = [Path(os.path.abspath(p)) for p in paths]
    by_name: dict[str, list[int]] = {}
    for i, p in enumerate(full):
        by_name.setdefault(p.name.casefold(), []).append(i)
    keys = [p.name for p in full]
    for same in by_name.values():
        if len(same) > 1:
            common = Path(os.path.commonpath([full[i].parent for i in same]))
            for i in same:
                keys[i] = KEY_SEPARATOR.join(full[i].relative_to(common).parts)
    owners: dict[str, int] = {}
    for i, k in enumerate(keys):
        j = owners.setdefault(k.casefold(), i)
        if j != i:
            raise AerofidInputError(f"frames {str(paths[j])!r} and {str(paths[i])!r} would share the outputs "
                                    f"{k!r}; rename one of them")
    return tuple(keys)


__all__ = ["SCAN_SUFFIXES", "expand_inputs", "frame_keys", "is_scan"]
