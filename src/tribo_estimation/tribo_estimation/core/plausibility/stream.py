"""Plausibility of a stream of aligned chunks: checks once, spikes per chunk (no rclpy)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.align import AlignedChunk, AlignEvent
from tribo_estimation.core.plausibility.checks import check_channels, check_time_base
from tribo_estimation.core.plausibility.scales import Scales
from tribo_estimation.core.plausibility.spikes import (
    EDGE_HOLD,
    SpikeLog,
    despike_chunk,
)

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


def checked_chunks(
    events: Iterable[AlignEvent],
    scales: Scales,
    source: str,
    log: SpikeLog,
    warn: list[str],
    check_samples: int = 20_000,
) -> Iterator[AlignEvent]:
    """Pass aligner events through the checks and the repair.

    The first ``check_samples`` samples are checked
    (time base and channels; warnings appended to ``warn``) before anything is
    yielded, spikes of every :class:`~tribo_estimation.core.align.AlignedChunk`
    are repaired (:func:`find_spikes`, judged across chunk boundaries) and logged
    in ``log``.
    """
    held: list[AlignEvent] = []
    n_held = 0
    checked = False
    desp = _Despiker(scales, log)

    def check() -> None:
        chunks = [e for e in held if isinstance(e, AlignedChunk)]
        if not chunks:
            return
        check_time_base(chunks[0].sample_rate, source, scales.f_stick_slip)
        warn.extend(
            check_channels(
                np.concatenate([c.torsion for c in chunks]),
                np.concatenate([c.accel for c in chunks]),
                np.concatenate([c.speed for c in chunks]),
                scales,
                source,
                whole_record=False,
            )
        )

    def stream() -> Iterator[AlignEvent]:
        for ev in events:
            if isinstance(ev, AlignedChunk):
                yield from desp.push(ev)
            else:
                yield from desp.flush()
                yield ev
        yield from desp.flush()

    for ev in stream():
        if isinstance(ev, AlignedChunk):
            n_held += len(ev)
        if checked:
            yield ev
            continue
        held.append(ev)
        if n_held >= check_samples:
            check()
            checked = True
            yield from held
            held.clear()
    if not checked:
        check()
        yield from held
