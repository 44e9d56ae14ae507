"""The shooting engine: drive knots crossed inside a segment and the stuck state
from a stick phase (core/shooting.py)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.model import DriveProfile, pack_params
from tribo_estimation.core.shooting import (
    lag2_segments,
    lag_segments,
    second_order_lag,
    shoot,
    stuck_kinematics,
    stuck_states,
    stuck_states_averaged,
    stuck_windows,
    torsion_smoother,
)

CFG = load_rig_config(Path(__file__).resolve().parents[4] / 'config' / 'rig.yaml')
DT = 1e-4


def test_knot_on_a_sample_instant_changes_the_drive_piece() -> None:
    """The start-up ramp's end (0.2 s) lies on a sample instant: the piecewise drive
    (knots 0, 0.2, 1 s) must stop ramping there, as the kernel's own start-up ramp
    does. Before the fix the state's time came out a rounding error short of the
    knot, the old piece was kept and the ramp ran on (0.7 N m off within 20 ms)."""
    w = 1.2566  # 12 rpm [rad/s]
    p_ramp = pack_params(CFG.rig, CFG.friction, DriveProfile(w, 0.2))
    tk = np.array([0.0, 0.2, 1.0])
    vk = np.array([0.0, w, w])
    t0 = np.array([0.1689])
    # a stuck state 31 ms before the knot (torsion 50 N m, common speed 1.1 rad/s)
    st = stuck_states(p_ramp, t0, np.array([50.0]), np.array([1.1]), np.array([0.0]),
                      np.array([0.003]), tk, vk, np.zeros(3))  # fmt: skip
    n = 600
    out = np.full((kn.N_CH, n), np.nan)
    shoot(p_ramp, st, np.array([0]), np.array([n]), tk, vk, np.zeros(3), DT, 4, out)
    ref = np.full((kn.N_CH, n), np.nan)
    s = st[0].copy()
    kn.integrate(p_ramp, s, n, DT, 4, ref)
    # same drive, two representations: equal within the integrator's error at the kink
    assert np.max(np.abs(out[kn.OUT_TORSION] - ref[kn.OUT_TORSION])) < 0.01


def test_stuck_kinematics_recovers_the_state_of_a_stick() -> None:
    """Chamber kinematics (Equ. 4) over a 15 ms stick phase: torsion moment and common
    speed at a sample 3 ms into it, exact without noise, within 3 standard errors
    (0.006 N m, 7e-4 rad/s) at the noise of config/rig.yaml."""
    c1 = CFG.rig.C1
    n = 150
    t = np.arange(n) * DT
    a = 300.0 * np.sin(2.0 * np.pi * 60.0 * t + 0.3)  # rad/s^2
    w = 1.2 + (300.0 / (2.0 * np.pi * 60.0)) * (np.cos(0.3) - np.cos(2.0 * np.pi * 60.0 * t + 0.3))
    phi = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * DT)))
    m = 50.0 + c1 * phi
    idx = np.array([30])
    lo, hi = np.array([0]), np.array([n])
    val, slope, ws = stuck_kinematics(m, a, w, idx, lo, hi, DT, c1)
    assert val[0] == pytest.approx(m[30], abs=2e-3)
    assert slope[0] == pytest.approx(c1 * w[30], rel=1e-3)
    assert ws[0] == pytest.approx(w[30], abs=1e-4)
    rng = np.random.default_rng(7)
    err_m, err_w = [], []
    for _ in range(200):
        val, _, ws = stuck_kinematics(
            m + rng.normal(0.0, 0.05, n), a + rng.normal(0.0, 2.0, n),
            w + rng.normal(0.0, 0.005, n), idx, lo, hi, DT, c1,
        )  # fmt: skip
        err_m.append(val[0] - m[30])
        err_w.append(ws[0] - w[30])
    assert float(np.std(err_m)) < 0.012  # a +-7 sample cubic: 0.021 N m
    assert abs(float(np.mean(err_m))) < 3e-3
    assert float(np.std(err_w)) < 1.5e-3
    assert abs(float(np.mean(err_w))) < 5e-4


def test_the_torsion_smoother_without_process_noise_is_the_stick_regression() -> None:
    """With a noise-free accelerometer (variance 0) the smoother is the least-squares
    fit of ``M = M_0 + v_0*tau + C1*A2`` over the stretch (A2 the double trapezoid
    integral): the same values and rates within 1e-6 N m and 1e-3 N m/s."""
    c1, n = CFG.rig.C1, 200
    rng = np.random.default_rng(3)
    t = np.arange(n) * DT
    a = 200.0 * np.sin(2.0 * np.pi * 80.0 * t)
    a1 = np.concatenate(([0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * DT)))
    a2 = np.concatenate(([0.0], np.cumsum(0.5 * (a1[1:] + a1[:-1]) * DT)))
    m = 40.0 + c1 * (0.9 * t + a2) + rng.normal(0.0, 0.05, n)
    xm, xv = torsion_smoother(m, a, DT, c1, 0.05**2, 0.0)
    x = np.column_stack((np.ones(n), t))
    (m0, v0), *_ = np.linalg.lstsq(x, m - c1 * a2, rcond=None)
    assert np.max(np.abs(xm - (m0 + v0 * t + c1 * a2))) < 1e-6
    assert np.max(np.abs(xv - (v0 + c1 * a1))) < 1e-3


def test_the_stuck_torsion_moment_at_2_khz_weighs_the_integrated_accelerometer_noise() -> None:
    """A 0.25 s stick phase at 2 kHz (noise of config/rig.yaml: 0.05 N m, 2 rad/s^2):
    a regression on ``M - C1*A2`` over +-60 samples carries the double integral's
    random walk (standard deviation 0.087 N m, measured); the smoother's is below
    0.02 N m (0.012 measured) and unbiased within 3 standard errors over 200 draws."""
    c1, dt, n, i = CFG.rig.C1, 5e-4, 500, 250
    t = np.arange(n) * dt
    a = 40.0 * np.sin(2.0 * np.pi * 30.0 * t)  # rad/s^2
    a1 = np.concatenate(([0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * dt)))
    a2 = np.concatenate(([0.0], np.cumsum(0.5 * (a1[1:] + a1[:-1]) * dt)))
    w = 0.36 + a1  # 3.4 rpm
    m = 30.0 + c1 * (0.36 * t + a2)
    rng = np.random.default_rng(11)
    err = []
    for _ in range(200):
        val, _, _ = stuck_kinematics(
            m + rng.normal(0.0, 0.05, n), a + rng.normal(0.0, 2.0, n),
            w + rng.normal(0.0, 0.005, n), np.array([i]), np.array([0]), np.array([n]), dt, c1,
        )  # fmt: skip
        err.append(val[0] - m[i])
    sd = float(np.std(err))
    assert sd < 0.02
    assert abs(float(np.mean(err))) < 3.0 * sd / np.sqrt(len(err))


def test_the_averaged_belt_deflection_is_exact_and_averages_the_accelerometer_noise() -> None:
    """A 20 ms stick of the kernel at a constant drive (Tab. 1, 12 rpm, 10 kHz): the
    shaft angle of the stuck state 4 ms into it. From the one-sample balance it is exact
    without noise and off by (I1 + I2)*da/C2 with it; averaged over the stick's window it
    is off by the trapezoid integrals' error without noise (below 2e-7 rad, 1e-3 N m of
    belt moment) and by less than a quarter of the one-sample error at config/rig.yaml's
    accelerometer noise (30 draws; the window centred on the start: 81 samples)."""
    w0 = 1.2566
    p = pack_params(CFG.rig, CFG.friction, DriveProfile(w0, 0.0))
    tk, vk = np.array([0.0, 1.0]), np.array([w0, w0])
    s = stuck_states(p, np.zeros(1), np.array([20.0]), np.array([1.0]), np.array([50.0]),
                     np.array([0.003]), tk, vk, np.zeros(2))[0]  # fmt: skip
    n, i = 200, 40
    out = np.full((kn.N_CH, n), np.nan)
    kn.integrate(p, s.copy(), n, DT, 4, out)
    assert np.all(out[kn.OUT_STICK] == 1.0)  # stuck throughout (20 -> 63 N m)
    s_i = s.copy()
    kn.integrate(p, s_i, i, DT, 4, np.full((kn.N_CH, i), np.nan))
    t = np.arange(n) * DT
    m, a, w = out[kn.OUT_TORSION], out[kn.OUT_ACCEL], out[kn.OUT_W1]

    def errors(acc: np.ndarray) -> tuple[float, float]:
        args = (
            p,
            t[i : i + 1],
            m[i : i + 1],
            w[i : i + 1],
            acc[i : i + 1],
            np.zeros(1),
            tk,
            vk,
            np.zeros(2),
        )
        win = stuck_windows(acc, np.array([i]), np.array([0]), np.array([n]), DT)
        one = stuck_states(*args)[0, kn.S_PHI2]
        avg = stuck_states_averaged(*args, *win)[0, kn.S_PHI2]
        return float(one - s_i[kn.S_PHI2]), float(avg - s_i[kn.S_PHI2])

    one, avg = errors(a)
    assert abs(one) < 1e-12
    assert abs(avg) < 2e-7
    rng = np.random.default_rng(3)
    draws = np.array([errors(a + rng.normal(0.0, CFG.noise.accel, n)) for _ in range(30)])
    rms = np.sqrt(np.mean(draws**2, axis=0))
    assert rms[1] < 0.25 * rms[0]


def test_the_second_order_sensor_is_exact_for_an_input_linear_between_samples() -> None:
    from scipy.integrate import solve_ivp

    dt, n = 1e-4, 300
    t = np.arange(n) * dt
    x = np.sin(2 * np.pi * 80 * t) + 40.0 * t  # an 80 Hz oscillation on a ramp [rad/s]
    a1, a2 = 2e-3, 1.5e-6  # [s], [s^2]
    out, out_d = np.zeros(n), np.zeros(n)
    y0, yd0 = 0.2, 5.0  # state before the first sample (input held at x[0] before it)
    lag2_segments(x, np.array([0]), np.array([n]), np.array([y0]), np.array([yd0]),
                  second_order_lag(a1, a2, dt), out, out_d)  # fmt: skip

    def rhs(tt: float, s: np.ndarray) -> list[float]:
        u = float(np.interp(tt, t, x)) if tt >= 0.0 else float(x[0])
        return [s[1], (u - s[0] - a1 * s[1]) / a2]

    ref = solve_ivp(rhs, (-dt, t[-1]), [y0, yd0], t_eval=t, method='DOP853',
                    rtol=1e-11, atol=1e-13, max_step=dt / 4)  # fmt: skip
    # the matrix-exponential step is exact: to the ODE solver's tolerance
    assert np.max(np.abs(out - ref.y[0])) < 1e-9
    assert np.max(np.abs(out_d - ref.y[1])) < 1e-5 * np.max(np.abs(ref.y[1]))


def test_a_vanishing_second_order_is_the_first_order_sensor() -> None:
    dt, n = 1e-4, 300
    t = np.arange(n) * dt
    x = np.sin(2 * np.pi * 80 * t) + 40.0 * t
    a1 = 2e-3
    a = float(np.exp(-dt / a1))
    first = np.zeros(n)
    lag_segments(x, np.array([0]), np.array([n]), np.array([0.2]), a, first, (1 - a) * a1 / dt)
    second, d = np.zeros(n), np.zeros(n)
    lag2_segments(x, np.array([0]), np.array([n]), np.array([0.2]), np.array([0.0]),
                  second_order_lag(a1, 1e-3 * dt * dt, dt), out=second, out_d=d)  # fmt: skip
    # a2 = 1e-3 dt^2 (the threshold below which the first order is used): the two
    # differ by under 1e-3 of the largest change per sample
    assert np.max(np.abs(first - second)) < 1e-3 * np.max(np.abs(np.diff(x)))


def test_a_raised_cosine_piece_drives_as_its_dense_linear_approximation() -> None:
    """An S-ramp from 0.6 to 1.8 rad/s over 0.3 s, one raised-cosine piece (shape 1),
    against the same ramp as 3000 linear pieces through the curve (Tab. 1, a stick
    phase, 10 kHz): the torsion moment agrees within 2e-3 N m (the linear pieces' own
    chord error, ~1e-7 rad of drive angle times C2) over the whole ramp."""
    p = pack_params(CFG.rig, CFG.friction, DriveProfile(0.6, 0.0))
    t_a, h, v_a, v_b = 0.05, 0.3, 0.6, 1.8
    tk = np.array([0.0, t_a, t_a + h, 1.0])
    vk = np.array([v_a, v_a, v_b, v_b])
    sk = np.array([0.0, 1.0, 0.0, 0.0])
    dense_t = np.linspace(t_a, t_a + h, 3001)
    dense_v = v_a + (v_b - v_a) * (0.5 - 0.5 * np.cos(np.pi * (dense_t - t_a) / h))
    tk_d = np.concatenate(([0.0], dense_t, [1.0]))
    vk_d = np.concatenate(([v_a], dense_v, [v_b]))
    st = stuck_states(p, np.zeros(1), np.array([5.0]), np.array([v_a]), np.array([0.0]),
                      np.array([0.003]), tk, vk, sk)  # fmt: skip
    n = 4000
    out = np.full((kn.N_CH, n), np.nan)
    ref = np.full((kn.N_CH, n), np.nan)
    shoot(p, st, np.array([0]), np.array([n]), tk, vk, sk, DT, 4, out)
    shoot(p, st, np.array([0]), np.array([n]), tk_d, vk_d, np.zeros(tk_d.size), DT, 4, ref)
    assert np.max(np.abs(out[kn.OUT_TORSION] - ref[kn.OUT_TORSION])) < 2e-3
    # (a linear piece through the same corners is 44 N m off)
    # the ramp itself moved the torsion moment (C1 times the speed gained, integrated)
    assert np.ptp(ref[kn.OUT_TORSION]) > 50.0


def test_the_angle_locked_ripple_counts_the_drive_angle_across_pieces() -> None:
    """A ripple locked to the drive angle (5 %, 7 per revolution, its second harmonic
    2 %) on a speed step
    (0.6 -> 1.8 rad/s, a linear piece of 0.2 s; Tab. 1, 10 kHz): the same profile as 4
    pieces and as 61 pieces (every piece cut in 20) drives the rig alike, to 1e-6 N m,
    because each piece's angle is counted from the first knot; the ripple itself moves
    the torsion moment by more than 1 N m."""
    from tribo_estimation.core.model import Extensions

    ext = Extensions(ripple_rel=0.05, ripple_order=7.0, ripple_angle_phase=0.3,
                     ripple2_rel=0.02, ripple2_angle_phase=1.1)  # fmt: skip
    p = pack_params(CFG.rig, CFG.friction, DriveProfile(0.6, 0.0), ext)
    p0 = pack_params(CFG.rig, CFG.friction, DriveProfile(0.6, 0.0))
    tk = np.array([0.0, 0.3, 0.5, 1.0])
    vk = np.array([0.6, 0.6, 1.8, 1.8])
    cuts = [np.linspace(a, b, 21)[:-1] for a, b in itertools.pairwise(tk)]
    tk_d = np.concatenate([*cuts, [1.0]])
    vk_d = np.interp(tk_d, tk, vk)
    st = stuck_states(p, np.zeros(1), np.array([5.0]), np.array([0.6]), np.array([0.0]),
                      np.array([0.003]), tk, vk, np.zeros(4))  # fmt: skip
    n = 9000
    out = {}
    for name, q, t_k, v_k in (('coarse', p, tk, vk), ('dense', p, tk_d, vk_d),
                              ('none', p0, tk, vk)):  # fmt: skip
        out[name] = np.full((kn.N_CH, n), np.nan)
        shoot(q, st, np.array([0]), np.array([n]), t_k, v_k, np.zeros(t_k.size), DT, 4,
              out[name])  # fmt: skip
    torsion = {k: v[kn.OUT_TORSION] for k, v in out.items()}
    assert np.max(np.abs(torsion['coarse'] - torsion['dense'])) < 1e-6
    assert np.max(np.abs(torsion['coarse'] - torsion['none'])) > 1.0


def test_the_angle_locked_ripple_speed_is_the_rate_of_its_angle() -> None:
    """On each piece of a profile with a raised-cosine step, drive_speed is the time
    derivative of drive_angle (central differences of 1 us, to 1e-6 rad/s); at the
    knots the drive angle from the first knot and the ripple's angle are continuous (to
    1e-12 rad), the pieces' own angles are not."""
    from tribo_estimation.core.model import Extensions
    from tribo_estimation.core.shooting import _piece_params

    ext = Extensions(ripple_rel=0.1, ripple_order=3.5, ripple_angle_phase=-1.0,
                     ripple2_rel=0.04, ripple2_angle_phase=0.7)  # fmt: skip
    p = pack_params(CFG.rig, CFG.friction, DriveProfile(0.6, 0.0), ext)
    tk = np.array([0.0, 0.3, 0.5, 1.0])
    vk = np.array([0.6, 0.6, 1.8, 1.2])
    sk = np.array([0.0, 1.0, 0.0, 0.0])
    h = 1e-6
    for j in range(-1, 4):
        q = _piece_params(p, tk, vk, sk, j)
        lo = tk[0] - 0.2 if j < 0 else tk[min(j, 3)]
        hi = tk[0] if j < 0 else (tk[j + 1] if j < 3 else 1.3)
        for t in np.linspace(lo, hi, 7)[1:-1]:
            rate = (kn.drive_angle(q, t + h) - kn.drive_angle(q, t - h)) / (2 * h)
            assert rate == pytest.approx(kn.drive_speed(q, t), abs=1e-6)
    for j in range(3):
        left = _piece_params(p, tk, vk, sk, j)
        right = _piece_params(p, tk, vk, sk, j + 1)
        t = tk[j + 1]
        theta = [kn.piece_angle(q, t) + q[kn.P_RIPA_ANGLE0] for q in (left, right)]
        ripple = [kn.drive_angle(q, t) - kn.piece_angle(q, t) for q in (left, right)]
        assert theta[0] == pytest.approx(theta[1], abs=1e-12)
        assert ripple[0] == pytest.approx(ripple[1], abs=1e-12)
        # the mean speed of every piece (line or raised cosine) is its ends' mean
        swept = float(np.sum((0.5 * (vk[1:] + vk[:-1]) * np.diff(tk))[: j + 1]))
        assert theta[1] == pytest.approx(swept, abs=1e-12)
