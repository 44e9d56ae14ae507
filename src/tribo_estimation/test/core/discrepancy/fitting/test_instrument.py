"""Instrument identification of the discrepancy fits (fitting/instrument.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.fitting.instrument import identify_hum

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
    found = {(c, f) for c, f, _, _ in identify_hum(t, res, 0.01).lines}
    assert ('torsion_moment', 50.0) in found
    assert ('torsion_moment', 60.0) not in found
    amp = {f: a for c, f, a, _ in identify_hum(t, res, 0.01).lines}
    assert amp[50.0] == pytest.approx(0.05, rel=0.15)  # amplitude within 15 %


def test_hum_false_alarm_rate_is_alpha() -> None:
    # alpha = 0.01 per record: on 100 records of white noise at most 3 have a line
    # (binomial, 1.8 % chance of 4 or more at the stated rate)
    with_line = 0
    for seed in range(100):
        res = _residuals([], seed)
        t = res.pop('t')
        with_line += bool(identify_hum(t, res, 0.01).lines)
    assert with_line <= 3
