"""``tribo replay``: publish a recorded bag with its timing."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
    """Add the ``replay`` subcommand."""
    from tribo_bringup.argtypes import bounded_float

    p = sub.add_parser(
        'replay',
        help='publish a recorded bag with its timing',
        description='Publish the messages of a bag on their topics with the recorded timing '
        '(scaled by --rate), with the lossless data QoS.',
    )
    p.add_argument('bag', help='bag directory (or .mcap file)')
    p.add_argument(
        '--rate',
        type=bounded_float(1e-3, 1e3, zero_ok=True),
        default=1.0,
        help='speed factor (0: as fast as possible; else 0.001-1000)',
    )
    p.add_argument('--topics', nargs='+', help='topics to replay (default: all)')
    p.add_argument(
        '--wait-subscribers',
        type=float,
        default=2.0,
        metavar='S',
        help='wait up to S seconds for subscribers before publishing',
    )
    p.add_argument(
        '--min-subscribers',
        type=int,
        default=1,
        metavar='N',
        help='subscribers each topic must have before publishing (e.g. 2: an estimator and '
        'a recorder)',
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Replay the bag once."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import try_shutdown

    from tribo_bringup.recorder import Replayer
    from tribo_common.node_main import spin_background, stop_signals

    # SIGINT/SIGTERM only end the playing: the spin thread stops, the node is destroyed,
    # and only then is the context shut down
    with stop_signals() as interrupted:
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        try:
            node = Replayer(args.bag, args.topics, args.rate)
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            spin, stop = spin_background(executor)
            n = node.play(
                wait_subscribers=args.wait_subscribers,
                min_subscribers=args.min_subscribers,
                progress=lambda k, t: print(f'replay: {t:7.1f} s, {k} messages', file=sys.stderr),
                stop=interrupted,
            )
            stop.set()
            spin.join()  # spin steps are 0.1 s
            executor.shutdown()
            node.destroy_node()
        finally:
            try_shutdown()
    print(f'replay: published {n} messages from {args.bag}', file=sys.stderr)
    return 0
