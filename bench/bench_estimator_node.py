"""Benchmark: the friction_estimator node on a live 10 kHz stream.

An in-process publisher streams the simulated rig (config/rig.yaml, seeded noise)
in real time as SampleBlocks of 100 samples; the ``friction_estimator`` node runs
as its own process. Prints, per 1 s block, the latency from the publication of the
block's last sample to the arrival of its /friction/estimate (target: 200 ms), the
completeness of /friction/moment (the node keeps up with 10 kHz) and the node's CPU
load. Run: `source env.sh && python bench/bench_estimator_node.py [--seconds 20]`.
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

import numpy as np
from bench_graph import cpu_seconds

ROOT = Path(__file__).resolve().parents[1]
BLOCK = 100
FS = 10_000.0


def main() -> int:
    """Run the benchmark."""
    ap = argparse.ArgumentParser()
    ap.add_argument('--seconds', type=float, default=20.0)
    args = ap.parse_args()
    os.environ['ROS_DOMAIN_ID'] = str(10 + os.getpid() % 90)
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    import rclpy
    from rclpy.utilities import try_shutdown

    from tribo_common.msgconv import make_sample_block
    from tribo_common.qos import data_qos
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.simulate import simulate
    from tribo_msgs.msg import FrictionEstimate, SampleBlock

    cfg = load_rig_config(ROOT / 'config' / 'rig.yaml')
    res = simulate(cfg.rig, cfg.friction, cfg.drive, args.seconds, FS, noise=cfg.noise, seed=3)
    tmp = Path(tempfile.mkdtemp(prefix='bench_estimator_'))
    node_proc = subprocess.Popen(
        [
            shutil.which('friction_estimator') or 'friction_estimator',
            '--ros-args',
            '--params-file',
            str(ROOT / 'config' / 'friction_estimator.yaml'),
        ],
        stdout=(tmp / 'node.log').open('w'),
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    rclpy.init()
    node = rclpy.create_node('bench_estimator_feeder')
    pubs = {
        name: node.create_publisher(SampleBlock, f'/rig/{name}', data_qos())
        for name in ('torsion_moment', 'angular_acceleration', 'speed')
    }
    arrivals: dict[int, float] = {}
    moment_samples = [0]

    def on_estimate(msg: FrictionEstimate) -> None:
        arrivals.setdefault(int(msg.first_index), time.monotonic())

    def on_moment(msg: SampleBlock) -> None:
        moment_samples[0] += len(msg.data)

    node.create_subscription(
        FrictionEstimate,
        '/friction/estimate',
        on_estimate,
        data_qos(),
    )
    node.create_subscription(
        SampleBlock,
        '/friction/moment',
        on_moment,
        data_qos(),
    )
    deadline = time.monotonic() + 120.0
    while any(p.get_subscription_count() == 0 for p in pubs.values()):
        rclpy.spin_once(node, timeout_sec=0.1)
        if time.monotonic() > deadline:
            print((tmp / 'node.log').read_text())
            return 1
    time.sleep(1.0)
    sent_at: dict[int, float] = {}
    n = res.time.size
    t0 = time.monotonic()
    c0 = cpu_seconds(node_proc.pid)
    for start in range(0, n, BLOCK):
        due = t0 + (start + BLOCK) / FS
        while (now := time.monotonic()) < due:
            rclpy.spin_once(node, timeout_sec=max(0.0, min(0.005, due - now)))
        stamp = round(1e9 * (1_000.0 + start / FS))
        for name, data in (
            ('torsion_moment', res.torsion_moment),
            ('angular_acceleration', res.angular_acceleration),
            ('speed', res.speed),
        ):
            pubs[name].publish(
                make_sample_block(
                    data[start : start + BLOCK],
                    first_index=start,
                    sample_rate=FS,
                    stamp_ns=stamp,
                    channel=name,
                    unit='',
                )
            )
        sent_at[start + BLOCK] = time.monotonic()
    t1 = time.monotonic()
    end = time.monotonic() + 5.0
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    c1 = cpu_seconds(node_proc.pid)
    os.killpg(node_proc.pid, signal.SIGINT)
    node_proc.wait(timeout=20)
    node.destroy_node()
    try_shutdown()
    block_n = round(FS)  # 1 s blocks
    lat = []
    for first, arrived in sorted(arrivals.items()):
        last_sent = sent_at.get(first + block_n)
        if last_sent is not None:
            lat.append(1e3 * (arrived - last_sent))
    lat_a = np.array(lat)
    print(f'estimates: {len(arrivals)} blocks of 1 s from {args.seconds:g} s of 10 kHz data')
    if lat_a.size:
        print(
            f"latency after the block's last sample: median {np.median(lat_a):.0f} ms, "
            f'max {lat_a.max():.0f} ms (target 200 ms)'
        )
    print(f'/friction/moment: {moment_samples[0]} of {n} samples')
    print(f'node CPU: {100.0 * (c1 - c0) / (t1 - t0):.1f} % of one core while streaming')
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
