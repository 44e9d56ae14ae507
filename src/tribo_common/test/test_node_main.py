"""node_main: a worker's publishes stop when its node closes (needs rclpy: ``source env.sh``)."""

from __future__ import annotations

import threading
import time

import pytest

pytest.importorskip('rclpy', reason='needs rclpy: source env.sh')

from tribo_common.node_main import PublishGate


class _SlowPublisher:
    """Records messages; each publish takes ``delay`` [s]."""

    def __init__(self, delay: float = 0.0) -> None:
        self.delay = delay
        self.sent: list[object] = []
        self.started = threading.Event()

    def publish(self, msg: object) -> None:
        self.started.set()
        time.sleep(self.delay)
        self.sent.append(msg)


def test_gate_publishes_until_closed_then_refuses() -> None:
    gate, pub = PublishGate(), _SlowPublisher()
    assert gate.publish(pub, 1) is True
    gate.close()
    assert gate.publish(pub, 2) is False
    with gate.batch() as ok:
        assert ok is False
    assert pub.sent == [1]


def test_close_waits_for_the_publish_in_progress() -> None:
    """close() returns only after a publish that had started: nothing reaches the
    publisher after close() returned."""
    gate, pub = PublishGate(), _SlowPublisher(delay=0.3)
    worker = threading.Thread(target=gate.publish, args=(pub, 'late'))
    worker.start()
    assert pub.started.wait(5.0)
    gate.close()
    # the 0.3 s publish had finished when close() returned
    assert pub.sent == ['late']
    worker.join(5.0)
    assert gate.publish(pub, 'after') is False and pub.sent == ['late']
