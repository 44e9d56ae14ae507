"""Streaming block-wise estimation: aligned chunks in, one result per block out.

:class:`BlockEstimator` cuts the aligned stream into fixed blocks of
``block_length`` seconds (paper section 2.5, Fig. 4/5) and runs the streaming
friction observer (Equ. 1 solved for M) on the way (its offline loop over the
checked input is :func:`tribo_estimation.fit_blocks`); :class:`StreamingPipeline`
adds the channel aligner for live input (the estimator node's core, no rclpy). The fit of a block is
:func:`.evaluate.evaluate_block`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..align import AlignedChunk, AlignEvent, GapEvent, RestartEvent
from ..model import DriveProfile, FrictionLaw, RigParams
from ..observer import FrictionObserver
from ..plausibility import CheckedStream, Scales, SpikeLog
from ..signal import CHAMBER_HALF, chamber_speed
from .evaluate import evaluate_block
from .results import BlockConfig, BlockDetail, BlockResult, FloatArray, PendingBlock


class BlockEstimator:
    """Streaming block-wise estimator: aligned chunks in, one result per block out.

    Blocks are fixed index ranges ``[i*N, (i+1)*N)`` (``N = block_length*fs``)
    of the stream, so results do not depend on how the input was chunked.
    Memory is one block of samples, whatever the session length.

    :meth:`push` collects (cheap, for a subscription callback) and returns
    :class:`PendingBlock` objects; :meth:`evaluate` does the fit (heavy, for a
    worker thread). :meth:`feed` does both.
    """

    def __init__(
        self,
        rig: RigParams,
        friction: FrictionLaw,
        cfg: BlockConfig,
        repairs: SpikeLog | None = None,
    ) -> None:
        """Set up the estimator.

        Parameters
        ----------
        rig : RigParams
            Rig parameters (Tab. 1, F_N [N], R [m]).
        friction : FrictionLaw
            Start values of the friction law (k fixed unless fitted).
        cfg : BlockConfig
            Settings of the block fit.
        repairs : SpikeLog or None
            Log of the samples replaced before (spikes, bursts:
            :func:`..plausibility.checked_chunks`), filled before each chunk
            arrives here; the blocks carry the mask, their fits leave those
            samples out and count them (``spikes``, ``bursts``).
        """
        self.rig = rig
        self.friction = friction
        self.cfg = cfg
        self.repairs = repairs
        self.fs: float | None = None
        self._n = 0
        self._cur: PendingBlock | None = None
        self._epoch_first: int | None = None  # first index of the current epoch
        self._epoch_t0 = math.nan
        self._observer: FrictionObserver | None = None
        #: Observer friction moment of the last chunk pushed [N m] (for /friction/moment).
        self.last_moment: FloatArray = np.zeros(0)

    # ---------------------------------------------------------------- collect
    def _new_block(self, bi: int, t_first: float, idx_first: int) -> PendingBlock:
        assert self.fs is not None
        n = self._n
        start_idx = bi * n
        t_start = t_first - (idx_first - start_idx) / self.fs
        flags: set[str] = set()
        if self._epoch_first is not None and (
            start_idx <= self._epoch_first or t_start < self._epoch_t0 + self.cfg.ramp_time - 1e-9
        ):
            flags.add('startup')
        return PendingBlock(
            index=bi,
            first_index=start_idx,
            t_start=t_start,
            fs=self.fs,
            torsion=np.full(n, np.nan),
            accel=np.full(n, np.nan),
            speed=np.full(n, np.nan),
            valid=np.zeros(n, dtype=bool),
            moment=np.full(n, np.nan),
            flags=flags,
            repaired=np.zeros(n, dtype=bool) if self.repairs is not None else None,
        )

    def push(self, event: AlignEvent) -> list[PendingBlock]:
        """Collect one aligner event; return the blocks completed by it."""
        done: list[PendingBlock] = []
        self.last_moment = np.zeros(0)
        if isinstance(event, RestartEvent):
            if self._cur is not None:
                done.append(self._cur)
            self._cur = None
            self._epoch_first = None
            self._observer = None
            return done
        if isinstance(event, GapEvent):
            if self._cur is not None:
                self._cur.flags.add('gap')
            self._observer = None  # the chamber speed is lost with the samples
            return done
        ch = event
        if self.fs is None:
            self.fs = ch.sample_rate
            self._n = max(1, round(self.cfg.block_length * self.fs))
        if self._epoch_first is None:
            self._epoch_first = ch.first_index
            self._epoch_t0 = ch.t0
        if self._observer is None:
            w_start = float(
                chamber_speed(ch.torsion[: 4 * CHAMBER_HALF], ch.sample_rate, self.rig.C1)[0]
            )
            self._observer = FrictionObserver(self.rig, ch.sample_rate, initial_speed=w_start)
        moment = self._observer.update(ch.torsion, ch.accel)
        self.last_moment = moment
        n = self._n
        pos = 0
        m = len(ch)
        while pos < m:
            idx = ch.first_index + pos
            bi = idx // n
            if self._cur is not None and self._cur.index != bi:
                done.append(self._cur)
                self._cur = None
            if self._cur is None:
                self._cur = self._new_block(bi, ch.t0 + pos / ch.sample_rate, idx)
            off = idx - bi * n
            take = min(n - off, m - pos)
            cur = self._cur
            cur.torsion[off : off + take] = ch.torsion[pos : pos + take]
            cur.accel[off : off + take] = ch.accel[pos : pos + take]
            cur.speed[off : off + take] = ch.speed[pos : pos + take]
            assert cur.moment is not None
            cur.moment[off : off + take] = moment[pos : pos + take]
            cur.valid[off : off + take] = True
            if self.repairs is not None and cur.repaired is not None:
                cur.repaired[off : off + take] = self.repairs.mask(idx, idx + take)
            pos += take
            if off + take == n:
                done.append(cur)
                self._cur = None
        if self.repairs is not None:
            self.repairs.forget_before(ch.first_index + m)  # bounded memory
        return done

    def flush(self) -> list[PendingBlock]:
        """End of input: the partial block (if any)."""
        if self._cur is None:
            return []
        blk = self._cur
        self._cur = None
        return [blk]

    # ---------------------------------------------------------------- evaluate
    def evaluate(self, blk: PendingBlock) -> BlockDetail:
        """Fit one collected block (see :func:`evaluate_block`)."""
        return evaluate_block(self.rig, self.friction, self.cfg, blk)

    def feed(self, event: AlignEvent) -> list[BlockDetail]:
        """Collect and evaluate in one go (offline use)."""
        return [self.evaluate(b) for b in self.push(event)]

    def finish(self) -> list[BlockDetail]:
        """Evaluate the partial last block (offline use)."""
        return [self.evaluate(b) for b in self.flush()]


@dataclass(frozen=True)
class MomentChunk:
    """Observer friction moment M [N m] for samples ``first_index ...`` (``/friction/moment``).

    ``t0`` time of the first sample [s], ``sample_rate`` [Hz].
    """

    first_index: int
    t0: float
    sample_rate: float
    moment: FloatArray


class StreamingPipeline:
    """Aligner + estimator for live input (the estimator node's core, no rclpy).

    :meth:`push` takes one SampleBlock of one channel (cheap: alignment and the
    observer) and returns the observer output chunks, the blocks ready to be
    fitted and the notices (gaps, restarts) for logging. The fit of a block
    (:meth:`evaluate`) is meant for a worker thread. Same input in the same
    order gives the same blocks as the offline ``tribo friction``.
    """

    def __init__(
        self,
        rig: RigParams,
        friction: FrictionLaw,
        cfg: BlockConfig,
        scales: Scales | None = None,
        source: str = 'live input',
    ) -> None:
        """Set up the aligner, the plausibility stage and the estimator.

        Parameters
        ----------
        rig : RigParams
            Rig parameters (Tab. 1, F_N [N], R [m]).
        friction : FrictionLaw
            Start values of the friction law.
        cfg : BlockConfig
            Settings of the block fit.
        scales : Scales or None
            Physical scales of the channels: the aligned stream then passes the
            plausibility stage of the offline ``tribo friction``
            (:class:`..plausibility.ChunkChecker`: unit and time-base check of the first
            2 s, spike repair); None: no checks.
        source : str
            Name of the input in the messages of the checks.
        """
        self.input = CheckedStream(scales, source)
        self.estimator = BlockEstimator(rig, friction, cfg, repairs=self.input.repairs)

    def push(
        self, channel: str, first_index: int, sample_rate: float, stamp: float, data: FloatArray
    ) -> tuple[list[MomentChunk], list[PendingBlock], list[str]]:
        """Add one block of one channel; see the class docstring.

        Parameters
        ----------
        channel : str
            Channel name (``torsion``, ``accel``, ``speed``).
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
        tuple
            Observer output chunks, blocks ready to fit, notices (gaps, restarts,
            plausibility warnings).

        Raises
        ------
        InvalidDataError
            The plausibility check of the first samples failed (a unit or time-base
            error); raised again on every later call.
        """
        return self._consume(self.input.push(channel, first_index, sample_rate, stamp, data))

    def _consume(
        self, events: list[AlignEvent]
    ) -> tuple[list[MomentChunk], list[PendingBlock], list[str]]:
        moments: list[MomentChunk] = []
        blocks: list[PendingBlock] = []
        notes: list[str] = []
        notes.extend(f'plausibility: {w}' for w in self.input.take_warnings())
        for ev in events:
            blocks.extend(self.estimator.push(ev))
            if isinstance(ev, AlignedChunk):
                moments.append(
                    MomentChunk(ev.first_index, ev.t0, ev.sample_rate, self.estimator.last_moment)
                )
            elif isinstance(ev, GapEvent):
                notes.append(
                    f'gap: samples {ev.start_index}..{ev.end_index - 1} ({ev.n_missing}) '
                    f'missing in {", ".join(ev.channels)}; not bridged'
                )
            elif isinstance(ev, RestartEvent):
                notes.append(
                    f'restart: {ev.channel} index went back from {ev.old_index} to '
                    f'{ev.new_index}; new stream epoch'
                )
        return moments, blocks, notes

    @property
    def holding(self) -> bool:
        """Whether the plausibility stage holds samples back (see :meth:`release`)."""
        return self.input.holding

    def release(self, idle: float = 0.0) -> tuple[list[MomentChunk], list[PendingBlock], list[str]]:
        """Pass on what the plausibility stage holds, for a stream that went quiet.

        The stage holds the first samples until they are checked and the last few
        samples of every chunk until the next one (spikes at a chunk edge are judged
        with both sides). When no input comes for a while (a paused or finished test),
        the node calls this so the last block completes; a later contiguous chunk is
        then despiked without the released tail as context.

        Parameters
        ----------
        idle : float
            Release only after this long without input [s] (0: now;
            :meth:`..plausibility.CheckedStream.release`).

        Returns
        -------
        tuple
            As :meth:`push`.

        Raises
        ------
        InvalidDataError
            The check of the held samples failed.
        """
        return self._consume(self.input.release(idle))

    def flush(self) -> list[PendingBlock]:
        """End of input: remaining aligned data and the partial block.

        Returns
        -------
        list of PendingBlock
            Blocks ready to fit.
        """
        blocks: list[PendingBlock] = []
        for ev in self.input.flush():
            blocks.extend(self.estimator.push(ev))
        blocks.extend(self.estimator.flush())
        return blocks

    def evaluate(self, blk: PendingBlock) -> BlockResult:
        """Fit one block (heavy; worker thread)."""
        return self.estimator.evaluate(blk).result

    def warm_up(self) -> None:
        """Fit a short simulated stretch once.

        The compiled code is then loaded before the first real block ends (keeps
        the first estimate's latency low).
        """
        from ..simulate import simulate

        est = self.estimator
        w0 = est.cfg.nominal_speed or 1.0
        r = simulate(est.rig, est.friction, DriveProfile(w0), 0.3)
        n = r.time.shape[0]
        blk = PendingBlock(
            -1,
            0,
            0.0,
            r.fs,
            r.torsion_moment,
            r.angular_acceleration,
            r.speed,
            np.ones(n, dtype=bool),
        )
        evaluate_block(est.rig, est.friction, replace(est.cfg, min_fraction=0.01), blk)
