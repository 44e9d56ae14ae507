"""``tribo decay``: identify the test chamber from a free-decay record (paper Equ. 7).

    tribo decay INPUT.csv --out DIR [--t-start S] [--t-end S]

INPUT.csv is a rig CSV (``time,torsion_moment,angular_acceleration,speed``; s, N m,
rad/s^2, rad/s) of the chamber oscillating alone (contact open). Writes
DIR/decay.json with I1 [kg m^2], K1 [N m s/rad], C1 [N m/rad], f_n_hz [Hz],
zeta [-] and their standard errors (``*_se``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_float

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
    """Add the ``decay`` subcommand."""
    p = sub.add_parser(
        'decay',
        help='free-decay identification of I1, K1, C1 (paper Equ. 7)',
        description='Identify the chamber inertia I1, damping K1 and torsion stiffness C1 '
        '(with natural frequency, damping ratio and standard errors) from the torsion moment '
        'and acceleration of the chamber oscillating alone (joint damped-sinusoid fit, '
        'paper Equ. 7).',
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog='Try it:\n'
        '  tribo simulate --rig config/rig_decay_example.yaml --free-decay --phi0 0.01 '
        '--duration 2 --noise --seed 1 --out /tmp/decay.csv\n'
        '  tribo decay /tmp/decay.csv --out /tmp/decay',
    )
    p.add_argument('input', metavar='INPUT.csv', help='rig CSV of a free decay')
    p.add_argument('--out', required=True, metavar='DIR', help='output directory')
    p.add_argument(
        '--t-start',
        type=bounded_float(0.0, 1e7, unit='s'),
        default=None,
        metavar='S',
        help='use t >= S [s] after the first sample',
    )
    p.add_argument(
        '--t-end',
        type=bounded_float(0.0, 1e7, unit='s'),
        default=None,
        metavar='S',
        help='use t <= S [s] after the first sample',
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the identification (:func:`tribo_estimation.identify_decay`); returns the exit code."""
    from tribo_bringup.outputs import atomic_output_dir
    from tribo_estimation.api import identify_decay, read_record

    rec = read_record(args.input)
    if rec.findings.spikes:
        print(f'decay: {rec.findings.spikes} spike samples replaced', file=sys.stderr)
    fit = identify_decay(rec, t_start=args.t_start, t_end=args.t_end)
    out = Path(args.out)
    with atomic_output_dir(out) as stage:
        fit.write(stage)
    res = fit.result
    print(
        f'I1 = {res.I1:.6g} +- {res.I1_se:.2g} kg m^2, K1 = {res.K1:.5g} +- {res.K1_se:.2g} '
        f'N m s/rad, C1 = {res.C1:.6g} +- {res.C1_se:.2g} N m/rad, f_n = {res.f_n_hz:.4f} Hz, '
        f'zeta = {res.zeta:.4g}'
    )
    print(f'wrote {out / "decay.json"}')
    return 0
