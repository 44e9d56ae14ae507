"""The measured noise: the white level of each channel from a model's residual."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.pipeline.noise import ChannelNoise, measure_noise

DT = 1e-4


def test_draw_has_the_stated_level() -> None:
    rng = np.random.default_rng(1)
    x = ChannelNoise(0.05).draw(rng, 200_000, DT)
    # 200k samples: the standard deviation within 1 % (its sampling error is 0.16 %)
    assert np.std(x) == pytest.approx(0.05, rel=0.01)


def test_measure_noise_sees_the_white_level_under_a_smooth_mismatch() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(100_000) * DT
    # a smooth 3 Hz mismatch 20x the noise and a few sparse 1 N m steps (breakaways)
    slow = 1.0 * np.sin(2 * np.pi * 3.0 * t) + (np.floor(t * 7) % 2)
    res = {
        'torsion_moment': slow + rng.normal(0.0, 0.05, t.size),
        'angular_acceleration': rng.normal(0.0, 2.0, t.size),
        'speed': 0.1 * slow + rng.normal(0.0, 0.005, t.size),
    }
    covered = np.ones(t.size, dtype=bool)
    covered[:100] = False
    noise = measure_noise(res, covered)
    # second differences: the white level within 3 % under the mismatch
    assert noise.torsion_moment.white == pytest.approx(0.05, rel=0.03)
    assert noise.angular_acceleration.white == pytest.approx(2.0, rel=0.03)
    assert noise.speed.white == pytest.approx(0.005, rel=0.03)
    assert noise.as_dict()['speed'] == {'white': noise.speed.white}
