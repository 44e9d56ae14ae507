"""Benchmark of the live model monitor: processing time and verdict of one 6 s window.

A 10 kHz record of config/rig.yaml (no effect) and of
config/rig_hidden_<effect>.yaml (default: frictional lag) with the sensor noise of the
rig file, pushed through
:class:`tribo_estimation.core.discrepancy.monitor.WindowMonitor` in 0.1 s chunks with
the default settings (6 s window, 2 s hop, the missing-physics pipeline with its live
budget: :meth:`~tribo_estimation.core.discrepancy.Policy.live`, every effect family,
5 bootstrap replicas, wall-time budget 1.5 s). Prints per record the windows'
processing times (median, max; target: below the 2 s hop on this 2-core machine), the
baseline's residual ratio (rms / noise floor, median), the verdicts (windows per
verdict), the families named (windows naming each; the hidden family expected, none for
the control), the best candidate's residual over the noise floor (median), the
windows over the hop, and the investigation of the first window whose budget ended
before every family was screened (its verdict and time; the node runs it beside the
windows).

    .venv/bin/python bench/bench_model_monitor.py [--duration 20] [--effects frictional_lag]
        [--budget 1.5] [--replicas 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
from collections import Counter
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


def run(
    name: str, duration: float, seed: int, cfg: MonitorConfig
) -> tuple[list[WindowResult], WindowResult | None]:
    """Return all windows of one simulated record with effect ``name`` hidden ('none': none).

    And the investigation of its first incomplete window (None if every window was
    complete), as the node runs it beside the windows.
    """
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
    inquiry: WindowResult | None = None
    for a in range(0, res.time.size, 1000):
        s = slice(a, a + 1000)
        for w in mon.add(
            res.time[s], res.torsion_moment[s], res.angular_acceleration[s], res.speed[s]
        ):
            out.append(mon.evaluate(w))
            if inquiry is None and not out[-1].complete:
                inquiry = mon.investigate(w, out[-1].null)
    return out, inquiry


def main() -> int:
    """Time the monitor's windows and print them; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--duration', type=float, default=20.0, help='record length [s] (20)')
    ap.add_argument('--effects', default='frictional_lag', help='comma-separated hidden effects')
    ap.add_argument('--seed', type=int, default=2026)
    ap.add_argument(
        '--budget', type=float, default=MonitorConfig().time_budget, help='time budget [s]'
    )
    ap.add_argument(
        '--replicas', type=int, default=MonitorConfig().replicas, help='bootstrap replicas'
    )
    args = ap.parse_args()
    cfg = MonitorConfig(time_budget=args.budget, replicas=args.replicas)
    # load the compiled kernels before timing
    run('none', cfg.window + 0.1, args.seed, cfg)
    print(
        f'window {cfg.window:g} s, hop {cfg.hop:g} s, budget {cfg.time_budget:g} s, '
        f'alpha {cfg.alpha:g}, {cfg.replicas} replicas, '
        f'families: {", ".join(cfg.candidates) or "all"}'
    )
    print(
        f'{"hidden":<22s} {"windows":>7s} {"median [s]":>10s} {"max [s]":>8s} {"ratio":>6s} '
        f'{"after/floor":>11s} {"over hop":>8s}  verdicts; named'
    )
    worst = 0.0
    for i, name in enumerate(['none', *[e for e in args.effects.split(',') if e]]):
        res, inquiry = run(name, args.duration, args.seed + i, cfg)
        if not res:
            print(f'{name:<22s} no window (record shorter than the window)')
            continue
        times = [r.processing_time for r in res]
        worst = max(worst, max(times))
        verdicts = Counter(r.verdict or r.quality for r in res)
        named = Counter(r.candidate for r in res if r.identifiable)
        over = sum(r.processing_time > cfg.hop for r in res)
        after = [r.candidate_rms / r.noise_floor for r in res if r.candidate]
        after_s = f'{statistics.median(after):11.2f}' if after else f'{"-":>11s}'
        print(
            f'{name:<22s} {len(res):7d} {statistics.median(times):10.3f} {max(times):8.3f} '
            f'{statistics.median(r.ratio for r in res):6.2f} {after_s} {over:8d}  '
            + ', '.join(f'{v} {n}' for v, n in sorted(verdicts.items()))
            + '; '
            + (', '.join(f'{c} {n}' for c, n in sorted(named.items())) or 'none')
        )
        print(f'    first window: {res[0].identifiable_reason}')
        if inquiry is not None:
            print(
                f'    investigation of the first incomplete window (every family screened, '
                f'{inquiry.processing_time:.1f} s): {inquiry.identifiable_reason}'
            )
    print(f'slowest window {worst:.3f} s (hop {cfg.hop:g} s)')
    return 0


if __name__ == '__main__':
    raise SystemExit(validation_doc.run(__file__, main))
