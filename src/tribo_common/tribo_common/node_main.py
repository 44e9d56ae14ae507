"""Start and stop a node the Jazzy way (``rclpy.init()`` returns None).

Every tribo executable's ``main`` calls :func:`run_node` with a factory; a
parameter error ends the process with one line on stderr and exit code 2.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.executors import (
    ExternalShutdownException,
    MultiThreadedExecutor,
    SingleThreadedExecutor,
)
from rclpy.node import Node

from tribo_common.params import ParameterError


def run_node(
    factory: Callable[[], Node], args: Sequence[str] | None = None, *, threads: int = 1
) -> int:
    """Create the node with ``factory`` and spin it until SIGINT / shutdown.

    ``threads`` > 1 uses a MultiThreadedExecutor; the default single-threaded
    executor costs far less CPU per message in rclpy (the tribo nodes do heavy work
    in their own threads, not in callbacks). Returns the process exit code (0, or 2
    on a parameter/configuration error).
    """
    rclpy.init(args=list(args) if args is not None else None)
    node: Node | None = None
    code = 0
    try:
        node = factory()
        executor = (
            MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
        )
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ParameterError, ValueError, OSError) as exc:
        name = node.get_name() if node is not None else 'node'
        print(f'{name}: error: {exc}', file=sys.stderr)
        code = 2
    finally:
        if node is not None:
            close = getattr(node, 'close', None)
            if callable(close):
                close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code


def spin_background(
    executor: Any, stop: threading.Event | None = None
) -> tuple[threading.Thread, threading.Event]:
    """Spin ``executor`` in a daemon thread until the returned event is set."""
    event = stop if stop is not None else threading.Event()

    def _spin() -> None:
        try:
            while not event.is_set():
                executor.spin_once(timeout_sec=0.1)
        except Exception:  # shutdown races end the spin
            event.set()

    thread = threading.Thread(target=_spin, daemon=True)
    thread.start()
    return thread, event
