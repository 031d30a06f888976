"""The memory budget: the most bytes one allocation that an input asks for may take (a whole decode of a TIFF
that cannot be read window by window). A file's header can declare any size; the size is checked against the
budget before anything is allocated, and the refusal names the budget and how to change it."""

from __future__ import annotations

import os

from aerofid.errors import AerofidInputError

__all__ = ["BUDGET_ENV", "DEFAULT_BUDGET_GB", "check_budget", "memory_budget"]

BUDGET_ENV = "AEROFID_MEMORY_BUDGET_GB"
"""Environment variable that sets the budget, in GB (10^9 bytes)."""
DEFAULT_BUDGET_GB = 1.0
"""The default budget: the 1 GB that a whole JPEG/PNG decode (:func:`aerofid.io.jpeg.decode_budget`) and a
window (:data:`aerofid.io.raster.WINDOW_LIMIT_BYTES`) may take."""


def memory_budget() -> int:
    """The budget in bytes: :data:`BUDGET_ENV` when set (a number of GB > 0), else :data:`DEFAULT_BUDGET_GB`."""
    text = os.environ.get(BUDGET_ENV, "").strip()
    if not text:
        return int(DEFAULT_BUDGET_GB * 1e9)
    try:
        gb = float(text)
    except ValueError:
        gb = float("nan")
    if not 0 < gb < 1e6:
        raise AerofidInputError(f"{BUDGET_ENV}={text!r} must be a number of GB, e.g. {BUDGET_ENV}=4")
    return int(gb * 1e9)


def check_budget(nbytes: int, what: str, instead: str) -> None:
    """An input error when ``what`` would need more than the budget: ``instead`` says what else to do.

    Examples
    --------
    >>> check_budget(10**6, "decoding it whole", "convert it to a tiled TIFF")
    >>> check_budget(10**13, "decoding it whole", "convert it to a tiled TIFF")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    aerofid.errors.AerofidInputError: decoding it whole would need 10000.0 GB, more than the memory budget of ...
    """
    budget = memory_budget()
    if nbytes > budget:
        raise AerofidInputError(f"{what} would need {nbytes / 1e9:.1f} GB, more than the memory budget of "
                                f"{budget / 1e9:.1f} GB ({BUDGET_ENV} raises it); {instead}")
