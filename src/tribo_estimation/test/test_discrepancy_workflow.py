"""The missing-physics workflow on simulated records with a hidden effect.

Each candidate effect is hidden in turn (at a realistic magnitude, seeded
noise 0.05 N m on the torsion moment, 2 rad/s^2 on the acceleration,
0.005 rad/s on the speed) in a 1 s record of the config/rig.yaml rig (paper
Tab. 1, F_N*R = 640 N m, 30 rpm, start-up ramp): it must be the first added
effect, the torsion-moment residual rms must drop at least by half and the
fitted parameters must be within 20 % of the truth. Controls: no hidden
effect -> nothing added; an effect outside the library (a sinusoidal torque
disturbance at 37 Hz, not a drive frequency) -> reported as unexplained, not
misnamed.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.discrepancy import SelectionSettings, run_discrepancy
from tribo_estimation.core.discrepancy.fitting import Record
from tribo_estimation.core.discrepancy.select import DiscrepancyResult
from tribo_estimation.core.model import Extensions
from tribo_estimation.core.simulate import NoiseSpec, simulate

pytestmark = pytest.mark.slow

RIG_YAML = Path(__file__).resolve().parents[3] / 'config' / 'rig.yaml'
NOISE = NoiseSpec(torque=0.05, accel=2.0, speed=0.005)
DURATION = 1.0  # s; the 6 s sweep is bench/bench_discrepancy.py

#: Hidden effect -> (Extensions fields, fields checked against the fit).
#: Trend-like effects are scaled so that their change over this 1 s record is
#: clearly above the noise (a 6 s record needs a sixth of the rate).
CASES: dict[str, tuple[dict[str, float], tuple[str, ...]]] = {
    'dwell_time_stiction': (
        {'stiction_gain': 0.02, 'stiction_tau': 0.005},
        ('stiction_gain', 'stiction_tau'),
    ),
    'frictional_lag': ({'lag_tau': 0.002}, ('lag_tau',)),
    'viscous_friction': ({'viscous': 0.5}, ('viscous',)),
    'friction_drift': (
        {'drift_mu0': -0.003, 'drift_mu_inf': -0.002},
        ('drift_mu0', 'drift_mu_inf'),
    ),
    'drive_speed_ripple': (
        {'ripple_amp': 0.1, 'ripple_freq': 13.0, 'ripple_phase': 0.5},
        ('ripple_amp', 'ripple_freq', 'ripple_phase'),
    ),
    # the constant offset is indistinguishable from a common mu shift (absorbed
    # by the baseline, see effects/torque_offset.py); only its drift is identifiable
    'torque_offset': ({'torque_offset': 0.5, 'torque_offset_drift': 0.5}, ('torque_offset_drift',)),
    'torque_sensor_lag': ({'torque_lag_tau': 0.0005}, ('torque_lag_tau',)),
    'bearing_friction': ({'bearing_moment': 0.5}, ('bearing_moment',)),
}


#: The records start this long after the drive start [s] (inside the 0.5 s start-up
#: ramp of config/rig.yaml; the drive is measured from the record). From rest (0 s),
#: a torque-offset drift and an equal drift of mu0 and mu_inf are not told apart in
#: a 1 s record (open, see test_realfit for the start-up itself).
START = 0.25


def _record(effects: dict[str, float], seed: int, *, disturbance: float = 0.0) -> Record:
    cfg = load_rig_config(RIG_YAML)
    r = simulate(
        cfg.rig,
        cfg.friction,
        cfg.drive,
        START + DURATION,
        extensions=Extensions(**effects),
        noise=NOISE,
        seed=seed,
    )
    torque = r.torsion_moment + disturbance * np.sin(2 * np.pi * 37.0 * r.time + 0.3)
    m = r.time >= START
    return Record(r.time[m], torque[m], r.angular_acceleration[m], r.speed[m])


def _run(record: Record, **kw: Any) -> DiscrepancyResult:
    cfg = load_rig_config(RIG_YAML)
    return run_discrepancy(
        record, cfg.rig, cfg.drive, k=cfg.friction.k, settings=SelectionSettings(**kw)
    )


@pytest.mark.parametrize('effect', list(CASES))
def test_hidden_effect_is_found_first(effect: str) -> None:
    truth, checked = CASES[effect]
    seed = 100 + list(CASES).index(effect)
    # a torsion-amplifier lag is part of the instrument model (compensated before
    # the fit, test_torsion_lag_is_instrument); with that off it is a candidate
    kw: dict[str, Any] = {'torsion_lag': False} if effect == 'torque_sensor_lag' else {}
    res = _run(_record(truth, seed), max_effects=1, **kw)
    assert res.added, f'{effect}: nothing added; rounds {res.rounds}'
    first = res.added[0]
    assert first.effect == effect
    # the criterion: the torsion-moment residual rms drops at least by half
    assert first.rms_after <= 0.5 * first.rms_before
    assert res.final.rms <= 0.5 * res.baseline.rms
    for name in checked:
        # the criterion: fitted effect parameters within 20 % of the truth
        assert first.params[name] == pytest.approx(truth[name], rel=0.2), name
    # and the residual ends near the noise floor (0.05 N m + start-state errors)
    assert res.final.rms < 0.1


def test_torsion_lag_is_instrument() -> None:
    # the hidden torque_sensor_lag record of test_hidden_effect_is_found_first: the
    # instrument model identifies the lag (within 10 %) and compensates it, nothing
    # is named and the baseline ends near the noise floor (0.05 N m + start states)
    truth = CASES['torque_sensor_lag'][0]['torque_lag_tau']
    res = _run(_record(CASES['torque_sensor_lag'][0], 100 + list(CASES).index('torque_sensor_lag')))
    lag = res.instrument['torsion_lag_tau']
    assert lag['used'] == pytest.approx(truth, rel=0.1)
    assert lag['se'] < 0.1 * truth
    assert res.added == (), [a.effect for a in res.added]
    assert res.baseline.rms < 0.1


def test_no_hidden_effect_adds_nothing() -> None:
    res = _run(_record({}, 7))
    assert res.added == ()
    assert res.final.rms == res.baseline.rms
    cfg = load_rig_config(RIG_YAML)
    # the baseline fit recovers the paper model's coefficients (noise 0.05 N m
    # on 640 N m per unit mu: errors ~1e-5; 1e-3 absolute is a loose bound)
    assert res.baseline.params['mu0'] == pytest.approx(cfg.friction.mu0, abs=1e-3)
    assert res.baseline.params['mu_inf'] == pytest.approx(cfg.friction.mu_inf, abs=1e-3)
    # residual = sensor noise (0.05 N m) plus start-state errors
    assert res.baseline.rms < 0.07


def test_effect_outside_library_is_unexplained_not_misnamed() -> None:
    res = _run(_record({}, 8, disturbance=0.3))
    assert res.added == (), [a.effect for a in res.added]
    lines = [u for u in res.unexplained if u.kind == 'spectral_line']
    assert lines, res.unexplained
    near = [u for u in lines if u.frequency is not None and abs(u.frequency - 37.0) < 0.5]
    assert near, [u.frequency for u in lines]
    # amplitude of the 0.3 N m disturbance from the final residual (20 %)
    assert near[0].size == pytest.approx(0.3, rel=0.2)
    assert 'not a harmonic' in near[0].where
    # the sparse regression proposes the disturbance's sinusoid (term names
    # 'sin(2*pi*<f>*t)' / 'cos(2*pi*<f>*t)' with f in Hz)
    freqs = [
        float(t.name.split('*')[2])
        for t in res.proposed_terms
        if t.name.startswith(('sin(2*pi*', 'cos(2*pi*'))
    ]
    assert any(abs(f - 37.0) < 0.5 for f in freqs), res.proposed_terms
    assert not math.isnan(res.noise_floor)
