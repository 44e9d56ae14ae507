"""``python -m tribo_scenarios SEED --out DIR``: write one scenario for a person to analyse.

Writes ``DIR/record.csv`` (rig CSV), ``DIR/rig.yaml`` (the RIG.yaml a lab would pass)
and ``DIR/truth.json`` (what is hidden), then prints the ``tribo discrepancy`` command.
Bad input: one line on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import sys

from .errors import ScenarioError
from .generate import generate
from .space import draw


def main(argv: list[str] | None = None) -> int:
    """Run the command; returns the exit code.

    Parameters
    ----------
    argv : list of str or None
        Arguments (None: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on bad input.
    """
    ap = argparse.ArgumentParser(
        prog='python -m tribo_scenarios',
        description='Write one drawn scenario: record.csv, rig.yaml and truth.json.',
    )
    ap.add_argument('seed', type=int, help='scenario seed (>= 0)')
    ap.add_argument('--out', required=True, metavar='DIR', help='output directory')
    ap.add_argument('--duration', type=float, default=None, metavar='S',
                    help='record duration [s] (default: drawn, 4-8 s)')  # fmt: skip
    ap.add_argument('--kind', default=None, help='drive kind (default: drawn)')
    ap.add_argument(
        '--family', default=None, help="hidden effect: 'none', a family, 'out_of_library[:NAME]'"
    )
    ap.add_argument('--no-cache', action='store_true', help='simulate without the record cache')
    args = ap.parse_args(argv)
    try:
        spec = draw(args.seed, duration=args.duration, kind=args.kind, family=args.family)
        sc = generate(spec, use_cache=not args.no_cache)
        csv, rig, truth = sc.write_dir(args.out)
    except ScenarioError as exc:
        print(f'tribo_scenarios: {exc}', file=sys.stderr)
        return 2
    print(f'seed {spec.seed}: {sc.truth.effect} ({sc.truth.form}), effect_snr '
          f'{sc.truth.effect_snr:.3g}; {spec.drive.kind} drive, {spec.fs:g} Hz, '
          f'{spec.duration:.2f} s ({sc.labels["motion"]})')  # fmt: skip
    print(f'wrote {csv}, {rig}, {truth}')
    print(f'./tribo discrepancy {csv} --rig {rig} --out {args.out}/discrepancy')
    return 0


if __name__ == '__main__':
    sys.exit(main())
