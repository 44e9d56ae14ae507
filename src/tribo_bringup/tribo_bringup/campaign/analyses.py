"""The one adapter between the campaign and the analysis library: one task in, table rows out.

A :class:`Task` is one unit of work on a worker: the block fit of one time chunk
of a session (paper 2.5, Equ. 8), the missing-physics workflow on a window of
it, or the nVCT wear evaluation of its counts (paper 3, Equ. 8-10). Each calls
the library functions the single-session commands call (``tribo friction``: the
checked aligner events through :class:`~tribo_estimation.core.blockfit.BlockEstimator`;
``tribo discrepancy``: its record reader and
:func:`~tribo_estimation.core.discrepancy.run_discrepancy`; ``tribo wear``:
:class:`~tribo_nvct.core.streaming.WearEvaluator`), so a campaign's numbers equal
the commands'. Nothing here runs a command line or imports rclpy.

Chunks: a session whose length is known (a rosbag2 directory's metadata) is cut
into ``chunk_s`` pieces on block boundaries. A chunk after the first reads a
warm-up of ``ramp_time + 2 block_s`` before its first block (the friction
observer's 10 Hz complementary filter forgets its start within it, and the
estimator's start-up flag stays with the session's own start), and keeps only
the blocks that start inside it; the blocks of all chunks are the blocks of one
pass over the session.

Input errors (the packages' specific exceptions: a unit mistake, a truncated
bag, a missing topic) are returned as the task's one-line ``error``; anything
else is raised (a bug, or a worker that died: the runner retries and records it).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .spec import Settings

if TYPE_CHECKING:
    from tribo_estimation.core.align import AlignEvent
    from tribo_estimation.core.blockfit import BlockResult

#: Scalar value of a table cell.
Cell = str | int | float | bool | None
#: One table row.
Row = dict[str, Cell]

#: Bag time slack around a chunk's window [s]: bag stamps are receive times,
#: a little after the samples' own stamps.
WINDOW_SLACK_S = 2.0


@dataclass(frozen=True)
class Task:
    """One unit of work of a session.

    Attributes
    ----------
    key
        The session's store key.
    analysis
        ``friction``, ``discrepancy`` or ``wear``.
    chunk
        Chunk number of a friction task (0 otherwise).
    n_chunks
        Chunks of the session's friction fit.
    path
        The session's bag or CSV.
    kind
        ``bag``, ``rig_csv`` or ``counts_csv``.
    config
        RIG.yaml (rig analyses) or NVCT.yaml (wear).
    namespace
        Rig namespace in a bag ('': its only rig).
    settings
        The campaign's analysis settings.
    """

    key: str
    analysis: str
    chunk: int
    n_chunks: int
    path: str
    kind: str
    config: str
    namespace: str
    settings: Settings


@dataclass(frozen=True)
class TaskResult:
    """What a task produced.

    Attributes
    ----------
    task
        The task.
    rows
        Table name -> rows (``blocks``, ``discrepancy``, ``wear``).
    error
        One-line error ('' when the analysis ran).
    seconds
        Wall time of the analysis on the worker [s].
    internal
        The error is not the input's (a bug, or the task's workers kept dying):
        the next run tries the session again.
    """

    task: Task
    rows: dict[str, list[Row]] = field(default_factory=dict)
    error: str = ''
    seconds: float = 0.0
    internal: bool = False


def session_duration(path: Path, kind: str) -> float:
    """Return a session's length from its bag metadata [s] (NaN when unknown without reading).

    Parameters
    ----------
    path : Path
        The session file.
    kind : str
        Its kind (:func:`.spec.session_kind`).

    Returns
    -------
    float
        Duration [s] of a rosbag2 directory (from ``metadata.yaml``), else NaN.
    """
    if kind != 'bag' or not (path.is_dir() and (path / 'metadata.yaml').is_file()):
        return math.nan
    from tribo_bringup.errors import BagError
    from tribo_common.yamlio import load_yaml

    try:
        meta = load_yaml(path / 'metadata.yaml', BagError, 'bag metadata')
        info = meta['rosbag2_bagfile_information']
        return float(info['duration']['nanoseconds']) * 1e-9
    except (BagError, KeyError, TypeError, ValueError):
        return math.nan


def n_chunks(duration: float, settings: Settings) -> int:
    """Return the number of time chunks of a session's friction fit.

    Parameters
    ----------
    duration : float
        Session length [s] (NaN: unknown, one chunk).
    settings : Settings
        ``chunk_s`` [s].

    Returns
    -------
    int
        At least 1.
    """
    if not math.isfinite(duration) or duration <= settings.chunk_s:
        return 1
    return max(1, math.ceil(duration / settings.chunk_s))


def run_task(task: Task) -> TaskResult:
    """Run one task (on a worker).

    Parameters
    ----------
    task : Task
        What to do.

    Returns
    -------
    TaskResult
        Rows, or the input error's one line.
    """
    from tribo_bringup.cli import _error_types

    t0 = time.perf_counter()
    try:
        if task.analysis == 'friction':
            rows = {'blocks': _friction(task)}
        elif task.analysis == 'discrepancy':
            rows = {'discrepancy': [_discrepancy(task)]}
        else:
            rows = {'wear': [_wear(task)]}
    except _error_types() as exc:
        return TaskResult(task, error=one_line(exc), seconds=time.perf_counter() - t0)
    return TaskResult(task, rows, seconds=time.perf_counter() - t0)


def one_line(exc: BaseException) -> str:
    """Return the first non-empty line of an error (its class name if empty).

    Parameters
    ----------
    exc : BaseException
        The error.

    Returns
    -------
    str
        One line.
    """
    for line in str(exc).splitlines():
        if line.strip():
            return line.strip()
    return type(exc).__name__


# --- friction ----------------------------------------------------------------------


def block_row(r: BlockResult) -> Row:
    """Return a block result as a table row (every field; quality as ``ok`` or its flags).

    Parameters
    ----------
    r : BlockResult
        One block (units: s, -, N m, rad/s).

    Returns
    -------
    Row
        Column -> value.
    """
    row: Row = {}
    for f in fields(r):
        v = getattr(r, f.name)
        row[f.name] = r.quality_str if f.name == 'quality' else v
    return row


def _rig_events(task: Task, warm_s: float) -> Iterator[AlignEvent]:
    """Aligner events of the task's rig input, from ``warm_s`` before its chunk."""
    from tribo_bringup.commands.friction import csv_events
    from tribo_bringup.sessions import rig_bag_events

    path = Path(task.path)
    if task.kind == 'rig_csv':
        return csv_events(path)
    ns = task.namespace or None
    if task.n_chunks == 1 or task.chunk == 0:
        return rig_bag_events(path, ns)
    start = task.chunk * task.settings.chunk_s - warm_s
    stop = (task.chunk + 1) * task.settings.chunk_s + task.settings.block_s
    return _bag_window_events(path, ns, start - WINDOW_SLACK_S, stop + WINDOW_SLACK_S)


def _bag_window_events(
    path: Path, namespace: str | None, start_s: float, stop_s: float
) -> Iterator[AlignEvent]:
    """Aligner events of the rig streams whose bag stamps lie in a window.

    The window is counted from the bag's first rig message [s]; messages outside
    it are skipped before they are decoded.
    """
    from tribo_bringup import bagio
    from tribo_bringup.errors import BagError
    from tribo_bringup.sessions import RIG_CHANNELS
    from tribo_estimation.core.align import ChannelAligner

    store = bagio.typestore()
    aligner = ChannelAligner()
    t_first: int | None = None
    seen = 0
    raw_msgs = bagio.iter_messages(
        path, topics=list(RIG_CHANNELS), namespace=namespace, deserialize=False
    )
    for m in raw_msgs:
        if t_first is None:
            t_first = m.timestamp_ns
        rel = (m.timestamp_ns - t_first) * 1e-9
        if rel < start_s:
            continue
        if rel >= stop_s:
            break
        ch = RIG_CHANNELS.get(m.topic)
        if ch is None:
            continue
        assert isinstance(m.msg, bytes | bytearray | memoryview)
        msg = store.deserialize_cdr(bytes(m.msg), m.msgtype)
        seen += 1
        stamp = float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)
        yield from aligner.push(
            ch, int(msg.first_index), float(msg.sample_rate), stamp, np.asarray(msg.data)
        )
    if seen == 0:
        raise BagError(f'{path}: no rig stream messages between {start_s:g} and {stop_s:g} s')
    yield from aligner.flush()


def _first_index(task: Task) -> tuple[int, float]:
    """Return the first sample index and the rate [Hz] of a bag's rig streams."""
    from tribo_bringup import bagio
    from tribo_bringup.errors import BagError
    from tribo_bringup.sessions import RIG_CHANNELS

    for m in bagio.iter_messages(
        Path(task.path), topics=list(RIG_CHANNELS), namespace=task.namespace or None
    ):
        return int(m.msg.first_index), float(m.msg.sample_rate)
    raise BagError(f'{task.path}: no rig stream messages')


def _friction(task: Task) -> list[Row]:
    """Block fit of one chunk (as ``tribo friction`` with the campaign's block length)."""
    from tribo_bringup.errors import BagError
    from tribo_estimation.core.blockfit import BlockConfig, BlockEstimator
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.plausibility import Scales, SpikeLog, checked_chunks

    st = task.settings
    cfg_rig = load_rig_config(task.config)
    nominal = cfg_rig.drive.nominal_speed
    cfg = BlockConfig(
        block_length=st.block_s,
        nominal_speed=None if nominal <= 0.0 else nominal,
        ramp_time=cfg_rig.drive.ramp_time,
    )
    lo, hi = -math.inf, math.inf
    warm_s = cfg_rig.drive.ramp_time + 2.0 * st.block_s
    if task.n_chunks > 1:
        i0, fs = _first_index(task)
        if task.chunk > 0:
            lo = i0 + round(task.chunk * st.chunk_s * fs)
        if task.chunk < task.n_chunks - 1:
            hi = i0 + round((task.chunk + 1) * st.chunk_s * fs)
    spikes = SpikeLog()
    est = BlockEstimator(cfg_rig.rig, cfg_rig.friction, cfg, repairs=spikes)
    scales = Scales.of(cfg_rig.rig, cfg_rig.friction, nominal)
    warnings: list[str] = []
    events = checked_chunks(_rig_events(task, warm_s), scales, task.path, spikes, warnings)
    rows: list[Row] = []

    def keep(blk_first: int) -> bool:
        return lo <= blk_first < hi

    past = False
    for ev in events:
        for blk in est.push(ev):
            if blk.first_index >= hi:
                past = True
            elif keep(blk.first_index):
                rows.append(block_row(est.evaluate(blk).result))
        if past:
            break
    if not past:
        for blk in est.flush():
            if keep(blk.first_index):
                rows.append(block_row(est.evaluate(blk).result))
    if not rows and task.chunk == 0:
        raise BagError(f'{task.path}: no complete block of data')
    return rows


# --- discrepancy -------------------------------------------------------------------


def _discrepancy(task: Task) -> Row:
    """Missing-physics workflow on the window of the settings (as ``tribo discrepancy``)."""
    import json
    from types import SimpleNamespace

    from tribo_bringup.commands.discrepancy import _load_record
    from tribo_bringup.report.analyses import discrepancy_finding
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.discrepancy import run_discrepancy
    from tribo_estimation.core.discrepancy.report import to_dict

    st = task.settings
    cfg = load_rig_config(task.config)
    window = SimpleNamespace(start=st.discrepancy_start_s, duration=st.discrepancy_duration_s)
    record, truncated, _ = _load_record(Path(task.path), window, cfg)  # type: ignore[arg-type]
    if truncated is not None:
        raise truncated
    result = run_discrepancy(record, cfg.rig, cfg.drive, k=cfg.friction.k)
    data = to_dict(result)
    base = result.baseline.params
    return {
        'window_start_s': float(record.time[0]),
        'window_s': float(record.time[-1] - record.time[0]),
        'added': ', '.join(a.effect for a in result.added),
        'n_added': len(result.added),
        'n_unexplained': len(result.unexplained),
        'not_identifiable': ', '.join(result.blocked),
        'rms_baseline': float(result.baseline.rms),
        'rms_final': float(result.final.rms),
        'noise_floor': float(result.noise_floor),
        'mu0': float(base.get('mu0', math.nan)),
        'mu_inf': float(base.get('mu_inf', math.nan)),
        'verdict': discrepancy_finding(data),
        'result_json': json.dumps(data, allow_nan=False),
    }


# --- wear --------------------------------------------------------------------------


def _wear(task: Task) -> Row:
    """NVCT wear evaluation of the session's counts (as ``tribo wear``)."""
    from tribo_bringup.sessions import bag_dwells
    from tribo_nvct.core.config import load_config
    from tribo_nvct.core.countsio import read_counts_csv
    from tribo_nvct.core.streaming import WearEvaluator

    cfg = load_config(task.config)
    path = Path(task.path)
    if task.kind == 'counts_csv':
        dwells = list(read_counts_csv(path))
    else:
        dwells, truncated = bag_dwells(path)
        if truncated is not None:
            raise truncated
    ev = WearEvaluator(cfg)
    for d in dwells:
        ev.add(d)
    evaluation = ev.evaluation()
    dwell_s = float(sorted(d.real_time for d in dwells)[len(dwells) // 2])
    summary = evaluation.summary(cfg, dwell_s)
    row: Row = {
        'dwells': len(ev.points),
        'load_N': float(cfg.load),
        'stroke_m': float(cfg.stroke),
        'frequency_hz': float(cfg.frequency),
        'temperature_K': float(cfg.temperature_K),
    }
    for k in WEAR_COLUMNS:
        v = summary.get(k)
        row[k] = float(v) if isinstance(v, int | float) else math.nan
    row['sliding_distance_convention'] = str(summary.get('sliding_distance_convention', ''))
    return row


#: Wear summary numbers kept per session (units in the names; k_w in um^3/(N m)).
WEAR_COLUMNS: tuple[str, ...] = (
    'total_volume_um3',
    'total_volume_se_um3',
    'total_volume_combined_se_um3',
    'progressive_rate_um3_per_min',
    'progressive_rate_se_um3_per_min',
    'running_in_volume_um3',
    'running_in_volume_se_um3',
    'k_w_progressive',
    'k_w_progressive_se',
    'k_w_progressive_combined_se',
    'k_w_running_in',
    'k_w_running_in_se',
    'k_w_running_in_combined_se',
)
