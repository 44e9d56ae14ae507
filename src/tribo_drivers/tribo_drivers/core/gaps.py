"""Sequence-counter unwrapping, gap accounting and batching into sample blocks.

Devices number their samples (DAQ: u32 sample index) or frames (CAN: u16 sequence) with
wrapping counters.  :class:`IndexTracker` turns them into monotonically increasing int64
indices and accounts for every irregularity:

* step 1 .. ``confirm_jump``: normal; a step d > 1 is a gap of d - 1 lost samples;
* step 0: duplicate, dropped;
* larger forward step or any backward step: accepted only if the next counter value follows
  it directly (d == 1), as a gap (forward) or a device restart (backward, a new epoch whose
  index starts at the raw counter again); otherwise the value is a corrupt outlier and dropped
  (a real sample dropped this way is included in the next gap).

:class:`BlockBatcher` cuts the accepted samples into :class:`SampleBlock` chunks of a fixed
size that never bridge a gap: after a gap the next block starts exactly at the index of the
first sample after the gap.  Nothing is interpolated, nothing is duplicated.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from tribo_drivers.errors import ConfigError, FrameError


@dataclass(frozen=True)
class SampleBlock:
    """Uniformly sampled values of one channel (mirrors tribo_msgs/SampleBlock).

    stamp: host time of the first sample [s, same clock as the host times fed to the clock].
    sample_rate: [Hz]; first_index: index of data[0] since the stream started [samples];
    unit: SI unit of data.
    """

    channel: str
    unit: str
    sample_rate: float
    first_index: int
    stamp: float
    data: npt.NDArray[np.float64]

    @property
    def next_index(self) -> int:
        """Return the index [samples] of the sample after the block."""
        return self.first_index + int(self.data.size)


@dataclass
class GapCounters:
    """Cumulative counter irregularities [events or samples]."""

    accepted: int = 0
    gaps: int = 0
    lost: int = 0
    duplicates: int = 0
    restarts: int = 0
    outliers: int = 0


@dataclass(frozen=True)
class TrackResult:
    """Outcome of one :meth:`IndexTracker.update` call.

    keep: mask over the input values (False = duplicate or outlier, dropped);
    index: unwrapped int64 index of every kept value;
    gap_lost: per kept value, number of samples lost right before it (0 if none);
    restart: per kept value, True if a device restart (new epoch) begins there.
    """

    keep: npt.NDArray[np.bool_]
    index: npt.NDArray[np.int64]
    gap_lost: npt.NDArray[np.int64]
    restart: npt.NDArray[np.bool_]


@dataclass
class IndexTracker:
    """Unwraps a ``bits``-wide counter and accounts for gaps, duplicates and restarts.

    step: index increment per counter step (e.g. 3 samples per CAN accelerometer frame);
    confirm_jump: largest counter step accepted without confirmation by the next value;
    confirm: if False, larger jumps are accepted at once (for checksummed, low-rate lines).
    A value held back as unconfirmed at the end of one update is confirmed by its successor
    arriving in a later update.
    """

    bits: int = 32
    confirm_jump: int = 1 << 20
    step: int = 1
    confirm: bool = True
    counters: GapCounters = field(default_factory=GapCounters)
    _last_raw: int | None = None
    _candidate: int | None = None
    _last_unwrapped: int = 0

    def __post_init__(self) -> None:
        """Refuse a counter width outside 2..62 bits or a jump outside the half range."""
        if not 2 <= self.bits <= 62:
            raise ConfigError(f'counter width must be 2..62 bits, got {self.bits}')
        if not 1 <= self.confirm_jump < (1 << (self.bits - 1)):
            raise ConfigError(
                f'confirm_jump must be in [1, 2**{self.bits - 1}), got {self.confirm_jump}'
            )
        if self.step < 1:
            raise ConfigError(f'step must be >= 1, got {self.step}')

    @property
    def modulus(self) -> int:
        """Return the counter modulus 2**bits."""
        return 1 << self.bits

    def reset(self) -> None:
        """Forget the last counter value (the next one starts a new stream)."""
        self._last_raw = None
        self._last_unwrapped = 0
        self._candidate = None

    @property
    def last_index(self) -> int | None:
        """Unwrapped counter value of the last accepted input (None before the first)."""
        return None if self._last_raw is None else self._last_unwrapped

    def update(self, raw: npt.ArrayLike, expected_advance: float | None = None) -> TrackResult:
        """Account for the next counter values ``raw`` (in arrival order).

        expected_advance: optional number of counter steps expected since the last accepted
        value (e.g. elapsed host time * frame rate); it resolves gaps longer than one wrap of
        the counter (a gap is extended by whole multiples of 2**bits towards it).
        """
        r = np.asarray(raw).astype(np.int64)
        if r.ndim != 1:
            raise FrameError(f'counter values must be 1-D, got shape {r.shape}')
        n = r.size
        if n == 0:
            empty = np.zeros(0, dtype=np.int64)
            return TrackResult(
                np.zeros(0, dtype=np.bool_), empty, empty, np.zeros(0, dtype=np.bool_)
            )
        mod = self.modulus
        if np.any((r < 0) | (r >= mod)):
            raise FrameError(f'counter value outside [0, 2**{self.bits})')
        prev = np.empty(n, dtype=np.int64)
        prev[1:] = r[:-1]
        prev[0] = r[0] - 1 if self._last_raw is None else self._last_raw
        d = (r - prev) % mod
        fast = (d >= 1) & (d <= self.confirm_jump)
        if self._last_raw is not None and expected_advance is not None and d[0] != 1:
            fast[0] = False
        if fast.all():
            unwrapped = self._last_unwrapped + np.cumsum(d)
            if self._last_raw is None:
                unwrapped = unwrapped - unwrapped[0] + r[0]
            lost = d - 1
            if self._last_raw is None:
                lost[0] = 0
            self._last_raw = int(r[-1])
            self._last_unwrapped = int(unwrapped[-1])
            self._candidate = None
            gaps = lost > 0
            c = self.counters
            c.accepted += n
            c.gaps += int(np.count_nonzero(gaps))
            c.lost += int(lost.sum()) * self.step
            return TrackResult(
                np.ones(n, dtype=np.bool_),
                unwrapped * self.step,
                lost * self.step,
                np.zeros(n, dtype=np.bool_),
            )
        return self._update_slow(r, expected_advance)

    def _resolve_wraps(self, d: int, expected_advance: float) -> int:
        # Step d + k*2**bits (k >= -1) closest to the expected advance; <= 0 means backwards.
        mod = self.modulus
        k = int(np.floor((expected_advance - d) / mod + 0.5))
        return d + max(k, -1) * mod

    def _update_slow(self, r: npt.NDArray[np.int64], expected_advance: float | None) -> TrackResult:
        mod = self.modulus
        n = r.size
        keep = np.zeros(n, dtype=np.bool_)
        index = np.zeros(n, dtype=np.int64)
        lost = np.zeros(n, dtype=np.int64)
        restart = np.zeros(n, dtype=np.bool_)
        c = self.counters
        for i in range(n):
            ri = int(r[i])
            if self._last_raw is None:
                keep[i] = True
                self._last_raw, self._last_unwrapped = ri, ri
                index[i] = ri
                c.accepted += 1
                continue
            d = (ri - self._last_raw) % mod
            timed = i == 0 and expected_advance is not None
            if timed and expected_advance is not None:
                d = self._resolve_wraps(d, expected_advance)
            if d == 0:
                c.duplicates += 1
                continue
            if d < 0 or d > self.confirm_jump:
                confirmed = (
                    timed
                    or not self.confirm
                    or (i + 1 < n and (int(r[i + 1]) - ri) % mod == 1)
                    or (self._candidate is not None and (ri - self._candidate) % mod == 1)
                )
                if not confirmed:
                    c.outliers += 1
                    self._candidate = ri
                    continue
                backward = d < 0 if timed else d >= mod // 2
                if backward:  # the device restarted: a new epoch
                    c.restarts += 1
                    restart[i] = True
                    self._candidate = None
                    self._last_raw, self._last_unwrapped = ri, ri
                    keep[i] = True
                    index[i] = ri
                    c.accepted += 1
                    continue
            self._candidate = None
            if d > 1:
                c.gaps += 1
                c.lost += (d - 1) * self.step
                lost[i] = d - 1
            self._last_raw = ri
            self._last_unwrapped += d
            keep[i] = True
            index[i] = self._last_unwrapped
            c.accepted += 1
        return TrackResult(keep, index[keep] * self.step, lost[keep] * self.step, restart[keep])


@dataclass
class BlockBatcher:
    """Cuts indexed multi-channel samples into :class:`SampleBlock` chunks of ``block_size``.

    channels: channel name -> SI unit.  ``push`` takes strictly increasing int64 sample indices
    (from :class:`IndexTracker`, expanded per sample) and one value array per channel; a block
    ends early where the index is not contiguous (gap or restart), so ``first_index`` of the
    next block is always the index of its first sample.
    """

    channels: Mapping[str, str]
    sample_rate: float
    block_size: int
    _pending_index: npt.NDArray[np.int64] = field(
        default_factory=lambda: np.zeros(0, dtype=np.int64)
    )
    _pending: dict[str, npt.NDArray[np.float64]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Refuse an empty channel list and a sample rate [Hz] that is not positive and finite."""
        if not self.channels:
            raise ConfigError('BlockBatcher needs at least one channel')
        if not (np.isfinite(self.sample_rate) and self.sample_rate > 0):
            raise ConfigError(f'sample_rate must be positive and finite, got {self.sample_rate}')
        if self.block_size < 1:
            raise ConfigError(f'block_size must be >= 1, got {self.block_size}')
        self._pending = {ch: np.zeros(0) for ch in self.channels}

    @property
    def pending(self) -> int:
        """Return the samples held for the next block [samples]."""
        return int(self._pending_index.size)

    def push(
        self,
        index: npt.NDArray[np.int64],
        values: Mapping[str, npt.ArrayLike],
        stamp: Callable[[int], float],
    ) -> list[SampleBlock]:
        """Add samples; return the completed blocks (stamped with ``stamp(first_index)``)."""
        idx = np.concatenate([self._pending_index, np.asarray(index, dtype=np.int64)])
        vals: dict[str, npt.NDArray[np.float64]] = {}
        for ch in self.channels:
            if ch not in values:
                raise FrameError(f'missing channel {ch!r} in batch')
            v = np.asarray(values[ch], dtype=np.float64)
            if v.shape != np.shape(index):
                raise FrameError(f'channel {ch!r} has {v.size} values for {np.size(index)} indices')
            vals[ch] = np.concatenate([self._pending[ch], v])
        if idx.size == 0:
            return []
        if np.any(np.diff(idx) == 0):
            raise FrameError('sample indices repeat within a batch')
        breaks = np.flatnonzero(np.diff(idx) != 1) + 1
        starts = np.concatenate([[0], breaks])
        ends = np.concatenate([breaks, [idx.size]])
        blocks: list[SampleBlock] = []
        keep_from = idx.size
        for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
            last_segment = e == idx.size
            pos = s
            while pos < e:
                stop = min(pos + self.block_size, e)
                if last_segment and stop - pos < self.block_size:
                    keep_from = pos
                    break
                blocks.extend(self._make(idx, vals, pos, stop, stamp))
                pos = stop
        self._pending_index = idx[keep_from:].copy()
        self._pending = {ch: vals[ch][keep_from:].copy() for ch in self.channels}
        return blocks

    def flush(self, stamp: Callable[[int], float]) -> list[SampleBlock]:
        """Emit the partial block (if any), e.g. before a disconnect or when data stall."""
        if self._pending_index.size == 0:
            return []
        blocks = self._make(self._pending_index, self._pending, 0, self._pending_index.size, stamp)
        self._pending_index = np.zeros(0, dtype=np.int64)
        self._pending = {ch: np.zeros(0) for ch in self.channels}
        return blocks

    def _make(
        self,
        idx: npt.NDArray[np.int64],
        vals: Mapping[str, npt.NDArray[np.float64]],
        start: int,
        stop: int,
        stamp: Callable[[int], float],
    ) -> list[SampleBlock]:
        first = int(idx[start])
        t = stamp(first)
        return [
            SampleBlock(ch, unit, self.sample_rate, first, t, vals[ch][start:stop].copy())
            for ch, unit in self.channels.items()
        ]


def block_size_for(sample_rate: float, blocks_per_second: float = 200.0) -> int:
    """Block length [samples] giving about ``blocks_per_second`` blocks (at least 1 sample)."""
    if sample_rate <= 0 or blocks_per_second <= 0:
        raise ConfigError(
            f'sample_rate and blocks_per_second must be positive, got {sample_rate}, '
            f'{blocks_per_second}'
        )
    return max(1, round(sample_rate / blocks_per_second))


__all__: Sequence[str] = (
    'BlockBatcher',
    'GapCounters',
    'IndexTracker',
    'SampleBlock',
    'TrackResult',
    'block_size_for',
)
