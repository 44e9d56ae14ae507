"""The drive profile measured from a record (core/drive.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tribo_estimation.core.drive import estimate_drive

FS = 10_000.0  # [Hz]


def _slow_stick_slip(seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """A constant drive (0.35 rad/s) under a shaft speed swinging with 16 Hz stick-slip."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(6.0 * FS)) / FS
    cycle = 1.0 / 16.0  # [s]
    phase = (t / cycle) % 1.0
    # stick (70 % of the cycle, the shaft at 0.1 rad/s) then a fast slip: mean 0.35 rad/s
    swing = np.where(
        phase < 0.7,
        0.1,
        0.1 + (0.35 - 0.1) / 0.3 * 2.0 * np.sin(math.pi * (phase - 0.7) / 0.3) ** 2,
    )
    speed = swing + rng.normal(0.0, 0.005, t.size)
    return t, speed, cycle


@pytest.mark.parametrize('seed', [1, 2])
def test_a_slow_constant_drive_has_no_corners_when_averaged_over_whole_cycles(seed: int) -> None:
    t, speed, cycle = _slow_stick_slip(seed)
    mean = float(np.mean(speed[: round(96 * cycle * FS)]))  # 96 whole cycles
    est = estimate_drive(t, speed, None, cycle)
    assert est.knot_time.size == 2  # constant: no corner
    assert est.level == pytest.approx(mean, rel=0.005)  # within 0.5 %
    # averaged over 0.1 s (1.6 cycles) the ripple is taken for speed changes
    assert estimate_drive(t, speed, None).knot_time.size > 2
