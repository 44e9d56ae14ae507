"""Stick detection with a speed-channel offset beyond the candidate threshold.

Records from the independent reference generator (scipy DOP853); the stick lines
give the drive speed when the speed channel's level is off by 1-3 rad/s, and the
fall-back never makes sticks in steady or slip-slip sliding.
"""

from __future__ import annotations

import dataclasses

import pytest

from tribo_estimation.core.model import Extensions, FrictionLaw, RigParams
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import (
    RecordSpec,
    RecordTruth,
    make_record,
    rig_channels,
    rpm,
)
from tribo_estimation.core.sticks import find_sticks

RIG = RigParams.tab1()


def _record(w_rpm: float, offset: float, law: tuple[float, float], noise: float = 1.0,
            ext: Extensions | None = None) -> RecordTruth:  # fmt: skip
    tq, ac, sp = rig_channels(noise)
    spec = RecordSpec(
        rig=RIG, friction=FrictionLaw(law[0], law[1], 2.0),
        drive=SpeedProfile(((0.0, rpm(w_rpm)),)), extensions=ext or Extensions(),
        torsion=tq, accel=ac, speed=dataclasses.replace(sp, offset=offset), seed=5,
        duration=2.0, start_offset=1.0,
    )  # fmt: skip
    return make_record(spec)


@pytest.mark.parametrize(
    ('w_rpm', 'offset', 'law'),
    [
        (10, 1.0, (0.104, 0.10)),  # oil: a slow-slip bump beside the stick peak
        (10, 3.0, (0.104, 0.10)),
        (30, -1.0, (0.13, 0.10)),
        (120, 1.0, (0.13, 0.10)),
    ],
)
def test_sticks_found_through_a_speed_offset(
    w_rpm: float, offset: float, law: tuple[float, float]
) -> None:
    r = _record(w_rpm, offset, law)
    rep = find_sticks(r.time, r.torsion_moment, r.angular_acceleration, r.speed, RIG)
    true = r.sticks_between(float(r.time[0]), float(r.time[-1]), rep.min_duration)
    # stick count within 5 % of the truth, and the drive speed from the stick lines
    # (not the channel's level) within 1 %
    assert rep.motion == 'stick-slip'
    assert len(rep.sticks) == pytest.approx(len(true), rel=0.05)
    assert rep.drive_speed == pytest.approx(rpm(w_rpm), rel=0.01)


@pytest.mark.parametrize('offset', [0.0, 1.0, 3.0, -1.0])
@pytest.mark.parametrize(
    ('w_rpm', 'law', 'noise'),
    [
        (60, (0.10, 0.10), 1.0),  # constant friction: steady sliding
        (60, (0.104, 0.10), 3.0),  # micro-sticks of 0.46 ms only (below the 1 ms minimum)
        (25, (0.104, 0.10), 1.0),
    ],
)
def test_no_sticks_made_in_sliding(
    w_rpm: float, law: tuple[float, float], noise: float, offset: float
) -> None:
    r = _record(w_rpm, offset, law, noise)
    rep = find_sticks(r.time, r.torsion_moment, r.angular_acceleration, r.speed, RIG)
    assert len(r.sticks_between(float(r.time[0]), float(r.time[-1]), rep.min_duration)) == 0
    assert len(rep.sticks) == 0, [(p.start, p.duration) for p in rep.sticks[:5]]


def _from_rest(w_rpm: float, law: tuple[float, float], offset: float = 0.0) -> RecordTruth:
    """At rest for 0.5 s, then a 0.2 s ramp to ``w_rpm`` (the record holds the rest)."""
    tq, ac, sp = rig_channels(1.0)
    spec = RecordSpec(
        rig=RIG, friction=FrictionLaw(law[0], law[1], 2.0),
        drive=SpeedProfile(((0.0, 0.0), (0.5, 0.0), (0.7, rpm(w_rpm)))),
        extensions=Extensions(), torsion=tq, accel=ac,
        speed=dataclasses.replace(sp, offset=offset), seed=5, duration=2.0,
    )  # fmt: skip
    return make_record(spec)


@pytest.mark.parametrize('law', [(0.10, 0.10), (0.104, 0.10)])
def test_start_from_rest_into_sliding_makes_one_stick(law: tuple[float, float]) -> None:
    # the stick at rest is one phase that ends at the breakaway; the steady sliding after
    # it (a still chamber: a flat stick residual, like a stick at rest) holds no stick
    r = _from_rest(60, law)
    rep = find_sticks(r.time, r.torsion_moment, r.angular_acceleration, r.speed, RIG)
    (t_start, t_break), *later = r.sticks
    assert later == []
    assert len(rep.sticks) == 1, [(p.start, p.duration) for p in rep.sticks[:5]]
    stick = rep.sticks[0]
    # start at the first sample, breakaway within 2 ms of the truth
    assert stick.start == pytest.approx(t_start, abs=1e-4)
    assert stick.end == pytest.approx(t_break, abs=2e-3)


def test_start_from_rest_into_stick_slip_keeps_the_stick_at_rest() -> None:
    r = _from_rest(60, (0.13, 0.10))
    rep = find_sticks(r.time, r.torsion_moment, r.angular_acceleration, r.speed, RIG)
    (t_start, t_break), *later = r.sticks
    first = rep.sticks[0]
    assert first.start == pytest.approx(t_start, abs=1e-4)
    assert first.end == pytest.approx(t_break, abs=2e-3)
    # the stick-slip after it: stick count within 5 % of the truth
    assert len(rep.sticks) - 1 == pytest.approx(len(later), rel=0.05)


@pytest.mark.parametrize('offset', [0.5, -0.5, 1.0])
def test_no_stick_in_sliding_after_rest_through_a_speed_offset(offset: float) -> None:
    # a channel offset beyond the candidate threshold: the offset that would put the
    # sliding drive at rest is no offset (the channel's level is far from rest there)
    r = _from_rest(30, (0.10, 0.10), offset)
    rep = find_sticks(r.time, r.torsion_moment, r.angular_acceleration, r.speed, RIG)
    (_, t_break), *later = r.sticks
    assert later == []
    after = [(p.start, p.duration) for p in rep.sticks if p.end > t_break + 2e-3]
    assert after == []
