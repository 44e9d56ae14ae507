"""``tribo discrepancy``: find the physics the rig model is missing.

    tribo discrepancy INPUT --rig RIG.yaml --out DIR [--start S] [--duration S]
    tribo discrepancy A B C --rig RIG.yaml --out DIR [--shared-friction]
        (several records, fitted jointly)

INPUT is a rig CSV (``time,torsion_moment,angular_acceleration,speed``) or a
bag (rosbag2 directory or ``.mcap``) with the ``/rig/torsion_moment``,
``/rig/angular_acceleration`` and ``/rig/speed`` SampleBlock streams. The
baseline (the paper's model, Equ. 1-8, with the record's instrument chain and
drive profile) is fitted; when it does not explain the record down to what noise
leaves (the null law of this record, a parametric bootstrap), every form of every
candidate family is fitted and a family is named only when it alone explains the
record; several that do are a set the record cannot tell apart, with the
experiment that would. Writes ``DIR/discrepancy.json`` (rms of the torsion-moment
residual in N m) and PNG plots; progress goes to stderr.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_float, bounded_int

if TYPE_CHECKING:
    from collections.abc import Sequence

    from tribo_bringup.argtypes import Subparsers


class _ListCandidates(argparse.Action):
    """``--list-candidates``: print the library of candidate effects and exit.

    The registry is imported only here, so ``tribo discrepancy --help`` starts at once.
    """

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[object] | None,
        option_string: str | None = None,
    ) -> None:
        from tribo_estimation.core.discrepancy import candidates as cand_lib

        for c in cand_lib.all_candidates():
            params = ', '.join(f'{q.name} [{q.unit}]' for q in c.params)
            form = f' (form {c.name})' if c.family_name != c.name else ''
            print(f'{c.family_name}{form}: {c.description} ({params})')
        parser.exit(0)


def register(sub: Subparsers) -> None:
    """Add the ``discrepancy`` subcommand."""
    p = sub.add_parser(
        'discrepancy',
        help='find where model and measurement disagree and name the missing effect',
        description="Fit the paper's rig model (Equ. 1-8) with the record's instrument chain "
        "and drive profile; judge it against what noise alone leaves (this record's null "
        'law, a parametric bootstrap); fit every form of every candidate family '
        '(--list-candidates); name a family only when it alone explains the record, report '
        'several that do as a set the record cannot tell apart (with the experiment that '
        'would), and describe what remains unexplained. Writes DIR/discrepancy.json and '
        'PNG plots.',
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog='Try it:\n'
        '  tribo simulate --rig config/rig_hidden_dwell_time_stiction.yaml --duration 3 '
        '--noise --seed 1 --out /tmp/hidden.csv\n'
        '  tribo discrepancy /tmp/hidden.csv --rig config/rig.yaml --out /tmp/disc',
    )
    p.add_argument(
        'input',
        nargs='+',
        metavar='INPUT',
        help='rig CSV, rosbag2 directory or .mcap file; several: fitted jointly (effect '
        'parameters shared, mu0/mu_inf, drive and instrument per record)',
    )
    p.add_argument(
        '--rig',
        required=True,
        metavar='RIG.yaml',
        help=(
            'rig parameters (SI); mu0/mu_inf/k are fitted, a factor on the chamber '
            "inertia I1 (0.9-1.1, discrepancy.json's instrument.chamber_I1), and for one "
            'record the shaft (I2, K2, C2: instrument.shaft); its effects are not used'
        ),
    )
    p.add_argument('--out', required=True, metavar='DIR', help='output directory')
    p.add_argument(
        '--start',
        type=bounded_float(0.0, 1e7, unit='s'),
        default=0.0,
        metavar='S',
        help='analyse from this time after the first sample [s] (0)',
    )
    p.add_argument(
        '--duration',
        type=bounded_float(0.0, 1e7, unit='s'),
        default=0.0,
        metavar='S',
        help='analyse this many seconds (0: to the end) [s]',
    )
    p.add_argument(
        '--candidates',
        default='',
        metavar='A,B,...',
        help='comma-separated effect families to try (default: the whole library, '
        'see --list-candidates)',
    )
    p.add_argument(
        '--list-candidates',
        action=_ListCandidates,
        nargs=0,
        help='print the library of candidate effects (name, what it models, parameters) and exit',
    )
    p.add_argument(
        '--max-effects',
        type=bounded_int(0, 5),
        default=2,
        metavar='N',
        help='most effects to add (2)',
    )
    p.add_argument(
        '--time-budget',
        type=bounded_float(1.0, 1e6, unit='s'),
        default=None,
        metavar='S',
        help='wall time after which no further candidate form is fitted [s] (none); a '
        'family is then named only if every family was fitted',
    )
    p.add_argument(
        '--alpha',
        type=bounded_float(1e-4, 0.2),
        default=0.01,
        metavar='P',
        help='false-alarm rate of the adequacy decisions: the chance that a record with '
        'nothing missing gets an effect named is at most this (0.01)',
    )
    p.add_argument(
        '--no-torsion-lag',
        action='store_true',
        help='no torsion-amplifier lag in the instrument model (left to torque_sensor_lag)',
    )
    p.add_argument(
        '--shared-friction',
        action='store_true',
        help='several records: one friction law (mu0, mu_inf) for all, the records being '
        'runs of one contact at several drive speeds (the speed contrast then decides '
        'speed-dependent effects); default: mu0/mu_inf per record',
    )
    p.add_argument('--no-plots', action='store_true', help='write only discrepancy.json')
    p.set_defaults(func=run)


def _say(msg: str) -> None:
    print(f'[discrepancy] {msg}', file=sys.stderr, flush=True)


def _check_window(args: argparse.Namespace) -> None:
    from tribo_bringup.errors import ConfigError

    if not (math.isfinite(args.start) and args.start >= 0):
        raise ConfigError(f'--start must be >= 0 s, got {args.start}')
    if not (math.isfinite(args.duration) and args.duration >= 0):
        raise ConfigError(f'--duration must be >= 0 s, got {args.duration}')


def run(args: argparse.Namespace) -> int:
    """Read the inputs, run the workflow, write discrepancy.json; returns the exit code."""
    from tribo_bringup.errors import ConfigError
    from tribo_bringup.outputs import atomic_output_dir
    from tribo_estimation.api import find_missing_physics, load_rig, read_record

    _check_window(args)
    rig = load_rig(args.rig)
    records = []
    for name in args.input:
        src = Path(name)
        if not src.exists():
            raise ConfigError(f'{src}: no such file or bag')
        is_csv = src.is_file() and src.suffix.lower() in ('.csv', '.txt')
        _say(f'reading {src} ({"rig CSV" if is_csv else "bag"})')
        rec = read_record(src, rig, start=args.start, duration=args.duration, progress=_say)
        f = rec.findings
        if f.max_jitter >= 0.01:
            _say(f'time stamps jitter up to {f.max_jitter:.1%} of the interval: resampled')
        for w in f.warnings:
            _say(f'warning: {w}')
        if f.spikes:
            _say(
                f'{f.spikes} samples replaced by interpolation (spikes, {f.bursts} bursts; '
                'discrepancy.json "input")'
            )
        _say(f'{len(rec)} samples at {rec.fs:.0f} Hz ({rec.time[-1] - rec.time[0]:.2f} s)')
        records.append(rec)
    names = tuple(n.strip() for n in args.candidates.split(',') if n.strip()) or None
    res = find_missing_physics(
        records if len(records) > 1 else records[0],
        rig,
        families=names,
        max_effects=args.max_effects,
        alpha=args.alpha,
        time_budget=args.time_budget,
        torsion_lag=not args.no_torsion_lag,
        shared_friction=args.shared_friction,
        progress=_say,
    )
    out = Path(args.out)
    with atomic_output_dir(out) as stage:
        res.write(stage)
        if not args.no_plots:
            res.plot(stage)
    _say(f'wrote {out / "discrepancy.json"}' + ('' if args.no_plots else ' and the plots'))
    for rep in res.records:
        warning = rep.drive.get('warning')
        if warning:
            _say(f'warning: {warning}')
    print(res.finding())
    return 0
