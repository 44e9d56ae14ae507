"""Benchmark of the block-wise friction estimation.

Prints:
1. accuracy per block at 10, 30 and 60 rpm with the issue's noise (0.05 N m,
   2 rad/s^2, 10 kHz) on records of the independent generator
   (``core/reference_records.py``: its own equations of motion, not the fit's
   kernel): largest relative error of mu0 and mu_inf after the start-up block,
   and how often the truth lies within 2 standard errors (coverage of the
   nominal 95 % interval; three records of 20 blocks per speed, ``--quick`` one
   of 7);
2. CPU time per 1 s block (median, one core: BLAS limited to one thread): the
   fit alone (``fit_block``), the whole block evaluation (stick detection + fit)
   and the stick detection
   (``sticks.detect_sticks``) alone, side by side with a
   plain scipy ``least_squares`` + ``solve_ivp`` fit of the same block
   (single shooting with the reference integrator of ``core/reference.py``,
   started from the TRUE state, which a real fit does not have);
3. a long streaming run: synthetic 10 kHz data generated chunk by chunk
   through aligner -> estimator -> blocks.csv, with the peak RSS.

Usage: ``.venv/bin/python bench/bench_friction.py [--hours 1.0] [--quick] [--timing-only]``
(``--timing-only``: part 1/2 only, for iterating on speed)
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import validation_doc

# one core: OpenBLAS worker threads busy-wait after each call (lstsq in the fit and its
# standard errors) and would be counted in process_time() as a second core
for _var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
    os.environ.setdefault(_var, '1')

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src' / 'tribo_estimation'))

from tribo_estimation.core.align import ChannelAligner  # noqa: E402
from tribo_estimation.core.blockfit import (  # noqa: E402
    BlockConfig,
    BlockCsvWriter,
    BlockEstimator,
    PendingBlock,
    evaluate_block,
    fit_block,
    initial_estimate,
)
from tribo_estimation.core.model import (  # noqa: E402
    DriveProfile,
    FrictionLaw,
    RigParams,
    RigState,
)
from tribo_estimation.core.simulate import NoiseSpec, simulate  # noqa: E402
from tribo_estimation.core.sticks import detect_sticks  # noqa: E402

RIG = RigParams.tab1()
TRUTH = FrictionLaw(0.13, 0.10, 2.0)
GUESS = FrictionLaw(0.12, 0.11, 2.0)
NOISE = NoiseSpec(0.05, 2.0, 0.005)
FS = 10_000.0


def rad_s(rpm: float) -> float:
    """Convert rpm to rad/s."""
    return rpm * math.pi / 30.0


def _blocks(
    rpm: float, n_blocks: int, seed: int
) -> tuple[list[PendingBlock], list[RigState | None]]:
    """Simulate 1 s blocks (chunk-wise, state carried); also the true state at each start."""
    rng = np.random.default_rng(seed)
    out: list[PendingBlock] = []
    states: list[RigState | None] = []
    st = None
    for b in range(n_blocks):
        r = simulate(
            RIG, TRUTH, DriveProfile(rad_s(rpm), 0.5), 1.0, FS, initial=st, noise=NOISE, seed=rng
        )
        states.append(st)
        st = r.final_state
        out.append(
            PendingBlock(
                b,
                b * 10_000,
                float(r.time[0]),
                FS,
                r.torsion_moment,
                r.angular_acceleration,
                r.speed,
                np.ones(10_000, bool),
            )
        )
    return out, states


def _reference_blocks(rpm: float, n_blocks: int, seed: int) -> list[PendingBlock]:
    """Cut one record of the independent generator into 1 s blocks.

    Its own equations of
    motion and instrument model, :mod:`core.reference_records`): start-up ramp of
    0.5 s to ``rpm``, the issue's white noise per channel, 10 kHz.
    """
    from tribo_estimation.core.reference import SpeedProfile
    from tribo_estimation.core.reference_records import RecordSpec, make_record, rig_channels

    tq, ac, sp = rig_channels(1.0)
    rec = make_record(
        RecordSpec(
            RIG,
            TRUTH,
            SpeedProfile.startup(rad_s(rpm), 0.5),
            torsion=tq,
            accel=ac,
            speed=sp,
            seed=seed,
            duration=float(n_blocks),
            fs=FS,
        )
    )
    n = round(FS)
    return [
        PendingBlock(
            b,
            b * n,
            float(rec.time[b * n]),
            FS,
            rec.torsion_moment[b * n : (b + 1) * n],
            rec.angular_acceleration[b * n : (b + 1) * n],
            rec.speed[b * n : (b + 1) * n],
            np.ones(n, bool),
        )
        for b in range(n_blocks)
    ]


def blk_time(blk: PendingBlock) -> np.ndarray:
    """Sample times of a block [s]."""
    out: np.ndarray = blk.t_start + np.arange(blk.torsion.shape[0]) / blk.fs
    return out


def accuracy_and_speed(n_blocks: int, n_records: int) -> None:
    """Accuracy, coverage of the 2-se interval and CPU time per 1 s block."""
    print('1) accuracy per block (blocks after the start-up block) and 2) CPU time per block')
    print(
        f'{"rpm":>4} {"blocks":>6} {"max|dmu0|/mu0":>14} {"max|dmuinf|/muinf":>18} '
        f'{"2se mu0":>8} {"2se muinf":>9} {"fit ms":>7} {"block ms":>8} {"sticks ms":>9} '
        f'{"evals":>5}'
    )
    for rpm in (10.0, 30.0, 60.0):
        cfg = BlockConfig(nominal_speed=rad_s(rpm), ramp_time=0.5)
        e0, e1, c0, c1, t_fit, t_blk, t_stk, evals = [], [], [], [], [], [], [], []
        for rec in range(n_records):
            blocks = _reference_blocks(rpm, n_blocks, seed=int(rpm) + 100 * rec)
            evaluate_block(RIG, GUESS, cfg, blocks[1])  # warm-up (compiled code loaded)
            for blk in blocks[1:]:
                t = time.process_time()
                det = evaluate_block(RIG, GUESS, cfg, blk)
                t_blk.append(time.process_time() - t)
                t = time.process_time()
                out = fit_block(RIG, det.data, rad_s(rpm), 2.0, cfg)
                t_fit.append(time.process_time() - t)
                evals.append(out.n_eval)
                t = time.process_time()
                detect_sticks(blk_time(blk), blk.torsion, blk.accel, blk.speed, RIG)
                t_stk.append(time.process_time() - t)
                res = det.result
                e0.append(abs(res.mu0 - TRUTH.mu0) / TRUTH.mu0)
                e1.append(abs(res.mu_inf - TRUTH.mu_inf) / TRUTH.mu_inf)
                c0.append(abs(res.mu0 - TRUTH.mu0) < 2 * res.mu0_se)
                c1.append(abs(res.mu_inf - TRUTH.mu_inf) < 2 * res.mu_inf_se)
        print(
            f'{rpm:4.0f} {len(e0):6d} {max(e0):14.2e} {max(e1):18.2e} '
            f'{np.mean(c0):8.0%} {np.mean(c1):9.0%} {np.median(t_fit) * 1e3:7.1f} '
            f'{np.median(t_blk) * 1e3:8.1f} {np.median(t_stk) * 1e3:9.1f} '
            f'{int(np.median(evals)):5d}'
        )


def plain_scipy_fit(rpm: float = 30.0) -> None:
    """Compare one block's fit with a plain scipy least_squares + solve_ivp fit."""
    from scipy.optimize import least_squares

    from tribo_estimation.core.reference import simulate_reference

    blocks, states = _blocks(rpm, 3, seed=5)
    blk, st0 = blocks[2], states[2]
    cfg = BlockConfig(nominal_speed=rad_s(rpm))
    det = evaluate_block(RIG, GUESS, cfg, blk)
    mu0_i, muinf_i = initial_estimate(det.data, RIG.F_N * RIG.R)
    drive = DriveProfile(rad_s(rpm), 0.5)
    n_sim = [0]

    def resid(th: np.ndarray) -> np.ndarray:
        n_sim[0] += 1
        r = simulate_reference(
            RIG, FrictionLaw(th[0], th[1], 2.0), drive, 1.0, FS, initial=st0, rtol=1e-6, atol=1e-9
        )
        return np.concatenate(
            (
                (r.torsion_moment - blk.torsion) / NOISE.torque,
                (r.angular_acceleration - blk.accel) / NOISE.accel,
            )
        )

    t = time.process_time()
    sol = least_squares(resid, [mu0_i, muinf_i], x_scale=[0.01, 0.01], max_nfev=40)
    dt = time.process_time() - t
    t = time.process_time()
    ours = evaluate_block(RIG, GUESS, cfg, blk).result
    dt_ours = time.process_time() - t
    print(
        f'\n2b) same 1 s block at {rpm:.0f} rpm: plain scipy least_squares + solve_ivp '
        f'(DOP853, rtol 1e-6, true start state): {dt * 1e3:.0f} ms CPU, {n_sim[0]} '
        f'simulations, mu0 = {sol.x[0]:.5f}, mu_inf = {sol.x[1]:.5f}'
    )
    print(
        f'    this fit (multiple shooting, compiled kernel): {dt_ours * 1e3:.0f} ms CPU, '
        f'mu0 = {ours.mu0:.5f}, mu_inf = {ours.mu_inf:.5f}  (truth 0.13000, 0.10000); '
        f'speed-up {dt / dt_ours:.0f}x'
    )


def streaming_memory(hours: float) -> None:
    """Stream ``hours`` of 10 kHz data through aligner and estimator; print the peak RSS."""
    rpm = 30.0
    n_blocks = max(1, round(hours * 3600.0))
    cfg = BlockConfig(nominal_speed=rad_s(rpm), ramp_time=0.5)
    est = BlockEstimator(RIG, GUESS, cfg)
    aligner = ChannelAligner()
    st = None
    n_ok = 0
    t_wall = time.monotonic()
    rng = np.random.default_rng(1)
    with tempfile.TemporaryDirectory() as tmp, BlockCsvWriter(Path(tmp) / 'blocks.csv') as w:
        for b in range(n_blocks):
            r = simulate(
                RIG,
                TRUTH,
                DriveProfile(rad_s(rpm), 0.5),
                1.0,
                FS,
                initial=st,
                noise=NOISE,
                seed=rng,
            )
            st = r.final_state
            for i in range(0, 10_000, 500):  # 20 SampleBlocks per channel and second
                j = b * 10_000 + i
                for name, arr in (
                    ('torsion_moment', r.torsion_moment),
                    ('angular_acceleration', r.angular_acceleration),
                    ('speed', r.speed),
                ):
                    for ev in aligner.push(name, j, FS, float(r.time[i]), arr[i : i + 500]):
                        for det in est.feed(ev):
                            w.write(det.result)
                            n_ok += det.result.ok
            if b % 300 == 299:
                rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
                print(
                    f'   {b + 1} blocks ({(b + 1) / 3600:.2f} h of data), peak RSS {rss:.0f} MB, '
                    f'{time.monotonic() - t_wall:.0f} s',
                    file=sys.stderr,
                )
        for ev in aligner.flush():
            for det in est.feed(ev):
                w.write(det.result)
        for det in est.finish():
            w.write(det.result)
        rows = w.rows
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(
        f'\n3) streaming {hours:g} h of 10 kHz data ({n_blocks} blocks, {rows} rows, '
        f'{n_ok} ok): peak RSS {rss:.0f} MB, {time.monotonic() - t_wall:.0f} s wall'
    )


def main() -> None:
    """Run the benchmark (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--hours', type=float, default=1.0, help='length of the streaming run [h]')
    ap.add_argument('--quick', action='store_true', help='short run (6 min of data)')
    ap.add_argument(
        '--timing-only',
        action='store_true',
        help='only part 1/2 (accuracy and CPU time per block), no scipy comparison or streaming',
    )
    args = ap.parse_args()
    accuracy_and_speed(8 if args.quick else 21, 1 if args.quick else 3)
    if args.timing_only:
        return
    plain_scipy_fit()
    streaming_memory(0.1 if args.quick else args.hours)


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
