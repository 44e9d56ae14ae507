"""Node test: sim_detector -> wear_monitor over DDS, state file survives a restart.

Needs rclpy and the built tribo_msgs (run under `source env.sh`); own
ROS_DOMAIN_ID, localhost discovery; subprocesses in their own session,
stopped with SIGINT to the group and waited for.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from ..conftest import CONFIG_DIR, REPO

pytestmark = pytest.mark.ros

try:
    import rclpy

    from tribo_msgs.msg import DetectorCounts, WearState
except ImportError:  # pragma: no cover - outside the built workspace
    pytest.skip('needs rclpy and tribo_msgs (source env.sh)', allow_module_level=True)

DOMAIN = os.environ['ROS_DOMAIN_ID']  # per test worker (root conftest.py)
ENV = {
    **os.environ,
    'ROS_DOMAIN_ID': DOMAIN,
    'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
    'PYTHONPATH': os.pathsep.join(
        [str(REPO / 'src' / p) for p in ('tribo_nvct', 'tribo_drivers', 'tribo_common')]
        + [os.environ.get('PYTHONPATH', '')]
    ),
}


def start(module: str, params: dict[str, Any], log: Path) -> subprocess.Popen[bytes]:
    args = [sys.executable, '-m', module, '--ros-args']
    for k, v in params.items():
        args += ['-p', f'{k}:={v}']
    return subprocess.Popen(
        args,
        stdout=log.open('wb'),
        stderr=subprocess.STDOUT,
        env=ENV,
        start_new_session=True,
        cwd=REPO,
    )


def stop(p: subprocess.Popen[bytes]) -> None:
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGINT)
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


@pytest.mark.slow
def test_pipeline_and_restart(tmp_path: Path) -> None:
    os.environ['ROS_DOMAIN_ID'] = DOMAIN
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    state = tmp_path / 'state.json'
    monitor_params = {'nvct_config': str(CONFIG_DIR / 'nvct.yaml'), 'state_file': str(state)}
    rclpy.init()
    node = rclpy.create_node('nvct_test_listener')
    got: list[Any] = []
    from tribo_common.qos import data_qos, history_qos

    # latched results: every WearState arrives even if this listener and the
    # monitor's publisher match only after the first results were published
    node.create_subscription(WearState, '/nvct/wear', got.append, history_qos())
    pub = node.create_publisher(DetectorCounts, '/nvct/counts', data_qos())
    procs = []
    try:
        mon = start('tribo_nvct.nodes.wear_monitor', monitor_params, tmp_path / 'mon.log')
        procs.append(mon)
        # the monitor subscribes before the detector's test clock starts (volatile QoS):
        # wait for its start line, the detector then waits for its subscriber
        deadline = time.monotonic() + 60.0
        while 'dwells restored' not in (tmp_path / 'mon.log').read_text(errors='replace'):
            assert time.monotonic() < deadline, (tmp_path / 'mon.log').read_text()
            time.sleep(0.1)
        det = start(
            'tribo_drivers.nodes.sim_detector',
            {
                'sim_config': str(CONFIG_DIR / 'sim_detector.yaml'),
                'time_scale': 2400.0,
                'wait_subscribers': 30.0,
            },
            tmp_path / 'det.log',
        )
        procs.append(det)
        # 240 dwells in 6 s of wall time; on a loaded machine it may take longer:
        # give up only when nothing arrives for 60 s
        last_progress, seen = time.monotonic(), 0
        while len(got) < 240 and time.monotonic() - last_progress < 60.0:
            rclpy.spin_once(node, timeout_sec=0.1)
            if len(got) != seen:
                last_progress, seen = time.monotonic(), len(got)
        logs = (tmp_path / 'mon.log').read_text()[-1500:] + (tmp_path / 'det.log').read_text()[
            -500:
        ]
        assert [m.t for m in got] == [60.0 * (i + 1) for i in range(240)], logs
        last = got[-1]
        assert last.t == pytest.approx(240 * 60.0)
        # 240 min of the shipped truth: ~5e5 um^3 = 5e-13 m^3 (SI on the wire).
        assert 3e-13 < last.wear_volume < 7e-13
        assert math.isfinite(last.running_in_volume) and math.isfinite(last.progressive_rate)
        assert not got[0].oil_mixed and last.oil_mixed
        stop(mon)
        assert len(json.loads(state.read_text())['dwells']) == 240
        # Restart: the restored evaluator continues; a finite recent rate needs history.
        mon2 = start('tribo_nvct.nodes.wear_monitor', monitor_params, tmp_path / 'mon2.log')
        procs.append(mon2)
        got.clear()
        msg = DetectorCounts()
        msg.seq = 240
        msg.t_start, msg.t_end = 240 * 60.0, 241 * 60.0
        msg.counts, msg.live_time = 15000, 59.9
        # published until the restarted monitor answers (it ignores exact repeats)
        deadline = time.monotonic() + 60.0
        while not got and time.monotonic() < deadline:
            pub.publish(msg)
            rclpy.spin_once(node, timeout_sec=0.5)
        assert got, (tmp_path / 'mon2.log').read_text()[-2000:]
        assert math.isfinite(got[0].wear_rate) and 'gap' not in got[0].quality
    finally:
        for p in procs:
            stop(p)
        node.destroy_node()
        rclpy.try_shutdown()
