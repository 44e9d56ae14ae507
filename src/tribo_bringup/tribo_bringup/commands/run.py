"""``tribo run``: start the graph's nodes in one process (one executor)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.errors import ConfigError
from tribo_bringup.paths import CONFIG
from tribo_common.nodes import BY_NAME, NodeInfo, NodeKind, of_kind

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
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
        help='wear monitor state file (default: $ROS_HOME/tribo_nvct/wear_state.json, '
        'ROS_HOME defaulting to ~/.ros)',
    )
    p.add_argument(
        '--resume',
        action='store_true',
        help='resume the wear test saved in the state file (default with --no-sim; a '
        'simulated run starts a fresh test and keeps the old state as a .bak file)',
    )
    p.add_argument(
        '--namespace',
        default='',
        metavar='NS',
        help='run the nodes in namespace NS (topics /NS/rig/..., as __ns:=/NS): several '
        'rigs on one graph',
    )
    for node in of_kind(NodeKind.DRIVER):
        for opt in node.run_options:
            p.add_argument(opt.flag, metavar=opt.metavar, help=opt.help)
    p.add_argument(
        '--params',
        nargs='*',
        default=None,
        help='ROS 2 parameter files (default: the config/ files of the nodes run, but the '
        "simulators')",
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
        '--nodes',
        nargs='+',
        metavar='NODE',
        help=f'explicit node list, of {", ".join(BY_NAME)} (overrides --sim/--bridge selection)',
    )
    p.set_defaults(func=run)


def default_params(nodes: list[str]) -> list[str]:
    """Return the ROS parameter files in config/ of the nodes run (not the simulators').

    The simulated rig takes its parameters from ``--rig`` instead.
    """
    names = [
        BY_NAME[n].config
        for n in nodes
        if n in BY_NAME and BY_NAME[n].config and BY_NAME[n].kind is not NodeKind.SIMULATOR
    ]
    return [str(CONFIG / n) for n in names if (CONFIG / n).is_file()]


def select_nodes(args: argparse.Namespace) -> list[str]:
    """Return the nodes of a ``tribo run``.

    Explicit ``--nodes``, else the simulators (unless ``--no-sim``), the drivers
    whose option is given, the estimators, the model monitor (unless
    ``--no-monitor``) and the bridge (``--bridge``).
    """
    if args.nodes:
        nodes = list(args.nodes)
    else:
        nodes = [n.name for n in of_kind(NodeKind.SIMULATOR)] if args.sim else []
        nodes += [n.name for n in of_kind(NodeKind.DRIVER) if _started(n, args)]
        nodes += [n.name for n in of_kind(NodeKind.ESTIMATOR)]
        if getattr(args, 'monitor', False):
            nodes += [n.name for n in of_kind(NodeKind.MONITOR)]
    if args.bridge:
        nodes += [n.name for n in of_kind(NodeKind.BRIDGE) if n.name not in nodes]
    return nodes


def _started(node: NodeInfo, args: argparse.Namespace) -> bool:
    """Return whether an option that starts ``node`` was given."""
    return any(o.starts and getattr(args, o.dest, None) for o in node.run_options)


def driver_overrides(args: argparse.Namespace) -> dict[str, dict[str, object]]:
    """Return the parameter values the drivers' ``tribo run`` options set, per node."""
    out: dict[str, dict[str, object]] = {}
    for node in of_kind(NodeKind.DRIVER):
        if not _started(node, args):
            continue
        for opt in node.run_options:
            value = getattr(args, opt.dest, None)
            if value:
                out.setdefault(node.name, {})[opt.parameter] = value
    return out


def run(args: argparse.Namespace) -> int:
    """Run until the duration is over or Ctrl-C."""
    from tribo_bringup import bagio
    from tribo_bringup.graph import Graph, rig_overrides
    from tribo_common.topics import normalize_namespace

    if args.duration < 0:
        raise ConfigError(f'--duration must be >= 0, got {args.duration}')
    nodes = select_nodes(args)
    overrides = rig_overrides(args.rig)
    overrides['sim_detector'] = {'sim_config': str(Path(args.detector).resolve())}
    overrides['wear_monitor'] = {'nvct_config': str(Path(args.nvct).resolve())}
    if args.wear_state:
        overrides['wear_monitor']['state_file'] = str(Path(args.wear_state).resolve())
    # a simulated rig starts a new wear test unless asked to resume; real rigs resume
    simulated = 'sim_detector' in nodes
    overrides['wear_monitor']['fresh_start'] = simulated and not args.resume
    if args.record and 'sim_rig' in nodes:
        # the simulated rig waits for the recorder (and the estimator, the bridge) to
        # match, so that the bag holds the stream from its first sample
        subscribers = 1 + sum(n in nodes for n in ('friction_estimator', 'live_bridge'))
        overrides.setdefault('sim_rig', {})['min_subscribers'] = subscribers
    overrides.update(driver_overrides(args))
    ns = normalize_namespace(args.namespace)
    graph = Graph(
        nodes=nodes,
        params_files=args.params if args.params is not None else default_params(nodes),
        overrides=overrides,
        namespace=ns,
    )
    writer = None
    try:
        graph.start()
        if args.record:
            from tribo_bringup.recorder import Recorder

            writer = bagio.BagWriter(args.record)
            graph.extra_nodes.append(Recorder(writer, namespaces=[ns]))
        where = f' in namespace {ns}' if ns else ''
        print(f'run: nodes {", ".join(nodes)}{where} (Ctrl-C to stop)', file=sys.stderr)
        graph.spin(args.duration, progress=lambda t: print(f'run: {t:6.1f} s', file=sys.stderr))
    finally:
        graph.close()
        if writer is not None:
            writer.close()
    if args.record:
        recorder_error = next(
            (n.error for n in graph.extra_nodes if getattr(n, 'error', None) is not None), None
        )
        if recorder_error is not None:
            from tribo_bringup.recorder import RecordingError

            raise RecordingError(f'recording into {args.record} failed: {recorder_error}')
        print(f'run: recorded {args.record}', file=sys.stderr)
        for c in bagio.check_streams(args.record, [ns + t for t in bagio.RIG_TOPICS]):
            state = 'ok' if c.missing == 0 else f'{c.missing} samples MISSING'
            print(f'  {c.topic}: {c.samples} samples: {state}', file=sys.stderr)
    return 0
