"""Errors of the tribo_drivers package.

Every error raised on purpose by the drivers derives from :class:`DriverError`, so callers
(the CLI, the nodes) can catch one base class. The subclasses say *what* went wrong; the
message names the offending value, port, parameter or file.
"""

from __future__ import annotations


class DriverError(Exception):
    """Base class of all tribo_drivers errors."""


class ConfigError(DriverError):
    """A parameter or configuration file is invalid (out of range, missing key, bad DBC)."""


class FrameError(DriverError):
    """A single frame or line is malformed (wrong length, missing sync, bad field)."""


class ChecksumError(FrameError):
    """A frame's CRC or a line's XOR checksum does not match its content."""


class ProtocolError(DriverError):
    """The device answered something unexpected (no ACK, wrong ACK, unknown message)."""


class TransportError(DriverError):
    """The port or bus could not be opened, read or written (device unplugged, busy, absent)."""


class TimestampError(DriverError):
    """Timestamp inputs are not usable (non-finite host time, non-positive sample rate)."""
