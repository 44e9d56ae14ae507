"""Counts to activity: dead time, background, decay, Poisson errors, bad dwells."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from tribo_nvct.core.counting import (
    Background,
    Dwell,
    check_sequence,
    counts_to_activity,
    currie_detection_limit_counts,
    decay_factor,
)
from tribo_nvct.core.nuclides import NUCLIDES, get_nuclide
from tribo_nvct.errors import (
    LiveTimeError,
    NegativeCountsError,
    NonMonotonicTimeError,
    UnknownNuclideError,
)


def nonparalysable(rng: np.random.Generator, rate: float, T: float, tau: float) -> Dwell:
    """Exact event-by-event non-paralysable counter over real time T."""
    n = rng.poisson(rate * T)
    times = np.sort(rng.uniform(0.0, T, n))
    registered = 0
    busy_until = -1.0
    for t in times:
        if t >= busy_until:
            registered += 1
            busy_until = t + tau
    return Dwell(0.0, T, registered, T - registered * tau)


def test_dead_time_correction_from_live_time_is_unbiased() -> None:
    # 20 % dead-time fraction: true rate 5000/s, tau 50 us.
    rng = np.random.default_rng(7)
    rate, T, tau = 5000.0, 2.0, 50e-6
    est = [
        counts_to_activity(nonparalysable(rng, rate, T, tau), Background(0.0), 1.0, 0.0, 0.0)
        for _ in range(40)
    ]
    mean = np.mean([e.net_rate for e in est])
    # 40 x 10^4 true events: relative sd of the mean ~ 0.2 %; naive counts/T would be 20 % low.
    assert mean == pytest.approx(rate, rel=0.01)


def test_decay_factor_matches_numeric_dwell_average() -> None:
    lam = get_nuclide('V-48').decay_constant
    offset = 30 * 86400.0
    t0, t1 = 7200.0, 7260.0
    avg, _ = quad(lambda t: math.exp(-lam * (offset + t)), t0, t1)
    assert decay_factor(t0, t1, lam, offset) == pytest.approx((t1 - t0) / avg, rel=1e-12)
    # Half-life check: after one half-life the activity has halved.
    T = get_nuclide('Co-56').half_life_s
    assert decay_factor(T, T + 1e-9, get_nuclide('Co-56').decay_constant, 0.0) == pytest.approx(
        2.0, rel=1e-9
    )


def test_poisson_error_through_every_step() -> None:
    d = Dwell(100.0, 160.0, 2500, 59.5)
    bg = Background.measured(3600, 3600.0)
    lam = NUCLIDES['Co-56'].decay_constant
    a = counts_to_activity(d, bg, 10.0, lam, 14 * 86400.0)
    c = decay_factor(100.0, 160.0, lam, 14 * 86400.0)
    net = 2500 / 59.5 - 1.0
    assert a.activity == pytest.approx(10.0 * net * c)
    assert a.se == pytest.approx(10.0 * c * math.sqrt(2500 / 59.5**2 + (60.0 / 3600) ** 2))


def test_nuclide_table_and_lookup() -> None:
    for name in ('Co-56', 'Co-57', 'Co-58', 'Fe-59', 'Cr-51', 'Be-7', 'Zn-65', 'V-48'):
        assert NUCLIDES[name].half_life_days > 10.0
    assert get_nuclide('co56') is NUCLIDES['Co-56']
    assert get_nuclide('56Co') is NUCLIDES['Co-56']
    with pytest.raises(UnknownNuclideError, match='half_life_days'):
        get_nuclide('Xx-999')


def test_bad_dwells_rejected() -> None:
    with pytest.raises(NegativeCountsError, match='negative counts'):
        Dwell(0.0, 60.0, -1, 60.0)
    with pytest.raises(NegativeCountsError):
        Dwell(0.0, 60.0, 1.5, 60.0)  # type: ignore[arg-type]
    with pytest.raises(LiveTimeError, match='exceeds the dwell'):
        Dwell(0.0, 60.0, 10, 61.0)
    with pytest.raises(LiveTimeError):
        Dwell(0.0, 60.0, 10, 0.0)
    with pytest.raises(NonMonotonicTimeError):
        Dwell(60.0, 60.0, 10, 0.5)
    with pytest.raises(NonMonotonicTimeError, match='overlaps'):
        check_sequence(Dwell(0.0, 60.0, 1, 60.0), Dwell(30.0, 90.0, 1, 60.0))
    assert check_sequence(Dwell(0.0, 60.0, 1, 60.0), Dwell(180.0, 240.0, 1, 60.0)) is True


def test_currie() -> None:
    # Currie 1968: L_D = 2.71 + 4.65 sqrt(B); zero background -> 2.71 counts.
    assert currie_detection_limit_counts(0.0) == pytest.approx(2.71)
    assert currie_detection_limit_counts(100.0) == pytest.approx(2.71 + 46.5)
