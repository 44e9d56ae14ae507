"""``tribo friction``: block-wise friction estimation of a recorded session (paper 2.5).

Reads a rig CSV (``time,torsion_moment,angular_acceleration,speed``) or a bag
with the ``/rig/*`` SampleBlock streams, estimates mu0 and mu_inf (Equ. 8) per
block, and writes ``OUT/blocks.csv`` plus the figures ``blocks.png`` (paper
Fig. 4/5 layout), ``mu_slip.png`` (mu versus slip speed) and ``detail.png``
(Fig. 6 style, stick phases shaded). A thin shell over
:func:`tribo_estimation.fit_blocks` (streaming: memory stays bounded whatever the
length of the session).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_float
from tribo_bringup.errors import BagError

if TYPE_CHECKING:
    from tribo_estimation.core.blockfit import BlockResult


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``friction`` subcommand."""
    p = sub.add_parser(
        'friction',
        help='block-wise mu0/mu_inf estimation of a rig CSV or bag (paper Fig. 4-6)',
        description='Estimate the friction law mu(|v|) = (mu0 - mu_inf)*exp(-k|v|) + mu_inf '
        '(paper Equ. 8) block by block from the torsion moment, the chamber acceleration '
        'and the shaft speed of a recorded session. Writes OUT/blocks.csv (one row per '
        'block, with a quality column: ok or flags gap, saturated, no_sliding, startup, '
        'fit_failed, short, spikes, bursts, repaired; the last columns count the samples '
        'replaced before the fit and the bursts among them: both are left out of the fit, '
        'a block with over 20 % replaced is not fitted; w0, drive_mismatch and speed_offset '
        "give the drive speed used, its deviation from nominal_speed and the speed channel's "
        'offset from the drive speed of the stick lines, which sets the level when it exceeds '
        '1 %) and the figures blocks.png, '
        'mu_slip.png and detail.png. The channels are checked against the rig first: a '
        'torque in N mm, a speed in rpm or a time in ms is named (exit 2); nothing is left '
        'in OUT on an error.',
    )
    p.add_argument(
        'input', help='rig CSV (time,torsion_moment,angular_acceleration,speed in SI) or a bag'
    )
    p.add_argument('--rig', required=True, help='RIG.yaml with the rig parameters (SI)')
    p.add_argument('--out', required=True, help='output directory (created if needed)')
    p.add_argument(
        '--block',
        type=bounded_float(0.01, 600.0, unit='s'),
        default=1.0,
        metavar='S',
        help='block length [s] (default 1.0)',
    )
    p.add_argument('--fit-k', action='store_true', help='also fit the Stribeck constant k [s/rad]')
    p.add_argument(
        '--tacho-speed',
        action='store_true',
        help='do not check the measured drive speed against nominal_speed of RIG.yaml '
        '(the drive speed is always measured from the speed channel)',
    )
    p.add_argument('--no-plots', action='store_true', help='write blocks.csv only')
    p.add_argument('--quiet', action='store_true', help='no progress on stderr')
    p.add_argument(
        '--namespace', metavar='NS', help='rig namespace in the bag (default: its only rig)'
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Estimate, write blocks.csv and the figures."""
    from tribo_bringup.outputs import PARTIAL_DIR, atomic_output_dir, keep_as_partial
    from tribo_estimation.api import fit_blocks, load_rig
    from tribo_estimation.errors import RecordTruncatedError

    src = Path(args.input)
    if not src.exists():
        raise BagError(f'{src}: no such file or bag')
    rig = load_rig(args.rig)
    out = Path(args.out)
    t_wall = time.monotonic()
    last_report = t_wall
    n_done = 0

    def progress(r: BlockResult) -> None:
        nonlocal last_report, n_done
        n_done += 1
        now = time.monotonic()
        if not args.quiet and (now - last_report > 2.0 or n_done == 1):
            print(
                f'friction: block {r.index} t={r.t_start:.1f} s mu0={r.mu0:.4f} '
                f'mu_inf={r.mu_inf:.4f} {r.motion} {r.quality_str} '
                f'({n_done} blocks, {now - t_wall:.0f} s)',
                file=sys.stderr,
            )
            last_report = now

    fit = fit_blocks(
        src,
        rig,
        block_length=args.block,
        fit_k=bool(args.fit_k),
        check_drive_speed=not args.tacho_speed,
        namespace=args.namespace,
        keep_truncated=True,
        on_block=progress,
    )
    with atomic_output_dir(out) as stage:
        fit.write(stage)
        if not args.no_plots:
            fit.plot(stage)
        if fit.truncated:
            keep_as_partial(stage)  # the blocks before the damage, never taken for the whole
    if fit.truncated:
        raise RecordTruncatedError(f'{fit.truncated} (blocks before it in {out / PARTIAL_DIR})')
    for w in (*fit.warnings, *fit.notices()):
        print(f'friction: warning: {w}', file=sys.stderr)
    if not args.quiet:
        if fit.max_jitter >= 0.01:
            print(
                f'friction: time stamps jitter up to {fit.max_jitter:.1%} of the sample '
                'interval: resampled onto the regular grid',
                file=sys.stderr,
            )
        if fit.replaced:
            print(
                f'friction: {fit.replaced} samples replaced (spikes, bursts; left out of the '
                'fits, blocks.csv columns spikes and bursts)',
                file=sys.stderr,
            )
        print(
            f'friction: {len(fit)} blocks ({len(fit.ok)} ok) -> {out / "blocks.csv"} '
            f'in {time.monotonic() - t_wall:.1f} s',
            file=sys.stderr,
        )
    return 0
