"""The one adapter between the campaign and the analysis library: one task in, table rows out.

A :class:`Task` is one unit of work on a worker: the block fit of one time chunk
of a session (paper 2.5, Equ. 8), the missing-physics workflow on a window of
it, or the nVCT wear evaluation of its counts (paper 3, Equ. 8-10). Each calls
the library API the single-session commands are shells over (``tribo friction``:
:func:`tribo_estimation.fit_blocks`, or for a time chunk its input stage
:class:`~tribo_estimation.core.inputs.CheckedInput` and
:class:`~tribo_estimation.core.blockfit.BlockEstimator`; ``tribo discrepancy``:
:func:`tribo_estimation.read_record` and :func:`tribo_estimation.find_missing_physics`;
``tribo wear``: :func:`tribo_nvct.evaluate_wear`), so a
campaign's numbers equal the commands'. Nothing here runs a command line or
imports rclpy.

Chunks: a session whose length is known (a rosbag2 directory's metadata) is cut
into ``chunk_s`` pieces on block boundaries. A chunk after the first reads a
warm-up of ``ramp_time + 2 block_s`` before its first block (the friction
observer's 10 Hz complementary filter forgets its start within it, and the
estimator's start-up flag stays with the session's own start), and keeps only
the blocks that start inside it; the blocks of all chunks are the blocks of one
pass over the session. A chunk seeks to its window through the bag's index.

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
from typing import TYPE_CHECKING, cast

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
    cpu_seconds
        CPU time of the worker process during the analysis [s] (below ``seconds``
        when other processes take the cores).
    internal
        The error is not the input's (a bug, or the task's workers kept dying):
        the next run tries the session again.
    """

    task: Task
    rows: dict[str, list[Row]] = field(default_factory=dict)
    error: str = ''
    seconds: float = 0.0
    cpu_seconds: float = 0.0
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
        meta = cast(
            'dict[str, dict[str, dict[str, int]]]',
            load_yaml(path / 'metadata.yaml', BagError, 'bag metadata'),
        )
        return float(meta['rosbag2_bagfile_information']['duration']['nanoseconds']) * 1e-9
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

    t0, c0 = time.perf_counter(), time.process_time()
    rows: dict[str, list[Row]] = {}
    error = ''
    try:
        if task.analysis == 'friction':
            rows = {'blocks': _friction(task)}
        elif task.analysis == 'discrepancy':
            rows = {'discrepancy': [_discrepancy(task)]}
        else:
            rows = {'wear': [_wear(task)]}
    except _error_types() as exc:
        error = one_line(exc)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return TaskResult(task, rows, error, seconds=wall, cpu_seconds=cpu)


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


def _window_events(
    path: Path, namespace: str | None, start_ns: int, stop_ns: int
) -> Iterator[AlignEvent]:
    """Aligner events of a bag's rig streams whose bag stamps lie in ``[start_ns, stop_ns)``."""
    from tribo_common import topics as topic_table
    from tribo_common.bag_read import iter_messages
    from tribo_estimation.core.align import ChannelAligner
    from tribo_estimation.errors import RecordBagError

    channels = {t.resolve(): t.channel for t in topic_table.RIG_STREAMS}
    aligner = ChannelAligner()
    seen = 0
    for m in iter_messages(
        path, topics=list(channels), namespace=namespace, start_ns=start_ns, stop_ns=stop_ns
    ):
        msg = m.msg
        seen += 1
        stamp = float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)
        yield from aligner.push(
            channels[m.topic], int(msg.first_index), float(msg.sample_rate), stamp,
            np.asarray(msg.data),
        )  # fmt: skip
    if seen == 0:
        raise RecordBagError(f'{path}: no rig stream messages in chunk window')
    yield from aligner.flush()


def _first_message(path: Path, namespace: str | None) -> tuple[int, float, int]:
    """Return a bag's first rig message: sample index, rate [Hz] and bag stamp [ns]."""
    from tribo_common import topics as topic_table
    from tribo_common.bag_read import iter_messages
    from tribo_estimation.errors import RecordBagError

    topics = [t.resolve() for t in topic_table.RIG_STREAMS]
    for m in iter_messages(path, topics=topics, namespace=namespace):
        return int(m.msg.first_index), float(m.msg.sample_rate), int(m.timestamp_ns)
    raise RecordBagError(f'{path}: no rig stream messages')


def _friction(task: Task) -> list[Row]:
    """Block fit of one chunk (``tribo friction`` with the campaign's block length).

    One chunk: :func:`tribo_estimation.fit_blocks` on the whole session. Several:
    the same input stage (:class:`~tribo_estimation.core.inputs.CheckedInput`) and
    estimator on the chunk's window with its warm-up, keeping the blocks that
    start inside the chunk.
    """
    import tribo_estimation as te
    from tribo_estimation.core.blockfit import BlockConfig, BlockEstimator
    from tribo_estimation.core.inputs import CheckedInput, bag_events, rig_scales
    from tribo_estimation.errors import TooShortError

    st = task.settings
    path = Path(task.path)
    ns = task.namespace or None
    cfg_rig = te.load_rig(task.config)
    if task.n_chunks == 1:
        fit = te.fit_blocks(path, cfg_rig, block_length=st.block_s, namespace=ns)
        return [block_row(r) for r in fit.results]
    nominal = cfg_rig.drive.nominal_speed
    cfg = BlockConfig(
        block_length=st.block_s,
        nominal_speed=nominal if nominal > 0.0 else None,
        ramp_time=cfg_rig.drive.ramp_time,
    )
    i0, fs, t0_ns = _first_message(path, ns)
    lo = -math.inf if task.chunk == 0 else i0 + round(task.chunk * st.chunk_s * fs)
    last = task.chunk == task.n_chunks - 1
    hi = math.inf if last else i0 + round((task.chunk + 1) * st.chunk_s * fs)
    if task.chunk == 0:
        raw = bag_events(path, ns)
    else:
        warm_s = cfg_rig.drive.ramp_time + 2.0 * st.block_s + WINDOW_SLACK_S
        start = task.chunk * st.chunk_s - warm_s
        stop = (task.chunk + 1) * st.chunk_s + st.block_s + WINDOW_SLACK_S
        raw = _window_events(path, ns, t0_ns + round(start * 1e9), t0_ns + round(stop * 1e9))
    stream = CheckedInput(raw, rig_scales(cfg_rig), str(path))
    est = BlockEstimator(cfg_rig.rig, cfg_rig.friction, cfg, repairs=stream.repairs)
    rows: list[Row] = []
    past = False
    for ev in stream:
        for blk in est.push(ev):
            past = past or blk.first_index >= hi
            if lo <= blk.first_index < hi:
                rows.append(block_row(est.evaluate(blk).result))
        if past:
            break
    if stream.truncated is not None:
        raise stream.truncated
    if not past:
        for blk in est.flush():
            if lo <= blk.first_index < hi:
                rows.append(block_row(est.evaluate(blk).result))
    if not rows:
        raise TooShortError(f'{path}: no complete block in chunk {task.chunk}')
    return rows


# --- discrepancy -------------------------------------------------------------------


def _discrepancy(task: Task) -> Row:
    """Missing-physics workflow on the settings' window (``tribo discrepancy``).

    The row is taken from the result's ``discrepancy.json`` content (its
    ``as_dict``): verdict, one-line finding, the families named or left apart,
    the torque residual rms of the baseline and final model [N m], the noise
    floor [N m], the baseline's mu0 and mu_inf, and the whole report as JSON.
    """
    import json

    import tribo_estimation as te
    from tribo_bringup.report.page import clean_json

    st = task.settings
    cfg = te.load_rig(task.config)
    record = te.read_record(
        task.path,
        cfg,
        start=st.discrepancy_start_s,
        duration=st.discrepancy_duration_s,
        namespace=task.namespace or None,
    )
    data = te.find_missing_physics(record, cfg).as_dict()
    base = _mapping(data.get('baseline'))
    params = _mapping(base.get('params'))

    def names(key: str) -> str:
        items = data.get(key)
        seq = items if isinstance(items, list) else []
        return ', '.join(str(_mapping(e).get('family', _mapping(e).get('effect'))) for e in seq)

    unexplained = data.get('unexplained')
    return {
        'window_start_s': float(record.time[0]),
        'window_s': float(record.time[-1] - record.time[0]),
        'verdict': str(data.get('verdict', '')),
        'finding': str(data.get('finding', '')),
        'reason': str(data.get('reason', '')),
        'experiment': str(data.get('experiment', '')),
        'added': names('added'),
        'cannot_tell_apart': names('cannot_tell_apart'),
        'n_unexplained': len(unexplained) if isinstance(unexplained, list) else 0,
        'rms_baseline': float(_number(base.get('rms'))),
        'rms_final': float(_number(_mapping(data.get('final')).get('rms'))),
        'noise_floor': float(_number(data.get('noise_floor'))),
        'mu0': float(_number(params.get('mu0'))),
        'mu_inf': float(_number(params.get('mu_inf'))),
        'result_json': json.dumps(clean_json(data), allow_nan=False, default=str),
    }


def _mapping(x: object) -> dict[str, object]:
    """Return a JSON object as a dict (anything else as an empty one)."""
    return {str(k): v for k, v in x.items()} if isinstance(x, dict) else {}


# --- wear --------------------------------------------------------------------------


def _wear(task: Task) -> Row:
    """NVCT wear evaluation of the session's counts (``tribo wear``)."""
    import tribo_nvct as tn

    summary = tn.evaluate_wear(task.path, task.config).summary()
    row: Row = {'dwells': _number(summary.get('dwells'))}
    for k in ('load_N', 'stroke_m', 'frequency_hz', 'temperature_K', *WEAR_COLUMNS):
        row[k] = float(_number(summary.get(k)))
    row['sliding_distance_convention'] = str(summary.get('sliding_distance_convention', ''))
    return row


def _number(v: object) -> float | int:
    """Return a summary number as is; anything else (None, text) as NaN."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return math.nan
    return v


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
