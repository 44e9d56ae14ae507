"""Benchmark: the serial DAQ driver node at 10 kHz (target: under 30 % of one core).

A DAQ emulator streams 20-byte frames at 10 kHz into a pseudo-terminal; the
``daq_driver`` node (its own process, autostart) reads, decodes and publishes
SampleBlocks; ``tribo record`` records them. Prints the node's CPU load in % of
one core and the continuity of the recorded streams.
Run: `source env.sh && python bench/bench_daq_node.py [--seconds 30]`.
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

from bench_graph import cpu_seconds

from tribo_bringup import bagio
from tribo_drivers.core.emulators import DaqEmulator


def main() -> int:
    """Run the benchmark."""
    ap = argparse.ArgumentParser()
    ap.add_argument('--seconds', type=float, default=30.0)
    args = ap.parse_args()
    env = {
        **os.environ,
        'ROS_DOMAIN_ID': str(10 + os.getpid() % 90),
        'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
    }
    tmp = Path(tempfile.mkdtemp(prefix='bench_daq_node_'))
    emu = DaqEmulator(10_000.0)
    emu.start()
    node = subprocess.Popen(
        [
            shutil.which('daq_driver') or 'daq_driver',
            '--ros-args',
            '-p',
            f'port:={emu.path}',
            '-p',
            'sample_rate:=10000.0',
            '-p',
            'block_size:=100',
        ],
        stdout=(tmp / 'node.log').open('w'),
        stderr=subprocess.STDOUT,
        start_new_session=True,
        env=env,
    )
    bag = tmp / 'bag'
    try:
        time.sleep(3.0)
        rec = subprocess.Popen(
            [
                sys.executable,
                '-m',
                'tribo_bringup.cli',
                'record',
                '--duration',
                str(args.seconds + 2.0),
                '--out',
                str(bag),
                '--topics',
                *bagio.RIG_TOPICS,
            ],
            start_new_session=True,
            env=env,
            stderr=subprocess.DEVNULL,
        )
        time.sleep(2.0)
        c0, t0 = cpu_seconds(node.pid), time.monotonic()
        time.sleep(args.seconds)
        c1, t1 = cpu_seconds(node.pid), time.monotonic()
        rec.wait()
    finally:
        if node.poll() is None:
            os.killpg(node.pid, signal.SIGINT)
            node.wait(timeout=20)
        emu.close()
    print(
        f'daq_driver node at 10 kHz: {100.0 * (c1 - c0) / (t1 - t0):.1f} % of one core '
        f'over {t1 - t0:.0f} s (target < 30 %)'
    )
    for c in bagio.check_streams(bag, bagio.RIG_TOPICS):
        print(f'  {c.topic}: {c.samples} samples, missing {c.missing}, duplicates {c.duplicates}')
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
