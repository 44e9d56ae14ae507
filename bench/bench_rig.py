"""Rig physics benchmark: simulator accuracy and speed, free-decay accuracy.

Run: .venv/bin/python bench/bench_rig.py [--repeats 21] [--seeds 10]

Prints, for the shipped config/rig.yaml (Tab. 1 rig, F_N*R = 640 N m,
mu0 = 0.13, mu_inf = 0.10) at 10, 30 and 60 rpm, 1 s of stick-slip at 10 kHz:
- relative RMS error of the torsion moment (and acceleration) of the compiled
  kernel against the scipy DOP853 reference (rtol 1e-10, event location),
  the number of switching events and the largest switch-instant difference;
- the kernel time for 1 s of simulated time (median and min over repeats after
  JIT warm-up), the real-time factor and the scipy reference time side by side;
and free-decay identification errors on noisy records (0.05 N m, 2 rad/s^2 at
10 kHz) for the non-Tab.-1 chamber of config/rig_decay_example.yaml over seeds.
Targets: rel. RMS <= 1e-3; <= 2 ms per simulated second (>= 500x
real time); I1, C1 within 1 %, K1 within 10 %.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import validation_doc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src' / 'tribo_estimation'))

from tribo_estimation.core import kernel as kn  # noqa: E402
from tribo_estimation.core.config import load_rig_config  # noqa: E402
from tribo_estimation.core.decay import identify_free_decay  # noqa: E402
from tribo_estimation.core.model import DriveProfile, RigParams, RigState, pack_params  # noqa: E402
from tribo_estimation.core.reference import simulate_reference  # noqa: E402
from tribo_estimation.core.simulate import NoiseSpec, simulate, simulate_free_decay  # noqa: E402


def _rel_rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def bench_simulator(repeats: int) -> None:
    """Print the kernel's accuracy against the scipy reference and its speed (``repeats`` runs)."""
    cfg = load_rig_config(ROOT / 'config' / 'rig.yaml')
    fs = 10_000.0
    print('Simulator: 1 s of stick-slip at 10 kHz, Tab. 1 rig (config/rig.yaml), from rest')
    print(
        f'{"rpm":>4} {"events":>6} {"relRMS M_t":>11} {"relRMS a":>10} {"max dt_sw":>10} '
        f'{"kernel ms":>10} {"(min)":>7} {"x realtime":>10} {"scipy ms":>9} {"ratio":>7}'
    )
    simulate(cfg.rig, cfg.friction, DriveProfile(1.0), 0.01)  # JIT warm-up / cache load
    for rpm in (10, 30, 60):
        drive = DriveProfile(rpm * np.pi / 30.0)
        r = simulate(cfg.rig, cfg.friction, drive, 1.0, fs)
        t0 = time.perf_counter()
        ref = simulate_reference(cfg.rig, cfg.friction, drive, 1.0, fs)
        t_ref = time.perf_counter() - t0
        e_m = _rel_rms(r.torsion_moment, ref.torsion_moment)
        e_a = _rel_rms(r.angular_acceleration, ref.angular_acceleration)
        if r.n_events == ref.n_events:
            dsw = float(np.max(np.abs(r.event_times - ref.event_times)))
        else:
            dsw = float('nan')
        # time the bare kernel (what the fits call) on the flat interface
        p = pack_params(cfg.rig, cfg.friction, drive)
        out = np.empty((kn.N_CH, round(fs)))
        n_sub = kn.substeps_for(p, 1.0 / fs)
        times = []
        for _ in range(repeats):
            s = RigState().to_vector()
            t0 = time.perf_counter()
            kn.integrate(p, s, round(fs), 1.0 / fs, n_sub, out)
            times.append(time.perf_counter() - t0)
        med = float(np.median(times))
        print(
            f'{rpm:>4} {r.n_events:>6} {e_m:>11.2e} {e_a:>10.2e} {dsw:>10.1e} '
            f'{1e3 * med:>10.3f} {1e3 * min(times):>7.3f} {1.0 / med:>10.0f} '
            f'{1e3 * t_ref:>9.0f} {t_ref / med:>7.0f}'
        )
    print('  (max dt_sw: largest difference of the stick/slip switch instants [s])')


def bench_decay(seeds: int) -> None:
    """Print the free-decay identification errors over ``seeds`` noisy records."""
    cfg = load_rig_config(ROOT / 'config' / 'rig_decay_example.yaml')
    rig = RigParams(**{**cfg.rig.__dict__, 'F_N': 0.0})
    noise = NoiseSpec(torque=0.05, accel=2.0)
    print()
    print(
        f'Free decay (Equ. 7): I1={rig.I1}, K1={rig.K1}, C1={rig.C1} (not Tab. 1), '
        f'phi0 = 0.01 rad, 1.5 s, noise 0.05 N m / 2 rad/s^2, {seeds} seeds'
    )
    errs: dict[str, list[float]] = {'I1': [], 'C1': [], 'K1': [], 'z_I1': [], 'z_K1': []}
    t_fit = []
    for seed in range(seeds):
        r = simulate_free_decay(rig, 0.01, 1.5, noise=noise, seed=seed)
        t0 = time.perf_counter()
        d = identify_free_decay(r.time, r.torsion_moment, r.angular_acceleration)
        t_fit.append(time.perf_counter() - t0)
        errs['I1'].append(d.I1 / rig.I1 - 1)
        errs['C1'].append(d.C1 / rig.C1 - 1)
        errs['K1'].append(d.K1 / rig.K1 - 1)
        errs['z_I1'].append((d.I1 - rig.I1) / d.I1_se)
        errs['z_K1'].append((d.K1 - rig.K1) / d.K1_se)
    for key in ('I1', 'C1', 'K1'):
        e = np.array(errs[key])
        print(f'  {key}: max |rel err| {np.max(np.abs(e)):.2e}, mean {np.mean(e):+.2e}')
    for key in ('z_I1', 'z_K1'):
        z = np.array(errs[key])
        print(f'  {key} (error/SE): std {np.std(z):.2f} (1 = calibrated SE)')
    print(f'  fit time: median {1e3 * np.median(t_fit):.0f} ms')


def main() -> int:
    """Run the rig benchmarks and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--repeats', type=int, default=21)
    ap.add_argument('--seeds', type=int, default=10)
    args = ap.parse_args()
    bench_simulator(args.repeats)
    bench_decay(args.seeds)
    return 0


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
