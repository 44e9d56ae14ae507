"""Stick detector through drive-speed steps (issue 12): onsets at the step, no false sticks.

Records of the independent generator (reference simulator + instrument model) at the
noise of config/rig.yaml, never the project's kernel.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import (
    Channel,
    RecordSpec,
    RecordTruth,
    make_record,
    rig_channels,
    rpm,
)
from tribo_estimation.core.sticks import MIN_STICK, StickReport, find_sticks

CONFIG = Path(__file__).resolve().parents[5] / 'config'
CFG = load_rig_config(CONFIG / 'rig.yaml')
#: issue 11 item 3: start and end of every stick within 0.3 ms, counts within 5 %
TOL = 3e-4


def _find(rec: RecordTruth) -> StickReport:
    return find_sticks(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, CFG.rig)


def _check_all(rec: RecordTruth, rep: StickReport) -> None:
    t0, t1 = float(rec.time[0]), float(rec.time[-1])
    truth = rec.sticks_between(t0, t1, MIN_STICK)
    for a, b in truth:
        match = [p for p in rep.sticks if abs(p.start - a) < 3e-3]
        assert len(match) == 1, f'stick {a:.4f}-{b:.4f} s not found exactly once'
        assert abs(match[0].start - a) < TOL, f'onset {a:.4f} s: found {match[0].start:.4f} s'
        assert abs(match[0].end - b) < TOL, f'end {b:.4f} s: found {match[0].end:.4f} s'
    inner = [p for p in rep.sticks if p.start > t0 and p.end < t1]
    assert abs(len(inner) - len(truth)) <= 0.05 * len(truth)


def _no_false_phase(rec: RecordTruth, rep: StickReport) -> None:
    """Every detected phase (sticks and micro-sticks) lies where the discs truly stick."""
    for p in (*rep.sticks, *rep.micro):
        i0, i1 = np.searchsorted(rec.time, [p.start, p.end])
        i1 = max(int(i1), int(i0) + 1)
        # 0.3 ms tolerance at each end: at most 3 of its samples may slip
        slipping = int(np.count_nonzero(~rec.stick[i0:i1]))
        assert slipping <= 6, (
            f'phase {p.start:.4f}-{p.end:.4f} s: {slipping} samples slip '
            f'(up to {float(np.max(np.abs(rec.slip_speed[i0:i1]))):.2f} rad/s)'
        )


@pytest.mark.parametrize('speed_lag', [0.0, 0.005])
def test_onset_of_the_stick_the_drive_step_starts_in(speed_lag: float) -> None:
    # the matrix bench's 'step' condition (15 -> 35 rpm in 50 ms at 2.0 s test time)
    # with dwell-time stiction hidden: a 19.6 ms stick starts 5.8 ms before the drive
    # ramp and lasts through most of it (r bends by C2*w0'/2*t^2, ~23 N m); before the
    # fix its onset came 1.6 ms late
    ext = load_rig_config(CONFIG / 'rig_hidden_dwell_time_stiction.yaml').extensions
    tq, ac, sp = rig_channels(1.0, speed_lag=speed_lag)
    prof = SpeedProfile.steps([rpm(15), rpm(35)], [2.0])
    rec = make_record(
        RecordSpec(CFG.rig, CFG.friction, prof, extensions=ext, torsion=tq, accel=ac,
                   speed=sp, seed=1010, duration=0.6, start_offset=1.7)
    )  # fmt: skip
    ramp = 2.0 - 1.7  # record time of the ramp's start [s]
    across = [(a, b) for a, b in rec.sticks if a < ramp < b]
    assert len(across) == 1 and ramp - across[0][0] > 2e-3  # the case the fix is about
    rep = _find(rec)
    _check_all(rec, rep)
    _no_false_phase(rec, rep)


def test_no_false_stick_in_the_slip_after_a_speed_step() -> None:
    # 1.6 s step record with start-up (seed 4, as test_baseline_realrecords): the
    # detector reported a 3 ms "stick" at 1.008 s while the discs slipped at 0.6-6.4 rad/s
    drive = SpeedProfile.steps([rpm(12), rpm(30)], [1.0], ramp=0.2, transition=0.05)
    tq, ac, sp = rig_channels(1.0)
    rec = make_record(
        RecordSpec(CFG.rig, CFG.friction, drive, torsion=tq, accel=ac, speed=sp, seed=4,
                   duration=1.6)
    )  # fmt: skip
    rep = _find(rec)
    assert not [p for p in rep.sticks if 1.0 < p.start < 1.0105]
    _no_false_phase(rec, rep)
    _check_all(rec, rep)


@pytest.mark.parametrize('seed', [1010, 1031])
def test_no_false_stick_at_constant_speed_with_dwell_time_stiction(seed: int) -> None:
    # the step record of the matrix bench before its step: slow ends of slips of
    # 4-8 rad/s passed as 1-2 ms sticks at 15 rpm
    ext = load_rig_config(CONFIG / 'rig_hidden_dwell_time_stiction.yaml').extensions
    tq, ac, sp = rig_channels(1.0)
    prof = SpeedProfile.steps([rpm(15), rpm(35)], [2.0])
    rec = make_record(
        RecordSpec(CFG.rig, CFG.friction, prof, extensions=ext, torsion=tq, accel=ac,
                   speed=sp, seed=seed, duration=1.0, start_offset=0.5)
    )  # fmt: skip
    rep = _find(rec)
    _no_false_phase(rec, rep)
    _check_all(rec, rep)


def test_speed_check_tolerates_speed_sensor_lag_gain_and_offset_drift() -> None:
    # the speed consistency inside the detector fits the speed channel's lag and a
    # drifting offset; a 10 % gain error leaves at most 0.1 rad/s (threshold 0.5).
    # (A constant offset of the speed channel is not covered: the first pass takes the
    # drive-speed level from it, before and after this change.)
    drive = SpeedProfile.steps([rpm(12), rpm(30)], [1.0], ramp=0.2, transition=0.05)
    tq, ac, _ = rig_channels(1.0)
    sp = Channel(lag=0.005, gain_error=0.1, offset_drift=0.2, noise=0.005)
    rec = make_record(
        RecordSpec(CFG.rig, CFG.friction, drive, torsion=tq, accel=ac, speed=sp, seed=4,
                   duration=1.6)
    )  # fmt: skip
    rep = _find(rec)
    _no_false_phase(rec, rep)
    _check_all(rec, rep)
