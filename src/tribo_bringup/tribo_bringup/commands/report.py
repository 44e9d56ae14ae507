"""``tribo report``: one self-contained HTML page plus CSV/JSON results for a recorded session."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.paths import CONFIG

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
    """Add the ``report`` subcommand."""
    p = sub.add_parser(
        'report',
        help='session report of a bag: one HTML page (plots embedded) plus CSV/JSON',
        description='Write DIR/report.html (self-contained: plots embedded as PNG, no network '
        'needed), DIR/results.json (every number on the page, SI units, plus the command line, '
        'versions and git commit), DIR/friction_blocks.csv, DIR/wear_states.csv and '
        'DIR/streams.csv for a recorded session. Sections: stream continuity, rig parameters, '
        'per-block friction (Fig. 4/5 style) and motion detail with stick phases (Fig. 6), nVCT '
        'wear with running-in/progressive split and k_w (Fig. 10/11), the offline analyses '
        '(the block fit of tribo friction, the nVCT evaluation of tribo wear; outputs in '
        'DIR/analyses/) and, with --discrepancy, the discrepancy workflow. A section whose '
        'input is missing is shown as unavailable with the reason. DIR is written '
        'atomically: on an error it keeps what it held.',
    )
    p.add_argument('bag', help='recorded bag (directory with metadata.yaml, or .mcap)')
    p.add_argument('--out', required=True, metavar='DIR', help='output directory')
    default_rig = CONFIG / 'rig.yaml'
    p.add_argument(
        '--rig',
        metavar='RIG.yaml',
        default=str(default_rig) if default_rig.is_file() else None,
        help='rig parameters of the run (default: config/rig.yaml when present)',
    )
    default_nvct = CONFIG / 'nvct.yaml'
    p.add_argument(
        '--nvct',
        metavar='NVCT.yaml',
        default=str(default_nvct) if default_nvct.is_file() else None,
        help='nVCT configuration for the wear analysis and k_w (default: config/nvct.yaml)',
    )
    p.add_argument(
        '--discrepancy', action='store_true', help='also run the discrepancy workflow on the bag'
    )
    p.add_argument(
        '--no-analyses',
        action='store_true',
        help='only the live results recorded in the bag (no offline block fit or wear evaluation)',
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the report; print where it is and the summary."""
    from tribo_bringup.report import build_report

    res = build_report(
        args.bag,
        args.out,
        rig=args.rig,
        nvct=args.nvct,
        discrepancy=args.discrepancy,
        analyses=() if args.no_analyses else None,
        command=['tribo', *sys.argv[1:]] if Path(sys.argv[0]).name != 'pytest' else None,
    )
    print(f'report: {res.html}')
    for line in res.summary:
        print(f'  {line}')
    return 0
