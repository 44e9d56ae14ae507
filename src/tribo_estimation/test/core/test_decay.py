"""Tests of free-decay identification (Equ. 7) on simulated noisy records."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.decay import identify_free_decay
from tribo_estimation.core.model import RigParams
from tribo_estimation.core.simulate import NoiseSpec, simulate_free_decay
from tribo_estimation.errors import (
    InvalidDataError,
    NonMonotonicTimeError,
    NoOscillationError,
    TooShortError,
)

# deliberately NOT the Tab. 1 values
RIG = RigParams(I1=0.0152, K1=0.09, C1=1850.0, I2=0.0315, K2=4.0, C2=5975.0, F_N=0.0, R=0.08)
NOISE = NoiseSpec(torque=0.05, accel=2.0)


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_identifies_non_tab1_chamber_on_noisy_data(seed: int) -> None:
    r = simulate_free_decay(RIG, 0.01, 1.5, noise=NOISE, seed=seed)
    d = identify_free_decay(r.time, r.torsion_moment, r.angular_acceleration)
    # issue targets: I1 and C1 within 1 %, K1 within 10 %
    assert abs(d.I1 / RIG.I1 - 1.0) < 0.01
    assert abs(d.C1 / RIG.C1 - 1.0) < 0.01
    assert abs(d.K1 / RIG.K1 - 1.0) < 0.10
    assert d.f_n_hz == pytest.approx(RIG.natural_frequency_hz, rel=1e-3)
    assert d.zeta == pytest.approx(RIG.damping_ratio, rel=0.10)
    # standard errors are positive and consistent with the actual error (5 sigma)
    for name in ('I1', 'K1', 'C1', 'f_n_hz', 'zeta'):
        se = getattr(d, f'{name}_se')
        assert se > 0.0
    assert abs(d.I1 - RIG.I1) < 5 * d.I1_se
    assert abs(d.K1 - RIG.K1) < 5 * d.K1_se
    # residuals at the noise level: the model explains everything else
    assert d.rms_torque == pytest.approx(0.05, rel=0.1)
    assert d.rms_accel == pytest.approx(2.0, rel=0.1)


def test_small_amplitude_with_offsets() -> None:
    # 0.5 mrad release (0.9 N m, 18x the noise), sensor offsets on both channels
    r = simulate_free_decay(RIG, 5e-4, 2.0, noise=NOISE, seed=4)
    d = identify_free_decay(r.time, r.torsion_moment + 3.0, r.angular_acceleration - 4.0)
    assert abs(d.I1 / RIG.I1 - 1.0) < 0.01
    assert abs(d.C1 / RIG.C1 - 1.0) < 0.01
    assert abs(d.K1 / RIG.K1 - 1.0) < 0.10
    assert d.torque_offset == pytest.approx(3.0, abs=0.01)
    assert d.accel_offset == pytest.approx(-4.0, abs=0.2)


def test_tab1_chamber_gives_73_7_hz() -> None:
    rig = RigParams.tab1(F_N=0.0)
    r = simulate_free_decay(rig, 0.005, 1.0, noise=NOISE, seed=5)
    d = identify_free_decay(r.time, r.torsion_moment, r.angular_acceleration)
    assert d.f_n_hz == pytest.approx(73.7, abs=0.05)


def test_bad_input_raises_specific_errors() -> None:
    r = simulate_free_decay(RIG, 0.01, 0.5, noise=NOISE, seed=6)
    t, m, a = r.time, r.torsion_moment.copy(), r.angular_acceleration
    m_nan = m.copy()
    m_nan[100] = np.nan
    with pytest.raises(InvalidDataError, match='torsion_moment'):
        identify_free_decay(t, m_nan, a)
    t_bad = t.copy()
    t_bad[50] = t_bad[49]
    with pytest.raises(NonMonotonicTimeError, match='sample 50'):
        identify_free_decay(t_bad, m, a)
    with pytest.raises(TooShortError):
        identify_free_decay(t[:20], m[:20], a[:20])
    with pytest.raises(TooShortError, match='periods'):
        identify_free_decay(t[:300], m[:300], a[:300])  # 30 ms = 1.7 periods
    rng = np.random.default_rng(0)
    with pytest.raises(NoOscillationError):
        identify_free_decay(t, 10.0 + rng.normal(0, 0.05, t.size), rng.normal(0, 2, t.size))
    with pytest.raises(NoOscillationError):
        identify_free_decay(t, np.full(t.size, 5.0), np.zeros(t.size))
    with pytest.raises(InvalidDataError, match='length'):
        identify_free_decay(t, m[:-1], a)
