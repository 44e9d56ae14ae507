"""Specific exceptions of tribo_common (bag reading shared by the analyses).

The ``tribo`` CLI answers any :class:`CommonError` with one line and exit code 2.
"""


class CommonError(Exception):
    """Base class of tribo_common errors."""


class BagError(CommonError):
    """A bag cannot be read or written (names the file and the last good message)."""


class BagTruncatedError(BagError):
    """A bag ends early or is corrupt after some good messages."""
