"""Benchmark of the live model monitor: processing time of one 6 s window.

A 10 kHz record of config/rig.yaml (no effect) and of
config/rig_hidden_<effect>.yaml (default: viscous friction) with the sensor
noise of the rig file, pushed through
:class:`tribo_estimation.core.discrepancy.monitor.WindowMonitor` in 0.1 s
chunks with the default settings (6 s window, 2 s hop, time budget 1 s, up to
2 candidates). Prints per record the windows' processing times (median, max;
target: below the 2 s hop on this 2-core machine), the residual ratio, the
named candidate, its residual rms over the noise floor (median) and the
identifiability verdict.

    .venv/bin/python bench/bench_model_monitor.py [--duration 20] [--effects viscous_friction]
        [--thin 2] [--budget 1.0]
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import validation_doc

ROOT = Path(__file__).resolve().parents[1]
for pkg in ('tribo_estimation',):
    sys.path.insert(0, str(ROOT / 'src' / pkg))

from tribo_estimation.core.config import load_rig_config  # noqa: E402
from tribo_estimation.core.discrepancy.monitor import (  # noqa: E402
    MonitorConfig,
    WindowMonitor,
    WindowResult,
)
from tribo_estimation.core.simulate import simulate  # noqa: E402


def run(name: str, duration: float, seed: int, cfg: MonitorConfig) -> list[WindowResult]:
    """All windows of one simulated record."""
    path = ROOT / 'config' / ('rig.yaml' if name == 'none' else f'rig_hidden_{name}.yaml')
    rc = load_rig_config(path)
    res = simulate(
        rc.rig,
        rc.friction,
        rc.drive,
        duration,
        10_000.0,
        noise=rc.noise,
        seed=seed,
        extensions=rc.extensions,
    )
    mon = WindowMonitor(rc.rig, rc.drive, k=rc.friction.k, config=cfg)
    out: list[WindowResult] = []
    for a in range(0, res.time.size, 1000):
        s = slice(a, a + 1000)
        out += mon.push(
            res.time[s], res.torsion_moment[s], res.angular_acceleration[s], res.speed[s]
        )
    return out


def main() -> int:
    """Time the monitor's windows and print them; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--duration', type=float, default=20.0, help='record length [s] (20)')
    ap.add_argument('--effects', default='viscous_friction', help='comma-separated hidden effects')
    ap.add_argument('--seed', type=int, default=2026)
    ap.add_argument('--thin', type=int, default=MonitorConfig().thin, help='segment thinning')
    ap.add_argument(
        '--budget', type=float, default=MonitorConfig().time_budget, help='time budget [s]'
    )
    args = ap.parse_args()
    cfg = MonitorConfig(thin=args.thin, time_budget=args.budget)
    # load the compiled kernels before timing
    run('none', cfg.window + 0.1, args.seed, cfg)
    print(
        f'window {cfg.window:g} s, hop {cfg.hop:g} s, budget {cfg.time_budget:g} s, '
        f'up to {cfg.max_candidates} candidates, every {cfg.thin}. segment in the candidate stage'
    )
    print(
        f'{"hidden":<22s} {"windows":>7s} {"median [s]":>10s} {"max [s]":>8s} {"ratio":>6s} '
        f'{"named":<22s} {"after/floor":>11s} {"identifiable":<12s} over budget'
    )
    worst = 0.0
    for i, name in enumerate(['none', *[e for e in args.effects.split(',') if e]]):
        res = run(name, args.duration, args.seed + i, cfg)
        times = [r.processing_time for r in res]
        worst = max(worst, max(times))
        named = {r.candidate or '-' for r in res}
        ident = {str(r.identifiable) for r in res if r.candidate}
        over = sum(r.processing_time > cfg.hop for r in res)
        after = [r.candidate_rms / r.noise_floor for r in res if r.candidate]
        after_s = f'{statistics.median(after):11.2f}' if after else f'{"-":>11s}'
        print(
            f'{name:<22s} {len(res):7d} {statistics.median(times):10.3f} {max(times):8.3f} '
            f'{statistics.median(r.ratio for r in res):6.2f} {",".join(sorted(named)):<22s} '
            f'{after_s} '
            f'{",".join(sorted(ident)) or "-":<12s} {over}'
        )
        for r in res[:1]:
            if r.candidate:
                print(f'    {r.candidate} {r.params}: {r.identifiable_reason}')
    print(f'slowest window {worst:.3f} s (hop {cfg.hop:g} s)')
    return 0


if __name__ == '__main__':
    raise SystemExit(validation_doc.run(__file__, main))
