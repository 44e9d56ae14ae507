"""Start and stop a node: the shared ``main`` of every tribo executable.

Every tribo executable's ``main`` calls :func:`run_node` with a factory; a
parameter error ends the process with one line on stderr and exit code 2. A
node's threads stop before its context is shut down: :func:`run_node` calls the
node's ``close`` first, and a worker thread publishes through a
:class:`PublishGate` that ``close`` shuts.
"""

from __future__ import annotations

import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Protocol, TypedDict

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
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


class Publishes(Protocol):
    """An rclpy publisher as :class:`PublishGate` uses it."""

    def publish(self, msg: object) -> None:
        """Publish one message."""


class Subscribed(Protocol):
    """An rclpy publisher as :func:`wait_for_subscribers` uses it."""

    def get_subscription_count(self) -> int:
        """Return the number of matched subscriptions."""


#: Wait after the subscriptions have matched, before the first message [s]: discovery is
#: two-sided, the subscriber may match the publisher a little after the publisher did,
#: and a volatile subscriber drops what arrives in between.
SUBSCRIBER_SETTLE_S = 0.3


def wait_for_subscribers(
    pubs: Mapping[str, Subscribed],
    timeout: float,
    min_count: int = 1,
    stop: threading.Event | None = None,
) -> dict[str, int]:
    """Wait until every publisher of ``pubs`` has ``min_count`` subscriptions.

    At most ``timeout`` [s] (or until ``stop`` is set), then :data:`SUBSCRIBER_SETTLE_S`.

    Parameters
    ----------
    pubs : mapping of str to publisher
        Topic -> its publisher.
    timeout : float
        Longest wait [s].
    min_count : int
        Subscriptions each publisher needs.
    stop : threading.Event, optional
        Ends the wait when set.

    Returns
    -------
    dict of str to int
        The topics still short of subscriptions, with their counts (empty: all matched).
    """
    wait = (stop or threading.Event()).wait
    deadline = time.monotonic() + timeout
    while True:
        short = {t: n for t, p in pubs.items() if (n := p.get_subscription_count()) < min_count}
        if not short:
            wait(SUBSCRIBER_SETTLE_S)
            return short
        if time.monotonic() >= deadline or wait(0.05):
            return short


class PublishGate:
    """Lets a node's worker thread publish only until the node closes.

    :meth:`close` waits for a publish in progress and refuses every later one, so
    nothing reaches rclpy once the node's ``close`` has returned, even while the
    worker is still computing: :func:`run_node` and the graph runner shut the
    context down only after ``close``.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._open = True

    @contextmanager
    def batch(self) -> Iterator[bool]:
        """Hold the gate for several publishes: yields whether they may go out.

        Yields
        ------
        bool
            True while the gate is open; :meth:`close` waits for the batch to end.
        """
        with self._lock:
            yield self._open

    def publish(self, publisher: Publishes, msg: object) -> bool:
        """Publish ``msg`` unless the gate is closed.

        Parameters
        ----------
        publisher : Publishes
            The rclpy publisher.
        msg : object
            The message.

        Returns
        -------
        bool
            True if published, False once the gate is closed.
        """
        with self.batch() as ok:
            if ok:
                publisher.publish(msg)
            return ok

    def close(self) -> None:
        """Refuse every later publish (returns after a publish in progress)."""
        with self._lock:
            self._open = False


class _StopRequest:
    """Python-level handler of SIGINT and SIGTERM: asks the spin to end, never raises.

    rclpy's own signal handlers are not installed (they shut the context down at
    once, while the node's threads may still publish). The first signal ends the
    spin; later ones (a terminal's Ctrl-C plus the SIGINT ``ros2 launch``
    forwards, or its SIGTERM escalation) are counted and ignored, so none lands
    in the middle of the shutdown (``close``, ``destroy_node``).
    """

    def __init__(self) -> None:
        self.count = 0
        self.event = threading.Event()

    def __call__(self, _signum: int, _frame: object) -> None:
        self.count += 1
        self.event.set()


#: Longest wait of one spin step [s]: how soon a signal ends the spin.
SPIN_STEP_S = 0.1

#: Signals that stop a node (Ctrl-C; the SIGTERM of ``ros2 launch``'s escalation).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def stop_signals() -> Iterator[threading.Event]:
    """Turn SIGINT and SIGTERM into an event while a command runs (:class:`_StopRequest`).

    For a process that calls ``rclpy.init`` with ``SignalHandlerOptions.NO``: the
    caller polls the event, stops its threads, destroys its nodes and only then
    shuts the context down. After a stop signal, later ones stay ignored until the
    process ends; otherwise the previous handlers come back. Outside the main
    thread no handler is installed and the event is only set by the caller.

    Yields
    ------
    threading.Event
        Set by the first SIGINT or SIGTERM.
    """
    stop = _StopRequest()
    main_thread = threading.current_thread() is threading.main_thread()
    previous = {sig: signal.signal(sig, stop) for sig in STOP_SIGNALS if main_thread}
    try:
        yield stop.event
    finally:
        for sig, handler in previous.items():
            # after a stop signal the process is ending: a further one, even during the
            # interpreter's exit (which resets Python-level handlers to the default, but
            # leaves an ignored signal ignored), must not kill it
            signal.signal(sig, signal.SIG_IGN if stop.count else handler)


def run_node(factory: Callable[[], Node], args: Sequence[str] | None = None) -> int:
    """Create the node with ``factory`` and spin it until SIGINT, SIGTERM or shutdown.

    The node spins on a SingleThreadedExecutor (the tribo nodes do heavy work in
    their own threads, not in callbacks). The stop order is fixed: the spin ends,
    the node's ``close`` stops its threads (e.g. the wear monitor's last state
    write, a worker's last publish), the node is destroyed, and only then is the
    context shut down; a further SIGINT or SIGTERM meanwhile is ignored.

    Parameters
    ----------
    factory : Callable[[], Node]
        Builds the node (after ``rclpy.init``).
    args : Sequence[str] or None
        Command line (``sys.argv`` when None).

    Returns
    -------
    int
        The process exit code: 0, or 2 on a parameter or configuration error (one
        line on stderr).
    """
    with stop_signals() as stop:
        rclpy.init(
            args=list(args) if args is not None else None,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        node: Node | None = None
        code = 0
        try:
            node = factory()
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            while not stop.is_set() and rclpy_ok():
                executor.spin_once(timeout_sec=SPIN_STEP_S)
        except ExternalShutdownException:
            pass
        except (ParameterError, ValueError, OSError) as exc:
            if not stop.is_set():
                name = node.get_name() if node is not None else _node_name(args)
                print(f'{name}: error: {exc}', file=sys.stderr)
                code = 2
        finally:
            if node is not None:
                close = getattr(node, 'close', None)
                if callable(close):
                    close()
                node.destroy_node()
            try_shutdown()
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
