"""Conversions between numpy arrays / plain values and tribo_msgs messages.

Float arrays go into ``float64[]`` fields as ``array.array('d')`` built from
the raw bytes (the generated setter then skips its per-element range check,
which would cost ~1 us per sample at 10 kHz).
"""

from __future__ import annotations

import array
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt
from builtin_interfaces.msg import Time

from tribo_msgs.msg import SampleBlock

NS_PER_S = 1_000_000_000


class StampLike(Protocol):
    """A builtin_interfaces/Time as rclpy and rosbags both give it."""

    @property
    def sec(self) -> int:
        """Return the whole seconds [s]."""

    @property
    def nanosec(self) -> int:
        """Return the nanoseconds [ns] within the second."""


class HeaderLike(Protocol):
    """A std_msgs/Header as far as the stamp goes."""

    @property
    def stamp(self) -> StampLike:
        """Return the stamp of the message."""


class StampedMessage(Protocol):
    """Any message with a header (rclpy or rosbags message object)."""

    @property
    def header(self) -> HeaderLike:
        """Return the message's header."""


def float64_array(values: npt.ArrayLike) -> array.array[float]:
    """Return ``values`` as ``array.array('d')`` (fast path of float64[] fields)."""
    out = array.array('d')
    out.frombytes(np.ascontiguousarray(values, dtype=np.float64).tobytes())
    return out


def time_from_ns(stamp_ns: int) -> Time:
    """builtin_interfaces/Time from integer nanoseconds."""
    sec, nsec = divmod(int(stamp_ns), NS_PER_S)
    return Time(sec=int(sec), nanosec=int(nsec))


def time_to_ns(stamp: Time) -> int:
    """Integer nanoseconds from builtin_interfaces/Time."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def make_sample_block(
    data: npt.ArrayLike,
    *,
    first_index: int,
    sample_rate: float,
    stamp_ns: int,
    channel: str,
    unit: str,
) -> SampleBlock:
    """Build a SampleBlock.

    Args:
        data: samples in ``unit``.
        first_index: index of the first sample since stream start [samples].
        sample_rate: sample rate [Hz].
        stamp_ns: time of the first sample [ns].
        channel: channel name (header.frame_id).
        unit: SI unit string of ``data``.
    """
    msg = SampleBlock()
    msg.header.stamp = time_from_ns(stamp_ns)
    msg.header.frame_id = channel
    msg.sample_rate = float(sample_rate)
    msg.first_index = int(first_index)
    msg.unit = unit
    msg.data = float64_array(data)
    return msg


@dataclass(frozen=True)
class Block:
    """Plain view of a SampleBlock: channel, index, rate [Hz], stamp [ns], samples."""

    channel: str
    first_index: int
    sample_rate: float
    stamp_ns: int
    unit: str
    data: npt.NDArray[np.float64]


def block_from_msg(msg: SampleBlock, channel: str | None = None) -> Block:
    """Convert a SampleBlock into a :class:`Block` (zero-copy view of the samples)."""
    return Block(
        channel=channel if channel is not None else msg.header.frame_id,
        first_index=int(msg.first_index),
        sample_rate=float(msg.sample_rate),
        stamp_ns=time_to_ns(msg.header.stamp),
        unit=msg.unit,
        data=np.frombuffer(msg.data, dtype=np.float64)
        if isinstance(msg.data, array.array)
        else np.asarray(msg.data, dtype=np.float64),
    )
