"""nVCT coverage benchmark: bias and interval coverage of the wear figures.

Run: .venv/bin/python bench/bench_nvct_coverage.py [--tests 150] [--replicas 200] [--seed 1]

Many generated tests (src/tribo_nvct/test/truthgen.py: numpy/scipy only, no
code shared with the evaluation) vary the depth-profile shape (flat-erfc,
exponential, linear ramp), the layer-removal noise (0.1-1 %), the layer step
(0.05-0.25 um), the days since the profile's reference date and the
background; each goes through `tribo_nvct` (config, profile fit, streaming
evaluator). Printed, for the total volume at 180 min and the progressive rate
(120-180 min slope): bias (mean relative error and its SE), the fraction of
tests whose truth lies within 1 and 2 combined SE (counting + profile), the
same with the counting SE alone, and the worst relative error, overall and at
0.3 % layer-removal noise.
Targets: |bias| <= 0.3 %, 2-SE coverage 90-98 %, worst <= 1 % at 0.3 %.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import validation_doc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src' / 'tribo_nvct' / 'test'))
sys.path.insert(0, str(ROOT / 'src' / 'tribo_nvct'))

NOISES = (0.001, 0.002, 0.003, 0.003, 0.005, 0.01)


def run_case(
    i: int, seed: int, replicas: int, tmp: Path, shape: str | None = None
) -> dict[str, float | str]:
    """Generate test i and evaluate it; relative errors and SEs of the two figures."""
    from truthgen import SHAPES, Truth, random_case

    from tribo_nvct.core.config import config_from_dict
    from tribo_nvct.core.counting import Dwell
    from tribo_nvct.core.streaming import WearEvaluator

    rng = np.random.default_rng([seed, i])
    case = random_case(rng, i, shape or SHAPES[i % 3], NOISES[(i // 3) % len(NOISES)])
    truth = Truth(case)
    csv = tmp / f'profile_{i}.csv'
    truth.write_layer_removal(csv, rng)
    raw = truth.nvct_yaml(csv)
    raw['profile_bootstrap_replicas'] = replicas
    cfg = config_from_dict(raw, tmp, f'case{i}')
    ev = WearEvaluator(cfg)
    for d in truth.dwells(rng):
        ev.add(Dwell(*d))
    e = ev.evaluation(fit_model=False)
    tg = truth.targets()
    um3 = 1e-18
    out: dict[str, float | str] = {
        'shape': case.shape,
        'noise': case.noise_rel,
        'step': case.step_um,
        'model': getattr(cfg.profile, 'model', 'spline'),
        'case': i,
        'days': case.days,
        'bg': case.background_cps,
    }
    for key, val, se, comb, t in (
        (
            'V',
            e.total_volume / um3,
            e.total_volume_se / um3,
            getattr(e, 'total_volume_combined_se', e.total_volume_se) / um3,
            tg['total_volume_um3'],
        ),
        (
            'w',
            e.progressive_rate * 60 / um3,
            e.progressive_rate_se * 60 / um3,
            getattr(e, 'progressive_rate_combined_se', e.progressive_rate_se) * 60 / um3,
            tg['progressive_rate_um3_per_min'],
        ),
    ):
        out[key + '_rel'] = val / t - 1.0
        out[key + '_z'] = (val - t) / comb
        out[key + '_zc'] = (val - t) / se
        out[key + '_relse'] = comb / t
    return out


def report(rows: list[dict[str, float | str]], title: str) -> None:
    """Print the statistics of a subset."""
    n = len(rows)
    if n == 0:
        return
    print(f'{title} ({n} tests)')
    print(
        f'  {"figure":<22}{"bias":>8}{"+-":>7}{"rel SE":>8}{"<1 SE":>7}{"<2 SE":>7}'
        f'{"<2 SEcnt":>9}{"worst":>8}'
    )
    for key, name in (('V', 'total volume @180 min'), ('w', 'progressive rate')):
        rel = np.array([float(r[key + '_rel']) for r in rows])
        z = np.array([float(r[key + '_z']) for r in rows])
        zc = np.array([float(r[key + '_zc']) for r in rows])
        rse = np.array([float(r[key + '_relse']) for r in rows])
        print(
            f'  {name:<22}{rel.mean() * 100:>7.3f}%{rel.std(ddof=1) / np.sqrt(n) * 100:>6.3f}%'
            f'{np.median(rse) * 100:>7.2f}%{np.mean(np.abs(z) < 1) * 100:>6.0f}%'
            f'{np.mean(np.abs(z) < 2) * 100:>6.0f}%{np.mean(np.abs(zc) < 2) * 100:>8.0f}%'
            f'{np.abs(rel).max() * 100:>7.2f}%'
        )


def main() -> None:
    """Run the coverage benchmark of the nVCT uncertainties and print the rates."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--tests', type=int, default=150)
    ap.add_argument('--replicas', type=int, default=200)
    ap.add_argument('--seed', type=int, default=1)
    ap.add_argument(
        '--other',
        type=int,
        default=12,
        help='extra tests with a profile outside the parametric families (reported apart)',
    )
    ap.add_argument(
        '--package-root', help='directory holding another tribo_nvct to compare (before/after)'
    )
    args = ap.parse_args()
    if args.package_root:
        sys.path.insert(0, args.package_root)
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for i in range(args.tests):
            rows.append(run_case(i, args.seed, args.replicas, Path(d)))
        other = [
            run_case(1000 + i, args.seed, args.replicas, Path(d), 'two_exponentials')
            for i in range(args.other)
        ]
    dt = time.perf_counter() - t0
    print(
        f'nVCT coverage: {args.tests} generated tests (seed {args.seed}, '
        f'{args.replicas} profile replicas) in {dt:.0f} s'
    )
    print('bias: mean relative error +- its SE; rel SE: median combined SE / truth;')
    print('<k SE: truth within k combined SE; <2 SEcnt: within 2 counting SE; worst: max |rel err|')
    report(rows, 'all')
    report([r for r in rows if r['noise'] == 0.003], 'layer-removal noise 0.3 %')
    for shape in sorted({str(r['shape']) for r in rows}):
        report([r for r in rows if r['shape'] == shape], f'profile {shape}')
    for noise in sorted({float(r['noise']) for r in rows}):
        if noise != 0.003:
            report([r for r in rows if r['noise'] == noise], f'noise {noise * 100:g} %')
    print('largest |error| / combined SE (total volume):')
    for r in sorted(rows, key=lambda r: -abs(float(r['V_z'])))[:4]:
        print(
            f'  case {r["case"]}: {r["shape"]}, noise {float(r["noise"]) * 100:g} %, step '
            f'{r["step"]} um, {float(r["days"]):.0f} d, bg {float(r["bg"]):.1f} cps, model '
            f'{r["model"]}: error {float(r["V_rel"]) * 100:+.2f} % = {float(r["V_z"]):+.2f} SE '
            f'(counting {float(r["V_zc"]):+.2f})'
        )
    report(other, 'outside the families: two exponentials (piecewise fallback expected)')
    models: dict[str, int] = {}
    for r in rows + other:
        models[str(r['model'])] = models.get(str(r['model']), 0) + 1
    print('profile models chosen:', ', '.join(f'{k} {v}' for k, v in sorted(models.items())))
    print('targets: |bias| <= 0.3 %, <2 SE 90-98 %, worst <= 1 % at 0.3 % noise')


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
