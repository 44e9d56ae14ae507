"""Align the rig's sample streams by sample index (no rclpy).

The rig publishes its channels (torsion moment C1*phi1 [N m], angular
acceleration w1' [rad/s^2], shaft speed w2 [rad/s]) as independent
``SampleBlock`` streams: each block carries the index of its first sample
since the stream started, the sample rate [Hz], the stamp of its first
sample [s] and the samples. Blocks of different channels arrive in any
interleaving. :class:`ChannelAligner` turns them into contiguous chunks
holding all channels for the same sample indices, in index order, and into
explicit events for everything that is not a plain continuation:

* :class:`GapEvent`: samples of at least one channel are missing (the
  ``first_index`` of a block jumps forward). The aligned stream skips the
  missing index range; it is never bridged or interpolated.
* :class:`RestartEvent`: the ``first_index`` of a channel goes backwards
  (the publisher restarted). Everything aligned so far is emitted, the
  aligner starts a new epoch and ignores old-epoch data of the channels that
  have not restarted yet.

The same class serves the online node (blocks from subscriptions) and the
offline CLI (blocks read from a bag, or a CSV read in chunks).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..errors import AlignmentError

FloatArray = npt.NDArray[np.float64]


#: Channel names in the order of :class:`AlignedChunk` fields (SampleBlock ``frame_id``).
CHANNELS: tuple[str, str, str] = ('torsion_moment', 'angular_acceleration', 'speed')

#: Relative tolerance when comparing the sample rates of the channels [-].
_RATE_RTOL = 1e-9


@dataclass(frozen=True)
class AlignedChunk:
    """Contiguous samples of all channels for indices ``first_index ...``.

    Attributes
    ----------
    first_index
        index of the first sample since the stream started [samples].
    t0
        stream time of the first sample [s] (stamp of the torsion channel).
    sample_rate
        sample rate [Hz].
    torsion
        torsion moment C1*phi1 [N m].
    accel
        angular acceleration of the chamber w1' [rad/s^2].
    speed
        shaft speed w2 [rad/s].
    """

    first_index: int
    t0: float
    sample_rate: float
    torsion: FloatArray
    accel: FloatArray
    speed: FloatArray

    def __len__(self) -> int:
        """Return the number of samples in the chunk."""
        return int(self.torsion.shape[0])

    @property
    def end_index(self) -> int:
        """Index one past the last sample [samples]."""
        return self.first_index + len(self)


@dataclass(frozen=True)
class GapEvent:
    """Samples ``[start_index, end_index)`` are missing in at least one channel.

    Attributes
    ----------
    start_index
        first missing index [samples].
    end_index
        first index after the gap [samples].
    channels
        channels that lost samples in this range.
    t_start
        stream time of ``start_index`` [s] (NaN if unknown).
    """

    start_index: int
    end_index: int
    channels: tuple[str, ...]
    t_start: float

    @property
    def n_missing(self) -> int:
        """Number of missing samples [samples]."""
        return self.end_index - self.start_index


@dataclass(frozen=True)
class RestartEvent:
    """A channel's ``first_index`` went backwards: a new stream epoch starts.

    Attributes
    ----------
    channel
        the channel whose index went backwards first.
    old_index
        index the aligner expected next for that channel [samples].
    new_index
        first index of the restarted stream [samples].
    """

    channel: str
    old_index: int
    new_index: int


AlignEvent = AlignedChunk | GapEvent | RestartEvent


@dataclass
class _Block:
    first_index: int
    stamp: float
    data: FloatArray


@dataclass
class _Channel:
    name: str
    blocks: deque[_Block] = field(default_factory=deque)
    next_index: int | None = None  # expected first_index of the next block
    restarted: bool = True  # belongs to the current epoch

    def buffered_end(self) -> int | None:
        if not self.blocks:
            return None
        last = self.blocks[-1]
        return last.first_index + int(last.data.shape[0])


class ChannelAligner:
    """Align independently arriving per-channel sample blocks by sample index.

    Push blocks with :meth:`push`; it returns the events that became ready
    (aligned chunks in index order, gaps, restarts). Memory is bounded by the
    skew between the channels: data are released as soon as every channel has
    delivered them. ``max_skew`` bounds that buffer: if one channel runs more
    than ``max_skew`` samples ahead of a silent one, the silent channel's
    missing range is declared a gap rather than buffering without bound.

    Parameters
    ----------
    channels
        channel names (default :data:`CHANNELS`); the first one gives
        the stream time.
    max_skew
        largest lead of one channel over another before the laggard's
        missing samples are declared a gap [samples].
    """

    def __init__(self, channels: tuple[str, ...] = CHANNELS, max_skew: int = 200_000) -> None:
        if len(channels) < 1 or len(set(channels)) != len(channels):
            raise AlignmentError(f'channel names must be unique and non-empty: {channels!r}')
        if max_skew < 1:
            raise AlignmentError(f'max_skew must be >= 1 sample, got {max_skew}')
        self.channels = tuple(channels)
        self.max_skew = int(max_skew)
        self._ch: dict[str, _Channel] = {name: _Channel(name) for name in channels}
        self.sample_rate: float | None = None
        self._emit_index: int | None = None  # next aligned index to emit
        self._epoch_waiting = False
        #: Samples dropped because they could not be aligned (old epoch, gap in others).
        self.dropped_samples = 0
        #: Number of restarts seen.
        self.restarts = 0

    # ------------------------------------------------------------------ input
    def push(
        self,
        channel: str,
        first_index: int,
        sample_rate: float,
        stamp: float,
        data: npt.ArrayLike,
    ) -> list[AlignEvent]:
        """Add one block of one channel; return the events now ready.

        Parameters
        ----------
        channel
            channel name (one of ``channels``).
        first_index
            index of the block's first sample since the stream started.
        sample_rate
            sample rate [Hz]; all channels must share it.
        stamp
            stream time of the block's first sample [s].
        data
            samples in the channel's SI unit.

        Raises
        ------
        AlignmentError
            unknown channel, bad sample rate, negative index or
            non-finite stamp.
        """
        ch = self._ch.get(channel)
        if ch is None:
            raise AlignmentError(f'unknown channel {channel!r}; expected one of {self.channels}')
        if first_index < 0:
            raise AlignmentError(f'{channel}: negative first_index {first_index}')
        if not (math.isfinite(sample_rate) and sample_rate > 0.0):
            raise AlignmentError(f'{channel}: sample_rate must be > 0 Hz, got {sample_rate}')
        if not math.isfinite(stamp):
            raise AlignmentError(f'{channel}: stamp is not finite ({stamp})')
        if self.sample_rate is None:
            self.sample_rate = float(sample_rate)
        elif abs(sample_rate - self.sample_rate) > _RATE_RTOL * self.sample_rate:
            raise AlignmentError(
                f'{channel}: sample_rate {sample_rate} Hz differs from {self.sample_rate} Hz '
                'of the other channels (resampling is not supported)'
            )
        arr = np.array(data, dtype=np.float64).reshape(-1)
        events: list[AlignEvent] = []
        if ch.next_index is not None and first_index < ch.next_index:
            if ch.restarted and not self._epoch_waiting:
                # first channel of a new epoch: flush and reset
                events.extend(self._drain())
                events.append(RestartEvent(channel, ch.next_index, int(first_index)))
                self.restarts += 1
                self._start_epoch(channel)
            elif not ch.restarted:
                # a lagging channel joins the new epoch
                ch.restarted = True
                ch.blocks.clear()
                ch.next_index = None
                self._epoch_waiting = not all(c.restarted for c in self._ch.values())
            else:
                # went backwards twice within one epoch: treat as a further restart
                events.extend(self._drain())
                events.append(RestartEvent(channel, ch.next_index, int(first_index)))
                self.restarts += 1
                self._start_epoch(channel)
        elif not ch.restarted:
            # old-epoch data of a channel that has not restarted yet
            self.dropped_samples += arr.shape[0]
            return events
        if arr.shape[0] == 0:
            return events
        if self._emit_index is not None and first_index + arr.shape[0] <= self._emit_index:
            # late data for a range already declared a gap
            self.dropped_samples += arr.shape[0]
            ch.next_index = int(first_index) + arr.shape[0]
            return events
        ch.blocks.append(_Block(int(first_index), float(stamp), arr))
        ch.next_index = int(first_index) + arr.shape[0]
        events.extend(self._drain())
        return events

    def flush(self) -> list[AlignEvent]:
        """Emit what is aligned (end of input); data only some channels have is dropped."""
        events = self._drain()
        for ch in self._ch.values():
            for b in ch.blocks:
                self.dropped_samples += b.data.shape[0]
            ch.blocks.clear()
        return events

    # --------------------------------------------------------------- internal
    def _start_epoch(self, channel: str) -> None:
        for c in self._ch.values():
            for b in c.blocks:
                self.dropped_samples += b.data.shape[0]
            c.blocks.clear()
            c.restarted = c.name == channel
            if c.name == channel:
                c.next_index = None
        self._emit_index = None
        self._epoch_waiting = len(self._ch) > 1

    def _drain(self) -> list[AlignEvent]:
        events: list[AlignEvent] = []
        if self._epoch_waiting or any(not c.blocks for c in self._ch.values()):
            self._check_skew(events)
            return events
        if self._emit_index is not None:
            self._discard_before(self._emit_index)
        while True:
            if any(not c.blocks for c in self._ch.values()):
                break
            starts = {c.name: c.blocks[0].first_index for c in self._ch.values()}
            if self._emit_index is None:
                self._emit_index = min(starts.values())
            start = self._emit_index
            latest_start = max(starts.values())
            if latest_start > start:
                # some channel has no samples at `start`: a gap up to its first sample
                lagging = tuple(n for n, s in starts.items() if s > start)
                events.append(GapEvent(start, latest_start, lagging, self._time_at(start)))
                self._discard_before(latest_start)
                self._emit_index = latest_start
                continue
            end = min(
                c.blocks[0].first_index + c.blocks[0].data.shape[0] for c in self._ch.values()
            )
            # all channels' first blocks start at `start`... or earlier (already trimmed)
            t0 = self._time_at(start)
            parts = [self._take(self._ch[n], start, end) for n in self.channels]
            rate = self.sample_rate if self.sample_rate is not None else float('nan')
            if len(self.channels) == 3:
                events.append(AlignedChunk(start, t0, rate, parts[0], parts[1], parts[2]))
            else:  # generic channel sets: pad missing roles with NaN arrays
                nan = np.full(end - start, np.nan)
                p = [*parts, nan, nan][:3]
                events.append(AlignedChunk(start, t0, rate, p[0], p[1], p[2]))
            self._emit_index = end
        self._merge_chunks(events)
        self._check_skew(events)
        return events

    def _check_skew(self, events: list[AlignEvent]) -> None:
        """Declare a gap when one channel is ``max_skew`` samples ahead of a silent one."""
        if self._epoch_waiting:
            # bound the buffers while waiting for the other channels to restart
            for c in self._ch.values():
                while c.blocks and sum(b.data.shape[0] for b in c.blocks) > self.max_skew:
                    self.dropped_samples += c.blocks.popleft().data.shape[0]
            return
        ends = {c.name: c.buffered_end() for c in self._ch.values()}
        known = [e for e in ends.values() if e is not None]
        if not known:
            return
        lead = max(known)
        emit = self._emit_index
        for c in self._ch.values():
            if c.blocks:
                continue
            behind = c.next_index if c.next_index is not None else emit
            if behind is None:
                behind = min(b.first_index for o in self._ch.values() for b in o.blocks)
            if lead - behind > self.max_skew:
                # the silent channel lost [behind, lead - max_skew // 2): give up on it
                cut = lead - self.max_skew // 2
                start = emit if emit is not None else behind
                if cut > start:
                    events.append(GapEvent(start, cut, (c.name,), self._time_at(start)))
                    self._discard_before(cut)
                    self._emit_index = cut

    def _discard_before(self, index: int) -> None:
        for c in self._ch.values():
            while c.blocks:
                b = c.blocks[0]
                end = b.first_index + b.data.shape[0]
                if end <= index:
                    self.dropped_samples += b.data.shape[0]
                    c.blocks.popleft()
                elif b.first_index < index:
                    k = index - b.first_index
                    self.dropped_samples += k
                    rate = self.sample_rate or 1.0
                    c.blocks[0] = _Block(index, b.stamp + k / rate, b.data[k:])
                    break
                else:
                    break

    def _take(self, ch: _Channel, start: int, end: int) -> FloatArray:
        b = ch.blocks[0]
        k0 = start - b.first_index
        k1 = end - b.first_index
        out = b.data[k0:k1]
        if k1 >= b.data.shape[0]:
            ch.blocks.popleft()
        else:
            rate = self.sample_rate or 1.0
            ch.blocks[0] = _Block(end, b.stamp + (end - b.first_index) / rate, b.data[k1:])
        return out

    def _time_at(self, index: int) -> float:
        ref = self._ch[self.channels[0]]
        rate = self.sample_rate or 1.0
        if ref.blocks:
            b = ref.blocks[0]
            return b.stamp + (index - b.first_index) / rate
        return float('nan')

    @staticmethod
    def _merge_chunks(events: list[AlignEvent]) -> None:
        """Merge consecutive contiguous chunks (fewer, larger arrays downstream)."""
        i = 0
        while i + 1 < len(events):
            a, b = events[i], events[i + 1]
            if (
                isinstance(a, AlignedChunk)
                and isinstance(b, AlignedChunk)
                and a.end_index == b.first_index
            ):
                events[i] = AlignedChunk(
                    a.first_index,
                    a.t0,
                    a.sample_rate,
                    np.concatenate((a.torsion, b.torsion)),
                    np.concatenate((a.accel, b.accel)),
                    np.concatenate((a.speed, b.speed)),
                )
                del events[i + 1]
            else:
                i += 1
