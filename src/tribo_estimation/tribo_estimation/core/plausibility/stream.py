"""Plausibility of a stream of aligned chunks: checks once, spikes per chunk (no rclpy)."""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.align import AlignedChunk, AlignEvent, ChannelAligner
from tribo_estimation.core.plausibility.checks import check_channels, check_time_base
from tribo_estimation.core.plausibility.scales import Scales
from tribo_estimation.core.plausibility.spikes import (
    EDGE_HOLD,
    SpikeLog,
    despike_chunk,
)
from tribo_estimation.errors import InvalidDataError

FloatArray = npt.NDArray[np.float64]


class _Despiker:
    """Repair spikes and bursts across chunk boundaries.

    The last :data:`EDGE_HOLD`
    samples of a chunk wait for the next contiguous chunk, so a step of the signal
    or a burst at a chunk edge is judged with samples on both sides.
    """

    def __init__(self, scales: Scales, log: SpikeLog) -> None:
        self.scales = scales
        self.log = log
        self.hold: AlignedChunk | None = None  # raw tail not yet emitted
        self.ctx: tuple[int, FloatArray, FloatArray, FloatArray] | None = None  # emitted tail

    def _run(self, ch: AlignedChunk, keep: int) -> list[AlignEvent]:
        c = 0
        arrs = [np.asarray(x, dtype=np.float64) for x in (ch.torsion, ch.accel, ch.speed)]
        if self.ctx is not None and self.ctx[0] == ch.first_index:
            c = self.ctx[1].shape[0]
            arrs = [np.concatenate([a, b]) for a, b in zip(self.ctx[1:], arrs, strict=True)]
        t, a, v, mask = despike_chunk(arrs[0], arrs[1], arrs[2], self.scales)
        n = ch.torsion.shape[0]
        m = max(0, n - keep)
        self.hold = (
            replace(
                ch,
                first_index=ch.first_index + m,
                t0=ch.t0 + m / ch.sample_rate,
                torsion=arrs[0][c + m :],
                accel=arrs[1][c + m :],
                speed=arrs[2][c + m :],
            )
            if m < n
            else None
        )
        if m == 0:
            return []
        self.log.add(ch.first_index, mask[c : c + m])
        out = replace(ch, torsion=t[c : c + m], accel=a[c : c + m], speed=v[c : c + m])
        k = max(0, m - EDGE_HOLD)
        self.ctx = (ch.first_index + m, t[c + k : c + m], a[c + k : c + m], v[c + k : c + m])
        return [out]

    def push(self, ch: AlignedChunk) -> list[AlignEvent]:
        out: list[AlignEvent] = []
        held = self.hold
        if held is not None:
            if held.end_index == ch.first_index and held.sample_rate == ch.sample_rate:
                ch = replace(
                    held,
                    torsion=np.concatenate([held.torsion, ch.torsion]),
                    accel=np.concatenate([held.accel, ch.accel]),
                    speed=np.concatenate([held.speed, ch.speed]),
                )
            else:
                out.extend(self.flush())
        self.hold = None
        out.extend(self._run(ch, EDGE_HOLD))
        return out

    def flush(self) -> list[AlignEvent]:
        held, self.hold = self.hold, None
        if held is None:
            return []
        out = self._run(held, 0)
        self.ctx = None
        return out


class ChunkChecker:
    """Push-style plausibility stage for aligner events (offline and live input).

    The first ``check_samples`` samples are held and checked once (time base and
    channels, :func:`check_time_base`, :func:`check_channels`; warnings collect in
    :attr:`warnings`; the channels only against physical scales, not against a
    record's own, :attr:`Scales.from_record`) before anything is passed on; spikes of every
    :class:`~tribo_estimation.core.align.AlignedChunk` are repaired
    (:func:`despike_chunk`, judged across chunk boundaries) and logged in ``log``.
    A failed check raises its :class:`~tribo_estimation.errors.InvalidDataError`
    (:class:`~tribo_estimation.errors.UnitError`,
    :class:`~tribo_estimation.errors.TimeBaseError`) and the same error again on
    every later call: nothing is passed on after it.
    """

    def __init__(self, scales: Scales, source: str, log: SpikeLog, check_samples: int = 20_000):
        """Set up the stage.

        Parameters
        ----------
        scales : Scales
            Physical scales of the channels (from the rig config).
        source : str
            Name of the input in messages (a file, a topic namespace).
        log : SpikeLog
            Log of the repaired samples.
        check_samples : int
            Samples held for the one-time check.
        """
        self.scales = scales
        self.source = source
        self.check_samples = check_samples
        #: Warnings of the check not yet taken (:meth:`take_warnings`).
        self.warnings: list[str] = []
        self._desp = _Despiker(scales, log)
        self._held: list[AlignEvent] = []
        self._n_held = 0
        self._checked = False
        self._failure: InvalidDataError | None = None

    def _check(self) -> None:
        self._checked = True
        chunks = [e for e in self._held if isinstance(e, AlignedChunk)]
        if not chunks:
            return
        try:
            check_time_base(chunks[0].sample_rate, self.source, self.scales.f_stick_slip)
            if not self.scales.from_record:  # a record's own scales are no physical bound
                self.warnings.extend(
                    check_channels(
                        np.concatenate([c.torsion for c in chunks]),
                        np.concatenate([c.accel for c in chunks]),
                        np.concatenate([c.speed for c in chunks]),
                        self.scales,
                        self.source,
                        whole_record=False,
                    )
                )
        except InvalidDataError as exc:
            self._failure = exc
            self._held.clear()
            raise

    @property
    def holding(self) -> bool:
        """Whether samples are held back (unchecked start, or a chunk's tail)."""
        return bool(self._held) or self._desp.hold is not None

    @property
    def failure(self) -> InvalidDataError | None:
        """The error of a failed check (None: passed or not yet checked)."""
        return self._failure

    def _gate(self, events: list[AlignEvent]) -> list[AlignEvent]:
        if self._failure is not None:
            raise self._failure
        out: list[AlignEvent] = []
        for ev in events:
            if self._checked:
                out.append(ev)
                continue
            self._held.append(ev)
            if isinstance(ev, AlignedChunk):
                self._n_held += len(ev)
            if self._n_held >= self.check_samples:
                self._check()
                out.extend(self._held)
                self._held.clear()
        return out

    def push(self, ev: AlignEvent) -> list[AlignEvent]:
        """Take one aligner event; return the events checked and repaired so far.

        Parameters
        ----------
        ev : AlignEvent
            A chunk, gap or restart of the aligner.

        Returns
        -------
        list of AlignEvent
            Events ready for the estimator (in order).
        """
        if isinstance(ev, AlignedChunk):
            return self._gate(self._desp.push(ev))
        return self._gate([*self._desp.flush(), ev])

    def flush(self) -> list[AlignEvent]:
        """End of input: check what is held (if not done yet) and pass on the rest.

        Returns
        -------
        list of AlignEvent
            The remaining events.
        """
        out = self._gate(self._desp.flush())
        if not self._checked:
            self._check()
            out.extend(self._held)
            self._held.clear()
        return out

    def take_warnings(self) -> list[str]:
        """Return the warnings collected so far and forget them.

        Returns
        -------
        list of str
            Warnings of the check (unit, speed-level), each naming the channel.
        """
        out, self.warnings = self.warnings, []
        return out


#: Input pause after which a live node releases the samples the checks hold [s]
#: (:meth:`CheckedStream.release`).
IDLE_RELEASE_S = 0.5


class CheckedStream:
    """Live input of the estimators: channel aligner, then the input checks.

    Per-channel sample blocks in (:class:`~tribo_estimation.core.align.ChannelAligner`),
    aligned events out that passed :class:`ChunkChecker` (unit and time-base check of
    the first ``check_samples``, spike repair logged in :attr:`repairs`); with
    ``scales`` None the aligner's events pass unchecked. One stage for every node
    that reads the rig channels, so they see the same samples as the offline
    commands.
    """

    def __init__(self, scales: Scales | None, source: str, check_samples: int = 20_000):
        """Set up the aligner and, with ``scales``, the checks.

        Parameters
        ----------
        scales : Scales or None
            Physical scales of the channels (None: no checks).
        source : str
            Name of the input in messages.
        check_samples : int
            Samples held for the one-time check.
        """
        self.aligner = ChannelAligner()
        self._last_push = time.monotonic()
        #: Samples replaced by the spike repair (None without checks).
        self.repairs: SpikeLog | None = SpikeLog() if scales is not None else None
        self.checker = (
            ChunkChecker(scales, source, self.repairs, check_samples)
            if scales is not None and self.repairs is not None
            else None
        )

    def _stage(self, events: list[AlignEvent]) -> list[AlignEvent]:
        if self.checker is None:
            return events
        if self.checker.failure is not None:
            raise self.checker.failure
        out: list[AlignEvent] = []
        for ev in events:
            out.extend(self.checker.push(ev))
        return out

    def push(
        self, channel: str, first_index: int, sample_rate: float, stamp: float, data: FloatArray
    ) -> list[AlignEvent]:
        """Add one block of one channel; return the events ready (checked, repaired).

        Parameters
        ----------
        channel : str
            Channel name (:data:`~tribo_estimation.core.align.CHANNELS`).
        first_index : int
            Sample counter of the first sample.
        sample_rate : float
            Sample rate [Hz].
        stamp : float
            Time of the first sample [s].
        data : FloatArray
            Samples [SI unit of the channel].

        Returns
        -------
        list of AlignEvent
            Events in order.

        Raises
        ------
        InvalidDataError
            The check of the first samples failed (a unit or time-base error), raised
            again on every later call; or the aligner refused the block.
        """
        self._last_push = time.monotonic()
        return self._stage(self.aligner.push(channel, first_index, sample_rate, stamp, data))

    @property
    def holding(self) -> bool:
        """Whether the checks hold samples back (see :meth:`release`)."""
        return self.checker is not None and self.checker.holding

    def release(self, idle: float = 0.0) -> list[AlignEvent]:
        """Pass on what the checks hold, for a stream that went quiet.

        The checks hold the first samples until they are checked and the last few
        samples of every chunk until the next one (a spike at a chunk edge is judged
        with both sides); a node calls this from a timer with ``idle`` =
        :data:`IDLE_RELEASE_S` so its last block or window completes after an input
        pause.

        Parameters
        ----------
        idle : float
            Release only if nothing was pushed for this long [s] (0: now).

        Returns
        -------
        list of AlignEvent
            The held events (none while input still arrives).
        """
        if self.checker is None or not self.checker.holding:
            return []
        if idle > 0.0 and time.monotonic() - self._last_push < idle:
            return []
        return self.checker.flush()

    def flush(self) -> list[AlignEvent]:
        """End of input: everything the aligner and the checks hold.

        Returns
        -------
        list of AlignEvent
            The remaining events.
        """
        events = self._stage(self.aligner.flush())
        return events + self.release()

    def take_warnings(self) -> list[str]:
        """Return the checks' warnings collected so far and forget them.

        Returns
        -------
        list of str
            Warnings (each names the channel).
        """
        return self.checker.take_warnings() if self.checker is not None else []


def checked_chunks(
    events: Iterable[AlignEvent],
    scales: Scales,
    source: str,
    log: SpikeLog,
    warn: list[str],
    check_samples: int = 20_000,
) -> Iterator[AlignEvent]:
    """Pass aligner events through the checks and the repair (:class:`ChunkChecker`).

    Parameters
    ----------
    events : iterable of AlignEvent
        Aligner events (offline input).
    scales : Scales
        Physical scales of the channels.
    source : str
        Name of the input in messages.
    log : SpikeLog
        Log of the repaired samples.
    warn : list of str
        Warnings of the check are appended here (before the first event is yielded).
    check_samples : int
        Samples held for the one-time check.

    Yields
    ------
    AlignEvent
        Checked and repaired events.
    """
    checker = ChunkChecker(scales, source, log, check_samples)
    for ev in events:
        out = checker.push(ev)
        warn.extend(checker.take_warnings())
        yield from out
    out = checker.flush()
    warn.extend(checker.take_warnings())
    yield from out
