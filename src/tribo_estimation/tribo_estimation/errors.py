"""Specific exceptions of tribo_estimation (rig model, simulator, identification, fits).

Every error names the problem (parameter, column, key, line, value). The ``tribo`` CLI
answers any :class:`EstimationError` with one line on stderr and exit code 2.
Other modules may append further subclasses at the end of this file.
"""

from __future__ import annotations

from tribo_common.errors import BagError, BagTruncatedError


class EstimationError(Exception):
    """Base class of all tribo_estimation errors."""


class InvalidParameterError(EstimationError, ValueError):
    """A model or algorithm parameter is out of range (e.g. zero or negative inertia)."""


class InvalidDataError(EstimationError, ValueError):
    """Measured or simulated data are unusable (NaN/inf, wrong shape, wrong units)."""


class NonMonotonicTimeError(InvalidDataError):
    """A time vector is not strictly increasing (names the first offending sample)."""


class TooShortError(InvalidDataError):
    """A record is too short for the requested analysis."""


class NoOscillationError(InvalidDataError):
    """A free-decay record shows no (under-damped) oscillation to identify."""


class MissingKeyError(EstimationError, LookupError):
    """A required key is missing from a configuration file (names the key and file)."""


class MissingColumnError(InvalidDataError):
    """A data file lacks a required column (names the column and file)."""


class UnitError(InvalidDataError):
    """A signal's magnitude indicates wrong units (e.g. a speed in rpm instead of rad/s)."""


class ConfigFileError(EstimationError, ValueError):
    """A configuration file cannot be read or parsed (names the file)."""


class SimulationError(EstimationError, RuntimeError):
    """The simulator failed (non-finite state, event location did not converge)."""


class AlignmentError(InvalidDataError):
    """A sample block cannot be aligned (unknown channel, bad rate, index or stamp)."""


class FitError(EstimationError):
    """The block fit could not produce an estimate (too little or unusable data)."""


class TimeBaseError(InvalidDataError):
    """The time column gives no usable sample rate (wrong unit, outside 0.1-100 kHz)."""


class IrregularSamplingError(TimeBaseError):
    """Sample times do not lie on one regular grid (names the time and the line)."""


class UnknownCandidateError(EstimationError, KeyError):
    """A candidate effect name that is not registered (names the known ones)."""

    def __str__(self) -> str:  # KeyError would quote the message
        """Return the message unquoted (KeyError would quote it)."""
        return str(self.args[0]) if self.args else ''


class RecordBagError(InvalidDataError, BagError):
    """A bag gives no rig record (no rig streams, several rigs, unreadable storage)."""


class RecordTruncatedError(RecordBagError, BagTruncatedError):
    """A bag ends early or is corrupt after some good rig samples."""
