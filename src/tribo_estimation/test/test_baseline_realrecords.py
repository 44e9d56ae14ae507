"""Discrepancy baseline on no-effect records of the independent generator: a speed
step (corners of the drive profile placed by the drive-angle fit), a 5 ms speed-sensor
lag (continuous sensor model, joint lag/offset refinement) and a record without sticks
(sliding segment starts) and a 1 ms torsion-amplifier lag (instrument model). Seeded
noise of config/rig.yaml (torsion 0.05 N m).
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.discrepancy import SelectionSettings, run_discrepancy
from tribo_estimation.core.discrepancy.fitting import MU0, MU_INF, Problem, Record
from tribo_estimation.core.discrepancy.report import to_dict
from tribo_estimation.core.model import DriveProfile, FrictionLaw
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import (
    RecordSpec,
    RecordTruth,
    make_record,
    rig_channels,
    rpm,
)

RIG_YAML = Path(__file__).resolve().parents[3] / 'config' / 'rig.yaml'
CFG = load_rig_config(RIG_YAML)
FLOOR = 0.05  # torsion-moment noise of config/rig.yaml [N m]
BASELINE_ONLY = SelectionSettings(max_effects=0, propose_terms=False)


@cache
def _rec(kind: str) -> RecordTruth:
    law = CFG.friction
    drive = SpeedProfile.startup(rpm(25), 0.2)
    lag = 0.0
    tq_lag = 0.0
    if kind == 'tqlag1':  # a 1 ms first-order lag of the torsion amplifier
        tq_lag = 0.001
    elif kind == 'step':  # 12 -> 30 rpm in 50 ms at 1.5 s test time (1.0 s record time)
        drive = SpeedProfile.steps([rpm(12), rpm(30)], [1.5], ramp=0.2, transition=0.05)
    elif kind == 'lag5':
        lag = 0.005
    elif kind == 'sliding':  # no falling friction: steady sliding, no sticks
        law = FrictionLaw(0.10, 0.10, law.k)
    tq, ac, sp = rig_channels(1.0, speed_lag=lag, torsion_lag=tq_lag)
    spec = RecordSpec(
        CFG.rig, law, drive, torsion=tq, accel=ac, speed=sp, seed=4, duration=2.5,
        start_offset=0.5,
    )  # fmt: skip
    return make_record(spec)


def _record(r: RecordTruth) -> Record:
    return Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed)


def test_speed_step_corners_placed_and_baseline_near_the_floor() -> None:
    r = _rec('step')
    pb = Problem(_record(r), CFG.rig, DriveProfile(rpm(12)), k=CFG.friction.k)
    fit = pb.fit([MU0, MU_INF], {'mu0': 0.13, 'mu_inf': 0.10})
    sim = pb.simulate(fit.values)
    d = pb.drive_estimate
    inner = d.knot_time[1:-1]
    # the step's two corners (1.0 s and 1.05 s record time) within 1 ms
    assert inner.size == 2
    assert inner[0] == pytest.approx(1.0, abs=1e-3)
    assert inner[1] == pytest.approx(1.05, abs=1e-3)
    assert float(d.speed(0.5)) == pytest.approx(rpm(12), rel=1e-3)
    assert float(d.speed(2.0)) == pytest.approx(rpm(30), rel=1e-3)
    # target: within 1.3x the noise floor (5.1x before the corner search)
    assert pb.torque_rms(sim) <= 1.3 * FLOOR
    assert fit.values['mu_inf'] == pytest.approx(0.10, rel=0.005)


def test_speed_sensor_lag_5ms_baseline_near_the_floor() -> None:
    r = _rec('lag5')
    res = run_discrepancy(
        _record(r), CFG.rig, DriveProfile(rpm(25)), k=CFG.friction.k, settings=BASELINE_ONLY
    )
    # target: within 1.3x the noise floor (1.58x with the sample-lagged sensor model)
    assert res.baseline.rms <= 1.3 * FLOOR
    inst = res.instrument
    assert inst['speed_lag_tau']['used'] == pytest.approx(0.005, rel=0.03)
    # the true offset is 0: the jointly refined one stays within 3e-3 rad/s
    assert abs(inst['speed_offset']['used']) < 3e-3
    assert res.baseline.params['mu0'] == pytest.approx(0.13, rel=0.005)


def test_record_without_sticks_is_analysed() -> None:
    r = _rec('sliding')
    assert not r.sticks  # the generator's truth: steady sliding
    res = run_discrepancy(
        _record(r), CFG.rig, DriveProfile(rpm(25)), k=CFG.friction.k, settings=BASELINE_ONLY
    )
    assert res.traces.problem.segments.sliding
    # target: baseline within 1.5x the floor, mu_inf within 2 %
    assert res.baseline.rms <= 1.5 * FLOOR
    assert res.baseline.params['mu_inf'] == pytest.approx(0.10, rel=0.02)
    assert np.isfinite(res.baseline.cv_rms)


def test_record_from_rest_tells_torque_offset_drift_from_friction_drift() -> None:
    # a record that begins at the drive start (config/rig.yaml: 0.5 s ramp from rest):
    # the drive speed at the first knot is pinned to 0, so a torque-offset drift is
    # not taken for a drift of mu0 and mu_inf (test_discrepancy_workflow starts its
    # records 0.25 s into the ramp)
    from tribo_estimation.core.model import Extensions
    from tribo_estimation.core.simulate import NoiseSpec, simulate

    truth = {'torque_offset': 0.5, 'torque_offset_drift': 0.5}
    r = simulate(
        CFG.rig, CFG.friction, CFG.drive, 1.0, extensions=Extensions(**truth),
        noise=NoiseSpec(torque=0.05, accel=2.0, speed=0.005), seed=105,
    )  # fmt: skip
    rec = Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed)
    res = run_discrepancy(
        rec, CFG.rig, CFG.drive, k=CFG.friction.k, settings=SelectionSettings(max_effects=1)
    )
    assert res.traces.problem.drive_estimate.knot_speed[0] == 0.0
    assert res.added and res.added[0].effect == 'torque_offset'
    drift = res.added[0].params['torque_offset_drift']
    assert drift == pytest.approx(0.5, rel=0.2)
    assert res.final.rms <= 0.5 * res.baseline.rms


def test_torsion_lag_1ms_identified_and_baseline_near_the_floor() -> None:
    r = _rec('tqlag1')
    res = run_discrepancy(
        _record(r), CFG.rig, DriveProfile(rpm(25)), k=CFG.friction.k,
        settings=SelectionSettings(max_effects=1, propose_terms=False),
    )  # fmt: skip
    lag = res.instrument['torsion_lag_tau']
    # the instrument model's torsion lag within 10 % (the estimator: ~0.2 %)
    assert lag['used'] == pytest.approx(0.001, rel=0.1)
    assert lag['se'] < 1e-4
    # issue 11: within 1.3x the noise floor (102x uncompensated); nothing named
    assert res.baseline.rms <= 1.3 * FLOOR
    assert res.added == (), [a.effect for a in res.added]


def test_speed_step_with_startup_regression() -> None:
    """A 1.6 s speed-step record with the drive's start-up in it (generator, seed 4):
    the start-up ramp's end (0.2 s, a knot on a sample instant), the step's corners
    (1.0, 1.05 s) and a false stick phase the detector reports at 1.008 s (the discs
    slip at 2-6 rad/s). Before the fixes: baseline rms 98x the noise floor (the
    false phase started a segment; the ramp ran on past 0.2 s: 15x over that
    segment). Tolerance: 1.2x the floor overall (measured 1.04), 1.3x over the
    segment across the ramp's end (0.98)."""
    law = CFG.friction
    drive = SpeedProfile.steps([rpm(12), rpm(30)], [1.0], ramp=0.2, transition=0.05)
    tq, ac, sp = rig_channels(1.0)
    r = make_record(
        RecordSpec(CFG.rig, law, drive, torsion=tq, accel=ac, speed=sp, seed=4, duration=1.6)
    )
    pb = Problem(_record(r), CFG.rig, DriveProfile(rpm(12), 0.2), k=law.k)
    fit = pb.fit([MU0, MU_INF], {'mu0': 0.13, 'mu_inf': 0.10})
    sim = pb.simulate(fit.values)
    seg = pb.segments
    # every segment starts where the discs truly stick
    assert bool(np.all(r.stick[seg.start]))
    inner = pb.drive_estimate.knot_time[1:-1]
    assert inner.size == 3
    assert inner[0] == pytest.approx(0.2, abs=1e-9)  # RIG.yaml's ramp end
    assert inner[1] == pytest.approx(1.0, abs=3e-4)
    assert inner[2] == pytest.approx(1.05, abs=3e-4)
    assert pb.torque_rms(sim) <= 1.2 * FLOOR
    k = int(np.flatnonzero((r.time[seg.start] < 0.2) & (r.time[seg.stop - 1] >= 0.2))[0])
    a, b = int(seg.start[k]), int(seg.stop[k])
    ramp_end = float(np.sqrt(np.mean((r.torsion_moment[a:b] - sim.torsion_moment[a:b]) ** 2)))
    assert ramp_end <= 1.3 * FLOOR
    assert fit.values['mu0'] == pytest.approx(law.mu0, rel=1e-3)
    assert fit.values['mu_inf'] == pytest.approx(law.mu_inf, rel=1e-3)


def test_record_without_stick_slip_from_the_start_up() -> None:
    """No falling friction, the drive's start-up in the record (generator, seed 5):
    the discs stick from rest for ~76 ms, then slide. The sliding segments start after
    that stick phase (its samples are not fitted and are listed in
    ``Segments.rejected``) and the drive follows RIG.yaml's ramp, not the smoothed
    speed's blur of it. Before: 52x the noise floor (a sliding state taken inside the
    stick; the ramp blurred over 0.05-0.24 s). Tolerance: 1.3x (measured 1.04)."""
    law = FrictionLaw(0.10, 0.10, CFG.friction.k)
    tq, ac, sp = rig_channels(1.0)
    r = make_record(
        RecordSpec(CFG.rig, law, SpeedProfile.startup(rpm(25), 0.2), torsion=tq, accel=ac,
                   speed=sp, seed=5, duration=1.5)
    )  # fmt: skip
    res = run_discrepancy(
        _record(r), CFG.rig, DriveProfile(rpm(25), 0.2), k=law.k, settings=BASELINE_ONLY
    )
    pb = res.traces.problem
    seg = pb.segments
    assert seg.sliding
    assert len(seg.rejected) == 1
    t_stick_end = r.sticks[0][1]
    assert r.time[seg.start[0]] > t_stick_end
    assert pb.drive_estimate.knot_time[1] == pytest.approx(0.2, abs=1e-9)
    assert res.baseline.rms <= 1.3 * FLOOR
    assert res.baseline.params['mu_inf'] == pytest.approx(0.10, rel=0.01)
    # the part left out is stated in discrepancy.json, with its time and reason
    rows = to_dict(res)['rejected_segments']
    assert isinstance(rows, list) and len(rows) == 1
    assert rows[0] == {'time': pytest.approx(float(r.time[0])), 'reason': seg.rejected[0][1]}
    assert 'stick phase' in seg.rejected[0][1]
