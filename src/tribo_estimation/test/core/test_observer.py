"""Tests of the inertia-corrected friction observer (Equ. 1)."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
from tribo_estimation.core.observer import FrictionObserver, friction_moment
from tribo_estimation.core.simulate import NoiseSpec, simulate
from tribo_estimation.errors import InvalidDataError, InvalidParameterError

RIG = RigParams.tab1(F_N=8000.0, R=0.08)
LAW = FrictionLaw(0.13, 0.10)


def test_observer_recovers_true_friction_moment_in_stick_slip() -> None:
    r = simulate(RIG, LAW, DriveProfile(2.0, 0.1), 0.6)
    m, w1 = friction_moment(RIG, r.torsion_moment, r.angular_acceleration)
    # clean signals: M is exact up to K1*(w1 error); w1 error < 0.15 rad/s from
    # trapezoid errors at the acceleration jumps -> < 0.01 N m
    np.testing.assert_allclose(m, r.friction_moment, atol=0.01)
    assert np.sqrt(np.mean((w1 - r.chamber_speed) ** 2)) < 0.05
    # the raw torsion moment is NOT the friction moment in stick-slip (inertia!)
    assert np.max(np.abs(r.torsion_moment - r.friction_moment)) > 5.0


def test_observer_noise_level() -> None:
    clean = simulate(RIG, LAW, DriveProfile(2.0, 0.1), 0.6)
    r = simulate(RIG, LAW, DriveProfile(2.0, 0.1), 0.6, noise=NoiseSpec(0.05, 2.0), seed=2)
    m, _ = friction_moment(RIG, r.torsion_moment, r.angular_acceleration)
    # expected noise sqrt(0.05^2 + (I1*2)^2) = 0.0566 N m; 10 % tolerance (6000 samples)
    assert np.std(m - clean.friction_moment) == pytest.approx(0.0566, rel=0.1)


def test_speed_estimate_does_not_drift_with_accelerometer_bias() -> None:
    r = simulate(RIG, LAW, DriveProfile(2.0, 0.1), 1.0)
    bias = 0.5  # rad/s^2: a plain integral would drift by 0.5 rad/s after 1 s
    _, w_bias = friction_moment(RIG, r.torsion_moment, r.angular_acceleration + bias)
    _, w_clean = friction_moment(RIG, r.torsion_moment, r.angular_acceleration)
    # the filter is linear: the bias alone adds bias/wc once the exp(-wc*t) transient
    # has gone (wc = 2 pi 10 Hz: e^-63 after 1 s), never a growing drift
    diff = w_bias - w_clean
    expected = bias / (2 * np.pi * 10.0)
    np.testing.assert_allclose(diff[-5000:], expected, rtol=1e-6)
    assert np.max(np.abs(diff)) <= expected * (1 + 1e-9)


def test_streaming_equals_one_shot() -> None:
    r = simulate(RIG, LAW, DriveProfile(2.0, 0.1), 0.5, noise=NoiseSpec(0.05, 2.0), seed=3)
    m_one, w_one = friction_moment(RIG, r.torsion_moment, r.angular_acceleration)
    obs = FrictionObserver(RIG)
    parts, speeds = [], []
    for i0, i1 in [(0, 1), (1, 700), (700, 701), (701, 3333), (3333, 5000)]:
        parts.append(obs.update(r.torsion_moment[i0:i1], r.angular_acceleration[i0:i1]))
        speeds.append(obs.last_speed)
    # identical arithmetic up to filter-state rounding
    np.testing.assert_allclose(np.concatenate(parts), m_one, rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.concatenate(speeds), w_one, rtol=0, atol=1e-10)


def test_bad_input() -> None:
    obs = FrictionObserver(RIG)
    with pytest.raises(InvalidDataError):
        obs.update(np.array([1.0, np.nan]), np.zeros(2))
    with pytest.raises(InvalidDataError):
        obs.update(np.zeros(3), np.zeros(2))
    with pytest.raises(InvalidParameterError, match='corner_hz'):
        FrictionObserver(RIG, fs=1000.0, corner_hz=500.0)
