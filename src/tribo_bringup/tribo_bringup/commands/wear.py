"""``tribo wear``: nVCT counts to wear volume, running-in vs progressive wear (paper section 3).

    tribo wear COUNTS --nvct NVCT.yaml --out DIR
    tribo wear RUN1.csv RUN2.csv ... --nvct A.yaml --nvct B.yaml ... --out DIR   (campaign)
    tribo wear --simulate OUT.csv [--sim config/sim_detector.yaml] [--seed N]

COUNTS is a CSV ``t_start,t_end,counts,live_time`` (s, s, counts, s) or a bag
with /nvct/counts. Writes DIR/wear.csv, DIR/summary.json and DIR/wear.png
(Fig. 10/11 style); with several runs one sub-directory per run plus
DIR/campaign.csv and DIR/campaign_kw.png (Fig. 12: k_w vs load, temperature,
stroke, frequency).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_bringup.argtypes import bounded_int
from tribo_bringup.paths import CONFIG

if TYPE_CHECKING:
    from tribo_bringup.argtypes import Subparsers

UM3 = 1e-18


def register(sub: Subparsers) -> None:
    """Add the ``wear`` subcommand."""
    p = sub.add_parser(
        'wear',
        help='nVCT counts -> wear volume, running-in and progressive wear (paper 3)',
        description='Convert nVCT detector counts to wear height and volume (inverting the '
        'activation depth profile, Equ. 8-9), evaluate running-in and progressive wear '
        '(progressive rate = regression slope 120-180 min, paper 3.5), wear coefficients '
        'k_w = V/(L d_s) (Equ. 10) and an exponential running-in model fit.',
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog='COUNTS: CSV with columns t_start,t_end,counts,live_time (s, s, counts, s) or a '
        'bag (directory or .mcap) with /nvct/counts.\n'
        'Outputs: DIR/wear.csv, DIR/summary.json, DIR/wear.png; several inputs: one '
        'sub-directory each plus DIR/campaign.csv and DIR/campaign_kw.png (Fig. 12).\n'
        'Try it: tribo wear --simulate /tmp/counts.csv && '
        'tribo wear /tmp/counts.csv --nvct config/nvct.yaml --out /tmp/wear',
    )
    p.add_argument('counts', nargs='*', help='counts CSV(s) or bag(s)')
    p.add_argument(
        '--nvct',
        action='append',
        metavar='NVCT.yaml',
        help='nVCT configuration; once for all inputs or once per input',
    )
    p.add_argument('--out', metavar='DIR', help='output directory')
    p.add_argument(
        '--convention',
        choices=('paper', 'astm_g133'),
        help='sliding distance for k_w: paper (stroke*f*t, default of NVCT.yaml) or '
        'astm_g133 (2*stroke*f*t)',
    )
    p.add_argument('--no-plots', action='store_true', help='skip the PNG plots')
    p.add_argument(
        '--simulate',
        metavar='OUT.csv',
        help='write a simulated counts CSV (forward model of a test) and exit',
    )
    p.add_argument(
        '--sim',
        metavar='SIM.yaml',
        default=str(CONFIG / 'sim_detector.yaml'),
        help='simulated-detector configuration for --simulate (default: %(default)s)',
    )
    p.add_argument(
        '--seed',
        type=bounded_int(0, 2**63 - 1),
        help='random seed for --simulate (default: from SIM.yaml)',
    )
    p.set_defaults(func=run)


def _err(msg: str) -> Exception:
    from tribo_nvct.errors import NvctConfigError

    return NvctConfigError(msg)


def _simulate(args: argparse.Namespace) -> int:
    from tribo_nvct.core.simulate import ForwardSimulator, load_sim_config, write_counts_csv

    nvct = args.nvct[0] if args.nvct else None
    sc = load_sim_config(args.sim, nvct)
    sim = ForwardSimulator(sc.nvct, sc.truth, sc.settings)
    seed = args.seed if args.seed is not None else sc.seed
    dwells = sim.run(seed)
    tr = sim.paper_truth()
    header = (
        f'simulated nVCT test ({args.sim}, nvct {sc.nvct.source}, seed {seed})\n'
        f'truth: V_r={sc.truth.running_in_volume / UM3:.6g} um^3, '
        f'tau={sc.truth.tau / 60:.4g} min, w={sc.truth.progressive_rate * 60 / UM3:.6g} um^3/min\n'
        f'truth (paper 3.5): total_volume_um3={tr["total_volume"] / UM3:.6g}, '
        f'progressive_rate_um3_per_min={tr["progressive_rate"] * 60 / UM3:.6g}, '
        f'running_in_volume_um3={tr["running_in_volume"] / UM3:.6g}'
    )
    from tribo_bringup.outputs import atomic_output_file

    with atomic_output_file(args.simulate) as tmp:
        write_counts_csv(tmp, dwells, header)
    print(f'wear: wrote {len(dwells)} simulated dwells to {args.simulate}', file=sys.stderr)
    return 0


def _evaluate_run(
    counts: Path, nvct: Path, out: Path, args: argparse.Namespace
) -> dict[str, object]:
    """Evaluate one run (:func:`tribo_nvct.evaluate_wear`) and write it into ``out``.

    A bag that ends early is evaluated up to its damage and written; the error is
    raised afterwards.
    """
    from tribo_nvct.api import evaluate_wear, read_counts
    from tribo_nvct.errors import CountsTruncatedError

    data = read_counts(counts, keep_truncated=True)
    if data.truncated:
        print(
            f'wear: warning: {data.truncated}; using the {len(data)} dwells before it',
            file=sys.stderr,
        )

    def progress(i: int, n: int) -> None:
        print(f'wear: {counts.name}: dwell {i}/{n}', file=sys.stderr)

    wear = evaluate_wear(data, nvct, convention=args.convention, progress=progress)
    wear.write(out)
    if not args.no_plots:
        wear.plot(out)
    if wear.truncated:
        raise CountsTruncatedError(wear.truncated)  # results of the good part are written
    return wear.summary()


def _jsonable(x: object) -> object:
    """NaN/inf -> None so the JSON is strict."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    return x


def run(args: argparse.Namespace) -> int:
    """Evaluate one or several runs (or write a simulated counts file)."""
    from tribo_bringup.errors import BagTruncatedError
    from tribo_bringup.outputs import PARTIAL_DIR, atomic_output_dir, keep_as_partial

    if args.simulate:
        return _simulate(args)
    if not args.counts:
        raise _err('give COUNTS (CSV or bag), or --simulate OUT.csv')
    if not args.nvct:
        raise _err('missing --nvct NVCT.yaml')
    if not args.out:
        raise _err('missing --out DIR')
    inputs = [Path(c) for c in args.counts]
    if len(args.nvct) not in (1, len(inputs)):
        raise _err(
            f'give --nvct once or once per input ({len(inputs)} inputs, {len(args.nvct)} --nvct)'
        )
    nvcts = [Path(n) for n in args.nvct] * (len(inputs) if len(args.nvct) == 1 else 1)
    out = Path(args.out)
    truncated: BagTruncatedError | None = None
    with atomic_output_dir(out) as stage:
        try:
            _run_all(inputs, nvcts, stage, args)
        except BagTruncatedError as exc:
            keep_as_partial(stage)  # results of the good part, never taken for the whole
            truncated = exc
    if truncated is not None:
        raise BagTruncatedError(f'{truncated} (results of the good part in {out / PARTIAL_DIR})')
    return 0


def _run_all(inputs: list[Path], nvcts: list[Path], out: Path, args: argparse.Namespace) -> int:
    """Evaluate the runs into ``out`` (the staging directory of ``--out``)."""
    if len(inputs) == 1:
        s = _evaluate_run(inputs[0], nvcts[0], out, args)
        print(
            f'wear: {Path(args.out) / "summary.json"}: total {_fmt(s["total_volume_um3"])} '
            f'+- {_fmt(s.get("total_volume_combined_se_um3"))} um^3 at 180 min, progressive '
            f'{_fmt(s["progressive_rate_um3_per_min"])} '
            f'+- {_fmt(s.get("progressive_rate_combined_se_um3_per_min"))} um^3/min, '
            f'running-in {_fmt(s["running_in_volume_um3"])} um^3 (+- combined SE: counting '
            'and depth profile)',
            file=sys.stderr,
        )
        return 0
    rows: list[dict[str, object]] = []
    used: set[str] = set()
    for c, n in zip(inputs, nvcts, strict=True):
        name = c.stem
        while name in used:
            name += '_'
        used.add(name)
        s = _evaluate_run(c, n, out / name, args)
        rows.append({k: _jsonable(v) for k, v in s.items()})
    keys = [
        'input',
        'label',
        'load_N',
        'temperature_K',
        'stroke_m',
        'frequency_hz',
        'total_volume_um3',
        'total_volume_se_um3',
        'total_volume_combined_se_um3',
        'progressive_rate_um3_per_min',
        'progressive_rate_se_um3_per_min',
        'progressive_rate_combined_se_um3_per_min',
        'running_in_volume_um3',
        'running_in_volume_se_um3',
        'running_in_volume_combined_se_um3',
        'k_w_progressive',
        'k_w_progressive_se',
        'k_w_progressive_combined_se',
        'k_w_running_in',
        'k_w_running_in_se',
        'k_w_running_in_combined_se',
        'sliding_distance_convention',
    ]
    with (out / 'campaign.csv').open('w', newline='', encoding='utf-8') as fh:
        w = csv.writer(fh)
        w.writerow(keys)
        for r in rows:
            w.writerow(['' if r.get(k) is None else r.get(k) for k in keys])
    if not args.no_plots:
        from tribo_nvct.plots import plot_campaign_kw

        plot_campaign_kw(out / 'campaign_kw.png', rows)
    print(f'wear: {len(rows)} runs, {Path(args.out) / "campaign.csv"}', file=sys.stderr)
    return 0


def _fmt(x: object) -> str:
    return 'n/a' if x is None or (isinstance(x, float) and not math.isfinite(x)) else f'{x:.5g}'
