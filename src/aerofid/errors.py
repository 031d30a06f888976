"""Errors raised for bad input.

Every error a user can cause (a missing file, a box outside the image, a malformed number) is an
:class:`AerofidInputError`. Its message is one line that says what is wrong and what to do; the CLI prints
it as ``error: ...`` and exits with status 2.
"""


class AerofidInputError(ValueError):
    """Bad input from the user: the message says what to do."""
