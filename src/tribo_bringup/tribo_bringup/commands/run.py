"""``tribo run``: start the graph's nodes in one process (one executor)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tribo_bringup.paths import CONFIG


def register(sub: Any) -> None:
    """Add the ``run`` subcommand."""
    p = sub.add_parser(
        'run',
        help='run the node graph (simulated rig by default)',
        description='Start the tribo nodes in one process: with --sim (the default) the '
        'simulated rig and detector, plus the friction estimator and the wear monitor. '
        'The stand-in for the launch files (src/tribo_bringup/launch) on machines without '
        'ros2 launch.',
    )
    mode = p.add_mutually_exclusive_group()
    mode.add_argument('--sim', dest='sim', action='store_true', default=True, help='simulated rig')
    mode.add_argument(
        '--no-sim',
        dest='sim',
        action='store_false',
        help='no simulators (hardware drivers run separately)',
    )
    p.add_argument('--rig', default=str(CONFIG / 'rig.yaml'), help='RIG.yaml for the rig nodes')
    p.add_argument('--nvct', default=str(CONFIG / 'nvct.yaml'), help='NVCT.yaml (wear monitor)')
    p.add_argument(
        '--detector',
        default=str(CONFIG / 'sim_detector.yaml'),
        help='simulated detector configuration (sim_detector)',
    )
    p.add_argument(
        '--wear-state',
        default='',
        metavar='FILE',
        help='wear monitor state file (resumed if it exists; default: the node default)',
    )
    p.add_argument(
        '--params',
        nargs='*',
        default=None,
        help='ROS 2 parameter files (default: config/{friction_estimator,wear_monitor,'
        'model_monitor}.yaml where present)',
    )
    p.add_argument('--duration', type=float, default=0.0, help='seconds to run (0: until Ctrl-C)')
    p.add_argument('--record', metavar='BAG', help='also record all topics into this bag')
    p.add_argument('--bridge', action='store_true', help='also serve the Foxglove live bridge')
    p.add_argument(
        '--monitor',
        action=argparse.BooleanOptionalAction,
        default=True,
        help='run the live model monitor (model_monitor -> /model/discrepancy; default: on)',
    )
    p.add_argument(
        '--nodes', nargs='+', help='explicit node list (overrides --sim/--bridge selection)'
    )
    p.set_defaults(func=run)


def default_params() -> list[str]:
    """The parameter files in config/ used by default."""
    names = ('friction_estimator.yaml', 'wear_monitor.yaml', 'model_monitor.yaml')
    return [str(CONFIG / n) for n in names if (CONFIG / n).is_file()]


def run(args: argparse.Namespace) -> int:
    """Run until the duration is over or Ctrl-C."""
    from tribo_bringup import bagio
    from tribo_bringup.graph import Graph, rig_overrides

    if args.duration < 0:
        raise ValueError(f'--duration must be >= 0, got {args.duration}')
    nodes = args.nodes or (
        (['sim_rig', 'sim_detector'] if args.sim else []) + ['friction_estimator', 'wear_monitor']
    )
    if args.monitor and not args.nodes:
        nodes.append('model_monitor')
    if args.bridge and 'live_bridge' not in nodes:
        nodes.append('live_bridge')
    overrides = rig_overrides(args.rig)
    overrides['sim_detector'] = {'sim_config': str(Path(args.detector).resolve())}
    overrides['wear_monitor'] = {'nvct_config': str(Path(args.nvct).resolve())}
    if args.wear_state:
        overrides['wear_monitor']['state_file'] = str(Path(args.wear_state).resolve())
    graph = Graph(
        nodes=nodes,
        params_files=args.params if args.params is not None else default_params(),
        overrides=overrides,
    )
    writer = None
    try:
        graph.start()
        if args.record:
            from tribo_bringup.recorder import Recorder

            writer = bagio.BagWriter(args.record)
            writer.__enter__()
            graph.extra_nodes.append(Recorder(writer))
        print(f'run: nodes {", ".join(nodes)} (Ctrl-C to stop)', file=sys.stderr)
        graph.spin(args.duration, progress=lambda t: print(f'run: {t:6.1f} s', file=sys.stderr))
    finally:
        graph.close()
        if writer is not None:
            writer.close()
    if args.record:
        print(f'run: recorded {args.record}', file=sys.stderr)
        for c in bagio.check_streams(args.record, bagio.RIG_TOPICS):
            state = 'ok' if c.missing == 0 else f'{c.missing} samples MISSING'
            print(f'  {c.topic}: {c.samples} samples: {state}', file=sys.stderr)
    return 0
