"""``tribo record``: record the graph's topics into a bag (rosbags; MCAP by default)."""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING

from tribo_bringup.errors import ConfigError

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
    """Add the ``record`` subcommand."""
    p = sub.add_parser(
        'record',
        help='record the graph topics into a bag',
        description='Subscribe to the graph topics (raw CDR, lossless QoS) and write them '
        'into a rosbag2 bag (MCAP by default, sqlite3 on request) that ros2 bag info opens. '
        'At the end the sample streams are checked for gaps by their first-sample indices.',
    )
    p.add_argument('--out', required=True, help='bag directory to create')
    p.add_argument(
        '--duration', type=float, default=0.0, help='seconds to record (0: until Ctrl-C)'
    )
    p.add_argument(
        '--idle-stop',
        type=float,
        default=0.0,
        metavar='S',
        help='stop once no message has arrived for S seconds after the first one '
        '(end of a replay or of a test; 0: off)',
    )
    p.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap', help='bag storage')
    p.add_argument('--topics', nargs='+', help='topics to record (default: all graph topics)')
    p.add_argument(
        '--namespace',
        action='append',
        metavar='NS',
        help='record the rig in namespace NS (repeat for several rigs; default: the root '
        'namespace); the topics are recorded under their full names, /NS/rig/...',
    )
    p.add_argument('--discover', action='store_true', help='also record other topics that appear')
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Record until the duration is over, Ctrl-C, or a recording error (exit 2)."""
    if args.duration < 0:
        raise ConfigError(f'--duration must be >= 0, got {args.duration}')
    if args.idle_stop < 0:
        raise ConfigError(f'--idle-stop must be >= 0, got {args.idle_stop}')
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import try_shutdown

    from tribo_bringup import bagio
    from tribo_bringup.recorder import Recorder, RecordingError
    from tribo_common.node_main import spin_background, stop_signals

    topics = None
    if args.topics:
        names = ['/' + t.lstrip('/') for t in args.topics]
        unknown = [t for t in names if t not in bagio.TOPIC_TYPES]
        if unknown:
            raise ConfigError(
                f'unknown topic(s) {", ".join(unknown)}; known: {", ".join(bagio.TOPIC_TYPES)}'
            )
        topics = {t: bagio.TOPIC_TYPES[t] for t in names}
    # not opened here: the recorder's writer thread opens, writes and closes the bag
    writer = bagio.BagWriter(args.out, storage=args.storage)
    node: Recorder | None = None
    failure: BaseException | None = None
    # SIGINT/SIGTERM only end the loop below: the spin thread and the writer stop, the
    # node is destroyed, and only then is the context shut down
    with stop_signals() as interrupted:
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        try:
            node = Recorder(writer, topics, discover=args.discover, namespaces=args.namespace)
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            spinner, stop = spin_background(executor)
            t0 = time.monotonic()
            last = t0
            seen, last_msg = 0, t0
            while not stop.is_set() and not interrupted.is_set() and not node.failed.is_set():
                now = time.monotonic()
                if args.duration and now - t0 >= args.duration:
                    break
                if node.received != seen:
                    seen, last_msg = node.received, now
                elif args.idle_stop and seen and now - last_msg >= args.idle_stop:
                    print(
                        f'record: no message for {args.idle_stop:g} s, stopping',
                        file=sys.stderr,
                    )
                    break
                if now - last >= 5.0:
                    print(f'record: {now - t0:6.1f} s, {node.received} messages', file=sys.stderr)
                    last = now
                interrupted.wait(0.05)
            stop.set()
            spinner.join()  # spin steps are 0.1 s: no callback runs after this
            executor.shutdown()
            failure = spinner.error
        finally:
            if node is not None:
                node.close()  # writes what is queued and finishes the bag
                failure = node.error or failure
                node.destroy_node()
            try_shutdown()
    for topic, n in sorted(writer.counts.items()):
        print(f'  {topic}: {n} messages', file=sys.stderr)
    if failure is not None:
        raise RecordingError(
            f'recording into {args.out} failed after {sum(writer.counts.values())} messages '
            f'({type(failure).__name__}: {failure}); what was written before is readable'
        )
    print(f'record: wrote {args.out}', file=sys.stderr)
    for c in bagio.check_streams(args.out):
        state = 'ok' if c.missing == 0 else f'{c.missing} samples MISSING in {c.gaps} gap(s)'
        print(
            f'  {c.topic}: {c.samples} samples from index {c.first_index}: {state}', file=sys.stderr
        )
    return 0
