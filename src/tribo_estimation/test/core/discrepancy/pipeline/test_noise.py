"""The measured noise: white + AR(1) from short demeaned windows (known truth, seeded)."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.pipeline.noise import ChannelNoise, fit_channel

DT = 1e-4


def _windows(x: np.ndarray, length: int, gap: int) -> list[np.ndarray]:
    return [x[i : i + length] for i in range(0, x.size - length, length + gap)]


def test_draw_has_the_stated_variance_and_correlation() -> None:
    rng = np.random.default_rng(1)
    noise = ChannelNoise(0.05, 0.03, 0.003)
    x = noise.draw(rng, 2_000_000, DT)
    # total variance s_w^2 + s_c^2 within 2 % (2M samples, correlation 30 samples)
    assert np.var(x) == pytest.approx(0.05**2 + 0.03**2, rel=0.02)
    # lag-60 autocovariance is the AR part's s_c^2 exp(-60 dt/tau) within 20 % (its
    # sampling error is about 6 %)
    c60 = float(np.mean((x[60:] - x.mean()) * (x[:-60] - x.mean())))
    assert c60 == pytest.approx(0.03**2 * np.exp(-60 * DT / 0.003), rel=0.2)


def test_fit_recovers_an_ar1_part_from_short_windows() -> None:
    rng = np.random.default_rng(2)
    truth = ChannelNoise(0.05, 0.03, 0.003)
    x = truth.draw(rng, 200_000, DT)
    # windows of 60 samples (6 ms) against a 3 ms correlation time: the demeaning's
    # bias is taken into account
    got = fit_channel(_windows(x, 60, 140), DT, 0.0)
    assert got.white == pytest.approx(0.05, rel=0.05)
    assert got.coloured == pytest.approx(0.03, rel=0.15)
    assert got.corr_time == pytest.approx(0.003, rel=0.3)


def test_fit_of_white_noise_has_its_total_level() -> None:
    rng = np.random.default_rng(3)
    x = ChannelNoise(0.05).draw(rng, 200_000, DT)
    got = fit_channel(_windows(x, 60, 140), DT, 0.0)
    # any coloured part found is shorter than a sample: the total is the white level
    assert got.total == pytest.approx(0.05, rel=0.03)
    assert got.coloured == 0.0 or got.corr_time < DT


def test_fit_without_windows_falls_back_to_the_given_level() -> None:
    assert fit_channel([], DT, 0.07) == ChannelNoise(0.07)
