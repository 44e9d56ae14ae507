"""Reading a recorded session for the analyses: rig streams and detector counts of a bag.

The one place where the analyses (``tribo friction``, ``tribo discrepancy``,
``tribo wear`` and the session report) turn bag messages into the inputs of
the library functions:

- :func:`rig_bag_events`: aligner events (aligned chunks, gaps, restarts) of the
  ``/rig/*`` SampleBlock streams, for the streaming block fit;
- :func:`read_rig_stretch`: the longest gap-free stretch of aligned rig samples
  inside a time window, as arrays, for the discrepancy workflow;
- :func:`bag_dwells`: the nVCT dwells of ``/nvct/counts``.

Units: time s, torsion moment N m, angular acceleration rad/s^2, shaft speed
rad/s; dwell times s, counts.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from tribo_bringup.errors import BagError, BagTruncatedError
from tribo_common import topics as topic_table

if TYPE_CHECKING:
    from tribo_common.msgconv import StampedMessage
    from tribo_estimation.core.align import AlignEvent
    from tribo_nvct.core.counting import Dwell

FloatArray = npt.NDArray[np.float64]
Progress = Callable[[str], None]

#: Topics of the rig streams (root-namespace names) and their aligner channel names,
#: from the topic table.
RIG_CHANNELS: dict[str, str] = {t.resolve(): t.channel for t in topic_table.RIG_STREAMS}

#: Topic of the detector's dwells.
COUNTS_TOPIC = topic_table.NVCT_COUNTS.resolve()


def _stamp_s(msg: StampedMessage) -> float:
    """Return the header stamp [s] of a message."""
    return float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)


def _quiet(_: str) -> None:
    """Progress sink that drops the lines."""


def rig_bag_events(path: Path, namespace: str | None = None) -> Iterator[AlignEvent]:
    """Aligner events from the ``rig/*`` SampleBlock streams of a bag.

    ``namespace`` names the rig to read (e.g. ``/rigB``); ``None``: the root
    namespace if it holds the streams, else the only rig of the bag
    (:func:`tribo_bringup.bagio.find_namespace`).

    Raises
    ------
    BagError
        the bag holds none of the three rig streams (raised once the
        bag has been read).
    """
    from tribo_bringup.bagio import iter_messages
    from tribo_estimation.core.align import ChannelAligner

    aligner = ChannelAligner()
    seen = 0
    for m in iter_messages(path, topics=list(RIG_CHANNELS), namespace=namespace):
        ch = RIG_CHANNELS.get(m.topic)
        if ch is None:
            continue
        msg = m.msg
        seen += 1
        yield from aligner.push(
            ch, int(msg.first_index), float(msg.sample_rate), _stamp_s(msg), np.asarray(msg.data)
        )
    if seen == 0:
        raise BagError(f'{path}: no {", ".join(RIG_CHANNELS)}')
    yield from aligner.flush()


def read_rig_stretch(
    path: Path, start: float, duration: float, progress: Progress = _quiet
) -> tuple[tuple[FloatArray, FloatArray, FloatArray, FloatArray], BagTruncatedError | None]:
    """Aligned rig channels of a bag inside a window, longest gap-free stretch.

    The window starts ``start`` [s] after the stream's first sample and lasts
    ``duration`` [s] (0: to the end). Reading stops at the window's end, so
    memory stays bounded by the window. Returns ``((time, torsion, accel,
    speed), truncated)``: time [s] counted from the stream's first sample index
    (the simulated rig's drive time base), and the truncation error of a bag
    that ends early (the good part before it is returned).

    Raises
    ------
    BagError
        no aligned rig samples in the window (or the truncation error
        when the bag breaks before any).
    """
    from tribo_bringup.bagio import iter_messages
    from tribo_estimation.core.align import AlignedChunk, ChannelAligner, GapEvent, RestartEvent

    aligner = ChannelAligner()
    runs: list[list[AlignedChunk]] = [[]]
    window: list[int] = []  # [first index, end index (or -1: open)] once the rate is known

    def take(events: list[AlignEvent]) -> bool:
        """Keep the window's part of the events; True once past the window's end."""
        for ev in events:
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
                    return True
            elif isinstance(ev, (GapEvent, RestartEvent)):
                progress(f'{type(ev).__name__}: {ev}')
                runs.append([])
        return False

    truncated: BagTruncatedError | None = None
    try:
        for n_msgs, m in enumerate(iter_messages(path, topics=list(RIG_CHANNELS)), start=1):
            msg = m.msg
            ch = RIG_CHANNELS[m.topic]
            events = aligner.push(
                ch, int(msg.first_index), float(msg.sample_rate), _stamp_s(msg), msg.data
            )
            if take(list(events)):
                break
            if n_msgs % 5000 == 0:
                progress(f'read {n_msgs} messages')
        else:
            take(list(aligner.flush()))
    except BagTruncatedError as exc:
        truncated = exc
        progress(f'warning: {exc}; analysing the good part before it')
    best = max(runs, key=lambda r: sum(len(c) for c in r))
    if not best:
        raise truncated or BagError(f'{path}: no aligned rig samples on {", ".join(RIG_CHANNELS)}')
    if len(runs) > 1:
        progress(f'using the longest gap-free stretch ({sum(len(c) for c in best)} samples)')
    fs = best[0].sample_rate
    idx = np.concatenate([np.arange(c.first_index, c.end_index) for c in best])
    arrays = (
        idx.astype(np.float64) / fs,
        np.concatenate([c.torsion for c in best]).astype(np.float64),
        np.concatenate([c.accel for c in best]).astype(np.float64),
        np.concatenate([c.speed for c in best]).astype(np.float64),
    )
    return arrays, truncated


def bag_dwells(
    path: Path, progress: Progress = _quiet
) -> tuple[list[Dwell], BagTruncatedError | None]:
    """Read the nVCT dwells of ``/nvct/counts`` in a bag, and the truncation error.

    A bag that ends early gives the error; the dwells before it are returned.

    Raises
    ------
    CountsError
        a message holds an invalid dwell (names the message).
    NvctConfigError
        no ``/nvct/counts`` message in the bag.
    """
    from tribo_bringup.bagio import iter_messages
    from tribo_nvct.core.counting import Dwell
    from tribo_nvct.errors import CountsError, NvctConfigError

    out: list[Dwell] = []
    truncated: BagTruncatedError | None = None
    try:
        for m in iter_messages(path, [COUNTS_TOPIC]):
            msg = m.msg
            try:
                out.append(
                    Dwell(
                        float(msg.t_start), float(msg.t_end), int(msg.counts), float(msg.live_time)
                    )
                )
            except CountsError as exc:
                raise type(exc)(f'{path}: message #{m.index}: {exc}') from None
    except BagTruncatedError as exc:
        truncated = exc
        progress(f'warning: {exc}; using the {len(out)} dwells before it')
    if not out:
        raise truncated or NvctConfigError(f'{path}: no {COUNTS_TOPIC} messages')
    return out, truncated
