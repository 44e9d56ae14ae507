"""nVCT benchmark: the wear figures over seeds, detection limits, Hertz table (Fig. 9).

Run: .venv/bin/python bench/bench_nvct.py [--seeds 200]
Prints, for the shipped config/sim_detector.yaml test (240 min, 60 s dwell,
Poisson counts, background, decay, dead time, oil circuit): relative errors of
total volume at 180 min, progressive rate and running-in volume (window
method and exponential fit), z-score statistics of the reported standard
errors, the Currie detection limit per dwell and per hour, and the Hertz
contact for the paper's Fig. 9 loads.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import validation_doc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src' / 'tribo_nvct'))

from tribo_nvct.core.config import geometry_from_dict  # noqa: E402
from tribo_nvct.core.simulate import ForwardSimulator, load_sim_config  # noqa: E402
from tribo_nvct.core.streaming import WearEvaluator  # noqa: E402
from tribo_nvct.core.wear import detection_limit_height  # noqa: E402

UM3 = 1e-18


def main() -> None:
    """Run the nVCT accuracy benchmark over seeds and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--seeds', type=int, default=200)
    ap.add_argument('--sim', default=str(ROOT / 'config' / 'sim_detector.yaml'))
    args = ap.parse_args()
    sc = load_sim_config(args.sim)
    cfg = sc.nvct
    sim = ForwardSimulator(cfg, sc.truth, sc.settings)
    tr = sim.paper_truth()
    print(
        f'config: {cfg.source}; tagged activity {cfg.tagged_activity / 1e3:.1f} kBq '
        f'({cfg.nuclide.name}, exemption {cfg.nuclide.exemption_bq:.0e} Bq), '
        f'k_A = {cfg.k_A:.3f}, contact {cfg.contact_area / 1e-12:.4g} um^2'
    )
    print(
        f'truth: total {tr["total_volume"] / UM3:.6g} um^3, rate '
        f'{tr["progressive_rate"] * 60 / UM3:.6g} um^3/min, running-in '
        f'{tr["running_in_volume"] / UM3:.6g} um^3 (paper 3.5 on the noise-free curve)'
    )
    rows = []
    t0 = time.perf_counter()
    for seed in range(args.seeds):
        ev = WearEvaluator(cfg)
        for d in sim.run(seed):
            ev.add(d)
        e = ev.evaluation()
        ef = e.exp_fit
        rows.append(
            [
                e.total_volume,
                e.total_volume_se,
                e.progressive_rate,
                e.progressive_rate_se,
                e.running_in_volume,
                e.running_in_volume_se,
                ef.w,
                ef.w_se,
                ef.V_r,
                ef.V_r_se,
            ]
        )
    dt = time.perf_counter() - t0
    r = np.array(rows)
    print(f'{args.seeds} seeds in {dt:.1f} s ({dt / args.seeds * 1e3:.1f} ms per 240-dwell test)')
    print(
        f'{"quantity":<28}{"target":>8}{"max|rel|":>10}{"mean rel":>10}{"rel SE":>9}'
        f'{"z mean":>8}{"z sd":>7}'
    )
    for name, i, tv, target in (
        ('total volume @180 min', 0, tr['total_volume'], '3 %'),
        ('progressive rate (window)', 2, tr['progressive_rate'], '10 %'),
        ('running-in volume (window)', 4, tr['running_in_volume'], '10 %'),
        ('w (exp fit)', 6, sc.truth.progressive_rate, '-'),
        ('V_r (exp fit)', 8, sc.truth.running_in_volume, '-'),
    ):
        rel = r[:, i] / tv - 1.0
        z = (r[:, i] - tv) / r[:, i + 1]
        print(
            f'{name:<28}{target:>8}{np.abs(rel).max() * 100:>9.2f}%{rel.mean() * 100:>9.2f}%'
            f'{np.mean(r[:, i + 1] / tv) * 100:>8.2f}%{z.mean():>8.2f}{z.std():>7.2f}'
        )
    print('Currie detection limit (mean wear height, background only, test start):')
    ld_dwell = detection_limit_height(cfg, sc.settings.dwell) * 1e9
    print(
        f'  per {sc.settings.dwell:g} s dwell: {ld_dwell:.3f} nm;'
        f' per hour: {detection_limit_height(cfg, 3600.0) * 1e9:.4f} nm'
    )
    late_rate = float(sim.expected_true_counts[-1] / sc.settings.dwell - cfg.background.rate)
    print(
        f'  wear increment at the end of the test (oil at {late_rate:.0f} counts/s): per dwell '
        f'{detection_limit_height(cfg, sc.settings.dwell, late_rate) * 1e9:.3f} nm, per hour '
        f'{detection_limit_height(cfg, 3600.0, late_rate) * 1e9:.4f} nm'
    )
    if isinstance(cfg.raw.get('contact'), dict):
        g = geometry_from_dict(cfg.raw['contact'])
        print('Hertz contact, ring section on liner section (Fig. 9 loads):')
        for P in (50.0, 100.0, 150.0, 200.0):
            c = g.contact(P)
            print(
                f'  {P:5.0f} N: {c.kind}, half-widths {c.half_width_circ * 1e3:.3f} x '
                f'{c.half_width_axial * 1e3:.3f} mm, area {c.area * 1e6:.3f} mm^2, '
                f'p_max {c.p_max / 1e6:.1f} MPa, p_mean {c.p_mean / 1e6:.1f} MPa'
            )


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
