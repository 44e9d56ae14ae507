"""``tribo simulate``: simulate the stick-slip rig (paper 2.3-2.4) and write a rig CSV or a bag.

    tribo simulate --rig RIG.yaml --duration S [--fs HZ] [--noise] [--seed N] --out FILE.csv
    tribo simulate --rig RIG.yaml --duration S [--noise] --out SESSION.mcap   (or a bag folder)
    tribo simulate --rig RIG.yaml --free-decay --phi0 RAD --duration S [--noise] --out FILE.csv

The CSV has the rig columns ``time,torsion_moment,angular_acceleration,speed``
(s, N m, rad/s^2, rad/s) followed by the truth ``friction_moment,slip_speed,stick``;
the rig parameters are written as ``# key: value`` comments. An ``--out`` that
does not end in ``.csv`` is a bag (``.mcap``: one MCAP file; else a rosbag2
folder) with the three ``rig/*`` SampleBlock streams as recorded from the rig
(:class:`tribo_bringup.rig_bag.RigBagWriter`; no truth). Long runs are
simulated and written in 1 s chunks (seamless continuation of the state).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_float, bounded_int

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers

CHUNK_S = 1.0
#: Longest simulated time [s] (one day) and rate range [Hz]: a record beyond
#: these is a typo, not an experiment (and would fill the disk).
MAX_DURATION_S = 86_400.0
FS_RANGE = (100.0, 100_000.0)


def register(sub: Subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    p = sub.add_parser(
        'simulate',
        help='simulate the stick-slip rig and write a rig CSV or a bag',
        description='Simulate the 2-DOF disc-on-disc stick-slip rig (paper Equ. 1-3, 6, 8, '
        'event-accurate stick/slip switching) and write the sensor signals (torsion moment, '
        'chamber acceleration, shaft speed) plus the truth (friction moment, slip speed, stick '
        'flag) as a rig CSV. With --free-decay the contact is opened and the chamber released '
        'from --phi0 (a record for `tribo decay`).',
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog='Try it:\n'
        '  tribo simulate --rig config/rig.yaml --duration 2 --noise --seed 1 --out /tmp/rig.csv\n'
        '  tribo simulate --rig config/rig_decay_example.yaml --free-decay --phi0 0.01 '
        '--duration 2 --noise --seed 1 --out /tmp/decay.csv\n'
        '  tribo decay /tmp/decay.csv --out /tmp/decay',
    )
    p.add_argument('--rig', required=True, metavar='RIG.yaml', help='rig parameters (SI)')
    p.add_argument(
        '--duration',
        required=True,
        type=bounded_float(0.0, MAX_DURATION_S, lo_open=True, unit='s'),
        metavar='S',
        help=f'simulated time [s] (up to {MAX_DURATION_S:g})',
    )
    p.add_argument(
        '--fs',
        type=bounded_float(*FS_RANGE, unit='Hz'),
        default=10_000.0,
        metavar='HZ',
        help='output rate [Hz] (10000; 100-100000)',
    )
    p.add_argument(
        '--noise',
        action='store_true',
        help='add the measurement noise of RIG.yaml (noise_torque, noise_accel, noise_speed)',
    )
    p.add_argument(
        '--seed', type=bounded_int(0, 2**63 - 1), default=None, metavar='N', help='noise seed'
    )
    p.add_argument(
        '--speed',
        type=bounded_float(-1000.0, 1000.0, unit='rad/s'),
        default=None,
        metavar='RAD_S',
        help='override nominal_speed of RIG.yaml [rad/s]',
    )
    p.add_argument(
        '--free-decay',
        action='store_true',
        help='free decay of the chamber alone (contact open, drive at rest)',
    )
    p.add_argument(
        '--phi0',
        type=bounded_float(-1.0, 1.0, unit='rad'),
        default=0.01,
        metavar='RAD',
        help='initial chamber deflection for --free-decay [rad] (0.01)',
    )
    p.add_argument(
        '--out',
        required=True,
        metavar='FILE.csv|BAG',
        help='output rig CSV (.csv), MCAP file (.mcap) or rosbag2 folder (anything else; '
        'must not exist)',
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the simulation; returns the exit code."""
    import dataclasses

    import numpy as np

    from tribo_bringup.outputs import atomic_output_file
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
    from tribo_estimation.core.rigio import RigCsvWriter
    from tribo_estimation.core.simulate import free_decay_state, simulate
    from tribo_estimation.errors import InvalidParameterError

    cfg = load_rig_config(args.rig)
    if not (math.isfinite(args.duration) and args.duration > 0.0):
        raise InvalidParameterError(f'--duration must be > 0 s, got {args.duration}')
    if not (math.isfinite(args.fs) and args.fs > 0.0):
        raise InvalidParameterError(f'--fs must be > 0 Hz, got {args.fs}')
    rig, friction, drive = cfg.rig, cfg.friction, cfg.drive
    if args.speed is not None:
        drive = dataclasses.replace(drive, nominal_speed=args.speed)
    initial = None
    ext = cfg.extensions
    if args.free_decay:
        if not (math.isfinite(args.phi0) and args.phi0 != 0.0):
            raise InvalidParameterError(f'--phi0 must be a non-zero angle [rad], got {args.phi0}')
        rig = RigParams(**{**rig.__dict__, 'F_N': 0.0})
        friction = FrictionLaw(0.0, 0.0)
        drive = DriveProfile(0.0)
        initial = free_decay_state(args.phi0)
    noise = cfg.noise if args.noise else None
    rng = np.random.default_rng(args.seed)
    meta: dict[str, object] = {
        'source': 'tribo simulate',
        'rig_config': str(Path(args.rig)),
        **{k: v for k, v in rig.__dict__.items()},
        'mu0': friction.mu0,
        'mu_inf': friction.mu_inf,
        'k': friction.k,
        'nominal_speed': drive.nominal_speed,
        'ramp_time': drive.ramp_time,
        'free_decay': bool(args.free_decay),
        'noise': bool(args.noise),
        'seed': args.seed,
    }
    if args.free_decay:
        meta['phi0'] = args.phi0
    n_total = round(args.duration * args.fs)
    if n_total < 1:
        raise InvalidParameterError('--duration too short for one sample at --fs')
    chunk = max(1, round(CHUNK_S * args.fs))
    done = 0
    state = initial
    if Path(args.out).suffix.lower() != '.csv':
        from tribo_bringup.rig_bag import RigBagWriter

        bag = RigBagWriter(args.out, args.fs)
        try:
            while done < n_total:
                n = min(chunk, n_total - done)
                r = simulate(
                    rig, friction, drive, n / args.fs, args.fs,
                    initial=state, extensions=ext, noise=noise, seed=rng,
                )  # fmt: skip
                state = r.final_state
                bag.write(r.torsion_moment, r.angular_acceleration, r.speed)
                done += n
        except BaseException:
            bag.abort()
            raise
        bag.close()
        print(f'wrote {n_total} samples ({args.duration:g} s at {args.fs:g} Hz) to {args.out}')
        return 0
    with (
        atomic_output_file(args.out) as tmp,
        RigCsvWriter(tmp, ('friction_moment', 'slip_speed', 'stick'), meta) as w,
    ):
        while done < n_total:
            n = min(chunk, n_total - done)
            r = simulate(
                rig,
                friction,
                drive,
                n / args.fs,
                args.fs,
                initial=state,
                extensions=ext,
                noise=noise,
                seed=rng,
            )
            state = r.final_state
            w.write(
                {
                    'time': r.time,
                    'torsion_moment': r.torsion_moment,
                    'angular_acceleration': r.angular_acceleration,
                    'speed': r.speed,
                    'friction_moment': r.friction_moment,
                    'slip_speed': r.slip_speed,
                    'stick': r.stick.astype(float),
                }
            )
            done += n
            if n_total > chunk:
                print(
                    f'\rtribo simulate: {done / args.fs:.1f}/{args.duration:g} s',
                    end='',
                    file=sys.stderr,
                )
    if n_total > chunk:
        print(file=sys.stderr)
    print(f'wrote {n_total} samples ({args.duration:g} s at {args.fs:g} Hz) to {args.out}')
    return 0
