"""The one input stage of the rig channels: a CSV, a bag or arrays in, checked samples out.

Every reader of the four rig channels goes through this module: ``tribo
friction``, ``tribo discrepancy``, ``tribo decay``, the session report and the
Python API (:func:`tribo_estimation.read_record`); the live nodes feed the same
checks (:class:`~tribo_estimation.core.plausibility.ChunkChecker`) through
:class:`~tribo_estimation.core.plausibility.CheckedStream`. Stages:

1. raw aligner events (:mod:`tribo_estimation.core.align`): a rig CSV read block by
   block (:func:`csv_events`: the stamps placed on one regular grid, jitter up to
   a quarter interval resampled, a time step that skips samples a gap, a stamp off
   the grid an error naming its line), the ``rig/*`` SampleBlock streams of a bag
   aligned by sample index (:func:`bag_events`), or arrays (:class:`GridPlacer`);
2. the checks of :mod:`tribo_estimation.core.plausibility` (units, time base,
   plausibility against the rig's physics, spikes and bursts replaced and logged):
   :class:`CheckedInput`, a bounded-memory stream for the block fit;
3. one :class:`~tribo_estimation.core.record.RigRecord` (:func:`read_record`,
   :func:`record_from_arrays`): a time window, its longest gap-free stretch, and
   the whole-record check of the channels.

The scales of the checks come from the rig config (``Scales.of``); without one,
from the record itself (``Scales.from_data``: the time base and the spikes are
checked, the channels are not compared with any physics).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tribo_estimation.core.align import AlignedChunk, AlignEvent, GapEvent, RestartEvent
from tribo_estimation.core.record import FloatArray, InputFindings, RigRecord
from tribo_estimation.errors import RecordBagError, RecordTruncatedError, TooShortError

if TYPE_CHECKING:
    from tribo_estimation.core.config import RigConfig
    from tribo_estimation.core.plausibility import Scales, SpikeLog

Progress = Callable[[str], None]

#: Rows of a rig CSV read (and checked) at a time.
CSV_BLOCK = 10_000
#: Samples of aligned chunks made from arrays or a record.
CHUNK = 10_000
#: Fewest samples a record may hold.
MIN_RECORD_SAMPLES = 100


def _quiet(_: str) -> None:
    """Progress sink that drops the lines."""


def is_bag(path: Path) -> bool:
    """Return whether ``path`` names a bag (a directory, ``.mcap`` or ``.db3``) not a CSV."""
    return path.is_dir() or path.suffix in ('.mcap', '.db3')


class GridPlacer:
    """Place stamped samples on one regular time grid, block after block.

    The rate comes from the first block
    (:func:`~tribo_estimation.core.rigio.estimate_rate`; epoch or relative stamps);
    each sample's index from the grid through the previous block's last sample,
    stamps that jitter are resampled onto the grid, a time step that skips samples
    becomes a :class:`~tribo_estimation.core.align.GapEvent` (never bridged) and a
    sample off the grid raises
    :class:`~tribo_estimation.errors.IrregularSamplingError` naming its line (or
    sample). Index 0 is the first sample.

    Parameters
    ----------
    source : str
        Name of the input in messages.
    """

    def __init__(self, source: str) -> None:
        self.source = source
        self.fs: float | None = None
        #: Largest distance of a stamp from the grid so far [sample intervals].
        self.max_jitter = 0.0
        self._t_first = math.nan
        self._t_ref = math.nan
        self._idx_ref = 0
        self._next: int | None = None

    def place(
        self,
        t: FloatArray,
        channels: tuple[FloatArray, FloatArray, FloatArray],
        lines: FloatArray | None = None,
    ) -> Iterator[AlignEvent]:
        """Yield the aligned chunks (and gaps) of one block of stamped samples.

        Parameters
        ----------
        t : numpy.ndarray
            Time stamps [s], strictly increasing.
        channels : tuple of numpy.ndarray
            Torsion moment [N m], chamber acceleration [rad/s^2], shaft speed [rad/s].
        lines : numpy.ndarray or None
            File line of each sample (for messages).

        Yields
        ------
        AlignEvent
            Chunks on the grid and the gaps between them.
        """
        from tribo_estimation.core.rigio import (
            centred_anchor,
            estimate_rate,
            grid_positions,
            resample_on_grid,
        )

        if self.fs is None:
            self.fs = estimate_rate(t, self.source)
            self._t_first = self._t_ref = centred_anchor(t, self.fs)
        fs = self.fs
        after = None if self._next is None else self._next - 1
        idx, frac = grid_positions(t, fs, self._t_ref, self._idx_ref, self.source, lines, after)
        if frac.size:
            self.max_jitter = max(self.max_jitter, float(np.max(np.abs(frac))))
        # next grid through this block's last sample, shifted by the block's mean offset
        # (follows a rate that differs from the estimate in its 7th digit, averages jitter)
        self._t_ref = float(t[-1]) - (float(frac[-1]) - float(np.mean(frac))) / fs
        self._idx_ref = int(idx[-1])
        chans = [resample_on_grid(idx, frac, np.asarray(c, dtype=np.float64)) for c in channels]
        cuts = np.flatnonzero(np.diff(idx) != 1) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(idx)], strict=True):
            a, b = int(a), int(b)
            first = int(idx[a])
            if self._next is not None and first != self._next:
                yield GapEvent(self._next, first, ('csv',), self._t_first + self._next / fs)
            yield AlignedChunk(
                first, self._t_first + first / fs, fs, chans[0][a:b], chans[1][a:b], chans[2][a:b]
            )
            self._next = int(idx[b - 1]) + 1


def csv_events(path: Path, placer: GridPlacer | None = None) -> Iterator[AlignEvent]:
    """Yield the aligner events of a rig CSV read block by block (:class:`GridPlacer`).

    Parameters
    ----------
    path : Path
        Rig CSV (``docs/ARCHITECTURE.md``, "Rig CSV").
    placer : GridPlacer or None
        The grid placement (its ``max_jitter`` tells the stamps' jitter afterwards).

    Yields
    ------
    AlignEvent
        Chunks and gaps in time order.
    """
    from tribo_estimation.core.rigio import iter_rig_csv

    placer = placer or GridPlacer(str(path))
    for blk in iter_rig_csv(path, CSV_BLOCK, extra=False):
        lines = blk.first_line + np.arange(len(blk), dtype=np.float64)
        yield from placer.place(
            blk.time, (blk.torsion_moment, blk.angular_acceleration, blk.speed), lines
        )


def bag_events(path: Path, namespace: str | None = None) -> Iterator[AlignEvent]:
    """Yield the aligner events of the ``rig/*`` SampleBlock streams of a bag.

    Parameters
    ----------
    path : Path
        Bag directory or ``.mcap`` file.
    namespace : str or None
        The rig to read (e.g. ``/rigB``); None: the root namespace if it holds the
        streams, else the only rig of the bag.

    Yields
    ------
    AlignEvent
        Chunks, gaps and restarts in stream order.

    Raises
    ------
    RecordBagError
        The bag cannot be read or holds none of the three rig streams (raised once
        the bag has been read).
    RecordTruncatedError
        The bag ends early (after the events of its good part).
    """
    from tribo_common import topics as topic_table
    from tribo_common.bag_read import iter_messages
    from tribo_common.errors import BagError, BagTruncatedError
    from tribo_estimation.core.align import ChannelAligner

    channels = {t.resolve(): t.channel for t in topic_table.RIG_STREAMS}
    aligner = ChannelAligner()
    seen = 0
    try:
        for m in iter_messages(path, topics=list(channels), namespace=namespace):
            ch = channels.get(m.topic)
            if ch is None:
                continue
            msg = m.msg
            seen += 1
            stamp = float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)
            yield from aligner.push(
                ch, int(msg.first_index), float(msg.sample_rate), stamp, np.asarray(msg.data)
            )
    except BagTruncatedError as exc:
        raise RecordTruncatedError(str(exc)) from None
    except BagError as exc:
        raise RecordBagError(str(exc)) from None
    if seen == 0:
        raise RecordBagError(f'{path}: no {", ".join(channels)}')
    yield from aligner.flush()


class CheckedInput:
    """The checked aligner events of one input: a rig CSV, a bag or arrays.

    Iterating gives the events (chunks with spikes and bursts replaced, gaps,
    restarts) after the checks of the first samples
    (:func:`~tribo_estimation.core.plausibility.checked_chunks`); memory stays
    bounded by one CSV block or bag message plus what the checks hold. A bag that
    ends early ends the stream after its good part and sets :attr:`truncated`.

    Parameters
    ----------
    raw : iterable of AlignEvent
        The unchecked events (:func:`csv_events`, :func:`bag_events`, :class:`GridPlacer`).
    scales : Scales
        Physical scales of the channels (from the rig config, or the record's own).
    source : str
        Name of the input in messages.
    placer : GridPlacer or None
        The grid placement of stamped input (for :attr:`max_jitter`).
    """

    def __init__(
        self,
        raw: Iterable[AlignEvent],
        scales: Scales,
        source: str,
        placer: GridPlacer | None = None,
    ) -> None:
        from tribo_estimation.core.plausibility import SpikeLog

        self.raw = raw
        self.scales = scales
        self.source = source
        self.placer = placer
        #: Samples replaced by the checks, by stream index.
        self.repairs: SpikeLog = SpikeLog()
        #: Warnings of the checks, in the order found.
        self.warnings: list[str] = []
        #: The error of a bag that ended early (None: read to its end).
        self.truncated: RecordTruncatedError | None = None

    @classmethod
    def open(
        cls, path: str | Path, scales: Scales, *, namespace: str | None = None
    ) -> CheckedInput:
        """Check the rig channels of a rig CSV or a bag.

        Parameters
        ----------
        path : str or Path
            Rig CSV, bag directory or ``.mcap`` file.
        scales : Scales
            Physical scales of the channels.
        namespace : str or None
            Rig namespace in a bag (default: its only rig).

        Returns
        -------
        CheckedInput
            The stream (read while iterated).

        Raises
        ------
        RecordBagError
            ``path`` does not exist.
        """
        p = Path(path)
        if not p.exists():
            raise RecordBagError(f'{p}: no such file or bag')
        if is_bag(p):
            return cls(bag_events(p, namespace), scales, str(p))
        placer = GridPlacer(str(p))
        return cls(csv_events(p, placer), scales, str(p), placer)

    @property
    def max_jitter(self) -> float:
        """Largest distance of a stamp from the grid [sample intervals] (0 for bags)."""
        return self.placer.max_jitter if self.placer is not None else 0.0

    def unchecked(self) -> Iterator[AlignEvent]:
        """Yield the raw events, up to the damage of a bag that ends early.

        Yields
        ------
        AlignEvent
            The events before the checks (sets :attr:`truncated` at a bag's damage).
        """
        try:
            yield from self.raw
        except RecordTruncatedError as exc:
            self.truncated = exc

    def __iter__(self) -> Iterator[AlignEvent]:
        """Yield the checked events.

        Yields
        ------
        AlignEvent
            Checked and repaired events, in order.

        Raises
        ------
        InvalidDataError
            A unit or time-base error of the first samples, a stamp off the grid,
            an unreadable file or bag (each names the source).
        """
        from tribo_estimation.core.plausibility import checked_chunks

        yield from checked_chunks(
            self.unchecked(), self.scales, self.source, self.repairs, self.warnings
        )


def rig_scales(config: RigConfig) -> Scales:
    """Return the physical scales of a rig config's channels.

    Parameters
    ----------
    config : RigConfig
        Rig, friction law and drive (RIG.yaml).

    Returns
    -------
    Scales
        ``F_N R mu`` [N m], ``/ I1`` [rad/s^2], nominal speed [rad/s], stick-slip frequency [Hz].
    """
    from tribo_estimation.core.plausibility import Scales

    return Scales.of(config.rig, config.friction, config.drive.nominal_speed)


def _data_scales(events: list[AlignEvent], source: str) -> Scales:
    """Scales from the samples themselves (a record without a rig config)."""
    from tribo_estimation.core.plausibility import Scales

    chunks = [e for e in events if isinstance(e, AlignedChunk)]
    if not chunks:
        return Scales(0.0, 0.0, 0.0, math.nan, True)
    return Scales.from_data(
        np.concatenate([c.torsion for c in chunks]),
        np.concatenate([c.accel for c in chunks]),
        np.concatenate([c.speed for c in chunks]),
        source,
    )


def _collect(
    stream: CheckedInput, start: float, duration: float, progress: Progress
) -> tuple[list[AlignedChunk], int]:
    """Return the longest gap-free run of chunks inside the window, and the runs found.

    The window starts ``start`` [s] after the stream's first sample and lasts
    ``duration`` [s] (0: to the end); reading stops once the checked stream passes
    its end.
    """
    runs: list[list[AlignedChunk]] = [[]]
    window: list[int] = []  # [first index, end index (or -1: open)] once the rate is known
    for ev in stream:
        if isinstance(ev, AlignedChunk):
            if not window:
                i0 = ev.first_index + round(start * ev.sample_rate)
                window[:] = [i0, i0 + round(duration * ev.sample_rate) if duration else -1]
            lo, hi = window
            a = max(ev.first_index, lo)
            b = ev.end_index if hi < 0 else min(ev.end_index, hi)
            if b > a:
                k0, k1 = a - ev.first_index, b - ev.first_index
                runs[-1].append(
                    AlignedChunk(
                        a,
                        ev.t0 + k0 / ev.sample_rate,
                        ev.sample_rate,
                        ev.torsion[k0:k1],
                        ev.accel[k0:k1],
                        ev.speed[k0:k1],
                    )
                )
            if hi >= 0 and ev.end_index >= hi:
                break
        elif isinstance(ev, GapEvent | RestartEvent):
            progress(f'{type(ev).__name__}: {ev}')
            if runs[-1]:
                runs.append([])
    best = max(runs, key=lambda r: sum(len(c) for c in r))
    n_runs = sum(1 for r in runs if r)
    if n_runs > 1:
        progress(f'using the longest gap-free stretch ({sum(len(c) for c in best)} samples)')
    return best, n_runs


def _record(
    stream: CheckedInput,
    scales: Scales,
    start: float,
    duration: float,
    keep_truncated: bool,
    progress: Progress,
) -> RigRecord:
    """Read the window of a checked stream into one record (see :func:`read_record`)."""
    from tribo_estimation.core.plausibility import check_channels

    best, n_runs = _collect(stream, start, duration, progress)
    if stream.truncated is not None:
        if not keep_truncated:
            raise stream.truncated
        progress(f'warning: {stream.truncated}; analysing the good part before it')
    n = sum(len(c) for c in best)
    if n < MIN_RECORD_SAMPLES:
        raise TooShortError(
            f'{stream.source}: the window start {start:g} s, duration {duration:g} s holds '
            f'{n} samples (need >= {MIN_RECORD_SAMPLES})'
        )
    first = best[0]
    fs = first.sample_rate
    idx = np.concatenate([np.arange(c.first_index, c.end_index) for c in best])
    tq = np.concatenate([c.torsion for c in best])
    ac = np.concatenate([c.accel for c in best])
    sp = np.concatenate([c.speed for c in best])
    warnings = list(stream.warnings)
    if not scales.from_record:
        for w in check_channels(tq, ac, sp, scales, stream.source, whole_record=True):
            if w not in warnings:
                warnings.append(w)
    findings = InputFindings(
        stream.repairs.mask(int(idx[0]), int(idx[-1]) + 1),
        tuple(warnings),
        stream.max_jitter,
        max(n_runs, 1),
        str(stream.truncated) if stream.truncated is not None else '',
    )
    return RigRecord(
        idx.astype(np.float64) / fs,
        tq,
        ac,
        sp,
        fs,
        findings,
        stream.source,
        first.t0 - first.first_index / fs,
    )


def read_record(
    path: str | Path,
    config: RigConfig | None = None,
    *,
    start: float = 0.0,
    duration: float = 0.0,
    namespace: str | None = None,
    keep_truncated: bool = False,
    progress: Progress | None = None,
) -> RigRecord:
    """Read a rig CSV or bag through the input checks into one record.

    Parameters
    ----------
    path : str or Path
        Rig CSV, bag directory or ``.mcap`` file.
    config : RigConfig or None
        The rig (RIG.yaml) whose physics the channels are checked against; None:
        only the time base and the spikes are checked (the record's own scales).
    start : float
        Window start after the first sample [s].
    duration : float
        Window length [s] (0: to the end).
    namespace : str or None
        Rig namespace in a bag (default: its only rig).
    keep_truncated : bool
        A bag that ends early gives its good part (``findings.truncated`` names the
        damage) instead of raising.
    progress : callable or None
        Receives one line per notable event (gaps, the stretch used).

    Returns
    -------
    RigRecord
        The longest gap-free stretch of the window on the drive's time base,
        spikes and bursts replaced (``findings``).

    Raises
    ------
    InvalidDataError
        Bad input, naming the file, line or channel: a unit or time-base error
        (:class:`~tribo_estimation.errors.UnitError`,
        :class:`~tribo_estimation.errors.TimeBaseError`), a column or value that
        cannot be read, a speed at rest under a driven rig config.
    RecordBagError
        No such file or bag, or a bag without rig streams;
        :class:`~tribo_estimation.errors.RecordTruncatedError` for a bag that ends
        early (unless ``keep_truncated``).
    TooShortError
        The window holds fewer than :data:`MIN_RECORD_SAMPLES` samples.
    """
    say = progress or _quiet
    p = Path(path)
    if not (math.isfinite(start) and start >= 0.0):
        raise TooShortError(f'{p}: window start must be >= 0 s, got {start}')
    if not (math.isfinite(duration) and duration >= 0.0):
        raise TooShortError(f'{p}: window duration must be >= 0 s, got {duration}')
    if config is not None:
        scales = rig_scales(config)
        return _record(
            CheckedInput.open(p, scales, namespace=namespace),
            scales,
            start,
            duration,
            keep_truncated,
            say,
        )
    # the record's own scales need all of it first (a free decay is short)
    raw = CheckedInput.open(p, _data_scales([], str(p)), namespace=namespace)
    events = list(raw.unchecked())
    scales = _data_scales(events, str(p))
    stream = CheckedInput(events, scales, str(p), raw.placer)
    stream.truncated = raw.truncated
    return _record(stream, scales, start, duration, keep_truncated, say)


def record_from_arrays(
    time: FloatArray,
    torsion_moment: FloatArray,
    angular_acceleration: FloatArray,
    speed: FloatArray,
    config: RigConfig | None = None,
    *,
    source: str = '<arrays>',
) -> RigRecord:
    """Put stamped samples through the input checks into one record.

    Parameters
    ----------
    time : numpy.ndarray
        Time stamps [s] (epoch or relative), strictly increasing, on a regular
        grid within a quarter interval (jitter is resampled).
    torsion_moment, angular_acceleration, speed : numpy.ndarray
        The channels [N m], [rad/s^2], [rad/s].
    config : RigConfig or None
        The rig the channels are checked against (None: their own scales).
    source : str
        Name of the samples in messages.

    Returns
    -------
    RigRecord
        As :func:`read_record` (index 0 at the first sample).

    Raises
    ------
    InvalidDataError
        As :func:`read_record`; also columns of different lengths.
    """
    from tribo_estimation.errors import InvalidDataError

    cols = [
        np.asarray(c, dtype=np.float64).reshape(-1)
        for c in (time, torsion_moment, angular_acceleration, speed)
    ]
    if any(c.size != cols[0].size for c in cols):
        raise InvalidDataError(
            f'{source}: columns differ in length ({", ".join(str(c.size) for c in cols)})'
        )
    placer = GridPlacer(source)
    events = list(placer.place(cols[0], (cols[1], cols[2], cols[3])))
    scales = rig_scales(config) if config is not None else _data_scales(events, source)
    return _record(CheckedInput(events, scales, source, placer), scales, 0.0, 0.0, False, _quiet)


def record_events(record: RigRecord) -> Iterator[AlignedChunk]:
    """Yield a record as aligned chunks on its drive time base.

    Parameters
    ----------
    record : RigRecord
        The record.

    Yields
    ------
    AlignedChunk
        Chunks of up to :data:`CHUNK` samples (sample index ``time * fs``, stamp
        ``time_origin + time``).
    """
    fs = record.fs
    first = record.first_index
    for a in range(0, len(record), CHUNK):
        b = min(len(record), a + CHUNK)
        yield AlignedChunk(
            first + a,
            record.time_origin + float(record.time[a]),
            fs,
            record.torsion_moment[a:b],
            record.angular_acceleration[a:b],
            record.speed[a:b],
        )


def record_repairs(record: RigRecord) -> SpikeLog:
    """Return the replaced samples of a record as a log by stream index.

    Parameters
    ----------
    record : RigRecord
        The record.

    Returns
    -------
    SpikeLog
        Its replaced samples (:attr:`RigRecord.replaced`) at ``first_index + i``.
    """
    from tribo_estimation.core.plausibility import SpikeLog

    log = SpikeLog()
    log.add(record.first_index, record.replaced)
    return log
