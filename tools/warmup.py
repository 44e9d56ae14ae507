"""Compile (and cache) the numba kernels once.

The first node, test or demo then does not wait for the compiler (or starve the
live graph while it compiles).

Run by `make setup` after the build; safe to run any time. Exercises, on a short
simulated record: the rig kernel (simulate), stick detection and the block fit
(friction estimator), and the discrepancy workflow's fit.

numba invalidates a cached function only when its own file changes, not when a
function it inlines from another file does (e.g. ``kernel.friction_coefficient``
inside ``shooting``): so the caches of the whole package are dropped first
whenever any of its sources changed since the last warmup.
"""

from __future__ import annotations

import sys
import time


def drop_stale_numba_caches() -> bool:
    """Delete the package's numba caches if any source changed (True if deleted)."""
    from tribo_estimation.core.kernel.cachecheck import purge_stale_caches

    return purge_stale_caches(every_source=True)


def main() -> int:
    """Call each jitted code path once on a small problem."""
    if drop_stale_numba_caches():
        print('warmup: sources changed, numba caches dropped', file=sys.stderr)
    t0 = time.monotonic()
    from tribo_estimation.core.align import AlignedChunk
    from tribo_estimation.core.blockfit import BlockConfig, BlockEstimator
    from tribo_estimation.core.discrepancy import Policy, find_missing_physics
    from tribo_estimation.core.discrepancy.fitting import Record
    from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
    from tribo_estimation.core.simulate import NoiseSpec, simulate

    rig = RigParams.tab1()
    friction = FrictionLaw(0.13, 0.10)
    drive = DriveProfile(3.14159, 0.1)
    fs = 10_000.0
    res = simulate(rig, friction, drive, 2.0, fs, noise=NoiseSpec(0.05, 2.0, 0.005), seed=1)
    t1 = time.monotonic()
    est = BlockEstimator(rig, friction, BlockConfig(nominal_speed=3.14159, ramp_time=0.1))
    chunk = AlignedChunk(0, 0.0, fs, res.torsion_moment, res.angular_acceleration, res.speed)
    list(est.feed(chunk))
    list(est.finish())
    t2 = time.monotonic()
    sel = res.time >= 0.5
    record = Record(
        res.time[sel], res.torsion_moment[sel], res.angular_acceleration[sel], res.speed[sel]
    )
    find_missing_physics(
        [record],
        rig,
        [drive],
        policy=Policy(
            families=('viscous_friction',), max_effects=1, replicas=2, confirm_replicas=0
        ),
    )
    # paths the short record may not reach: sliding nodes, the speed sensor's first- and
    # second-order lags, and the kernel's functions called from Python (the model's
    # vectorised friction and drive, its stick moment and equations of motion)
    import numpy as np

    from tribo_estimation.core import kernel, model, shooting

    p = model.pack_params(rig, friction, drive)
    one = np.ones(1)
    start, stop = np.zeros(1, np.int64), np.ones(1, np.int64)
    knots = shooting.DriveKnots.constant(3.14159)
    shooting.sliding_states(p, one, one, one, one, one, one, knots.time, knots.speed, knots.shape)
    shooting.lag_segments(one, start, stop, one, 0.5, one.copy())
    shooting.lag_segments(one, start, stop, one, 0.5, one.copy(), 1.0)
    lag2 = shooting.second_order_lag(1e-3, 2e-7, 1e-4)
    shooting.lag2_segments(one, start, stop, one, one, lag2, one.copy(), one.copy())
    friction.mu(one)
    drive.speed(one)
    drive.angle(one)
    model.stick_moment(rig, drive, 0.0, 0.0, 0.0, 0.0)
    model.derivatives(rig, friction, drive, model.RigState())
    kernel.chamber_moment(p, 0.0, 1.0)
    t3 = time.monotonic()
    print(
        f'warmup: numba code ready in {t3 - t0:.1f} s (simulator {t1 - t0:.1f} s, '
        f'friction fit {t2 - t1:.1f} s, discrepancy {t3 - t2:.1f} s)',
        file=sys.stderr,
    )
    return 0


if __name__ == '__main__':
    sys.exit(main())
