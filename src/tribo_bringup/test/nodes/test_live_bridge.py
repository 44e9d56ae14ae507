"""The live bridge with a real Foxglove WebSocket client (needs ``source env.sh``).

A publisher node sends known SampleBlocks and a FrictionEstimate; a plain
``websockets`` client speaks the Foxglove WebSocket protocol v1 (serverInfo,
advertise, subscribe, binary messageData) and checks what arrives against
what was published.
"""

from __future__ import annotations

import json
import os
import struct
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

pytestmark = pytest.mark.ros

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

rclpy = pytest.importorskip('rclpy', reason='needs rclpy: run under `make test`')
tm = pytest.importorskip('tribo_msgs.msg', reason='needs the built workspace (source env.sh)')
ws_sync = pytest.importorskip('websockets.sync.client')

FS = 10_000.0
RATE = 1000.0  # factor 10: 10 points per published block of 100 samples
C1 = 2338.6
T0_NS = 1_700_000_000_000_000_000


@pytest.fixture()
def graph() -> Iterator[dict[str, Any]]:
    from rclpy.executors import MultiThreadedExecutor
    from rclpy.parameter import Parameter

    from tribo_bringup.nodes.live_bridge import LiveBridgeNode
    from tribo_common.node_main import spin_background
    from tribo_common.qos import data_qos

    rclpy.init()
    bridge = LiveBridgeNode(
        parameter_overrides=[
            Parameter('port', value=0),
            Parameter('downsample_rate', value=RATE),
            Parameter('C1', value=C1),
        ]
    )
    pub_node = rclpy.create_node('bridge_test_pub')
    pubs = {
        t: pub_node.create_publisher(tm.SampleBlock, t, data_qos())
        for t in ('/rig/torsion_moment', '/rig/speed')
    }
    pubs['/friction/estimate'] = pub_node.create_publisher(
        tm.FrictionEstimate, '/friction/estimate', data_qos()
    )
    ex = MultiThreadedExecutor(num_threads=2)
    ex.add_node(bridge)
    ex.add_node(pub_node)
    thread, stop = spin_background(ex)
    try:
        yield {'bridge': bridge, 'pubs': pubs}
    finally:
        stop.set()
        thread.join(timeout=5)
        ex.shutdown(timeout_sec=2)
        bridge.close()
        bridge.destroy_node()
        pub_node.destroy_node()
        rclpy.try_shutdown()


def wait(pred: Any, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(0.02)
    return False


def block(data: np.ndarray, first: int, unit: str) -> Any:
    from tribo_common.msgconv import make_sample_block

    return make_sample_block(
        data,
        first_index=first,
        sample_rate=FS,
        stamp_ns=T0_NS + round(first * 1e9 / FS),
        channel='x',
        unit=unit,
    )


def test_client_receives_downsampled_and_full_rate_data(graph: dict[str, Any]) -> None:
    bridge, pubs = graph['bridge'], graph['pubs']
    url = f'ws://127.0.0.1:{bridge.port}'
    # foxglove-sdk 0.30 speaks the Foxglove WebSocket protocol v1 under the subprotocol name
    # foxglove.sdk.v1 (same messages as foxglove.websocket.v1); offer both as Foxglove does
    protocols = ['foxglove.sdk.v1', 'foxglove.websocket.v1']
    with ws_sync.connect(url, subprotocols=protocols, open_timeout=10) as ws:  # type: ignore[arg-type]
        assert ws.subprotocol in protocols
        channels: dict[str, dict[str, Any]] = {}
        deadline = time.monotonic() + 10
        while len(channels) < 9 and time.monotonic() < deadline:
            msg = json.loads(ws.recv(timeout=5))
            if msg.get('op') == 'advertise':
                channels.update({c['topic']: c for c in msg['channels']})
        for topic in ('/rig/torsion_moment', '/live/stick', '/friction/estimate', '/nvct/wear'):
            assert topic in channels, f'{topic} not advertised'
            assert channels[topic]['encoding'] == 'json'
            assert channels[topic]['schemaEncoding'] == 'jsonschema'
            json.loads(channels[topic]['schema'])  # a valid JSON schema text
        subs = {1: '/rig/torsion_moment', 2: '/live/stick', 3: '/friction/estimate'}
        ws.send(
            json.dumps(
                {
                    'op': 'subscribe',
                    'subscriptions': [
                        {'id': sid, 'channelId': channels[t]['id']} for sid, t in subs.items()
                    ],
                }
            )
        )
        # the server has the subscriptions, DDS has matched the publishers
        assert wait(lambda: bridge._samples['/rig/torsion_moment'][0].has_sinks(), 10)
        assert wait(lambda: bridge._records['/friction/estimate'].has_sinks(), 10)
        assert wait(lambda: all(p.get_subscription_count() > 0 for p in pubs.values()), 10)

        # 3 blocks: sticking ramp (w1 = w2 = 3 rad/s), then torsion held (w1 = 0)
        rng = np.random.default_rng(11)
        w = 3.0
        t = np.arange(300) / FS
        torsion = C1 * w * t + rng.normal(0.0, 1e-3, 300)
        torsion[200:] = torsion[199]
        speed = np.full(300, w)
        for i in range(3):
            sl = slice(100 * i, 100 * (i + 1))
            pubs['/rig/torsion_moment'].publish(block(torsion[sl], 100 * i, 'N m'))
            pubs['/rig/speed'].publish(block(speed[sl], 100 * i, 'rad/s'))
        est = tm.FrictionEstimate()
        est.header.stamp.sec = 1_700_000_001
        est.t_start, est.t_end, est.first_index = 1.0, 2.0, 10_000
        est.mu0, est.mu0_se, est.mu_inf, est.mu_inf_se = 0.131, 0.002, 0.098, 0.001
        est.motion, est.n_sticks, est.stick_fraction, est.quality = 'stick-slip', 3, 0.4, 'ok'
        est.rms_residual = float('nan')
        pubs['/friction/estimate'].publish(est)

        got: dict[int, list[tuple[int, dict[str, Any]]]] = {1: [], 2: [], 3: []}
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline and (
            len(got[1]) < 30 or len(got[2]) < 30 or len(got[3]) < 1
        ):
            try:
                frame = ws.recv(timeout=1)
            except TimeoutError:
                continue
            if isinstance(frame, str):
                continue
            assert frame[0] == 0x01  # messageData
            sid, stamp = struct.unpack_from('<IQ', frame, 1)
            got[sid].append((stamp, json.loads(frame[13:])))

    # torsion: 30 bins of 10 samples, min/max/mean exact (JSON floats round-trip)
    assert len(got[1]) == 30
    for stamp, m in got[1]:
        seg = torsion[m['index'] : m['index'] + 10]
        assert m['n'] == 10 and m['unit'] == 'N m'
        assert m['min'] == seg.min() and m['max'] == seg.max()
        assert m['value'] == pytest.approx(seg.mean(), rel=1e-12)
        assert stamp == T0_NS + round(m['index'] * 1e9 / FS)  # log time = sample time
    assert sorted(m['index'] for _, m in got[1]) == list(range(0, 300, 10))
    # stick flags: first 20 bins stick (slope/C1 = w within noise/slope error
    # ~1e-3*sqrt(12/10)/1e-3 s/C1 ~ 5e-4 rad/s << 0.05), last 10 slip
    flags = {m['index']: m['stick'] for _, m in got[2]}
    assert [flags[i] for i in range(0, 300, 10)] == [1] * 20 + [0] * 10
    # the estimate at full rate with its bands and NaN -> null
    (stamp, e) = got[3][0]
    assert stamp == 1_700_000_001 * 1_000_000_000
    assert e['mu0'] == 0.131 and e['mu_inf'] == 0.098 and e['motion'] == 'stick-slip'
    assert e['mu0_lo'] == pytest.approx(0.131 - 2 * 0.002, rel=1e-12)
    assert e['rms_residual'] is None
    assert e['n_sticks'] == 3 and e['first_index'] == 10_000


def test_bad_parameters_are_rejected() -> None:
    from rclpy.parameter import Parameter

    from tribo_bringup.nodes.live_bridge import LiveBridgeNode
    from tribo_common.params import ParameterError

    rclpy.init()
    try:
        with pytest.raises(ParameterError, match='downsample_mode'):
            LiveBridgeNode(parameter_overrides=[Parameter('downsample_mode', value='median')])
        with pytest.raises(ParameterError, match='port'):
            LiveBridgeNode(parameter_overrides=[Parameter('port', value=70000)])
    finally:
        rclpy.try_shutdown()


def test_idle_bridge_does_no_work(graph: dict[str, Any]) -> None:
    # no client subscribed: blocks are dropped at once, nothing binned
    bridge, pubs = graph['bridge'], graph['pubs']
    assert wait(lambda: pubs['/rig/torsion_moment'].get_subscription_count() > 0, 10)
    for i in range(5):
        pubs['/rig/torsion_moment'].publish(block(np.zeros(100), 100 * i, 'N m'))
    done = threading.Event()
    wait(done.is_set, 0.5)
    assert bridge.forwarded == 0
