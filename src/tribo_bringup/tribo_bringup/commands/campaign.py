"""``tribo campaign``: several ``tribo friction`` runs side by side (paper Fig. 4 vs Fig. 5).

Each run is an output directory of ``tribo friction`` (its ``blocks.csv``).
Runs are given on the command line (``DIR ... --labels ...``) or in a small
YAML file::

    title: ATF A vs B
    runs:
      - {dir: out/A10, label: 10 rpm, group: oil A}
      - {dir: out/A30, label: 30 rpm, group: oil A}
      - {dir: out/B10, label: 10 rpm, group: oil B}

One column per run of a group, two rows per group (torsion moment envelope
[N m] above, mu0 and mu_inf below).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.errors import ConfigError

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
    """Add the ``campaign`` subcommand."""
    p = sub.add_parser(
        'campaign',
        help='several friction runs side by side in one figure (paper Fig. 4 vs 5)',
        description='Draw the block results (blocks.csv of `tribo friction`) of several '
        'runs side by side: torsion moment max/min/mean [N m] above and mu0/mu_inf below '
        "for each run, one row pair per group (e.g. per oil), as in the paper's Fig. 4 "
        'and 5. Runs come from directories with --labels, or from a YAML file (--spec).',
    )
    p.add_argument('dirs', nargs='*', help='output directories of `tribo friction`')
    p.add_argument('--labels', nargs='+', help='one label per directory (default: the names)')
    p.add_argument('--group', default='', help='group name for all directories (e.g. oil A)')
    p.add_argument('--spec', help='YAML file with title and runs (dir, label, group)')
    p.add_argument('--title', default='', help='figure title')
    p.add_argument('--out', required=True, help='output PNG file')
    p.set_defaults(func=run)


def _runs_from_spec(path: Path) -> tuple[str, list[tuple[Path, str, str]]]:
    from tribo_common.yamlio import check_keys, load_yaml

    data = load_yaml(path, ConfigError, 'campaign spec')
    if not isinstance(data, dict) or not isinstance(data.get('runs'), list) or not data['runs']:
        raise ConfigError(f'{path}: expected a mapping with a non-empty list "runs"')
    runs: list[tuple[Path, str, str]] = []
    check_keys(data, ('title', 'runs'), str(path), ConfigError)
    for i, item in enumerate(data['runs']):
        if not isinstance(item, dict) or 'dir' not in item:
            raise ConfigError(f'{path}: runs[{i}] needs a "dir" key')
        check_keys(item, ('dir', 'label', 'group'), f'{path}: runs[{i}]', ConfigError)
        d = Path(str(item['dir']))
        if not d.is_absolute():
            d = path.parent / d
        runs.append((d, str(item.get('label', d.name)), str(item.get('group', ''))))
    return str(data.get('title', '')), runs


def run(args: argparse.Namespace) -> int:
    """Read the runs' blocks.csv and draw the campaign figure."""
    from tribo_estimation.core.blockfit import read_blocks_csv
    from tribo_estimation.plots import CampaignRun, plot_campaign

    title = args.title
    if args.spec:
        if args.dirs:
            raise ConfigError('give either directories or --spec, not both')
        spec_title, runs = _runs_from_spec(Path(args.spec))
        title = title or spec_title
    else:
        if not args.dirs:
            raise ConfigError('no runs: give output directories of `tribo friction` or --spec')
        labels = args.labels or [Path(d).name for d in args.dirs]
        if len(labels) != len(args.dirs):
            raise ConfigError(
                f'{len(args.dirs)} directories but {len(labels)} labels (give one per directory)'
            )
        runs = [(Path(d), lab, args.group) for d, lab in zip(args.dirs, labels, strict=True)]
    items = []
    for d, label, group in runs:
        f = d / 'blocks.csv' if d.is_dir() else d
        if not f.is_file():
            raise ConfigError(f'{d}: no blocks.csv (run `tribo friction ... --out {d}` first)')
        items.append(CampaignRun(label, group, read_blocks_csv(f)))
    from tribo_bringup.outputs import atomic_output_file

    with atomic_output_file(args.out) as tmp:
        plot_campaign(items, tmp, title)
    return 0
