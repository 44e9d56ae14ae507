"""The generator's integrator against analytic cases, the stick kinematics and itself."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from tribo_scenarios import draw, simulate_truth
from tribo_scenarios import layout as L
from tribo_scenarios.generate import (
    DEFAULT_RTOL,
    HMAX,
    ModelTables,
    model_tables,
    state_scale,
)
from tribo_scenarios.integrator import OK, integrate
from tribo_scenarios.spec import EffectSpec

NO_RESTART = (np.zeros(0, dtype=np.int64), np.zeros((0, L.NY)), np.zeros((0, L.NM)))


def _run(tab: ModelTables, y0, m0, t_out, scale, rtol=DEFAULT_RTOL):
    Y, MODE, ACC, FM, info = integrate(
        tab.P, tab.Q, tab.TR, tab.RIP, tab.DR, y0, m0, 0.0, t_out, tab.boundaries,
        *NO_RESTART, scale, rtol, HMAX,
    )  # fmt: skip
    assert info[0] == OK
    return Y, MODE, ACC, FM


def test_free_decay_of_the_chamber_matches_the_damped_oscillation():
    # contact open (F_N = 0), motor at rest: Equ. 7, phi1(0) = 0.01 rad, w1(0) = 0
    spec = draw(3, family='none')
    tab = model_tables(spec)
    P = tab.P.copy()
    P[L.P_FN] = 0.0
    tab = ModelTables(P, tab.Q, np.zeros((0, 4)), tab.RIP, tab.DR, np.zeros(0))
    I1, K1, C1 = P[L.P_I1], P[L.P_K1], P[L.P_C1]
    y0 = np.zeros(L.NY)
    y0[L.PHI1] = 0.01
    m0 = np.array([0.0, 1.0, 0.0, 0.0])
    t = np.arange(5000) / 10_000.0
    Y, _, ACC, FM = _run(tab, y0, m0, t, state_scale(spec))
    sigma = K1 / (2.0 * I1)
    wd = math.sqrt(C1 / I1 - sigma**2)
    phi = 0.01 * np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))
    w = -0.01 * np.exp(-sigma * t) * (wd + sigma**2 / wd) * np.sin(wd * t)
    acc = -(K1 * w + C1 * phi) / I1
    # torsion moment and acceleration exact to 1e-8 of their amplitudes; no friction
    # moment, the shaft at rest
    assert np.max(np.abs(C1 * Y[:, L.PHI1] - C1 * phi)) < 1e-8 * C1 * 0.01
    assert np.max(np.abs(ACC - acc)) < 1e-8 * np.max(np.abs(acc))
    assert np.max(np.abs(FM)) == 0.0
    assert np.max(np.abs(Y[:, L.W2])) < 1e-9  # rad/s: the slip ends locate v = 0 to ~1e-12


def test_steady_sliding_settles_at_the_friction_moment_after_the_peak():
    # a fast drive (70 rpm) on a well-damped chamber ends in steady sliding at v = w0:
    # M_t = F_N R mu + c_v w0 (linear viscous friction c_v), mu = mu(w0) of Equ. 8 or,
    # once |v| passed a maximum (deceleration rule), mu_inf; the chamber stands still
    spec = draw(5, family='viscous_friction', kind='constant')
    spec = dataclasses.replace(spec, effect=EffectSpec('library', 'viscous_friction', 'linear',
                                                       {'c': 0.5}))  # fmt: skip
    tab = model_tables(spec)
    P = tab.P.copy()
    P[L.P_K1] = 4.0 * math.sqrt(P[L.P_C1] * P[L.P_I1])  # overdamped chamber
    w0 = 70 * 2 * math.pi / 60
    TR = np.array([[0.0, 0.3, w0, 1.0]])
    Q = tab.Q.copy()
    Q[L.Q_TF] = Q[L.Q_AF] = Q[L.Q_SF] = 0
    tab = ModelTables(P, Q, TR, tab.RIP, tab.DR, np.array([0.0, 0.3]))
    y0 = np.zeros(L.NY)
    m0 = np.array([1.0, 1.0, 0.0, 0.0])
    t = 3.0 + np.arange(2000) / 2000.0
    Y, MODE, _, FM = _run(tab, y0, m0, t, state_scale(spec))
    mu0, mu_inf, k = P[L.P_MU0], P[L.P_MUINF], P[L.P_K]
    peak = MODE[0, L.PEAK] == 1.0
    mu = mu_inf if peak else (mu0 - mu_inf) * math.exp(-k * w0) + mu_inf
    expected = P[L.P_FN] * P[L.P_R] * mu + 0.5 * w0
    assert np.all(MODE[:, L.STUCK] == 0.0) and np.all(MODE[:, L.PEAK] == MODE[0, L.PEAK])
    np.testing.assert_allclose(P[L.P_C1] * Y[:, L.PHI1], expected, rtol=1e-6)
    np.testing.assert_allclose(FM, expected, rtol=1e-9)
    assert np.max(np.abs(Y[:, L.W1])) < 1e-4  # rad/s
    np.testing.assert_allclose(Y[:, L.W2], w0, rtol=1e-6)


def test_stick_phases_hold_the_stick_kinematics_and_the_static_limit():
    spec = draw(9)  # a stick-slip record of the paper's model (no hidden effect)
    assert spec.effect.category == 'none'
    tr = simulate_truth(spec)
    Y, st = tr.states, tr.stick
    assert 0.1 < st.mean() < 0.9
    r = spec.rig
    # sticking: one speed (exactly), the moment within the static limit F_N R mu0
    # (Equ. 5, 6); sliding: the friction moment on the curve between mu_inf and mu0
    assert np.array_equal(Y[st, L.W1], Y[st, L.W2])
    limit = r.F_N * r.R * r.mu0
    assert np.max(np.abs(tr.friction_moment[st])) <= limit * (1 + 1e-12)
    slip = ~st
    fm = np.abs(tr.friction_moment[slip])
    assert np.all(fm <= limit * (1 + 1e-12))
    assert np.all(fm >= r.F_N * r.R * r.mu_inf * (1 - 1e-12))
    # each complete stick ends at the static limit (breakaway, sampled: within 2 %)
    edges = np.flatnonzero(np.diff(st.astype(int)) == -1)
    assert edges.size > 10
    assert np.all(np.abs(tr.friction_moment[edges]) > 0.98 * limit)
    # Equ. 1 at every sample: M = I1 a + K1 w1 + C1 phi1
    lhs = r.I1 * tr.accel_raw + r.K1 * Y[:, L.W1] + r.C1 * Y[:, L.PHI1]
    np.testing.assert_allclose(lhs, tr.friction_moment, rtol=0, atol=1e-9 * limit)


def _compare(spec, tight, ref):
    ins = spec.instrument
    return (
        np.max(np.abs(tight.torque - ref.torque)) / ins.torque.noise,
        np.max(np.abs(tight.accel - ref.accel)) / ins.accel.noise,
        np.max(np.abs(tight.speed - ref.speed)) / ins.speed.noise,
    )


def test_integrator_at_two_tolerances_agrees_far_below_the_noise():
    # restarted at the stick onsets and every 50 ms from the same states (as a
    # segment-wise fit restarts its model) a 10x tighter run agrees to < 1e-3 of the
    # noise on every channel; records with a time delay, a ripple, lags and a fast rig
    for seed in (35, 17, 22):
        spec = draw(seed, duration=2.0)
        ref = simulate_truth(spec)
        tight = simulate_truth(spec, rtol=DEFAULT_RTOL / 10, restart_from=ref)
        assert max(_compare(spec, tight, ref)) < 1e-3, seed
    # and over a whole 2 s record without restarts
    spec = draw(0, duration=2.0)
    ref = simulate_truth(spec)
    assert max(_compare(spec, simulate_truth(spec, rtol=DEFAULT_RTOL / 10), ref)) < 1e-3
