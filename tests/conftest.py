"""Shared fixtures.

Real data lives beside the repository, in ``../shared/realdata`` (never copied into it). Tests that read it
use :func:`realdata`: they skip when the folder is absent (a fresh clone elsewhere) and *fail* when it is
present but the file they need is missing or unreadable (so CI never silently skips the checks against
real scans and published numbers).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

settings.register_profile("reproducible", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile("reproducible")
"""Property tests draw the same examples at every run (``derandomize``: a run that passes passes again, and CI
cannot fail by the draw); ``python -m pytest --hypothesis-profile=explore`` draws new ones (each run its own
examples: how the regularized beta's wrong reference at x = 1 - 2^-53 was found, session 45)."""

REPO = Path(__file__).resolve().parents[1]
REALDATA = REPO.parent / "shared" / "realdata"


def realdata_path(relative: str) -> Path:
    """The path of ``relative`` inside ``../shared/realdata``: skips the test when the folder is absent,
    fails it when the folder is there but ``relative`` is not a readable file or folder."""
    if not REALDATA.is_dir():
        pytest.skip(f"{REALDATA} is absent")
    path = REALDATA / relative
    if not path.exists():
        pytest.fail(f"{relative} is missing from {REALDATA}")
    if not os.access(path, os.R_OK):
        pytest.fail(f"{path} is not readable")
    return path


@pytest.fixture
def realdata():
    """``realdata("unbc_bc_wild_rc20/15BCC02013_114.jpg") -> Path`` (see :func:`realdata_path`)."""
    return realdata_path


@pytest.fixture(autouse=True)
def fresh_kept():
    """Each test starts with nothing kept (:func:`aerofid.kept.forget_kept`: the fits and window analyses ``hough``
    keeps, a JPEG's top rows): a test that counts or replaces them sees its own, whatever ran before it."""
    from aerofid.kept import forget_kept

    forget_kept()
