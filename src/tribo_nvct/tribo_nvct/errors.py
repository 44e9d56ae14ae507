"""Specific exceptions of tribo_nvct (nVCT wear measurement).

Every error names the offending file, column, key or value. The ``tribo`` CLI
answers any :class:`NvctError` with one line and exit code 2.
"""

from tribo_common.errors import BagError, BagTruncatedError


class NvctError(Exception):
    """Base class of tribo_nvct errors."""


class NvctConfigError(NvctError):
    """NVCT.yaml (or the simulated-detector YAML) is missing a key or has an invalid value."""


class UnknownNuclideError(NvctConfigError):
    """The configured nuclide is not in the half-life table (give ``half_life_days``)."""


class DepthProfileError(NvctError):
    """The layer-removal depth profile is unreadable or physically impossible."""


class ProfileNotDecreasingError(DepthProfileError):
    """Remaining activity rises with depth by more than its noise allows."""


class CountsError(NvctError):
    """Detector counts of a dwell are invalid."""


class NegativeCountsError(CountsError):
    """A dwell reports negative (or non-integer, non-finite) counts."""


class LiveTimeError(CountsError):
    """Live time is not positive or exceeds the dwell's real time."""


class NonMonotonicTimeError(CountsError):
    """Dwells overlap or go back in test time."""


class CountsFileError(CountsError):
    """A counts CSV is unreadable, has missing columns or bad values."""


class ContactError(NvctError):
    """Contact geometry or materials are invalid (e.g. the ring is not inside the liner)."""


class EvaluationError(NvctError):
    """Running-in/progressive evaluation is impossible with the given data."""


class StateError(NvctError):
    """A saved evaluator state is corrupt or belongs to another configuration."""


class CountsBagError(CountsFileError, BagError):
    """A bag gives no dwells (no ``/nvct/counts`` messages, unreadable storage)."""


class CountsTruncatedError(CountsBagError, BagTruncatedError):
    """A bag ends early or is corrupt after some good dwells."""
