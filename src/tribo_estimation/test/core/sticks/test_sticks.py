"""Tests of stick detection and motion classification on simulated noisy data."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.model import DriveProfile, Extensions, FrictionLaw, RigParams, RigState
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import (
    Channel,
    RecordSpec,
    RecordTruth,
    make_record,
    rig_channels,
    rpm,
)
from tribo_estimation.core.simulate import NoiseSpec, SimResult, simulate
from tribo_estimation.core.sticks import (
    MIN_STICK,
    StickReport,
    classify_motion,
    detect_sticks,
    estimate_torsion_lag,
    find_sticks,
    kinematic_pair,
)
from tribo_estimation.errors import InvalidDataError

RIG = RigParams.tab1(F_N=8000.0, R=0.08)
LAW = FrictionLaw(0.13, 0.10)
NOISE = NoiseSpec(torque=0.05, accel=2.0, speed=0.005)


def _true_sticks(r: SimResult) -> list[tuple[float, float]]:
    """Closed stick phases from the kernel's exact event log."""
    out, start = [], None
    for t, k in zip(r.event_times, r.event_kinds, strict=True):
        if k == kn.EV_SLIP_END:
            start = t
        elif k == kn.EV_BREAKAWAY and start is not None:
            out.append((float(start), float(t)))
            start = None
    return out


@pytest.mark.parametrize(('rpm', 'seed'), [(10, 1), (30, 2), (60, 3)])
def test_every_stick_found_with_accurate_ends(rpm: int, seed: int) -> None:
    r = simulate(RIG, LAW, DriveProfile(rpm * np.pi / 30, 0.1), 0.6, noise=NOISE, seed=seed)
    truth = [s for s in _true_sticks(r) if s[1] - s[0] >= 2e-3]
    assert len(truth) >= 10
    found = detect_sticks(r.time, r.torsion_moment, r.angular_acceleration, r.speed, RIG)
    for a, b in truth:
        match = [p for p in found if abs(p.start - a) < 1e-3]
        assert len(match) == 1, f'stick {a:.4f}-{b:.4f} s not found exactly once'
        # issue target: start and end within 0.3 ms
        assert abs(match[0].start - a) < 3e-4
        assert abs(match[0].end - b) < 3e-4
    # nothing spurious: every detection is a true stick, the initial stick from rest
    # (no slip-end event) or one still running at the end of the record
    for p in found:
        known = any(abs(p.start - a) < 1e-3 for a, _ in truth)
        assert known or p.start == r.time[0] or p.end == r.time[-1]


def test_stick_slip_classified() -> None:
    r = simulate(RIG, LAW, DriveProfile(3.0), 0.5, noise=NOISE, seed=4)
    sl = slice(2000, 5000)
    assert (
        classify_motion(
            r.time[sl], r.torsion_moment[sl], r.angular_acceleration[sl], r.speed[sl], RIG
        )
        == 'stick-slip'
    )


def _sliding_record(duration: float, k1: float) -> SimResult:
    # start sliding fast with the chamber unloaded: it rings at 74 Hz without ever sticking
    rig = RigParams(**{**RIG.__dict__, 'K1': k1})
    m = rig.F_N * rig.R * 0.10
    init = RigState(w2=20.0, phi2=-m / rig.C2, stuck=False, slip_dir=1)
    return simulate(
        rig,
        FrictionLaw(0.10, 0.10),
        DriveProfile(20.0),
        duration,
        initial=init,
        noise=NOISE,
        seed=5,
    )


def test_slip_slip_and_steady_classified() -> None:
    r = _sliding_record(1.0, k1=1.0)
    assert np.all(r.slip_speed > 0)  # truth: never sticks
    first = slice(0, 2000)
    assert (
        classify_motion(
            r.time[first],
            r.torsion_moment[first],
            r.angular_acceleration[first],
            r.speed[first],
            RIG,
        )
        == 'slip-slip'
    )
    last = slice(8000, 10000)  # ringing decayed (zeta = 0.1, 0.8 s = 58 time constants)
    assert (
        classify_motion(
            r.time[last], r.torsion_moment[last], r.angular_acceleration[last], r.speed[last], RIG
        )
        == 'steady'
    )


def test_bad_input() -> None:
    t = np.arange(100) * 1e-4
    z = np.zeros(100)
    with pytest.raises(InvalidDataError, match='speed'):
        detect_sticks(t, z, z, np.full(100, np.nan), RIG)
    with pytest.raises(InvalidDataError, match='torsion_moment'):
        detect_sticks(t, z[:50], z, z, RIG)


@pytest.mark.parametrize(('rpm', 'seed'), [(10, 6), (30, 7), (60, 8)])
def test_sticks_at_block_start_found(rpm: int, seed: int) -> None:
    # blocks cut from a running record start in mid-slide, where the chamber-speed
    # filter's state is unknown: sticks in the first tens of ms must still be found
    r = simulate(RIG, LAW, DriveProfile(rpm * np.pi / 30, 0.1), 1.0, noise=NOISE, seed=seed)
    truth = _true_sticks(r)
    n_checked = 0
    for k in range(40):
        i0 = 4000 + 25 * k  # block starts every 2.5 ms from 0.4 s on
        sl = slice(i0, i0 + 2000)
        t = r.time[sl]
        found = detect_sticks(t, r.torsion_moment[sl], r.angular_acceleration[sl], r.speed[sl], RIG)
        # sticks that start within the first 40 ms of the block and end inside it
        early = [(a, b) for a, b in truth if t[0] < a < t[0] + 0.04 and b < t[-1] and b - a >= 2e-3]
        for a, b in early:
            n_checked += 1
            match = [p for p in found if abs(p.start - a) < 1e-3]
            assert len(match) == 1, f'stick {a:.4f} s, {1e3 * (a - t[0]):.1f} ms into block'
            # same 0.3 ms tolerance as the target for any stick
            assert abs(match[0].start - a) < 3e-4
            assert abs(match[0].end - b) < 3e-4
    assert n_checked >= 20  # the blocks do cover many early sticks


# ------------------------------------------------ records of the independent generator
# (reference simulator + instrument model, not the kernel the fits use)
def _gen(
    speed_rpm: float,
    speed_lag: float,
    noise: float,
    *,
    law: FrictionLaw = LAW,
    drive: SpeedProfile | None = None,
    ext: Extensions | None = None,
    start: float = 0.3,
    duration: float = 0.6,
    seed: int = 1,
) -> RecordTruth:
    tq, ac, sp = rig_channels(noise, speed_lag=speed_lag)
    return make_record(
        RecordSpec(
            RIG,
            law,
            drive if drive is not None else SpeedProfile.startup(rpm(speed_rpm)),
            extensions=ext if ext is not None else Extensions(),
            torsion=tq,
            accel=ac,
            speed=sp,
            seed=seed,
            duration=duration,
            start_offset=start,
        )
    )


def _check_against_truth(rec: RecordTruth, rep: StickReport, tol: float = 3e-4) -> None:
    t0, t1 = float(rec.time[0]), float(rec.time[-1])
    truth = rec.sticks_between(t0, t1, MIN_STICK)
    assert len(truth) >= 10
    for a, b in truth:
        match = [p for p in rep.sticks if abs(p.start - a) < 1e-3]
        assert len(match) == 1, f'stick {a:.4f}-{b:.4f} s not found exactly once'
        # issue target: start and end within 0.3 ms
        assert abs(match[0].start - a) < tol
        assert abs(match[0].end - b) < tol
    inner = [p for p in rep.sticks if p.start > t0 and p.end < t1]
    # issue target: counts (>= 1 ms) within 5 %
    assert abs(len(inner) - len(truth)) <= 0.05 * len(truth)
    assert rep.motion == 'stick-slip'


@pytest.mark.parametrize('noise', [1.0, 3.0])
@pytest.mark.parametrize('speed_lag', [0.0, 0.005])
@pytest.mark.parametrize('speed_rpm', [10, 25, 60])
def test_generator_records_counts_and_boundaries(
    speed_rpm: int, speed_lag: float, noise: float
) -> None:
    rec = _gen(speed_rpm, speed_lag, noise)
    rep = find_sticks(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG)
    _check_against_truth(rec, rep)
    assert rep.drive_speed == pytest.approx(rpm(speed_rpm), rel=0.02)


@pytest.mark.parametrize('speed_lag', [0.0, 0.005])
def test_short_sticks_of_a_converging_oil(speed_lag: float) -> None:
    # mu0 close to mu_inf: every stick lasts 1.5-1.9 ms (slip-slip above ~27 rpm)
    law = FrictionLaw(0.104, 0.10)
    for speed_rpm in (20, 25):
        rec = _gen(speed_rpm, speed_lag, 1.0, law=law)
        assert all(b - a < 2e-3 for a, b in rec.sticks_between(rec.time[0], rec.time[-1]))
        rep = find_sticks(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG)
        _check_against_truth(rec, rep)


def test_start_up_and_speed_step_in_the_record() -> None:
    # record from the drive start (0.2 s ramp to 12 rpm), step to 30 rpm at 0.5 s
    drive = SpeedProfile.steps([rpm(12), rpm(30)], [0.5], ramp=0.2, transition=0.05)
    rec = _gen(0, 0.005, 1.0, drive=drive, start=0.0, duration=1.0)
    rep = find_sticks(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG)
    _check_against_truth(rec, rep)


def test_micro_sticks_counted_apart() -> None:
    # drive ripple makes the stick durations spread over 1.3-3.4 ms; with a 2 ms
    # threshold the shorter phases are micro-sticks, counted apart from the sticks
    rec = _gen(
        25, 0.005, 1.0, law=FrictionLaw(0.11, 0.10),
        ext=Extensions(ripple_amp=1.5, ripple_freq=5.0), duration=1.0, seed=2,
    )  # fmt: skip
    t0, t1 = rec.time[0], rec.time[-1]
    rep = find_sticks(
        rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG, min_duration=2e-3
    )
    long_ = rec.sticks_between(t0, t1, 2e-3)
    short = [s for s in rec.sticks_between(t0, t1) if s[1] - s[0] < 2e-3]
    assert len(short) >= 1 and len(long_) >= 10
    assert all(p.duration >= 2e-3 for p in rep.sticks)
    assert all(p.duration < 2e-3 for p in rep.micro)
    n_long = sum(1 for p in rep.sticks if t0 < p.start and p.end < t1)
    n_short = sum(1 for p in rep.micro if t0 < p.start and p.end < t1)
    # phases within the 0.3 ms boundary tolerance of the threshold may change class
    near = sum(1 for a, b in rec.sticks_between(t0, t1) if abs((b - a) - 2e-3) < 3e-4)
    assert abs(n_long - len(long_)) <= max(near, 0.05 * len(long_))
    assert abs(n_short - len(short)) <= max(near, 1)


def test_detect_sticks_is_find_sticks() -> None:
    rec = _gen(60, 0.005, 1.0)
    args = (rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG)
    assert detect_sticks(*args) == list(find_sticks(*args).sticks)


@pytest.mark.parametrize('speed_rpm', [10, 60])
def test_torsion_lag_estimated_and_compensated(speed_rpm: int) -> None:
    tq, ac, sp = rig_channels(1.0, speed_lag=0.005, torsion_lag=0.001)
    rec = make_record(
        RecordSpec(RIG, LAW, SpeedProfile.startup(rpm(speed_rpm)), torsion=tq, accel=ac,
                   speed=sp, seed=3, duration=0.6, start_offset=0.3)
    )  # fmt: skip
    args = (rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG)
    rep = find_sticks(*args)  # lag estimated from the record
    assert rep.torsion_lag == pytest.approx(1e-3, abs=2e-5)
    _check_against_truth(rec, rep)
    _check_against_truth(rec, find_sticks(*args, torsion_lag=1e-3))
    # uncompensated, a 1 ms amplifier lag bends the stick lines: sticks are lost or cut
    lost = find_sticks(*args, torsion_lag=0.0)
    t0, t1 = rec.time[0], rec.time[-1]
    truth = rec.sticks_between(t0, t1, MIN_STICK)
    good = [p for p in lost.sticks if any(abs(p.start - a) < 3e-4 and abs(p.end - b) < 3e-4
                                          for a, b in truth)]  # fmt: skip
    assert len(good) < 0.5 * len(truth)


@pytest.mark.parametrize(('tau', 'noise'), [(0.0, 1.0), (5e-4, 3.0), (1e-3, 1.0), (2e-3, 3.0)])
def test_estimate_torsion_lag(tau: float, noise: float) -> None:
    tq, ac, sp = rig_channels(noise, torsion_lag=tau)
    tq = Channel(**{**tq.__dict__, 'gain_error': 0.02, 'offset': 3.0})  # gain, offset absorbed
    rec = make_record(
        RecordSpec(RIG, LAW, SpeedProfile.startup(rpm(25)), torsion=tq, accel=ac, speed=sp,
                   seed=5, duration=0.5, start_offset=0.3)
    )  # fmt: skip
    est = estimate_torsion_lag(
        rec.torsion_moment, rec.angular_acceleration, rec.spec.fs, RIG.C1, RIG.fastest_mode_hz
    )
    # stated accuracy: 2 % + 20 us (the amplifier lag of the issue: up to 2 ms)
    assert est == pytest.approx(tau, abs=2e-5 + 0.02 * tau)


@pytest.mark.parametrize('f', [50.0, 105.0, 250.0])
def test_the_kinematic_pair_holds_for_a_band_limited_signal_at_2_khz(f: float) -> None:
    # M = C1*phi1 and a = phi1'' sampled exactly at 2 kHz (theta = 2*pi*f*dt up to
    # 0.79): D against K has slope 1 within theta^4/60 (the stated theta^4/90 with a
    # margin); the trapezoid sum read 1 + theta^2/12 (0.9 % at 105 Hz, 5 % at 250 Hz)
    fs, c1 = 2000.0, RIG.C1
    t = np.arange(4000) / fs
    w = 2.0 * np.pi * f
    phi = 1e-4 * np.sin(w * t + 0.4) + 3e-5 * np.sin(0.37 * w * t)
    a = -1e-4 * w * w * np.sin(w * t + 0.4) - 3e-5 * (0.37 * w) ** 2 * np.sin(0.37 * w * t)
    d, k = kinematic_pair(c1 * phi, a, fs, c1, 2)
    slope = float(np.dot(k, d) / np.dot(k, k))
    theta = w / fs
    assert slope == pytest.approx(1.0, abs=theta**4 / 60.0)


def test_converging_oil_block_is_stick_slip_with_every_stick() -> None:
    # the case: mu0 drifts down towards mu_inf, the sticks shrink to 1.0-2.1 ms
    # in this block (5 ms speed lag); every one of them is counted, motion stick-slip
    rec = _gen(
        25, 0.005, 1.0, law=FrictionLaw(0.12, 0.10), ext=Extensions(drift_mu0=-0.004),
        start=3.5, duration=1.0, seed=2,
    )  # fmt: skip
    durations = [b - a for a, b in rec.sticks_between(rec.time[0], rec.time[-1])]
    assert min(durations) < 1.2e-3 and max(durations) < 2.5e-3
    rep = find_sticks(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, RIG)
    _check_against_truth(rec, rep)
    # at the end of the block the sticks fall below 1 ms: micro-sticks, counted apart
    t0, t1 = rec.time[0], rec.time[-1]
    micro = [(a, b) for a, b in rec.sticks_between(t0, t1) if b - a < MIN_STICK]
    assert len(micro) >= 3
    near = sum(1 for a, b in rec.sticks_between(t0, t1) if abs((b - a) - MIN_STICK) < 1e-4)
    assert abs(rep.n_micro - len(micro)) <= max(1, near)
    hit = [
        (a, b) for a, b in micro
        if any(abs(p.start - a) < 3e-4 and abs(p.end - b) < 3e-4 for p in rep.micro)
    ]  # fmt: skip
    assert len(hit) >= len(micro) - 1, f'{len(hit)} of {len(micro)} micro-sticks matched'
