"""Campaign benchmark: a generated campaign on 1 and 2 dask workers, a re-run, the overheads.

Run: source env.sh && python bench/bench_campaign.py [--sessions 24] [--duration 20]
     [--discrepancy] [--dir DIR]

Generates ``--sessions`` bags of ``--duration`` s each with ``tribo simulate --out``
(three oils with mu0 = 0.12, 0.13, 0.14 at four drive speeds, 10 kHz, noise),
then analyses the campaign (friction; ``--discrepancy`` adds the missing-physics
workflow on a 2 s window) into a fresh store on a local cluster of 1 worker and
of 2 workers (each cluster started before the run: its start time is printed
apart), re-runs the unchanged campaign, and prints: wall time per run, speed-up,
the analyses' own time (sum over tasks, measured on the workers), the overhead
per session beyond the analysis, peak memory per worker, the re-run's time, the
raw bag scan rate (what a time chunk pays to reach its window), and checks that
both stores hold the same numbers. docs/scaling.md turns these figures into the
estimate for 1000 three-hour sessions.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
import math
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

import validation_doc

ROOT = Path(__file__).resolve().parents[1]
for _pkg in ('tribo_bringup', 'tribo_common', 'tribo_estimation', 'tribo_nvct'):
    sys.path.insert(0, str(ROOT / 'src' / _pkg))

from tribo_bringup import bagio, cli  # noqa: E402
from tribo_bringup.campaign.query import query  # noqa: E402
from tribo_bringup.campaign.runner import RunSummary, analyse  # noqa: E402
from tribo_bringup.campaign.spec import load_spec  # noqa: E402

OILS = {'A': 0.12, 'B': 0.13, 'C': 0.14}
SPEEDS = (1.0, 2.0, 3.14159, 5.0)  # rad/s


def _peak_rss_mb() -> float:
    """Peak resident memory of the calling process [MB] (run on each worker)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _cpu_s() -> float:
    """CPU time (user + system) of the calling process so far [s]."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def generate(d: Path, n: int, duration: float, discrepancy: bool) -> Path:
    """Write the rigs, ``n`` session bags and the spec into ``d``; return the spec."""
    text = (ROOT / 'config' / 'rig.yaml').read_text()
    (d / 'runs').mkdir(parents=True)
    groups = []
    for oil, mu0 in OILS.items():
        (d / f'rig_{oil}.yaml').write_text(text.replace('mu0: 0.13 ', f'mu0: {mu0} '))
        groups.append(f'  - rig: rig_{oil}.yaml\n    meta: {{oil: {oil}}}\n    sessions:\n')
    for i in range(n):
        oil = list(OILS)[i % len(OILS)]
        speed = SPEEDS[(i // len(OILS)) % len(SPEEDS)]
        name = f'{oil}_{i:03d}'
        out = d / 'runs' / name
        args = ['simulate', '--rig', str(d / f'rig_{oil}.yaml'), '--duration', str(duration)]
        args += ['--noise', '--seed', str(i), '--speed', str(speed), '--out', str(out)]
        with contextlib.redirect_stdout(io.StringIO()):
            rc = cli.main(args)
        if rc != 0:
            raise SystemExit(f'simulate failed for {name}')
        rpm = speed * 60 / (2 * math.pi)
        k = list(OILS).index(oil)
        groups[k] += f'      - {{path: runs/{name}, meta: {{speed_rpm: {rpm:.3f}}}}}\n'
    analyses = '[friction, discrepancy]' if discrepancy else '[friction]'
    settings = '{discrepancy_duration_s: 2.0}'
    spec = d / 'spec.yaml'
    spec.write_text(
        f'name: bench\nanalyses: {analyses}\nsettings: {settings}\ngroups:\n' + ''.join(groups)
    )
    return spec


def run(spec: Path, store: Path, workers: int) -> tuple[RunSummary, float, list[float], float]:
    """Analyse on a fresh local cluster.

    Returns (summary, cluster start [s], peak MB per worker, CPU seconds of every
    process of the run: workers, scheduler and client).
    """
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(
        n_workers=workers, threads_per_worker=1, dashboard_address=None, silence_logs=logging.ERROR
    )
    client = Client(cluster)
    start_s = time.perf_counter() - t0
    try:
        c0, w0 = _cpu_s(), sum(client.run(_cpu_s).values())
        res = analyse(load_spec(spec), store, scheduler=cluster.scheduler_address, stream=None)
        cpu = _cpu_s() - c0 + sum(client.run(_cpu_s).values()) - w0
        mem = sorted(client.run(_peak_rss_mb).values())
    finally:
        client.close()
        cluster.close()
    return res, start_s, mem, cpu


def scan_rate(bag: Path) -> float:
    """Return the raw (not decoded) message rate of a bag scan [messages/s]."""
    t0 = time.perf_counter()
    n = sum(1 for _ in bagio.iter_messages(bag, deserialize=False))
    return n / (time.perf_counter() - t0)


def main() -> None:
    """Generate the campaign, run it on 1 and 2 workers, re-run it, print the figures."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--sessions', type=int, default=24)
    ap.add_argument('--duration', type=float, default=20.0, help='session length [s]')
    ap.add_argument('--discrepancy', action='store_true')
    ap.add_argument('--dir', help='work directory (default: a temporary one, removed)')
    args = ap.parse_args()
    work = Path(args.dir) if args.dir else Path(tempfile.mkdtemp(prefix='bench_campaign_'))
    try:
        t0 = time.perf_counter()
        spec = generate(work / 'campaign', args.sessions, args.duration, args.discrepancy)
        gen_s = time.perf_counter() - t0
        n = args.sessions
        print(
            f'campaign: {n} sessions x {args.duration:g} s (3 oils x 4 speeds, 10 kHz), '
            f'analyses {"friction, discrepancy (2 s window)" if args.discrepancy else "friction"}'
            f'; generated in {gen_s:.1f} s ({gen_s / n:.2f} s per session)'
        )
        results = {}
        for workers in (1, 2):
            res, start_s, mem, cpu = run(spec, work / f'store{workers}', workers)
            results[workers] = res
            over = (res.seconds * workers - res.task_seconds) / n
            extra = cpu - res.task_cpu_seconds
            print(
                f'{workers} worker(s): wall {res.seconds:.1f} s (cluster start {start_s:.1f} s '
                f'apart), analyses {res.task_seconds:.1f} s of worker time '
                f'({res.task_cpu_seconds:.1f} s CPU: the rest went to other processes), '
                f'{res.tasks} tasks, '
                f'{res.analysed} sessions ({res.failed} failed); overhead per session '
                f'{over:.2f} s of worker time; peak memory per worker '
                f'{", ".join(f"{m:.0f}" for m in mem)} MB; CPU of all its processes '
                f'{cpu:.1f} s, of which {extra:.1f} s ({100 * extra / cpu:.1f} %) beyond the '
                f'analyses ({extra / n:.2f} s per session); the run got '
                f'{cpu / res.seconds:.2f} cores'
            )
        w1, w2 = results[1], results[2]
        print(f'speed-up 2 vs 1 worker: {w1.seconds / w2.seconds:.2f}x')
        t0 = time.perf_counter()
        again = analyse(load_spec(spec), work / 'store2', workers=2, stream=None)
        print(
            f're-run of the unchanged campaign: {time.perf_counter() - t0:.2f} s, '
            f'{again.analysed} analysed, {again.up_to_date} up to date'
        )
        sql = (
            'SELECT oil, avg(mu0), count(*) FROM blocks JOIN sessions USING (session_id) '
            "WHERE quality = 'ok' GROUP BY oil ORDER BY oil"
        )
        a, b = query(work / 'store1', sql)[1], query(work / 'store2', sql)[1]
        same = a == b
        print(
            'per-oil mean mu0 (1 worker = 2 workers: ' + ('identical' if same else 'DIFFER') + ')'
        )
        for oil, mu0, count in a:
            print(f'  oil {oil}: mu0 {mu0:.5f} over {count} blocks (truth {OILS[str(oil)]})')
        per_s = w1.task_cpu_seconds / (n * args.duration)
        bag = work / 'campaign' / 'runs' / 'A_000'
        print(
            f'analysis cost: {per_s:.4f} s of CPU per second of data; raw bag scan '
            f'{scan_rate(bag):.0f} messages/s (120 messages per second of data)'
        )
        if not same:
            raise SystemExit('the stores of the 1- and 2-worker runs differ')
    finally:
        if not args.dir:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
