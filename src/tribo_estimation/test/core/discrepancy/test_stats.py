"""Unit tests of the discrepancy workflow's building blocks on synthetic arrays.

Residual statistics (phases, stick durations, breakaway timing, noise floor,
spectral lines, trend, angle dependence), the sparse regression, the candidate
library and the bounded Levenberg-Marquardt solver; analytic expectations.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
import pytest

from tribo_estimation.core.discrepancy import candidates as cl
from tribo_estimation.core.discrepancy.sparse import stlsq
from tribo_estimation.core.discrepancy.stats import (
    SLIP_ACCEL,
    SLIP_DECEL,
    STICK,
    angle_dependence,
    binned,
    fit_sinusoid,
    noise_floor,
    phase_labels,
    preceding_stick_duration,
    spectral_lines,
    stick_durations,
    time_since_breakaway,
    trend,
)
from tribo_estimation.core.lsq import levenberg_marquardt
from tribo_estimation.core.model import Extensions
from tribo_estimation.errors import FitError

FS = 10_000.0


def _stick_pattern() -> tuple[np.ndarray, np.ndarray]:
    """stick 10 | slip 9 (|v| up 0..4 then down) | stick 6 | slip 9 | stick 4 (samples)."""
    tri = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 4.0, 3.0, 2.0, 1.0])
    v = np.concatenate([np.zeros(10), tri, np.zeros(6), -tri, np.zeros(4)])
    return v, v == 0.0


def test_phase_labels_follow_the_deceleration_rule() -> None:
    v, stick = _stick_pattern()
    lab = phase_labels(v, stick)
    assert np.all(lab[stick] == STICK)
    # up to and including the |v| peak (5th slip sample) = accelerating, then decelerating
    assert list(lab[10:19]) == [SLIP_ACCEL] * 5 + [SLIP_DECEL] * 4
    assert list(lab[25:34]) == [SLIP_ACCEL] * 5 + [SLIP_DECEL] * 4


def test_stick_durations_and_preceding_stick() -> None:
    _, stick = _stick_pattern()
    # complete stick phases (not touching the ends): only the middle one, 6 samples
    assert stick_durations(stick, FS) == pytest.approx([6 / FS])
    pre = preceding_stick_duration(stick, FS)
    assert np.all(np.isnan(pre[stick]))
    # the first stick phase starts with the record: its duration is unknown
    assert np.all(np.isnan(pre[10:19]))
    assert np.allclose(pre[25:34], 6 / FS)


def test_time_since_breakaway_is_signed_distance() -> None:
    _, stick = _stick_pattern()
    tb = time_since_breakaway(stick, FS)
    # breakaways (end of stick) at samples 10 and 25
    assert tb[10] == 0.0 and tb[25] == 0.0
    assert tb[8] == pytest.approx(-2 / FS)
    assert tb[13] == pytest.approx(3 / FS)
    assert tb[20] == pytest.approx(-5 / FS)  # nearer to the second breakaway
    assert np.all(np.isnan(time_since_breakaway(np.zeros(10, dtype=bool), FS)))


def test_noise_floor_ignores_sharp_features() -> None:
    rng = np.random.default_rng(3)
    r = rng.normal(0.0, 0.05, 40_000)
    r[::500] += 2.0  # sparse breakaway spikes must not inflate the estimate
    # MAD of 40 000 second differences: relative standard error ~1 %, so 5 % is safe
    assert noise_floor(r) == pytest.approx(0.05, rel=0.05)


def test_spectral_line_frequency_and_amplitude() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(20_000) / FS
    r = 0.3 * np.sin(2 * np.pi * 37.0 * t + 0.4) + rng.normal(0.0, 0.05, t.size)
    lines = spectral_lines(t, r, FS)
    assert len(lines) == 1
    # least-squares refinement over 2 s: frequency error << 1/T = 0.5 Hz;
    # amplitude error ~ noise/sqrt(n/2) = 5e-4 N m, 2 % leaves margin
    assert lines[0].frequency == pytest.approx(37.0, abs=0.05)
    assert lines[0].amplitude == pytest.approx(0.3, rel=0.02)
    assert spectral_lines(t, rng.normal(0.0, 0.05, t.size), FS) == []


def test_fit_sinusoid_recovers_phase() -> None:
    t = np.arange(5000) / FS
    f, a, p = fit_sinusoid(t, 2.0 * np.sin(2 * np.pi * 13.0 * t - 1.1) + 5.0, 13.0)
    assert (f, a, p) == pytest.approx((13.0, 2.0, -1.1), abs=1e-9)


def test_trend_slope_and_significance() -> None:
    rng = np.random.default_rng(5)
    t = np.arange(30_000) / FS
    tr = trend(t, 0.2 * t + rng.normal(0.0, 0.05, t.size))
    # block means of 1500 samples: slope standard error ~1e-3 N m/s -> 3 % is > 5 sigma
    assert tr.slope == pytest.approx(0.2, rel=0.03)
    assert tr.change == pytest.approx(0.6, rel=0.03)
    assert tr.t_stat > 20
    flat = trend(t, rng.normal(0.0, 0.05, t.size))
    assert abs(flat.t_stat) < 5  # seeded white noise: no significant trend


def test_angle_dependence_harmonic() -> None:
    rng = np.random.default_rng(6)
    th = np.mod(np.linspace(0, 12 * np.pi, 30_000), 2 * np.pi)
    ad = angle_dependence(th, 0.1 * np.cos(2 * th - 0.3) + rng.normal(0, 0.05, th.size))
    assert ad.order == 2
    # amplitude standard error ~ 0.05*sqrt(2/30000) = 4e-4: 5 % = 5e-3 is ample
    assert ad.amplitude == pytest.approx(0.1, rel=0.05)
    assert ad.phase == pytest.approx(0.3, abs=0.05)


def test_binned_statistics() -> None:
    x = np.repeat(np.arange(4.0), 50)
    r = np.repeat(np.array([1.0, -1.0, 2.0, 0.0]), 50)
    b = binned(x, r, name='x', unit='-', bins=np.array([-0.5, 0.5, 1.5, 2.5, 3.5]))
    assert b.mean == pytest.approx((1.0, -1.0, 2.0, 0.0))
    assert b.rms == pytest.approx((1.0, 1.0, 2.0, 0.0))
    assert b.count == (50, 50, 50, 50)


def test_stlsq_selects_the_true_terms() -> None:
    rng = np.random.default_rng(7)
    n = 5000
    feats = {f'x{i}': rng.normal(size=n) for i in range(6)}
    y = 0.5 * feats['x1'] - 0.2 * feats['x3'] + rng.normal(0.0, 0.02, n)
    model = stlsq(feats, y, threshold=0.05)
    assert {t.name for t in model.terms} == {'x1', 'x3'}
    coef = {t.name: t.coefficient for t in model.terms}
    # least squares with noise 0.02 over 5000 samples: coefficient error ~3e-4
    assert coef['x1'] == pytest.approx(0.5, abs=0.005)
    assert coef['x3'] == pytest.approx(-0.2, abs=0.005)
    assert model.rms_after == pytest.approx(0.02, rel=0.1)


def test_candidate_library_is_complete_and_nested() -> None:
    required = {
        'dwell_time_stiction',
        'frictional_lag',
        'viscous_friction',
        'friction_drift',
        'drive_speed_ripple',
        'torque_offset',
        'torque_sensor_lag',
        'bearing_friction',
    }
    assert required <= set(cl.families())
    ext_fields = {f.name for f in fields(Extensions)}
    for c in cl.all_candidates():
        if c.levels is not None:
            # a change of the friction levels with test time: its parameters are the
            # form's own; zero changes give the levels back (nested)
            t = np.linspace(0.0, 5.0, 11)
            zero = {p.name: 0.0 for p in c.params if not p.log} | {
                p.name: p.initial for p in c.params if p.log
            }
            assert all(np.all(x == 0.0) for x in c.levels(zero, t)), c.name
            continue
        assert set(c.param_names) <= ext_fields, c.name
        # nested: the candidate's fields at zero give the paper's model
        assert Extensions(**{n: 0.0 for n in c.param_names}).is_baseline
        vals = {
            p.name: 0.5 * (p.lower + p.upper) if not p.log else math.sqrt(p.lower * p.upper)
            for p in c.params
        }
        back = c.from_unit(c.to_unit(vals))
        assert back == pytest.approx(vals, rel=1e-12)


def test_candidate_registry_rejects_bad_entries() -> None:
    c = cl.get('viscous_friction')
    with pytest.raises(ValueError, match='already registered'):
        cl.register(c)
    with pytest.raises(KeyError, match='unknown candidate'):
        cl.get('no_such_effect')
    with pytest.raises(ValueError, match='unknown localiser'):
        cl.Candidate('x', 'x', (), 'nowhere')
    with pytest.raises(ValueError, match='outside'):
        cl.ParamSpec('viscous', 'N m s/rad', 0.0, 1.0, 1.0, 2.0)


def test_levenberg_marquardt_exponential_fit_and_bounds() -> None:
    t = np.linspace(0.0, 1.0, 200)
    y = 3.0 * np.exp(-2.5 * t)

    def fun(x: np.ndarray) -> np.ndarray:
        return x[0] * np.exp(-x[1] * t) - y

    lo, hi = np.array([0.0, 0.0]), np.array([10.0, 10.0])
    sol = levenberg_marquardt(fun, np.array([1.0, 1.0]), lo, hi, max_nfev=200)
    assert sol.converged and sol.nfev <= 200
    assert sol.x == pytest.approx([3.0, 2.5], rel=1e-4)  # noise-free: converges to the truth
    # with the decay rate capped below its true value the solution sits on the bound
    hi2 = np.array([10.0, 2.0])
    x2 = levenberg_marquardt(fun, np.array([1.0, 1.0]), lo, hi2, max_nfev=200).x
    assert x2[1] == pytest.approx(2.0)


def test_levenberg_marquardt_rejects_non_finite_steps_and_stops_at_its_limits() -> None:
    t = np.linspace(0.0, 1.0, 50)
    y = 3.0 * np.exp(-2.5 * t)

    def fun(x: np.ndarray) -> np.ndarray:
        # a model that overflows for large rates: such steps must be rejected
        return np.where(x[1] > 2.6, np.inf, x[0] * np.exp(-x[1] * t) - y)

    lo, hi = np.array([0.0, 0.0]), np.array([10.0, 10.0])
    sol = levenberg_marquardt(fun, np.array([1.0, 1.0]), lo, hi, max_iter=100)
    assert np.all(np.isfinite(sol.fun))
    assert sol.x == pytest.approx([3.0, 2.5], rel=1e-3)
    capped = levenberg_marquardt(fun, np.array([1.0, 1.0]), lo, hi, max_iter=2, max_nfev=7)
    assert capped.n_iter <= 2 and capped.nfev <= 7
    with pytest.raises(FitError):
        levenberg_marquardt(lambda x: np.full(3, np.nan), np.array([1.0]), lo[:1], hi[:1])
