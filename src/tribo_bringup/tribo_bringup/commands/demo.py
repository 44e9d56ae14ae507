"""``tribo demo``: the whole story on the simulated rig in about two minutes.

1. Run the live graph in this process: simulated rig (10 kHz) with one hidden
   model extension switched on, simulated nVCT detector (a 240 min wear test
   compressed into the run), friction estimator, wear monitor, and a recorder
   writing every topic into ``OUT/bag``.
2. Check the bag's sample streams for gaps.
3. Run the analyses (``tribo friction``, ``tribo wear``) and the discrepancy
   workflow on the bag and write the session report ``OUT/report/report.html``.
4. Print where the report is and a five-line summary.

A node or analysis that is not available is left out with a note (the
report marks its section unavailable); only the simulated rig is required.
"""

from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import yaml

from tribo_bringup.errors import BringupError, ConfigError

CONFIG = Path(__file__).resolve().parents[4] / 'config'
MARKER = '.tribo-demo'

#: The paper's rig (Tab. 1) and a friction law with stick-slip at the nominal speed.
DEFAULT_RIG: dict[str, float] = {
    'I1': 0.0109,
    'K1': 0.04034,
    'C1': 2338.6,
    'I2': 0.0315,
    'K2': 4.0,
    'C2': 5975.0,
    'F_N': 8000.0,
    'R': 0.08,
    'mu0': 0.13,
    'mu_inf': 0.10,
    'k': 2.0,
    'nominal_speed': 3.1416,
    'ramp_time': 0.5,
    'noise_torque': 0.05,
    'noise_accel': 2.0,
}

#: Hidden effects used when config/rig_hidden_<name>.yaml does not exist
#: (fields of tribo_estimation.core.model.Extensions, SI units).
EFFECTS: dict[str, dict[str, float]] = {
    'none': {},
    'dwell_time_stiction': {'stiction_gain': 0.03, 'stiction_tau': 0.005},
    'frictional_lag': {'lag_tau': 0.003},
    'viscous': {'viscous': 2.0},
    'drift': {'drift_mu0': -2.0e-4, 'drift_mu_inf': -1.0e-4},
    'speed_ripple': {'ripple_amp': 0.3, 'ripple_freq': 4.0},
    'bearing_friction': {'bearing_moment': 2.0},
    'torque_offset': {'torque_offset': 1.5},
}

#: Options a discrepancy command may offer to limit the analysed span (first found is used).
WINDOW_OPTIONS = (('--start', '--duration'), ('--t-start', '--t-duration'), ('--t0', '--seconds'))


def register(sub: Any) -> None:
    """Add the ``demo`` subcommand."""
    p = sub.add_parser(
        'demo',
        help='simulated rig on the live graph, recorded, analysed and reported (make demo)',
        description='Run the simulated rig (one hidden effect on), the simulated nVCT detector, '
        'the friction estimator and the wear monitor on the live ROS 2 graph for --duration '
        'seconds, record everything, run the friction, wear and discrepancy analyses on the bag '
        'and write OUT/report/report.html. Prints progress while running and a five-line '
        'summary at the end.',
    )
    p.add_argument(
        '--duration', type=float, default=60.0, help='seconds of live run (default %(default)s)'
    )
    p.add_argument('--out', default='demo_output', help='output directory (default %(default)s)')
    p.add_argument(
        '--effect',
        default='dwell_time_stiction',
        help='hidden effect switched on in the simulated rig: config/rig_hidden_<EFFECT>.yaml '
        f'if present, else one of {", ".join(EFFECTS)} (default %(default)s)',
    )
    p.add_argument(
        '--rig', help='RIG.yaml to start from (default: config/rig.yaml or the paper rig)'
    )
    p.add_argument(
        '--discrepancy-seconds',
        type=float,
        default=5.0,
        help='seconds of the bag the discrepancy workflow analyses (0: all; default %(default)s)',
    )
    p.add_argument('--no-discrepancy', action='store_true', help='skip the discrepancy workflow')
    p.add_argument(
        '--no-bridge',
        dest='bridge',
        action='store_false',
        help='do not serve the Foxglove live bridge (default: served on ws://127.0.0.1:8765 '
        'while the demo runs; open it in Foxglove with config/foxglove_layout.json)',
    )
    p.set_defaults(func=run)


def rig_for_demo(base: str | None, effect: str) -> tuple[dict[str, Any], str]:
    """RIG.yaml contents with the hidden effect, and where the effect came from."""
    hidden = CONFIG / f'rig_hidden_{effect}.yaml'
    if hidden.is_file():
        data = yaml.safe_load(hidden.read_text(encoding='utf-8'))
        if not isinstance(data, dict):
            raise ConfigError(f'{hidden}: a rig file is a mapping')
        merged = dict(DEFAULT_RIG)
        merged.update(data)
        return merged, str(hidden)
    if effect not in EFFECTS:
        raise ConfigError(
            f'unknown effect {effect!r}: no {hidden.name} in config/ and not one of '
            f'{", ".join(EFFECTS)}'
        )
    base_path = Path(base) if base else CONFIG / 'rig.yaml'
    rig: dict[str, Any] = dict(DEFAULT_RIG)
    if base or base_path.is_file():
        data = yaml.safe_load(base_path.read_text(encoding='utf-8'))
        if not isinstance(data, dict):
            raise ConfigError(f'{base_path}: a rig file is a mapping')
        rig.update(data)
    rig['effects'] = dict(EFFECTS[effect])
    return rig, f'built-in effect {effect}'


def prepare_out(out: Path) -> None:
    """Create OUT (or clear a previous demo's bag and report; never foreign files)."""
    if out.exists() and any(out.iterdir()) and not (out / MARKER).exists():
        raise ConfigError(f'{out}: exists and is not a tribo demo directory (choose a new --out)')
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text('written by tribo demo\n', encoding='utf-8')
    for name in ('bag', 'report'):
        if (out / name).exists():
            shutil.rmtree(out / name)


def _node_class(name: str) -> Any | None:
    """The node class of a graph node name (tolerant of class-name variants); None if absent."""
    from rclpy.node import Node

    from tribo_bringup.graph import NODES

    module_name, cls_name = NODES[name]
    try:
        module = importlib.import_module(module_name)
    except ImportError:
        return None
    cls = getattr(module, cls_name, None)
    if cls is not None:
        return cls
    for obj in vars(module).values():
        if isinstance(obj, type) and issubclass(obj, Node) and obj.__module__ == module.__name__:
            return obj
    return None


def _say(msg: str) -> None:
    print(f'demo: {msg}', file=sys.stderr, flush=True)


def run_graph(
    rig_file: Path, bag: Path, duration: float, bridge: bool
) -> tuple[list[str], list[str]]:
    """Run the live graph with a recorder; returns (nodes run, notes about nodes left out)."""
    from rclpy.parameter import Parameter

    from tribo_bringup import bagio
    from tribo_bringup.graph import Graph, rig_overrides
    from tribo_bringup.recorder import Recorder

    over = rig_overrides(rig_file)
    time_scale = 240.0 * 60.0 / duration  # the 240 min wear test fills the run
    params: dict[str, dict[str, Any]] = {
        'sim_rig': over['sim_rig'],
        'friction_estimator': over['friction_estimator'],
        'sim_detector': {
            'sim_config': str(CONFIG / 'sim_detector.yaml'),
            'time_scale': time_scale,
        },
        'wear_monitor': {
            'nvct_config': str(CONFIG / 'nvct.yaml'),
            'state_file': '',
            'rate_window_s': 600.0,
        },
        'live_bridge': {'C1': float(over['friction_estimator']['C1'])},
    }
    # the rig last: its stream starts at once, every subscriber should be there first
    wanted = ['sim_detector', 'friction_estimator', 'wear_monitor', 'sim_rig']
    if bridge:
        wanted.insert(0, 'live_bridge')
    graph = Graph(nodes=[])
    warm_up(over['sim_rig'])
    writer = bagio.BagWriter(bag)
    writer.__enter__()
    ran: list[str] = []
    notes: list[str] = []
    try:
        graph.start()
        graph.extra_nodes.append(Recorder(writer))
        for name in wanted:
            cls = _node_class(name)
            if cls is None:
                notes.append(f'{name} not available (module missing): left out')
                continue
            overrides = [Parameter(k, value=v) for k, v in params.get(name, {}).items()]
            try:
                try:
                    node = cls(parameter_overrides=overrides)
                except TypeError:  # a node class that takes no rclpy Node keyword arguments
                    node = cls()
                    notes.append(f'{name} does not take parameter overrides: ran with defaults')
            except Exception as exc:  # one node failing leaves the others running
                if name == 'sim_rig':
                    raise BringupError(f'the simulated rig cannot start: {exc}') from exc
                notes.append(f'{name} failed to start ({type(exc).__name__}: {exc}): left out')
                continue
            graph.extra_nodes.append(node)
            ran.append(name)
            if name == 'live_bridge':
                _say(
                    f'watch live in Foxglove: open ws://127.0.0.1:{node.port} with the layout '
                    f'{CONFIG / "foxglove_layout.json"}'
                )
        if 'sim_rig' not in ran:
            raise BringupError('the simulated rig (tribo_drivers sim_rig) is not available')
        for n in notes:
            _say(n)
        _say(f'live graph: {", ".join(ran)} + recorder -> {bag}')
        _spin_recording(graph, writer, duration)
    finally:
        graph.close()
        writer.close()
    return ran, notes


def warm_up(rig: dict[str, Any]) -> None:
    """Compile (or load from numba's cache) the rig model before the clock starts."""
    try:
        from tribo_estimation.core.model import DriveProfile, Extensions, FrictionLaw, RigParams
        from tribo_estimation.core.simulate import simulate
    except ImportError:
        return
    _say('preparing the rig model (numba kernel; compiled once, then cached)')
    t0 = time.monotonic()
    effects = {k[len('effects.') :]: v for k, v in rig.items() if k.startswith('effects.')}
    simulate(
        RigParams(*(float(rig[k]) for k in ('I1', 'K1', 'C1', 'I2', 'K2', 'C2', 'F_N', 'R'))),
        FrictionLaw(float(rig['mu0']), float(rig['mu_inf']), float(rig['k'])),
        DriveProfile(float(rig['nominal_speed']), float(rig.get('ramp_time', 0.0))),
        0.001,
        10_000.0,
        extensions=Extensions(**effects),
    )
    _say(f'rig model ready ({time.monotonic() - t0:.1f} s)')


def _spin_recording(graph: Any, writer: Any, duration: float, wait_max: float = 600.0) -> None:
    """Spin the graph; record ``duration`` [s] from the first rig block on, with progress."""
    import threading

    stop = threading.Event()
    spinner = threading.Thread(
        target=graph.spin, kwargs={'duration': 0.0, 'stop': stop}, daemon=True
    )
    spinner.start()
    try:
        t_wait = time.monotonic()
        last = t_wait
        while writer.counts.get('/rig/torsion_moment', 0) == 0:
            now = time.monotonic()
            if now - t_wait > wait_max:
                raise BringupError(f'the simulated rig published nothing in {wait_max:.0f} s')
            if now - last >= 10.0:
                _say(f'waiting for the simulated rig to stream ({now - t_wait:.0f} s)')
                last = now
            time.sleep(0.1)
        t0 = time.monotonic()
        last = t0
        _say(f'recording {duration:g} s')
        while (now := time.monotonic()) - t0 < duration:
            if not spinner.is_alive():
                raise BringupError('the graph stopped spinning unexpectedly')
            if now - last >= 5.0:
                c = writer.counts
                _say(
                    f'{now - t0:5.0f}/{duration:g} s: '
                    f'{c.get("/rig/torsion_moment", 0)} rig blocks, '
                    f'{c.get("/friction/estimate", 0)} friction estimates, '
                    f'{c.get("/nvct/wear", 0)} wear states recorded'
                )
                last = now
            time.sleep(0.1)
        _say(f'live run finished after {time.monotonic() - t0:.1f} s')
    finally:
        stop.set()
        spinner.join(timeout=10.0)


def run(args: argparse.Namespace) -> int:
    """Run the demo; prints the report location and the summary."""
    from tribo_bringup.report import build_report, command_options

    if not 2.0 <= args.duration <= 3600.0:
        raise ConfigError(f'--duration must be between 2 and 3600 s, got {args.duration}')
    if args.discrepancy_seconds < 0:
        raise ConfigError(f'--discrepancy-seconds must be >= 0, got {args.discrepancy_seconds}')
    t0 = time.monotonic()
    out = Path(args.out)
    prepare_out(out)
    rig, source = rig_for_demo(args.rig, args.effect)
    rig_file = out / 'rig_used.yaml'
    rig_file.write_text(yaml.safe_dump(rig, sort_keys=False), encoding='utf-8')
    # the analyses get the nominal rig: the hidden effect is for them to find
    nominal_file = out / 'rig_nominal.yaml'
    nominal_file.write_text(yaml.safe_dump({**rig, 'effects': {}}, sort_keys=False), 'utf-8')
    effects = rig.get('effects') or {}
    _say(
        f'hidden effect: {args.effect} ('
        + (', '.join(f'{k}={v}' for k, v in effects.items()) or 'none')
        + f'; from {source})'
    )
    bag = out / 'bag'
    _ran, notes = run_graph(rig_file, bag, float(args.duration), bool(args.bridge))

    extra: dict[str, list[str]] = {}
    report_notes: dict[str, str] = {}
    if not args.no_discrepancy:
        opts = command_options('discrepancy') or set()
        span = float(args.discrepancy_seconds)
        if span > 0:
            # from the first sample: the start from rest gives sticks of different lengths,
            # which tells dwell-time effects apart from a plain higher mu0
            start = 0.0
            pair = next((p for p in WINDOW_OPTIONS if p[0] in opts and p[1] in opts), None)
            if pair is not None:
                extra['discrepancy'] = [pair[0], f'{start:g}', pair[1], f'{span:g}']
                report_notes['discrepancy'] = (
                    f'analysed {span:g} s of the bag (from t = {start:g} s) to keep the demo short'
                )
            else:
                report_notes['discrepancy'] = 'whole bag analysed (no window option)'
    _say('analysing the recording')
    res = build_report(
        bag,
        out / 'report',
        rig=rig_file,
        nvct=CONFIG / 'nvct.yaml',
        discrepancy=not args.no_discrepancy,
        analysis_rig=nominal_file,
        analyses=('friction', 'wear'),
        extra_args=extra,
        notes=report_notes,
        command=['tribo', *sys.argv[1:]]
        if Path(sys.argv[0]).name not in ('pytest', '-c')
        else None,
        progress=_say,
    )
    print(f'\nReport: {res.html.resolve()}')
    print(f'(finished in {time.monotonic() - t0:.0f} s; hidden effect: {args.effect})')
    for line in res.summary:
        print(f'  {line}')
    for n in notes:
        print(f'  note: {n}')
    return 0
