"""Instrument identification of the discrepancy fits (fitting/instrument.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.fitting import Problem, Record
from tribo_estimation.core.discrepancy.fitting.instrument import (
    SpeedSensor,
    identify_accel_sensor,
    identify_hum,
    identify_speed_sensor,
    identify_torsion_lag,
    speed_error_at_sticks,
    torsion_compensated_record,
)
from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import RecordSpec, make_record, rig_channels, rpm

FS = 2500.0  # [Hz]
SPAN = 6.0  # [s]


def _residuals(lines: list[tuple[float, float]], seed: int) -> dict[str, np.ndarray]:
    """White noise (0.05 N m) plus sines (frequency [Hz], amplitude [N m]) on the torque."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(SPAN * FS)) / FS
    r = rng.normal(0.0, 0.05, t.size)
    for f, a in lines:
        r += a * np.sin(2.0 * math.pi * f * t + 0.7)
    z = np.zeros(t.size)
    return {'t': t, 'torsion_moment': r, 'angular_acceleration': z, 'speed': z}


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_hum_is_the_line_at_the_mains_frequency_not_one_beside_it(seed: int) -> None:
    # a 50 Hz line (1x the noise) is hum; a strong stick-slip harmonic 0.6/T beside
    # 60 Hz (its main lobe covers the mains bins) is not
    beside = 60.0 + 0.6 / SPAN
    res = _residuals([(50.0, 0.05), (beside, 2.0)], seed)
    t = res.pop('t')
    lines = identify_hum(t, res, 0.01).lines
    # one line, on the torque, at 50 Hz within a tenth of the resolution 1/T
    assert [c for c, _, _, _ in lines] == ['torsion_moment']
    assert lines[0][1] == pytest.approx(50.0, abs=0.1 / SPAN)
    assert lines[0][2] == pytest.approx(0.05, rel=0.15)  # amplitude within 15 %


@pytest.mark.parametrize('seed', [1, 2])
def test_hum_lines_are_fitted_at_the_grid_frequency(seed: int) -> None:
    # the grid at 50.05 Hz (0.1 % off): harmonics 1, 3 and 5 (0.1, 0.05, 0.05 N m) on
    # white noise of 0.05 N m. Fitted at the nominal 250 Hz, the fifth harmonic turns
    # 2 pi*0.25*6 = 9.4 rad against the fit over the record and stays in it; at the
    # grid's frequency (within 1 mHz) every line goes, the residual left at its noise
    # within 2 %
    grid = 50.05
    res = _residuals([(grid, 0.1), (3 * grid, 0.05), (5 * grid, 0.05)], seed)
    t = res.pop('t')
    hum = identify_hum(t, res, 0.01)
    found = sorted(f for _, f, _, _ in hum.lines)
    assert len(found) == 3
    for k, f in zip((1, 3, 5), found, strict=True):
        assert f == pytest.approx(k * grid, abs=k * 1e-3)
    left = hum.remove(Record(t, res['torsion_moment'], res['speed'], res['speed']))
    assert float(np.std(left.torsion_moment)) == pytest.approx(0.05, rel=0.02)


def test_hum_false_alarm_rate_is_alpha() -> None:
    # alpha = 0.01 per record: on 100 records of white noise at most 3 have a line
    # (binomial, 1.8 % chance of 4 or more at the stated rate)
    with_line = 0
    for seed in range(100):
        res = _residuals([], seed)
        t = res.pop('t')
        with_line += bool(identify_hum(t, res, 0.01).lines)
    assert with_line <= 3


def test_torsion_lag_used_through_a_stop() -> None:
    # four ~1 s pieces, one at rest (no kinematics: an arbitrary estimate); the lag
    # of the three moving pieces is used, within 2 % + 20 us (the estimator's accuracy)
    w = rpm(25)
    drive = SpeedProfile(((0.0, 0.0), (0.2, w), (1.15, w), (1.2, 0.0), (2.8, 0.0), (2.85, w)))
    tq, ac, sp = rig_channels(1.0, torsion_lag=5e-4)
    r = make_record(
        RecordSpec(RigParams.tab1(), FrictionLaw(0.13, 0.1), drive, torsion=tq, accel=ac,
                   speed=sp, seed=5, duration=4.0, start_offset=0.6)
    )  # fmt: skip
    lag = identify_torsion_lag(Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed),
                               RigParams.tab1())  # fmt: skip
    assert lag.used == pytest.approx(5e-4, abs=2e-5 + 0.02 * 5e-4)


@pytest.mark.parametrize('fs', [2000.0, 10000.0])
def test_torsion_lag_and_accelerometer_gain_at_low_and_high_rates(fs: float) -> None:
    # Tab. 1 rig (fastest mode ~100 Hz), 1.5 ms torsion lag, accelerometer 5 % high.
    # At 2 kHz integrals of the acceleration over cycles gave 1.41 ms and 1.075.
    tq, ac, sp = rig_channels(1.0, torsion_lag=1.5e-3)
    ac = dataclasses.replace(ac, gain_error=0.05)
    r = make_record(
        RecordSpec(RigParams.tab1(), FrictionLaw(0.13, 0.1), SpeedProfile.startup(rpm(25), 0.2),
                   torsion=tq, accel=ac, speed=sp, seed=3, duration=3.0, start_offset=1.0, fs=fs)
    )  # fmt: skip
    rec = Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed)
    lag = identify_torsion_lag(rec, RigParams.tab1())
    assert lag.used == pytest.approx(1.5e-3, abs=2e-5 + 0.02 * 1.5e-3)  # stated accuracy
    acc = identify_accel_sensor(torsion_compensated_record(rec, RigParams.tab1(), lag.used),
                                RigParams.tab1())  # fmt: skip
    assert acc.gain == pytest.approx(1.05, rel=0.015)  # within 1.5 %


@pytest.mark.parametrize('lag', [6e-5, 0.0])
def test_a_lag_of_a_fraction_of_a_sample_is_used_where_it_is_significant(lag: float) -> None:
    # a 60 us torsion amplifier (an eighth of a sample at 2 kHz) is significant over
    # its pieces (standard error about 2 us, Student's t with 3 degrees of freedom at
    # alpha = 0.01): used within 10 % (a fixed 0.1 ms floor left it out: random
    # control 30, 4.1x -> 3.5x its noise with it); none is not used
    tq, ac, sp = rig_channels(1.0, torsion_lag=lag)
    r = make_record(
        RecordSpec(RigParams.tab1(), FrictionLaw(0.13, 0.1), SpeedProfile.startup(rpm(25), 0.2),
                   torsion=tq, accel=ac, speed=sp, seed=3, duration=3.0, start_offset=1.0,
                   fs=2000.0)
    )  # fmt: skip
    got = identify_torsion_lag(
        Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed), RigParams.tab1()
    )
    assert got.used == pytest.approx(lag, rel=0.1, abs=0.0)


@pytest.mark.parametrize('lag', [5e-4, 0.0])
def test_pieces_at_rest_neither_hide_nor_fake_a_torsion_lag(lag: float) -> None:
    # two of four ~1 s pieces at rest: a piece without kinematics ends its estimate at
    # the range's end (censored: random record 38 had three of four there, their
    # median -0.87 ms against a true +0.31 ms); the rest's spread is the standard
    # deviation's (their median absolute deviation came out near 0 for this seed and
    # made a 2 us lag significant). 0.5 ms used within 2 % + 20 us; none not used
    w = rpm(25)
    drive = SpeedProfile(((0.0, 0.0), (0.2, w), (0.95, w), (1.0, 0.0), (3.0, 0.0), (3.05, w)))
    tq, ac, sp = rig_channels(1.0, torsion_lag=lag)
    r = make_record(
        RecordSpec(RigParams.tab1(), FrictionLaw(0.13, 0.1), drive, torsion=tq, accel=ac,
                   speed=sp, seed=5, duration=4.0, start_offset=0.6)
    )  # fmt: skip
    got = identify_torsion_lag(
        Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed), RigParams.tab1()
    )
    assert got.used == pytest.approx(lag, abs=2e-5 + 0.02 * lag)
    assert (got.used != 0.0) is (lag > 0.0)


@pytest.mark.parametrize(('error', 'used'), [(0.04, True), (0.25, False)])
def test_a_speed_gain_beyond_the_physical_bound_is_reported_not_used(
    error: float, used: bool
) -> None:
    # a start-up to 25 rpm (sticks at many speeds: the gain is identifiable), the
    # tachometer 4 % high (used, within 0.5 %) or 25 % high, beyond the 10 % a
    # calibrated tachometer stays within (SPEED_GAIN_BOUND): reported as rejected
    # (within 0.5 %), 1 used
    tq, ac, sp = rig_channels(1.0)
    sp = dataclasses.replace(sp, gain_error=error)
    r = make_record(
        RecordSpec(RigParams.tab1(), FrictionLaw(0.13, 0.1), SpeedProfile.startup(rpm(25), 1.0),
                   torsion=tq, accel=ac, speed=sp, seed=4, duration=3.0, start_offset=0.0)
    )  # fmt: skip
    rec = Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed)
    rig = RigParams.tab1()
    sticks = Problem(rec, rig, DriveProfile(rpm(25), 1.0), k=2.0).segments.stick_phases()
    sensor = identify_speed_sensor(rec, rig, sticks)
    if used:
        assert sensor.gain == pytest.approx(1.0 + error, rel=5e-3)
        assert math.isnan(sensor.gain_rejected)
    else:
        assert sensor.gain == 1.0
        assert sensor.gain_rejected == pytest.approx(1.0 + error, rel=5e-3)


@pytest.mark.parametrize(
    ('tau_raw', 'tau_se', 'rejected', 'holds'),
    [
        (-1e-3, 1e-4, math.nan, False),
        (-2e-4, 1e-4, math.nan, True),
        (2e-3, 1e-4, math.nan, True),
        (2e-3, 1e-4, 1.5, False),
        (0.0, math.nan, math.nan, False),
    ],
)
def test_the_sensor_model_holds_only_where_the_regression_describes_the_sticks(
    tau_raw: float, tau_se: float, rejected: float, holds: bool
) -> None:
    # no sensor lags by a negative time: a regression lag over 3 standard errors below
    # zero says the stick phases are not described by the first-order model (its offset
    # is then no estimate); within 3 SE it holds; a gain beyond the physical bound says
    # the same, and a regression without a standard error had no stick samples at all
    sensor = SpeedSensor(
        max(tau_raw, 0.0), tau_se, 0.5, 0.01, 100, gain_rejected=rejected, tau_raw=tau_raw
    )
    assert sensor.identified() is math.isfinite(tau_se)
    assert sensor.consistent() is holds


def _scenario_record(order: int, tau: float, zeta: float) -> tuple[Record, RigParams]:
    """Tab. 1 at 20 rpm, 3 s, the torsion amplifier of the given order (generator's)."""
    from discrepancy_scenarios import NOISE, constant, record
    from discrepancy_scenarios import rpm as rpm_of
    from tribo_scenarios.spec import ChannelSpec, InstrumentSpec

    t, a, s = NOISE
    inst = InstrumentSpec(
        ChannelSpec(1.0, 0.0, order, tau, zeta, t),
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, a),
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, s),
    )
    rec, rig, _ = record(5, constant(rpm_of(20)), instrument=inst, duration=3.0)
    return Record(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed), rig


@pytest.mark.parametrize(('tau', 'zeta'), [(1e-3, 0.7), (3e-4, 0.9), (5e-4, 0.5)])
def test_a_second_order_torsion_amplifier_is_identified_and_compensated(
    tau: float, zeta: float
) -> None:
    # omega = 1/tau: a1 = 2*zeta*tau, shape a2/a1^2 = 1/(4*zeta^2); a first-order
    # compensation of a 1 ms, zeta 0.7 amplifier leaves 1.9 N m (39x the noise)
    rec, rig = _scenario_record(2, tau, zeta)
    tq = identify_torsion_lag(rec, rig)
    # a1 within 2 %, the shape within 0.03 (the estimates' spread is below 1 %)
    assert tq.used == pytest.approx(2.0 * zeta * tau, rel=0.02)
    assert tq.shape_used == pytest.approx(1.0 / (4.0 * zeta * zeta), abs=0.03)
    clean, _ = _scenario_record(0, 0.0, 0.0)  # same seed: same noise, no lag
    out = torsion_compensated_record(rec, rig, tq.used, a2=tq.a2)
    k = slice(100, -100)
    # the compensated torsion moment within 1.5x the white noise (0.05 N m) of the
    # record without the lag
    diff = out.torsion_moment[k] - clean.torsion_moment[k]
    assert float(np.sqrt(np.mean(diff**2))) < 1.5 * 0.05


def test_a_first_order_torsion_amplifier_stays_first_order() -> None:
    rec, rig = _scenario_record(1, 1e-3, 0.0)
    tq = identify_torsion_lag(rec, rig)
    # no second order: the compensation is the first-order lag, within 1 %
    assert tq.shape_used == 0.0
    assert tq.used == pytest.approx(1e-3, rel=0.01)


def test_an_offset_beyond_the_physical_bound_is_reported_not_used() -> None:
    # a regression offset of 1.5 rad/s at 7.6 rad/s (random record 24; true -0.01):
    # beyond a tenth of the record's mean speed it is no tachometer's zero
    ok = SpeedSensor(2e-3, 1e-5, 0.05, 1e-3, 100)
    bad = dataclasses.replace(ok, offset=1.5, offset_rejected=1.5)
    assert ok.consistent() and ok.values()['speed_offset'] == 0.05
    assert not bad.consistent()
    assert bad.values()['speed_offset'] == 0.0


def test_the_regression_rejects_an_offset_beyond_a_tenth_of_the_peak_speed() -> None:
    rec, rig = _scenario_record(0, 0.0, 0.0)  # Tab. 1 at 20 rpm (2.09 rad/s)
    peak = float(np.percentile(np.abs(rec.speed), 99.0))
    for off, rejected in ((0.05, False), (0.8, True)):
        shifted = dataclasses.replace(rec, speed=rec.speed + off)
        sensor = identify_speed_sensor(shifted, rig)
        # the regression finds the offset within 0.01 rad/s; it is rejected beyond
        # 0.1 x the peak speed (about 0.3 rad/s here)
        assert sensor.offset == pytest.approx(off, abs=0.01)
        assert math.isfinite(sensor.offset_rejected) is rejected, (off, peak)


@pytest.mark.parametrize('drift', [0.0, 0.01])
def test_stick_phases_farther_apart_than_the_narrowest_window_are_calibrated(
    drift: float,
) -> None:
    # stick phases every 0.15 s at 12.8 kHz (random record 8's replicas: the 0.1 s
    # windows hold only their own phase and predicted nothing, the window's error was
    # NaN and the choice raised StopIteration): a slow 0.5 Hz error of amplitude
    # ``drift`` [rad/s] plus an offset comes back within 15 % of the amplitude (10 %
    # measured: the narrowest window that predicts smooths it); an offset alone leaves
    # zeros
    rig = RigParams(0.0109, 0.04034, 2338.6, 0.0315, 4.0, 5975.0, 8000.0, 0.08)
    fs, w = 12_800.0, 1.0
    t = np.arange(round(6.0 * fs)) / fs
    err = drift * np.sin(2.0 * math.pi * 0.5 * t) + 0.02
    rng = np.random.default_rng(4)
    rec = Record(t, rig.C1 * w * t, np.zeros(t.size), w + err + rng.normal(0.0, 1e-3, t.size))
    starts = np.arange(0, t.size - 1200, round(0.15 * fs))
    out = speed_error_at_sticks(rec, rig, (starts, starts + 1100))
    slow = err - 0.02
    inside = (t > 0.5) & (t < 5.5)
    assert np.max(np.abs(out[inside] - slow[inside])) <= 0.15 * drift + 1e-3


@pytest.mark.parametrize('offset', [0.3, 0.0])
def test_the_accelerometer_zero_is_measured_in_the_stick_phases(offset: float) -> None:
    # Tab. 1 rig at 5 rpm (long sticks) and 2 kHz, the accelerometer's zero 0.3 rad/s^2
    # off (under half its white noise of 0.7 rad/s^2): over all samples the kinematic
    # pair's scatter in the slips hides it (random control 30 of the bench: 0.29 +- 0.26
    # rad/s^2); inside the stick phases it is measured to a few hundredths and taken out
    # (3 standard errors); a zero offset is not used
    rig = RigParams.tab1()
    tq, ac, sp = rig_channels(1.0)
    r = make_record(
        RecordSpec(rig, FrictionLaw(0.13, 0.1), SpeedProfile.startup(rpm(5), 0.2), torsion=tq,
                   accel=dataclasses.replace(ac, offset=offset, noise=0.7), speed=sp, seed=5,
                   duration=4.0, start_offset=1.0, fs=2000.0)
    )  # fmt: skip
    rec = Record(r.time, r.torsion_moment, r.angular_acceleration, r.speed)
    sticks = Problem(rec, rig, DriveProfile(rpm(5), 0.2), k=2.0).segments.stick_phases()
    assert sticks is not None
    everywhere = identify_accel_sensor(rec, rig)
    acc = identify_accel_sensor(rec, rig, sticks)
    assert acc.offset_se < everywhere.offset_se  # the sticks measure it better
    assert abs(acc.offset - offset) < 3.0 * acc.offset_se  # within 3 standard errors
    assert acc.offset_used == (offset > 0.0)
    corrected = acc.correct(rec.angular_acceleration)
    # taken out where used, else left as it is (the gain 1 within 3 standard errors)
    gone = float(np.mean(rec.angular_acceleration * acc.gain - corrected * acc.gain))
    assert gone == pytest.approx(acc.offset if acc.offset_used else 0.0, abs=1e-9)
