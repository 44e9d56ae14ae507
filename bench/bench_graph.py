"""Benchmark: the simulated rig at 10 kHz recorded for 60 s.

Prints the samples recorded per rig topic, missing samples (by first-sample
indices in the bag) and the CPU load of the sim_rig driver process and of the
recorder in % of one core. Run: `source env.sh && python bench/bench_graph.py [--duration 60]`.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process and its threads [s]."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    ticks = os.sysconf('SC_CLK_TCK')
    return (int(fields[11]) + int(fields[12])) / ticks


def main() -> int:
    """Run the benchmark."""
    ap = argparse.ArgumentParser()
    ap.add_argument('--duration', type=float, default=60.0)
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT / 'src' / 'tribo_bringup'))
    from tribo_bringup import bagio

    env = {
        **os.environ,
        'ROS_DOMAIN_ID': str(10 + os.getpid() % 90),
        'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
    }
    tmp = Path(tempfile.mkdtemp(prefix='bench_graph_'))
    sim_log = (tmp / 'sim.log').open('w')
    sim = subprocess.Popen(
        [shutil.which('sim_rig') or 'sim_rig'],
        stdout=sim_log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
        env=env,
    )
    try:
        deadline = time.monotonic() + 300
        while 'streaming started' not in (tmp / 'sim.log').read_text():
            if time.monotonic() > deadline or sim.poll() is not None:
                print((tmp / 'sim.log').read_text())
                return 1
            time.sleep(0.2)
        bag = tmp / 'bag'
        rec = subprocess.Popen(
            [
                sys.executable,
                '-m',
                'tribo_bringup.cli',
                'record',
                '--duration',
                str(args.duration),
                '--out',
                str(bag),
                '--topics',
                *bagio.RIG_TOPICS,
            ],
            start_new_session=True,
            env=env,
        )
        time.sleep(2.0)
        c0, t0 = cpu_seconds(sim.pid), time.monotonic()
        r0 = cpu_seconds(rec.pid)
        # the recorder's CPU is read just before its duration ends
        time.sleep(max(args.duration - 4.0, 1.0))
        r1, tr = cpu_seconds(rec.pid), time.monotonic()
        rec.wait()
        c1, t1 = cpu_seconds(sim.pid), time.monotonic()
    finally:
        os.killpg(sim.pid, signal.SIGINT)
        sim.wait(timeout=20)
    load = 100.0 * (c1 - c0) / (t1 - t0)
    print(f'sim_rig CPU while recording: {load:.1f} % of one core (target < 50 %)')
    print(
        f'recorder (tribo record, bag flushed every 1 s) CPU: '
        f'{100.0 * (r1 - r0) / (tr - t0):.1f} % of one core'
    )
    for c in bagio.check_streams(bag, bagio.RIG_TOPICS):
        print(
            f'{c.topic}: {c.samples} samples ({c.samples / 1e4:.1f} s at 10 kHz), '
            f'missing {c.missing}, duplicates {c.duplicates}'
        )
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
