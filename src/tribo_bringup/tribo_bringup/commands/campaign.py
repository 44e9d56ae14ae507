"""``tribo campaign``: many sessions analysed into one store, queried and reported.

    tribo campaign analyse SPEC.yaml --store DIR [--workers N | --scheduler ADDRESS]
    tribo campaign query DIR "SQL" [--csv FILE | --parquet FILE]
    tribo campaign report DIR --out OUTDIR
    tribo campaign plot RUN_DIR... --out FIG.png    (blocks.csv of `tribo friction` runs)

The work is done by :mod:`tribo_bringup.campaign` (spec, runner, store, query,
report); this module only turns the command line into its calls. ``plot`` draws
several ``tribo friction`` output directories side by side (paper Fig. 4 vs 5),
from the command line (``DIR ... --labels ...``) or a small YAML file::

    title: ATF A vs B
    runs:
      - {dir: out/A10, label: 10 rpm, group: oil A}
      - {dir: out/A30, label: 30 rpm, group: oil A}
      - {dir: out/B10, label: 10 rpm, group: oil B}
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_int
from tribo_bringup.errors import CampaignError, ConfigError

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers


def register(sub: Subparsers) -> None:
    """Add the ``campaign`` subcommand and its own subcommands."""
    p = sub.add_parser(
        'campaign',
        help='many sessions on a dask cluster into one DuckDB store; query, report, plot',
        description='Analyse the sessions of a campaign spec on dask.distributed into a '
        'Parquet + DuckDB store (re-runs analyse only new or changed sessions), query '
        'the store with SQL, write its HTML report, or plot `tribo friction` runs side '
        'by side.',
    )
    csub = p.add_subparsers(dest='campaign_command', metavar='SUBCOMMAND')
    csub.required = True
    a = csub.add_parser(
        'analyse',
        help='analyse the sessions of SPEC into the store',
        description='Run the analyses of every new or changed session of the campaign '
        'spec (friction per time chunk, discrepancy, wear) as tasks on a local dask '
        'cluster (or the scheduler given) and commit each session to the store when it '
        'is complete. A failed session (e.g. a truncated bag) is recorded with its error '
        'and the others are analysed; the run then exits with code 2.',
    )
    a.add_argument('spec', metavar='SPEC.yaml', help='campaign spec')
    a.add_argument('--store', required=True, metavar='DIR', help='store directory')
    where = a.add_mutually_exclusive_group()
    where.add_argument(
        '--workers',
        type=bounded_int(1, 1024),
        metavar='N',
        help='worker processes of the local cluster (default: the CPU cores)',
    )
    where.add_argument('--scheduler', metavar='ADDRESS', help='address of a running dask scheduler')
    a.add_argument('--quiet', action='store_true', help='no progress on stderr')
    a.set_defaults(func=run_analyse)
    q = csub.add_parser(
        'query',
        help='run SQL on the store (views sessions, blocks, discrepancy, wear, provenance)',
        description='Run one SQL statement on STORE/campaign.duckdb (read-only) and print '
        'the result as a table, or write it to a CSV or Parquet file.',
    )
    q.add_argument('store', metavar='STORE', help='store directory')
    q.add_argument('sql', metavar='SQL', help='the statement')
    out = q.add_mutually_exclusive_group()
    out.add_argument('--csv', metavar='FILE', help='write the result as CSV')
    out.add_argument('--parquet', metavar='FILE', help='write the result as Parquet')
    q.set_defaults(func=run_query)
    r = csub.add_parser(
        'report',
        help="one HTML page with the campaign's figures",
        description='Write OUT/index.html: Fig. 4/5 per oil and speed, mu0 and mu_inf '
        'against drive speed per oil with standard errors, the motion map over speed and '
        'test time, Fig. 12 wear coefficients, and the missing-physics verdict per session.',
    )
    r.add_argument('store', metavar='STORE', help='store directory')
    r.add_argument('--out', required=True, metavar='DIR', help='output directory')
    r.set_defaults(func=run_report)
    pl = csub.add_parser(
        'plot',
        help='several friction runs side by side in one figure (paper Fig. 4 vs 5)',
        description='Draw the block results (blocks.csv of `tribo friction`) of several '
        'runs side by side: torsion moment max/min/mean [N m] above and mu0/mu_inf below '
        "for each run, one row pair per group (e.g. per oil), as in the paper's Fig. 4 "
        'and 5. Runs come from directories with --labels, or from a YAML file (--spec).',
    )
    pl.add_argument('dirs', nargs='*', help='output directories of `tribo friction`')
    pl.add_argument('--labels', nargs='+', help='one label per directory (default: the names)')
    pl.add_argument('--group', default='', help='group name for all directories (e.g. oil A)')
    pl.add_argument('--spec', help='YAML file with title and runs (dir, label, group)')
    pl.add_argument('--title', default='', help='figure title')
    pl.add_argument('--out', required=True, help='output PNG file')
    pl.set_defaults(func=run)


def run_analyse(args: argparse.Namespace) -> int:
    """Analyse the spec into the store; exit 2 when a session failed."""
    from tribo_bringup.campaign.progress import fmt_seconds
    from tribo_bringup.campaign.runner import analyse, default_workers
    from tribo_bringup.campaign.spec import load_spec

    spec = load_spec(args.spec)
    workers = args.workers or default_workers()
    stream = None if args.quiet else sys.stderr
    res = analyse(spec, args.store, workers=workers, scheduler=args.scheduler, stream=stream)
    print(
        f'{res.sessions} sessions: {res.analysed} analysed ({res.failed} failed), '
        f'{res.up_to_date} up to date; {res.tasks} tasks on {res.workers} workers in '
        f'{fmt_seconds(res.seconds)} ({fmt_seconds(res.cluster_seconds)} starting and '
        f'stopping the cluster) -> {Path(args.store) / "campaign.duckdb"}'
    )
    if res.failures:
        raise CampaignError(
            f'{len(res.failures)} of {res.sessions} sessions failed (the others are stored; '
            f'see the sessions table): {res.failures[0]}'
        )
    return 0


def run_query(args: argparse.Namespace) -> int:
    """Run the statement; print the table or write the file."""
    from tribo_bringup.campaign.query import export, format_table, query

    target = args.csv or args.parquet
    if target:
        n = export(args.store, args.sql, target, 'csv' if args.csv else 'parquet')
        print(f'wrote {n} rows to {target}', file=sys.stderr)
        return 0
    cols, rows = query(args.store, args.sql)
    print(format_table(cols, rows))
    return 0


def run_report(args: argparse.Namespace) -> int:
    """Write the campaign's HTML page."""
    from tribo_bringup.campaign.report import build_report

    page = build_report(args.store, args.out)
    print(f'wrote {page}', file=sys.stderr)
    return 0


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
