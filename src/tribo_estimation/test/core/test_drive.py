"""The drive profile: the speed channel's smoothed profile and its refit to drive angles."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.drive import estimate_drive, refine_with_angles

FS = 1000.0


def _stop_and_restart(t: np.ndarray) -> np.ndarray:
    """5 rad/s, down to rest at 3.0-3.5 s, at rest to 4.8 s, back up at 4.8-5.3 s [rad/s]."""
    return np.interp(t, [0.0, 3.0, 3.5, 4.8, 5.3, 8.0], [5.0, 5.0, 0.0, 0.0, 5.0, 5.0])


def test_refine_keeps_the_speed_channel_where_no_angles_pin_the_profile() -> None:
    # angles only through the stop (a long stick) and a few near the end: stick phases
    # too short to sample elsewhere (a low sample rate)
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 8.0, 1.0 / FS)
    speed = _stop_and_restart(t) + rng.normal(0.0, 0.02, t.size)
    drive = estimate_drive(t, speed)
    ta = np.concatenate((np.arange(3.6, 4.7, 0.002), np.arange(7.0, 7.2, 0.05)))
    fine = np.arange(0.0, 8.0, 1e-4)
    angle = np.interp(ta, fine, np.cumsum(_stop_and_restart(fine)) * 1e-4)
    phi = 0.3 + angle + rng.normal(0.0, 1e-4, ta.size)
    got = refine_with_angles(drive, ta, phi)
    # where no angle pins it the profile keeps the channel's 5 rad/s (its noise
    # averaged: 0.02 rad/s is 4x the smoothed level's); the stop stays at rest
    for when in (0.5, 1.5, 2.5, 6.0, 7.5):
        assert float(got.speed(when)) == pytest.approx(5.0, abs=0.05), when
    assert float(got.speed(4.0)) == pytest.approx(0.0, abs=0.01)
