"""node_main: a worker's publishes stop when its node closes; signals become a stop event.

Needs rclpy: ``source env.sh``.
"""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

pytest.importorskip('rclpy', reason='needs rclpy: source env.sh')

from tribo_common.node_main import PublishGate, stop_signals


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


def test_stop_signals_sets_the_event_and_keeps_later_signals_ignored() -> None:
    if threading.current_thread() is not threading.main_thread():
        pytest.skip('signal handlers are installed from the main thread only')
    before = signal.getsignal(signal.SIGINT)
    try:
        with stop_signals() as stop:
            assert not stop.is_set()
            os.kill(os.getpid(), signal.SIGINT)  # handled in Python: no KeyboardInterrupt
            assert stop.wait(1.0)
            os.kill(os.getpid(), signal.SIGTERM)  # a second signal is only counted
        # the process is ending: a further SIGINT must not interrupt its shutdown
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, before)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def test_stop_signals_restores_the_handlers_without_a_signal() -> None:
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    with stop_signals() as stop:
        assert signal.getsignal(signal.SIGINT) is not before[0]
    assert not stop.is_set()
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
