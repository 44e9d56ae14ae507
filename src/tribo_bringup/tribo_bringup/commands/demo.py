"""``tribo demo``: the whole story on the simulated rig in about two minutes.

1. Run the live graph in this process: simulated rig (10 kHz) with one hidden
   model extension switched on, simulated nVCT detector (a 240 min wear test
   compressed into the run), friction estimator, live model monitor, wear monitor, and a recorder
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
import shutil
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from tribo_bringup.errors import BringupError, ConfigError
from tribo_bringup.paths import CONFIG

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers
    from tribo_bringup.bagio import BagWriter
    from tribo_bringup.graph import Graph

MARKER = '.tribo-demo'


def register(sub: Subparsers) -> None:
    """Add the ``demo`` subcommand."""
    p = sub.add_parser(
        'demo',
        help='simulated rig on the live graph, recorded, analysed and reported (make demo)',
        description='Run the simulated rig (one hidden effect on), the simulated nVCT detector, '
        'the friction estimator, the live model monitor and the wear monitor on the live ROS 2 '
        'graph for --duration '
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
        help='hidden effect switched on in the simulated rig, an effect family (or form) of '
        'the discrepancy workflow (tribo discrepancy --list-candidates): the rig of '
        'config/rig_hidden_<EFFECT>.yaml if present, else config/rig.yaml with the demo '
        "values of the family's first form that has them; or 'none' for config/rig.yaml "
        '(default %(default)s)',
    )
    p.add_argument('--rig', help='run this RIG.yaml (with its own effects) instead of --effect')
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


def rig_for_demo(base: str | None, effect: str) -> tuple[dict[str, object], str]:
    """Return the RIG.yaml contents with the hidden effect, and the file they came from.

    ``effect`` names an effect family or one of its forms (:mod:`candidates
    <tribo_estimation.core.discrepancy.candidates>`): its ``config/rig_hidden_<effect>.yaml``
    if present, else ``config/rig.yaml`` with the ``demo_effects`` of the first form (of the
    family, or the form itself) that has them.
    """
    from tribo_bringup.report.page import as_mapping
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.discrepancy import candidates

    demo_effects: dict[str, float] | None = None
    if base:
        path = Path(base)
    elif effect == 'none':
        path = CONFIG / 'rig.yaml'
    else:
        path = CONFIG / f'rig_hidden_{effect}.yaml'
        if not path.is_file():
            if effect in candidates.families():
                forms = candidates.forms(effect)
            elif effect in candidates.names():
                forms = (candidates.get(effect),)
            else:
                known = ', '.join(candidates.families())
                raise ConfigError(f'unknown effect {effect!r}; known: none, {known}')
            spec = next((f.demo_effects for f in forms if f.demo_effects is not None), None)
            if spec is None:
                raise ConfigError(f'effect {effect!r}: no {path.name} and no demo values')
            demo_effects = dict(spec)
            path = CONFIG / 'rig.yaml'
    load_rig_config(path)  # validates (names a missing key, a bad value)
    data: dict[str, object] = dict(yaml.safe_load(path.read_text(encoding='utf-8')))
    if demo_effects is None:
        return data, str(path)
    data['effects'] = {**as_mapping(data.get('effects') or {}), **demo_effects}
    return data, f'{path} + {effect} demo values'


def prepare_out(out: Path) -> None:
    """Create OUT (or clear a previous demo's bag and report; never foreign files)."""
    if out.exists() and any(out.iterdir()) and not (out / MARKER).exists():
        raise ConfigError(f'{out}: exists and is not a tribo demo directory (choose a new --out)')
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text('written by tribo demo\n', encoding='utf-8')
    for name in ('bag', 'report'):
        if (out / name).exists():
            shutil.rmtree(out / name)


def _say(msg: str) -> None:
    print(f'demo: {msg}', file=sys.stderr, flush=True)


def run_graph(rig_file: Path, bag: Path, duration: float, bridge: bool) -> list[str]:
    """Run the live graph with a recorder; returns the nodes run."""
    from tribo_bringup import bagio
    from tribo_bringup.graph import Graph, rig_overrides
    from tribo_bringup.recorder import Recorder

    over = rig_overrides(rig_file)
    time_scale = 240.0 * 60.0 / duration  # the 240 min wear test fills the run
    params: dict[str, dict[str, Any]] = {
        'sim_rig': {**over['sim_rig'], 'duration': float(duration)},
        'friction_estimator': over['friction_estimator'],
        'model_monitor': over['model_monitor'],
        'sim_detector': {
            'sim_config': str(CONFIG / 'sim_detector.yaml'),
            'time_scale': time_scale,
        },
        'wear_monitor': {
            'nvct_config': str(CONFIG / 'nvct.yaml'),
            'state_file': '',
            'rate_window_s': 600.0,
        },
        'live_bridge': dict(over['live_bridge']),
    }
    # the rig last: its stream starts at once, every subscriber should be there first
    wanted = ['sim_detector', 'friction_estimator', 'model_monitor', 'wear_monitor', 'sim_rig']
    if bridge:
        wanted.insert(0, 'live_bridge')
    graph = Graph(nodes=[], overrides=params)
    warm_up(rig_file)
    writer = bagio.BagWriter(bag)
    writer.__enter__()
    ran: list[str] = []
    try:
        graph.init_ros()
        # the recorder before the rig: the recording starts at the stream's first sample
        graph.extra_nodes.append(Recorder(writer))
        for name in wanted:
            node = graph.add(name)
            ran.append(name)
            if name == 'live_bridge':
                from tribo_bringup.nodes.live_bridge import LiveBridgeNode

                assert isinstance(node, LiveBridgeNode)
                _say(
                    f'watch live in Foxglove: open ws://127.0.0.1:{node.port} with the layout '
                    f'{CONFIG / "foxglove_layout.json"}'
                )
        _say(f'live graph: {", ".join(ran)} + recorder -> {bag}')
        _spin_recording(graph, writer, duration)
    finally:
        graph.close()
        writer.close()
    return ran


def warm_up(rig_file: Path) -> None:
    """Compile (or load from numba's cache) the rig model before the clock starts."""
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.simulate import simulate

    _say('preparing the rig model (numba kernel; compiled once, then cached)')
    t0 = time.monotonic()
    cfg = load_rig_config(rig_file)
    simulate(cfg.rig, cfg.friction, cfg.drive, 0.001, 10_000.0, extensions=cfg.extensions)
    _say(f'rig model ready ({time.monotonic() - t0:.1f} s)')


def _spin_recording(
    graph: Graph, writer: BagWriter, duration: float, wait_max: float = 600.0
) -> None:
    """Spin the graph until the recorder holds the rig's whole ``duration`` [s] of stream.

    The simulated rig stops after it; progress lines go to stderr, and the rig
    must start streaming within ``wait_max`` [s].

    Completion is counted in recorded rig blocks, not wall-clock time: if the machine
    is slow the run takes longer, but the session is always complete.
    """
    import threading

    from tribo_drivers.nodes.sim_rig import RIG_BLOCK_SIZE, RIG_SAMPLE_RATE

    n_blocks = round(duration * RIG_SAMPLE_RATE / RIG_BLOCK_SIZE)
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
        deadline = t0 + 3.0 * duration + 60.0
        while (blocks := writer.counts.get('/rig/torsion_moment', 0)) < n_blocks:
            now = time.monotonic()
            if not spinner.is_alive():
                raise BringupError('the graph stopped spinning unexpectedly')
            if now > deadline:
                raise BringupError(
                    f'the simulated rig delivered {blocks} of {n_blocks} blocks in '
                    f'{now - t0:.0f} s (machine overloaded?)'
                )
            if now - last >= 5.0:
                c = writer.counts
                _say(
                    f'{blocks * RIG_BLOCK_SIZE / RIG_SAMPLE_RATE:5.0f}/{duration:g} s: '
                    f'{blocks} rig blocks, '
                    f'{c.get("/friction/estimate", 0)} friction estimates, '
                    f'{c.get("/nvct/wear", 0)} wear states recorded'
                )
                last = now
            time.sleep(0.1)
        time.sleep(1.0)  # the estimate of the last block follows its final sample
        _say(f'live run finished after {time.monotonic() - t0:.1f} s')
    finally:
        stop.set()
        spinner.join(timeout=10.0)


def run(args: argparse.Namespace) -> int:
    """Run the demo; prints the report location and the summary."""
    from tribo_bringup.report import build_report
    from tribo_bringup.report.page import as_mapping

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
    effects = as_mapping(rig.get('effects') or {})
    _say(
        f'hidden effect: {args.effect} ('
        + (', '.join(f'{k}={v}' for k, v in effects.items()) or 'none')
        + f'; from {source})'
    )
    bag = out / 'bag'
    run_graph(rig_file, bag, float(args.duration), bool(args.bridge))

    window = (0.0, 0.0)
    report_notes: dict[str, str] = {}
    if not args.no_discrepancy:
        span = float(args.discrepancy_seconds)
        if span > 0:
            # from the first sample: the start from rest gives sticks of different lengths,
            # which tells dwell-time effects apart from a plain higher mu0
            window = (0.0, span)
            report_notes['discrepancy'] = (
                f'analysed the first {span:g} s of the bag to keep the demo short'
            )
    _say('analysing the recording')
    res = build_report(
        bag,
        out / 'report',
        rig=rig_file,
        nvct=CONFIG / 'nvct.yaml',
        discrepancy=not args.no_discrepancy,
        analysis_rig=nominal_file,
        discrepancy_window=window,
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
    return 0
