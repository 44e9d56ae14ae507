"""Run a campaign on dask.distributed: plan the tasks, run them, commit each session.

:func:`analyse` keys every session of the spec (:func:`.store.session_key`),
skips the keys already in the store, cuts the rest into tasks
(:mod:`.analyses`: friction per time chunk, discrepancy, wear) and runs them on a
local cluster of worker processes (``workers``; embedded, nothing to set up) or
on the cluster behind a scheduler address (SSH, SLURM through dask-jobqueue,
Kubernetes: the workers need this workspace importable). The client (this
process) gathers the tasks of a session and commits the session to the store
in one atomic step as soon as its last task ends; nothing is written by the
workers. A task whose worker dies is run again by the scheduler (up to its
``allowed-failures``); a session is committed once, whatever ran twice.
"""

from __future__ import annotations

import datetime
import json
import logging
import math
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TextIO

from tribo_bringup.errors import CampaignError

from .analyses import Row, Task, TaskResult, n_chunks, one_line, session_duration
from .progress import Progress, fmt_seconds
from .spec import CampaignSpec, SessionSpec
from .store import Store, content_hash, file_fingerprint, session_key

#: Software whose versions are part of every session key.
_KEY_VERSIONS = (
    'python',
    'numpy',
    'scipy',
    'numba',
    'tribo_bringup',
    'tribo_common',
    'tribo_estimation',
    'tribo_nvct',
)


@dataclass(frozen=True)
class RunSummary:
    """What a campaign run did.

    Attributes
    ----------
    sessions
        Sessions in the spec.
    analysed
        Sessions analysed by this run (ok or failed).
    failed
        Of those, the failed ones.
    up_to_date
        Sessions whose results were in the store already.
    tasks
        Tasks run.
    seconds
        Wall time of the run [s].
    task_seconds
        Sum of the analyses' own wall times on the workers [s].
    task_cpu_seconds
        Sum of the analyses' CPU times on the workers [s].
    workers
        Workers of the cluster (0: nothing to run, no cluster started).
    cluster_seconds
        Time to start and stop the cluster [s].
    failures
        ``session_id: error`` of each session of the spec that is failed in the
        store (this run's and earlier ones').
    """

    sessions: int
    analysed: int
    failed: int
    up_to_date: int
    tasks: int
    seconds: float
    task_seconds: float
    task_cpu_seconds: float
    workers: int
    cluster_seconds: float
    failures: tuple[str, ...] = ()


@dataclass
class _Pending:
    """A session being analysed: its tasks and the results so far."""

    session: SessionSpec
    key: str
    content: str
    tasks: int
    results: list[TaskResult]


def software_versions() -> str:
    """Return the software versions that key the results (JSON).

    Returns
    -------
    str
        JSON object name -> version.
    """
    from tribo_bringup.report.provenance import provenance

    versions = provenance([])['versions']
    return json.dumps({k: versions.get(k, '?') for k in _KEY_VERSIONS}, sort_keys=True)


def analyse(
    spec: CampaignSpec,
    store_dir: str | Path,
    *,
    workers: int = 2,
    scheduler: str | None = None,
    stream: TextIO | None = sys.stderr,
) -> RunSummary:
    """Analyse the campaign's new or changed sessions into the store.

    Parameters
    ----------
    spec : CampaignSpec
        The loaded spec.
    store_dir : str or Path
        The store directory (created if needed).
    workers : int
        Worker processes of the local cluster (one thread each).
    scheduler : str or None
        Address of a running dask scheduler (then ``workers`` is not used).
    stream : TextIO or None
        Progress output (None: silent).

    Returns
    -------
    RunSummary
        Counts and times.

    Raises
    ------
    StoreBusyError
        Another run holds the store.
    CampaignError
        The scheduler cannot be reached.
    """
    t0 = time.monotonic()
    store = Store(store_dir)
    with store.lock():
        prepared = _prepare(spec, store)
        committed = store.committed()
        todo: dict[str, _Pending] = {}
        for s, key, content, _ in prepared:
            status = committed.get(key)
            if status is not None and status[1] != 'internal':
                continue
            if key not in todo:
                todo[key] = _Pending(s, key, content, 0, [])
        up_to_date = len(prepared) - sum(1 for p in prepared if p[1] in todo)
        tasks = _plan(todo, {p[1]: p[3] for p in prepared}, spec)
        if stream is not None:
            what = f'{len(todo)} to analyse in {len(tasks)} tasks' if todo else 'nothing to do'
            stream.write(
                f'campaign {spec.name!r}: {len(prepared)} sessions, {up_to_date} up to date, '
                f'{what} -> {store.root}\n'
            )
        run = _run(tasks, todo, store, workers, scheduler, stream) if tasks else (0, 0.0)
        failures = tuple(
            f'{s.session_id}: {err}' for s, err in store.failures([p[:2] for p in prepared])
        )
    done = [p for p in todo.values() if p.tasks == len(p.results)]
    return RunSummary(
        sessions=len(prepared),
        analysed=len(done),
        failed=sum(1 for p in done if any(r.error for r in p.results)),
        up_to_date=up_to_date,
        tasks=len(tasks),
        seconds=time.monotonic() - t0,
        task_seconds=sum(r.seconds for p in done for r in p.results),
        task_cpu_seconds=sum(r.cpu_seconds for p in done for r in p.results),
        workers=run[0],
        cluster_seconds=run[1],
        failures=failures,
    )


def _prepare(spec: CampaignSpec, store: Store) -> list[tuple[SessionSpec, str, str, float]]:
    """Key every session and write ``sessions.parquet``; return (session, key, hash, duration)."""
    software = software_versions()
    settings = asdict(spec.settings)
    previous = store.previous_sessions()
    config_hash: dict[Path, str] = {}

    def cfg_hash(p: Path | None) -> str:
        if p is None:
            return ''
        if p not in config_hash:
            config_hash[p] = content_hash(p)
        return config_hash[p]

    out: list[tuple[SessionSpec, str, str, float]] = []
    rows: list[Mapping[str, object]] = []
    for s in spec.sessions:
        try:
            size, mtime = file_fingerprint(s.path)
        except OSError as exc:
            raise CampaignError(f'{s.path}: cannot read ({exc.strerror})') from exc
        prev = previous.get(str(s.path))
        if prev and prev.get('file_size') == size and prev.get('file_mtime_ns') == mtime:
            content = str(prev['content_hash'])
        else:
            content = content_hash(s.path)
        key = session_key(
            content,
            [cfg_hash(s.rig), cfg_hash(s.nvct)],
            s.analyses,
            json.dumps({**settings, 'namespace': s.namespace}, sort_keys=True),
            software,
        )
        duration = session_duration(s.path, s.kind)
        out.append((s, key, content, duration))
        rows.append(
            {
                'session_id': s.session_id,
                'path': str(s.path),
                'kind': s.kind,
                'key': key,
                'content_hash': content,
                'file_size': size,
                'file_mtime_ns': mtime,
                'rig': str(s.rig) if s.rig else None,
                'nvct': str(s.nvct) if s.nvct else None,
                'namespace': s.namespace,
                'analyses': ','.join(s.analyses),
                'duration_s': duration if math.isfinite(duration) else None,
                **s.meta,
            }
        )
    store.write_sessions(rows)  # type: ignore[arg-type]
    return out


def _plan(
    todo: Mapping[str, _Pending], durations: Mapping[str, float], spec: CampaignSpec
) -> list[Task]:
    """Cut the sessions into tasks, longest session first."""
    tasks: list[Task] = []
    order = sorted(todo.values(), key=lambda p: -_finite(durations.get(p.key, math.nan)))
    for p in order:
        s = p.session
        for analysis in s.analyses:
            config = str(s.nvct if analysis == 'wear' else s.rig)
            base = Task(
                p.key, analysis, 0, 1, str(s.path), s.kind, config, s.namespace, spec.settings
            )
            if analysis == 'friction':
                n = n_chunks(durations.get(p.key, math.nan), spec.settings)
                tasks.extend(replace(base, chunk=i, n_chunks=n) for i in range(n))
            else:
                tasks.append(base)
        p.tasks = sum(1 for t in tasks if t.key == p.key)
    return tasks


def _finite(x: float) -> float:
    return x if math.isfinite(x) else 0.0


def _run(
    tasks: Sequence[Task],
    todo: Mapping[str, _Pending],
    store: Store,
    workers: int,
    scheduler: str | None,
    stream: TextIO | None,
) -> tuple[int, float]:
    """Run the tasks on the cluster, committing each session when it is complete.

    Returns (workers, seconds spent starting and stopping the cluster).
    """
    from dask.distributed import Client, LocalCluster, as_completed

    from .analyses import run_task

    t_start = time.monotonic()
    cluster: LocalCluster | None = None
    if scheduler:
        try:
            client = Client(scheduler, timeout='10s')
        except (OSError, TimeoutError) as exc:
            raise CampaignError(f'cannot reach the dask scheduler {scheduler}: {exc}') from None
    else:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        client = Client(cluster)
    n_workers = len(client.scheduler_info(n_workers=-1).get('workers', {})) or workers
    cluster_s = time.monotonic() - t_start
    progress = Progress(len(tasks), len(todo), stream)
    try:
        futures = {}
        for i, t in enumerate(tasks):
            name = f'{t.analysis}-{t.chunk}-{t.key}'
            futures[client.submit(run_task, t, key=name, priority=-i, pure=False)] = t
        for fut in as_completed(list(futures)):
            task = futures[fut]
            try:
                res = fut.result()
            except Exception as exc:  # a bug in an analysis, or its workers kept dying
                res = TaskResult(
                    task, error=f'{type(exc).__name__}: {one_line(exc)}', internal=True
                )
            fut.release()
            pending = todo[task.key]
            pending.results.append(res)
            progress.task_done()
            if len(pending.results) == pending.tasks:
                ok, line = _commit(store, pending)
                progress.session_done(line, ok)
    finally:
        t_stop = time.monotonic()
        progress.close()
        client.close()
        if cluster is not None:
            cluster.close()
        cluster_s += time.monotonic() - t_stop
    return n_workers, cluster_s


def _first_error(results: Sequence[TaskResult]) -> str:
    for r in results:
        if r.error:
            return f'{r.task.analysis}: {r.error}'
    return ''


def _commit(store: Store, p: _Pending) -> tuple[bool, str]:
    """Commit one complete session; return (ok, its status line)."""
    error = _first_error(p.results)
    internal = any(r.internal for r in p.results)
    seconds = sum(r.seconds for r in p.results)
    prov: Row = {
        'status': 'failed' if error else 'ok',
        'error': error or None,
        'error_kind': ('internal' if internal else 'input') if error else '',
        'seconds': seconds,
        'analysed_at': datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds'),
        'software': software_versions(),
        'settings': json.dumps(asdict(p.results[0].task.settings), sort_keys=True),
        'content_hash': p.content,
    }
    tables: dict[str, list[Row]] = {'provenance': [prov]}
    if not error:
        blocks: list[Row] = []
        for r in sorted(p.results, key=lambda r: r.task.chunk):
            for name, rows in r.rows.items():
                if name == 'blocks':
                    blocks.extend({**row, 'chunk': r.task.chunk} for row in rows)
                else:
                    tables.setdefault(name, []).extend(rows)
        tables['blocks'] = blocks
    if internal:
        store.discard(p.key)
    store.commit(p.key, tables)
    sid = p.session.session_id
    if error:
        return False, f'{sid}: failed: {error}'
    return True, f'{sid}: ok, {_summary(tables)} ({fmt_seconds(seconds)} of analysis)'


def _summary(tables: Mapping[str, Sequence[Row]]) -> str:
    """One-line result of a session: blocks, mean mu0, motion; verdict; wear rate."""
    parts: list[str] = []
    blocks = tables.get('blocks', ())
    if blocks:
        good = [b for b in blocks if b.get('quality') == 'ok']
        mu0 = [v for b in good if isinstance(v := b.get('mu0'), float)]
        motions = sorted({str(b.get('motion')) for b in good})
        mean = f', mu0 {sum(mu0) / len(mu0):.4f}' if mu0 else ''
        parts.append(f'{len(blocks)} blocks ({len(good)} ok{mean}, {"/".join(motions) or "-"})')
    for d in tables.get('discrepancy', ()):
        parts.append(f'discrepancy: {d.get("finding")}')
    for w in tables.get('wear', ()):
        kw = w.get('k_w_progressive')
        parts.append(f'wear: k_w progressive {kw:.4g} um^3/(N m)' if isinstance(kw, float) else '')
    return '; '.join(p for p in parts if p) or 'no results'


def default_workers() -> int:
    """Return the default number of local workers: the CPU cores available to this process.

    Returns
    -------
    int
        At least 1.
    """
    return max(1, len(os.sched_getaffinity(0)))
