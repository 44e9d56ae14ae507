"""Bag scan of the session report.

Message counts, live results, stream continuity, and full-rate rig windows for
the motion detail (paper Fig. 6).

Times in ns where they are bag receive times, else s; values SI.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from tribo_bringup import bagio
from tribo_bringup import bridge_core as bc
from tribo_bringup.errors import BagError
from tribo_common import topics as topic_table
from tribo_estimation.errors import EstimationError

if TYPE_CHECKING:
    from tribo_estimation.core.model import RigParams

FloatArray = npt.NDArray[np.float64]

#: Topics whose messages the report keeps in full (low rate).
FRICTION_TOPIC = topic_table.FRICTION_ESTIMATE.resolve()
WEAR_TOPIC = topic_table.NVCT_WEAR.resolve()
MONITOR_TOPIC = topic_table.MODEL_DISCREPANCY.resolve()


@dataclass
class BagScan:
    """What the report needs from a bag (all times in ns, values SI).

    Attributes
    ----------
    counts
        messages per topic.
    t_first_ns, t_last_ns
        receive time of the first and last message [ns].
    estimates
        one dict per /friction/estimate message (bridge_core field names).
    wear
        one dict per /nvct/wear message.
    monitor
        one dict per /model/discrepancy window (live model monitor; bridge_core
        field names plus ``params``, the candidate's fitted values as text).
    streams
        sample continuity per SampleBlock topic.
    truncated
        the warning of a bag that ends early ('' if none).
    """

    counts: dict[str, int] = field(default_factory=dict)
    t_first_ns: int = 0
    t_last_ns: int = 0
    estimates: list[dict[str, Any]] = field(default_factory=list)
    wear: list[dict[str, Any]] = field(default_factory=list)
    monitor: list[dict[str, Any]] = field(default_factory=list)
    streams: list[bagio.StreamCheck] = field(default_factory=list)
    truncated: str = ''


def scan_bag(path: str | Path) -> BagScan:
    """Read counts, estimates, wear states and stream continuity from a bag.

    Raises
    ------
    BagError
        the bag holds no message of a known type.
    """
    scan = BagScan()
    small = {FRICTION_TOPIC, WEAR_TOPIC, MONITOR_TOPIC}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        for m in bagio.iter_messages(path, on_error='warn', deserialize=False):
            scan.counts[m.topic] = scan.counts.get(m.topic, 0) + 1
            if scan.t_first_ns == 0:
                scan.t_first_ns = m.timestamp_ns
            scan.t_last_ns = max(scan.t_last_ns, m.timestamp_ns)
        for m in bagio.iter_messages(path, small, on_error='warn'):
            if m.topic == FRICTION_TOPIC:
                scan.estimates.append(bc.record_message(m.msg, bc.FRICTION_FIELDS, {}))
            elif m.topic == MONITOR_TOPIC:
                d = bc.record_message(m.msg, bc.DISCREPANCY_FIELDS, {})
                d['params'] = ', '.join(
                    f'{n} = {float(v):.4g} {u}'.rstrip()
                    for n, v, u in zip(
                        m.msg.param_names, m.msg.param_values, m.msg.param_units, strict=False
                    )
                )
                scan.monitor.append(d)
            else:
                scan.wear.append(bc.record_message(m.msg, bc.WEAR_FIELDS, {}))
        sample_topics = [t for t in bc.SAMPLE_TOPICS if scan.counts.get(t)]
        if sample_topics:
            scan.streams = bagio.check_streams(path, sample_topics)
    trunc = [str(w.message) for w in caught if 'truncated' in str(w.message)]
    scan.truncated = trunc[0] if trunc else ''
    if not scan.counts:
        raise BagError(f'{path}: the bag holds no message of a known type')
    return scan


@dataclass(frozen=True)
class RigWindow:
    """Aligned full-rate rig samples of a window (NaN where a channel lost samples).

    Attributes
    ----------
    sample_rate
        sample rate [Hz].
    torsion
        torsion moment C1*phi1 [N m].
    accel
        chamber angular acceleration w1' [rad/s^2].
    speed
        shaft speed w2 [rad/s].
    """

    sample_rate: float
    torsion: FloatArray
    accel: FloatArray
    speed: FloatArray


def read_rig_window(path: str | Path, first_index: int, seconds: float) -> RigWindow | None:
    """Read ``seconds`` [s] of the /rig/* streams from sample ``first_index``.

    The channels are aligned by sample index as the friction analysis aligns them;
    None when the bag has no samples there.

    Raises
    ------
    BagError
        no rig stream in the bag, or the bag is truncated before the window.
    """
    from tribo_estimation.core.align import AlignedChunk, RestartEvent
    from tribo_estimation.core.inputs import bag_events

    chunks: list[AlignedChunk] = []
    end: int | None = None
    for ev in bag_events(Path(path)):  # the generator (and the bag) closes on return
        if isinstance(ev, RestartEvent) and chunks:
            break  # a new stream epoch reuses the indices
        if not isinstance(ev, AlignedChunk):
            continue
        if end is None:
            end = first_index + max(1, round(seconds * ev.sample_rate))
        if ev.first_index >= end:
            break
        if ev.end_index > first_index:
            chunks.append(ev)
    if not chunks or end is None:
        return None
    rows = np.full((3, end - first_index), np.nan)
    for c in chunks:
        a, b = max(c.first_index, first_index), min(c.end_index, end)
        for row, data in zip(rows, (c.torsion, c.accel, c.speed), strict=True):
            row[a - first_index : b - first_index] = data[a - c.first_index : b - c.first_index]
    return RigWindow(chunks[0].sample_rate, rows[0], rows[1], rows[2])


def stick_flags(win: RigWindow, rig: RigParams) -> npt.NDArray[np.bool_]:
    """Flag the stick samples of a window with the friction analysis' own stick detection.

    :func:`tribo_estimation.core.sticks.detect_sticks` (slip speed w2 - w1 [rad/s]
    and the stick residual of Equ. 1 + 2, phases >= 2 ms), run on each gap-free
    stretch.
    """
    from tribo_estimation.core.sticks import detect_sticks

    fs = win.sample_rate
    stick = np.zeros(win.torsion.size, dtype=bool)
    ok = np.isfinite(win.torsion) & np.isfinite(win.accel) & np.isfinite(win.speed)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    for a, b in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        t = np.arange(a, b) / fs
        try:
            phases = detect_sticks(t, win.torsion[a:b], win.accel[a:b], win.speed[a:b], rig)
        except EstimationError:  # stretch too short for the detection
            continue
        for ph in phases:  # sample i sticks for start <= t_i < end, as in the block fit
            i0 = max(a, math.ceil(ph.start * fs - 1e-9))
            i1 = min(b, math.ceil(ph.end * fs - 1e-9))
            stick[i0:i1] = True
    return stick
