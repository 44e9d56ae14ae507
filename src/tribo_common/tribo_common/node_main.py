"""Start and stop a node the Jazzy way (``rclpy.init()`` returns None).

Every tribo executable's ``main`` calls :func:`run_node` with a factory; a
parameter error ends the process with one line on stderr and exit code 2.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol, TypedDict

import rclpy
from rclpy.context import Context
from rclpy.executors import (
    ExternalShutdownException,
    MultiThreadedExecutor,
    SingleThreadedExecutor,
)
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.utilities import ok as rclpy_ok
from rclpy.utilities import try_shutdown

from tribo_common.params import ParameterError


class NodeOptions(TypedDict, total=False):
    """Keyword arguments of ``rclpy.node.Node`` a tribo node passes on unchanged.

    A node class takes them as ``**kwargs: Unpack[NodeOptions]`` (the graph and
    the tests give parameter overrides and the namespace this way).
    """

    context: Context
    cli_args: list[str]
    namespace: str
    use_global_arguments: bool
    enable_rosout: bool
    start_parameter_services: bool
    parameter_overrides: list[Parameter]
    allow_undeclared_parameters: bool
    automatically_declare_parameters_from_overrides: bool


class SpinsOnce(Protocol):
    """An rclpy executor as :func:`spin_background` uses it."""

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run one callback or wait up to ``timeout_sec`` [s] for one."""


class _SigintLatch:
    """Python-level SIGINT handler under rclpy's: counts Ctrl-C, never raises.

    rclpy's own handler (installed by ``rclpy.init`` over this one and calling it)
    shuts the context down, which ends the spin; this handler only keeps Python
    from raising KeyboardInterrupt, so neither the first SIGINT nor a second one
    (a terminal's Ctrl-C plus the SIGINT ``ros2 launch`` forwards) lands in the
    middle of the shutdown (``close``, ``destroy_node``).
    """

    def __init__(self) -> None:
        self.count = 0

    def __call__(self, signum: int, frame: object) -> None:
        self.count += 1


def run_node(
    factory: Callable[[], Node], args: Sequence[str] | None = None, *, threads: int = 1
) -> int:
    """Create the node with ``factory`` and spin it until SIGINT / shutdown.

    ``threads`` > 1 uses a MultiThreadedExecutor; the default single-threaded
    executor costs far less CPU per message in rclpy (the tribo nodes do heavy work
    in their own threads, not in callbacks). Returns the process exit code (0, or 2
    on a parameter/configuration error). Ctrl-C, once or repeatedly, ends the node
    cleanly: its ``close`` (e.g. the wear monitor's last state write) always runs.
    """
    latch = _SigintLatch()
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGINT, latch)
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
        if latch.count == 0:
            name = node.get_name() if node is not None else _node_name(args)
            print(f'{name}: error: {exc}', file=sys.stderr)
            code = 2
    except Exception:
        # SIGINT shuts the context down from rclpy's handler; a spin that was just
        # building its wait set then fails with RCLError ("context is not valid")
        # instead of ExternalShutdownException: that is the same clean stop.
        if latch.count == 0 and rclpy_ok():
            raise
    finally:
        if node is not None:
            close = getattr(node, 'close', None)
            if callable(close):
                close()
            node.destroy_node()
        try_shutdown()
        if previous is not None:
            # after a Ctrl-C the process is ending: a further SIGINT, even during the
            # interpreter's exit (which resets Python-level handlers to the default,
            # but leaves an ignored signal ignored), must not kill it with -SIGINT
            signal.signal(signal.SIGINT, signal.SIG_IGN if latch.count else previous)
    return code


def _node_name(args: Sequence[str] | None) -> str:
    """Return the executable's name, for an error raised before the node exists."""
    argv0 = (list(args) if args is not None else sys.argv)[:1]
    return Path(argv0[0]).stem if argv0 and argv0[0] else 'node'


class SpinThread(threading.Thread):
    """The thread of :func:`spin_background`; :attr:`error` holds what ended it, if anything."""

    error: BaseException | None = None


def spin_background(
    executor: SpinsOnce, stop: threading.Event | None = None
) -> tuple[SpinThread, threading.Event]:
    """Spin ``executor`` in a daemon thread until the returned event is set.

    An exception raised by a callback ends the spin: it is kept in the thread's
    ``error`` attribute and the event is set, so the caller can report it (a
    shutdown of the context ends the spin without an error).
    """
    event = stop if stop is not None else threading.Event()

    def _spin() -> None:
        try:
            while not event.is_set():
                executor.spin_once(timeout_sec=0.1)
        except (ExternalShutdownException, KeyboardInterrupt):
            pass
        except Exception as exc:  # a callback failed, or the context went away
            if rclpy_ok():
                thread.error = exc
        finally:
            event.set()

    thread = SpinThread(target=_spin, daemon=True)
    thread.start()
    return thread, event
