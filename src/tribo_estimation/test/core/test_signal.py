"""The shared smoothed derivative and the shaft-chamber speed check against analytic cases."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.signal import (
    chamber_speed,
    first_order_lag,
    grouped_medians,
    local_slope,
    rig_half,
    span_medians,
)
from tribo_estimation.core.sticks import speed_mismatch

DT = 1e-4


def test_local_slope_is_exact_for_its_polynomial_degree() -> None:
    t = np.arange(400) * DT
    x = 0.3 - 2.0 * t + 50.0 * t**2 - 4e3 * t**3
    exact = -2.0 + 100.0 * t - 12e3 * t**2
    # a cubic is reproduced by the local cubic everywhere, ends included (rounding only)
    assert np.max(np.abs(local_slope(x, DT, 29, order=3) - exact)) < 1e-8
    line = 1.5 + 7.0 * t
    assert np.max(np.abs(local_slope(line, DT, 9) - 7.0)) < 1e-9


def test_local_slope_order_one_is_the_least_squares_line() -> None:
    x = np.random.default_rng(3).normal(size=300)
    h = 4
    k = np.arange(-h, h + 1, dtype=float)
    i = 150
    expected = float(np.sum(k * x[i - h : i + h + 1]) / (DT * np.sum(k * k)))
    # the explicit formula x'_i = sum k x_(i+k) / (dt sum k^2), to rounding
    assert local_slope(x, DT, 2 * h + 1)[i] == pytest.approx(expected, rel=1e-12)
    # ends: the line of the first full window
    first = float(np.sum(k * x[: 2 * h + 1]) / (DT * np.sum(k * k)))
    assert local_slope(x, DT, 2 * h + 1)[0] == pytest.approx(first, rel=1e-12)


def test_local_slope_short_records() -> None:
    # shorter than the window: the window shrinks to the record; too short: zeros
    t = np.arange(6) * DT
    assert np.allclose(local_slope(2.0 * t, DT, 29), 2.0, atol=1e-9)
    assert np.all(local_slope(np.ones(2), DT, 9) == 0.0)


def test_chamber_speed_of_a_sine() -> None:
    c1 = 2000.0  # N m/rad
    w = 2 * np.pi * 20.0  # rad/s
    t = np.arange(2000) * DT
    torsion = c1 * 0.01 * np.sin(w * t)  # phi1 = 0.01 sin(w t) rad
    w1 = chamber_speed(torsion, 1.0 / DT, c1)
    # local cubic over 1.5 ms of a 50 ms period: relative error ~1e-4
    assert np.max(np.abs(w1 - 0.01 * w * np.cos(w * t))) < 1e-4 * 0.01 * w


def _sticky_record(
    tau: float, offset: float
) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """Chamber speed, speed channel and ten phases; the third is a slow slip at 3 rad/s."""
    n = 4000
    t = np.arange(n) * DT
    w1 = 3.0 + 0.5 * np.sin(2 * np.pi * 5.0 * t)  # rad/s
    w2 = w1.copy()
    spans = [(100 + 400 * j, 300 + 400 * j) for j in range(10)]
    a, b = spans[2]
    w2[a:b] += 3.0  # the discs still slip here
    y = first_order_lag(w2, DT, tau, y0=float(w2[0])) + offset
    return w1, y, spans


@pytest.mark.parametrize('known', [True, False])
def test_speed_mismatch_finds_the_phase_that_slips(known: bool) -> None:
    tau, offset = 2e-3, 0.2  # s, rad/s
    w1, y, spans = _sticky_record(tau, offset)
    slope = local_slope(y, DT, 9)
    sensor = (tau, offset) if known else None
    out = speed_mismatch(y, slope, w1, spans, sensor=sensor)
    # the slipping phase shows its slip speed (3 rad/s, within 5 %); the sticks ~0
    # (fitted sensor: the second pass refits without the slipping phase)
    # (lag inversion through the slope estimate: within 0.05 rad/s)
    assert out[2] == pytest.approx(3.0, rel=0.05)
    for k in (0, 1, *range(3, 10)):
        assert abs(out[k]) < 0.05


def test_speed_mismatch_skips_a_channel_that_never_agrees() -> None:
    w1, y, spans = _sticky_record(1e-3, 0.0)
    y = 10.0 * y  # a wrong unit: disagrees in every phase
    out = speed_mismatch(y, local_slope(y, DT, 9), w1, spans)
    assert out == [0.0] * len(spans)


@pytest.mark.parametrize(
    ('half', 'fs', 'f_max', 'least', 'expected'),
    [
        (7, 20_000.0, 74.0, 2, 7),  # 20 kHz: a quarter period is 34 samples each side
        (7, 2_000.0, 94.0, 2, 2),  # 2 kHz: 0.25*2000/94/2 = 2.66 samples
        (14, 10_000.0, 108.0, 2, 11),  # 0.25*10000/108/2 = 11.6
        (7, 2_000.0, 400.0, 2, 2),  # never below ``least``
        (7, 2_000.0, 400.0, 1, 1),
    ],
)
def test_rig_half_spans_at_most_a_quarter_period(
    half: int, fs: float, f_max: float, least: int, expected: int
) -> None:
    assert rig_half(half, fs, f_max, least) == expected


def test_span_medians_are_numpys_medians() -> None:
    rng = np.random.default_rng(5)
    x = rng.normal(size=3000)
    x[1234] = np.nan
    starts = rng.integers(0, 2900, 400)
    stops = starts + rng.integers(-3, 90, 400)  # empty and reversed spans too
    got = span_medians(x, starts, stops)
    expected = [np.median(x[a:b]) if b > a else np.nan for a, b in zip(starts, stops, strict=True)]
    # the same values to the last bit (odd and even lengths; NaN where np.median gives NaN
    # and for an empty span)
    np.testing.assert_array_equal(got, expected)
    assert np.isnan(got).sum() >= 2


def test_grouped_medians_refuse_lengths_that_do_not_add_up() -> None:
    with pytest.raises(ValueError, match='do not add up'):
        grouped_medians([1.0, 2.0, 3.0], [1, 1])
