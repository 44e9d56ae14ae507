"""``tribo discrepancy``: find the physics the rig model is missing.

    tribo discrepancy INPUT --rig RIG.yaml --out DIR [--start S] [--duration S]
    tribo discrepancy A B C --rig RIG.yaml --out DIR [--shared-friction]
        (several records, fitted jointly)

INPUT is a rig CSV (``time,torsion_moment,angular_acceleration,speed``) or a
bag (rosbag2 directory or ``.mcap``) with the ``/rig/torsion_moment``,
``/rig/angular_acceleration`` and ``/rig/speed`` SampleBlock streams. The
baseline (the paper's model, Equ. 1-8) is fitted, candidate effects are tried
one by one (cross validation + BIC), the clearly better ones added, and what
remains is described. Writes ``DIR/discrepancy.json`` (rms of the
torsion-moment residual in N m) and PNG plots; progress goes to stderr.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_float, bounded_int

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers
    from tribo_bringup.errors import BagTruncatedError
    from tribo_estimation.core.config import RigConfig
    from tribo_estimation.core.discrepancy.fitting import Record
    from tribo_estimation.core.discrepancy.select import SelectionSettings
    from tribo_estimation.core.signal import FloatArray


def register(sub: Subparsers) -> None:
    """Add the ``discrepancy`` subcommand."""
    from tribo_estimation.core.discrepancy import candidates as cand_lib
    from tribo_estimation.core.discrepancy.select import SelectionSettings

    min_gain = SelectionSettings().min_gain
    library = ', '.join(c.name for c in cand_lib.all_candidates())
    p = sub.add_parser(
        'discrepancy',
        help='find where model and measurement disagree and name the missing effect',
        description="Fit the paper's rig model (Equ. 1-8) to a record segment by segment, "
        'localise the residual (phase, breakaway, slip speed, stick duration, test time, '
        'shaft angle, spectral lines), try every candidate effect of the library '
        f'({library}), add the best one '
        'while it improves held-out blocks clearly (cross validation and BIC), and report '
        'what remains unexplained. Writes DIR/discrepancy.json and PNG plots.',
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
        help='rig parameters (SI); mu0/mu_inf are fitted, its effects are not used',
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
        help='comma-separated candidate effects to try (default: the whole library: '
        + '; '.join(f'{c.name}: {c.description.split(":")[0]}' for c in cand_lib.all_candidates())
        + ')',
    )
    p.add_argument(
        '--max-effects',
        type=bounded_int(0, 20),
        default=3,
        metavar='N',
        help='most effects to add (3)',
    )
    p.add_argument(
        '--min-gain',
        type=bounded_float(0.0, 100.0),
        default=min_gain,
        metavar='F',
        help=f'relative held-out improvement needed to add an effect ({min_gain:g})',
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


def _load_csv(path: Path) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Read the channels of a rig CSV on a regular time base.

    Time [s] from the first sample (epoch stamps made relative, jitter resampled:
    :func:`tribo_estimation.core.rigio.regularise`), torsion moment [N m], angular
    acceleration [rad/s^2] and speed [rad/s].
    """
    from tribo_estimation.core.rigio import read_rig_csv, regularise

    rec, grid = regularise(read_rig_csv(path), str(path))
    if grid.max_jitter >= 0.01:
        _say(f'time stamps jitter up to {grid.max_jitter:.1%} of the interval: resampled')
    return rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed


def _load_bag(
    path: Path, start: float, duration: float
) -> tuple[tuple[FloatArray, FloatArray, FloatArray, FloatArray], BagTruncatedError | None]:
    """Read the aligned rig channels of a bag within a window.

    The window starts ``start`` [s] after the stream's first sample and is
    ``duration`` [s] long (0: to the end); the longest gap-free stretch in
    the window is used. Reading stops at the window's end, so memory stays bounded by
    the window. A bag that ends early gives the good part and its truncation error.
    """
    from tribo_bringup.sessions import read_rig_stretch

    return read_rig_stretch(path, start, duration, _say)


def _candidate_names(args: argparse.Namespace) -> tuple[str, ...] | None:
    """Return the ``--candidates`` list, checked against the library (None: all)."""
    from tribo_bringup.errors import ConfigError
    from tribo_estimation.core.discrepancy import candidates as cand_lib

    names = tuple(n.strip() for n in args.candidates.split(',') if n.strip()) or None
    for n in names or ():
        if n not in cand_lib.names():
            raise ConfigError(
                f'--candidates: unknown effect {n!r} (known: {", ".join(cand_lib.names())})'
            )
    return names


def _load_record(
    src: Path, args: argparse.Namespace, cfg: RigConfig
) -> tuple[Record, Exception | None, dict[str, int | str]]:
    """Read one input (rig CSV or bag) as a :class:`Record`.

    The record holds the ``--start``/``--duration`` window, its time base and
    channels checked and its spikes and bursts repaired
    (:mod:`tribo_estimation.core.plausibility`); also returned are the truncation
    error of a bag that ends early (its good part is returned) and the count of
    replaced samples.
    """
    import numpy as np

    from tribo_bringup.errors import ConfigError
    from tribo_estimation.core.discrepancy.fitting import Record
    from tribo_estimation.core.plausibility import (
        Scales,
        check_channels,
        check_time_base,
        despike_chunk,
        repair_summary,
    )

    if not src.exists():
        raise ConfigError(f'{src}: no such file or bag')
    is_csv = src.is_file() and src.suffix.lower() in ('.csv', '.txt')
    _say(f'reading {src} ({"rig CSV" if is_csv else "bag"})')
    truncated: Exception | None = None
    if is_csv:
        t, torque, accel, speed = _load_csv(src)
        t0 = float(t[0]) + args.start
    else:
        (t, torque, accel, speed), truncated = _load_bag(src, args.start, args.duration)
        t0 = float(t[0])
    sel = t >= t0
    if args.duration > 0:
        sel &= t < t0 + args.duration
    if int(np.count_nonzero(sel)) < 100:
        raise ConfigError(
            f'{src}: the window start {args.start} s, duration {args.duration} s holds '
            f'{int(np.count_nonzero(sel))} samples (need >= 100)'
        )
    scales = Scales.of(cfg.rig, cfg.friction, cfg.drive.nominal_speed)
    fs_est = (t.size - 1) / float(t[-1] - t[0]) if t.size > 1 else math.nan
    check_time_base(fs_est, str(src), scales.f_stick_slip)
    torque, accel, speed, spk = despike_chunk(
        np.asarray(torque, dtype=np.float64),
        np.asarray(accel, dtype=np.float64),
        np.asarray(speed, dtype=np.float64),
        scales,
    )
    for w in check_channels(torque[sel], accel[sel], speed[sel], scales, str(src)):
        _say(f'warning: {w}')
    repairs = repair_summary(spk[sel])
    if repairs['spikes']:
        _say(
            f'{repairs["spikes"]} samples replaced by interpolation (spikes, '
            f'{repairs["bursts"]} bursts; discrepancy.json "input")'
        )
    record = Record(
        *(np.ascontiguousarray(a[sel], dtype=np.float64) for a in (t, torque, accel, speed))
    )
    _say(
        f'{record.time.size} samples at {record.fs:.0f} Hz '
        f'({record.time[-1] - record.time[0]:.2f} s)'
    )
    return record, truncated, repairs


def _add_input(path: Path, repairs: dict[str, int | str]) -> None:
    """Add the input's replaced samples to a written ``discrepancy.json``.

    The ``input`` section holds the counts of spike and burst samples and the quality flag.
    """
    import json

    data = json.loads(path.read_text())
    data['input'] = repairs
    path.write_text(json.dumps(data, indent=2, allow_nan=False) + '\n')


def _settings(
    args: argparse.Namespace, names: tuple[str, ...] | None, max_effects: int | None = None
) -> SelectionSettings:
    """Return the selection settings of the command line."""
    from tribo_estimation.core.discrepancy import SelectionSettings

    st = SelectionSettings(
        min_gain=args.min_gain, candidates=names, torsion_lag=not args.no_torsion_lag
    )
    return st if max_effects is None else dataclasses.replace(st, max_effects=max_effects)


def _check_window(args: argparse.Namespace) -> None:
    from tribo_bringup.errors import ConfigError

    if not (math.isfinite(args.start) and args.start >= 0):
        raise ConfigError(f'--start must be >= 0 s, got {args.start}')
    if not (math.isfinite(args.duration) and args.duration >= 0):
        raise ConfigError(f'--duration must be >= 0 s, got {args.duration}')


def run(args: argparse.Namespace) -> int:
    """Run the workflow; returns the exit code."""
    from tribo_bringup.outputs import atomic_output_dir
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.discrepancy import run_discrepancy
    from tribo_estimation.core.discrepancy.report import write_json

    _check_window(args)
    if len(args.input) > 1:
        return _run_joint(args)
    names = _candidate_names(args)
    cfg = load_rig_config(args.rig)
    settings = _settings(args, names, max_effects=args.max_effects)
    record, truncated, repairs = _load_record(Path(args.input[0]), args, cfg)
    result = run_discrepancy(
        record, cfg.rig, cfg.drive, k=cfg.friction.k, settings=settings, progress=_say
    )
    if truncated is not None:
        raise truncated  # nothing is written for a damaged bag; exit 2 names the damage
    out = Path(args.out)
    with atomic_output_dir(out) as stage:
        write_json(result, stage / 'discrepancy.json')
        _add_input(stage / 'discrepancy.json', repairs)
        if not args.no_plots:
            from tribo_estimation.core.discrepancy.plots import write_plots

            write_plots(result, stage)
    _say(f'wrote {out / "discrepancy.json"}' + ('' if args.no_plots else ' and the plots'))
    if result.drive.get('warning'):
        _say(f'warning: {result.drive["warning"]}')
    added = ', '.join(a.effect for a in result.added) or 'nothing'
    print(
        f'added: {added}; torque residual rms {result.baseline.rms:.4g} -> '
        f'{result.final.rms:.4g} N m; unexplained: {len(result.unexplained)}'
    )
    return 0


def _run_joint(args: argparse.Namespace) -> int:
    """Fit several records jointly (:func:`run_joint_discrepancy`).

    ``--start`` and ``--duration`` apply to each. Writes ``DIR/discrepancy.json`` (joint layout).
    """
    from tribo_bringup.outputs import atomic_output_dir
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.discrepancy.joint import run_joint_discrepancy
    from tribo_estimation.core.discrepancy.report import write_json

    names = _candidate_names(args)
    cfg = load_rig_config(args.rig)
    records = []
    for name in args.input:
        record, truncated, _ = _load_record(Path(name), args, cfg)
        if truncated is not None:
            raise truncated  # a joint fit needs every record whole
        records.append(record)
    settings = _settings(args, names)
    res = run_joint_discrepancy(
        records,
        cfg.rig,
        [cfg.drive] * len(records),
        k=cfg.friction.k,
        settings=settings,
        progress=_say,
        shared_friction=args.shared_friction,
    )
    out = Path(args.out)
    with atomic_output_dir(out) as stage:
        write_json(res, stage / 'discrepancy.json')
    _say(f'wrote {out / "discrepancy.json"}')
    blocked = ', '.join(res.not_identifiable)
    print(
        f'added: {res.named or "nothing"} (joint fit of {len(records)} records)'
        + (f'; not identifiable: {blocked}' if blocked else '')
    )
    return 0
