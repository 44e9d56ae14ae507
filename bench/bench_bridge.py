"""Live bridge under load: 3 Foxglove clients while the simulated rig streams at 10 kHz.

Runs sim_rig + live_bridge + a recorder in one process (the graph runner),
connects 3 WebSocket clients that subscribe to every channel, and after
``--seconds`` checks the recorded rig streams for missing samples (first
indices) and prints what each client received.

    source env.sh && python bench/bench_bridge.py [--seconds 30]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault('ROS_DOMAIN_ID', str(30 + os.getpid() % 60))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'


def client(port: int, stop: threading.Event, stats: dict[str, float]) -> None:
    """Run a Foxglove WebSocket client that subscribes to every advertised channel."""
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    protocols = ['foxglove.sdk.v1', 'foxglove.websocket.v1']
    with connect(f'ws://127.0.0.1:{port}', subprotocols=protocols) as ws:  # type: ignore[arg-type]
        next_id = 1
        while not stop.is_set():
            try:
                frame = ws.recv(timeout=0.5)
            except TimeoutError:
                continue
            except ConnectionClosed:  # the bridge stopped at the end of the run
                return
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg.get('op') == 'advertise':
                    subs = []
                    for ch in msg['channels']:
                        subs.append({'id': next_id, 'channelId': ch['id']})
                        next_id += 1
                    ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))
                continue
            stats['messages'] += 1
            stats['bytes'] += len(frame)


def main() -> int:
    """Run the bridge benchmark (clients, message rates, CPU) and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument('--seconds', type=float, default=30.0)
    parser.add_argument('--clients', type=int, default=3)
    args = parser.parse_args()

    from tribo_bringup import bagio
    from tribo_bringup.graph import Graph
    from tribo_bringup.recorder import Recorder

    tmp = Path(tempfile.mkdtemp(prefix='bench_bridge_'))
    bag = tmp / 'bag'
    graph = Graph(nodes=['sim_rig', 'live_bridge'], overrides={'live_bridge': {'port': 0}})
    writer = bagio.BagWriter(bag)
    writer.__enter__()
    stop = threading.Event()
    stats = [{'messages': 0.0, 'bytes': 0.0} for _ in range(args.clients)]
    try:
        graph.start()
        bridge = graph._instances[1]
        rig_topics = {t: bagio.TOPIC_TYPES[t] for t in bagio.RIG_TOPICS}
        graph.extra_nodes.append(Recorder(writer, rig_topics))
        threads = [
            threading.Thread(target=client, args=(bridge.port, stop, s), daemon=True) for s in stats
        ]
        for t in threads:
            t.start()
        spin_stop = threading.Event()
        spinner = threading.Thread(
            target=graph.spin, kwargs={'duration': 0.0, 'stop': spin_stop}, daemon=True
        )
        spinner.start()
        t_wait = time.monotonic()
        while writer.counts.get('/rig/torsion_moment', 0) == 0:  # numba compile of the rig
            if time.monotonic() - t_wait > 600:
                print('bench_bridge: the simulated rig did not start in 600 s', file=sys.stderr)
                return 2
            time.sleep(0.1)
        print(f'bench_bridge: rig streaming after {time.monotonic() - t_wait:.1f} s', flush=True)
        cpu0 = time.process_time()
        t0 = time.monotonic()
        time.sleep(args.seconds)
        wall = time.monotonic() - t0
        cpu = time.process_time() - cpu0
        spin_stop.set()
        spinner.join(timeout=10)
    finally:
        stop.set()
        graph.close()
        writer.close()
    checks = bagio.check_streams(bag, bagio.RIG_TOPICS)
    print(f'bench_bridge: {args.seconds:g} s, sim_rig at 10 kHz, {args.clients} clients')
    for c in checks:
        print(
            f'  {c.topic}: {c.samples} samples ({c.samples / wall:.0f}/s), '
            f'missing {c.missing}, gaps {c.gaps}'
        )
    for i, s in enumerate(stats):
        print(
            f'  client {i + 1}: {s["messages"]:.0f} messages ({s["messages"] / wall:.0f}/s), '
            f'{s["bytes"] / wall / 1024:.0f} KiB/s'
        )
    print(f'  process CPU {100 * cpu / wall:.0f} % of one core over {wall:.1f} s')
    ok = bool(checks) and all(c.missing == 0 for c in checks)
    print('  rig streams lossless' if ok else '  SAMPLES LOST on the rig streams')
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
