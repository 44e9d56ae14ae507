"""Benchmark of the ``tribo`` command's start: CPU time of whole processes.

Prints, for several runs each (min and median of user + sys CPU seconds of the
whole process, ``resource.getrusage(RUSAGE_CHILDREN)``), beside the targets of
issue 22:

- ``tribo --help`` and ``tribo CMD --help`` for every command (target 0.3 s);
- ``tribo friction`` on an 8 s, 10 kHz simulated record with ``--no-plots``
  (target 1.5 s), beside the fit's own CPU time in a warm process
  (:func:`tribo_estimation.fit_blocks` on the same file).

The numba caches must be ready (``make setup`` runs ``tools/warmup.py``); a first
run after a source change compiles and is not representative. CPU times grow on a
loaded machine (two cores shared with other jobs): read the minimum.

Usage: ``.venv/bin/python bench/bench_cli.py [--runs 5]`` (under ``source env.sh``).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import validation_doc

ROOT = Path(__file__).resolve().parents[1]
RIG = ROOT / 'config' / 'rig.yaml'
COMMANDS = (
    'run',
    'record',
    'replay',
    'simulate',
    'decay',
    'friction',
    'campaign',
    'wear',
    'discrepancy',
    'report',
    'demo',
)
HELP_TARGET_S = 0.3
FRICTION_TARGET_S = 1.5


def cpu_of(argv: list[str], env: dict[str, str]) -> float:
    """Return the user + sys CPU seconds of one run of ``argv`` (must exit 0)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(argv, env=env, check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def line(label: str, times: list[float], target: float) -> str:
    """Format one result line: min, median, target and verdict."""
    lo, med = min(times), statistics.median(times)
    verdict = 'ok' if med <= target else 'OVER'
    return f'{label:<28} min {lo:5.2f} s  median {med:5.2f} s  (target {target:g} s: {verdict})'


def main() -> int:
    """Measure and print."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--runs', type=int, default=5, help='runs per command (default 5)')
    args = ap.parse_args()
    env = dict(os.environ, OPENBLAS_NUM_THREADS='1', OMP_NUM_THREADS='1')
    tribo = [sys.executable, '-m', 'tribo_bringup.cli']
    print(f'CPU time (user + sys) of whole processes, {args.runs} runs each')
    worst = 0.0
    for cmd in ('', *COMMANDS):
        argv = [*tribo, *([cmd] if cmd else []), '--help']
        times = [cpu_of(argv, env) for _ in range(args.runs)]
        worst = max(worst, statistics.median(times))
        print(line(f'tribo {cmd + " " if cmd else ""}--help', times, HELP_TARGET_S))
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / 'run8.csv'
        import tribo_estimation as te

        rig = te.load_rig(RIG)
        te.simulate(rig, 8.0, noise=True, seed=1).write(csv)
        argv = [*tribo, 'friction', str(csv), '--rig', str(RIG), '--out', str(Path(tmp) / 'f')]
        argv += ['--no-plots', '--quiet']
        times = [cpu_of(argv, env) for _ in range(args.runs)]
        print(line('tribo friction (8 s)', times, FRICTION_TARGET_S))
        te.fit_blocks(csv, rig)  # warm: imports and numba caches loaded
        fit_times = []
        for _ in range(args.runs):
            t0 = time.process_time()
            fit = te.fit_blocks(csv, rig)
            fit_times.append(time.process_time() - t0)
        print(
            f'{"  of which the fit":<28} min {min(fit_times):5.2f} s  median '
            f'{statistics.median(fit_times):5.2f} s  ({len(fit)} blocks, warm process)'
        )
    print(f'slowest --help median {worst:.2f} s')
    return 0


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
