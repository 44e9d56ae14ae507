"""Sliding segments of a record without stick-slip: where they go, what is left out."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.fitting.segments import (
    SLIP_MAX,
    SLIP_STRIDE,
    free_stretches,
    make_segments,
    sliding_segments,
    slip_peak_starts,
    slip_samples,
)
from tribo_estimation.core.model import RigParams
from tribo_estimation.core.record import RigRecord
from tribo_estimation.errors import TooShortError

FS = 2000.0


def _record(seconds: float) -> RigRecord:
    n = round(seconds * FS)
    t = np.arange(n) / FS
    return RigRecord(t, np.full(n, 10.0), np.zeros(n), np.full(n, 3.0))


@pytest.mark.parametrize(
    ('starts', 'stops', 'n', 'expected'),
    [
        ((), (), 100, [(0, 100)]),
        ((0,), (30,), 100, [(30, 100)]),  # at rest, then sliding
        ((90,), (100,), 100, [(0, 90)]),  # sliding into a stop at the end
        ((0, 70), (20, 80), 100, [(20, 70), (80, 100)]),
        ((0, 10), (50, 40), 100, [(50, 100)]),  # overlapping phases
        ((40,), (45,), 100, [(0, 40), (45, 100)]),  # a brief stick inside
    ],
)
def test_free_stretches(
    starts: tuple[int, ...], stops: tuple[int, ...], n: int, expected: list[tuple[int, int]]
) -> None:
    got = free_stretches(np.asarray(starts, np.int64), np.asarray(stops, np.int64), n)
    assert got == expected


def test_sliding_segments_fill_every_stretch_between_stick_phases() -> None:
    # sliding at one speed, a stick through a speed step at 2.0-2.1 s, sliding again
    rec = _record(4.0)
    a, b = round(2.0 * FS), round(2.1 * FS)
    seg = sliding_segments(rec, 0.25, stretches=[(0, a), (b, rec.time.size)])
    # no segment reaches into the stick phase, and both stretches hold segments
    assert not np.any((seg.start < b) & (seg.stop > a))
    assert np.count_nonzero(seg.stop <= a) >= 7 and np.count_nonzero(seg.start >= b) >= 7
    # the stick phase is listed as not fitted, at its start
    assert [r[0] for r in seg.rejected] == [pytest.approx(2.0)]


def test_sliding_segments_stop_before_a_stick_at_the_end() -> None:
    rec = _record(3.0)
    last = round(2.0 * FS)
    seg = sliding_segments(rec, 0.25, first=0, last=last)
    # every segment inside [0, 2 s), 0.25 s long, and the tail listed as not fitted
    assert int(seg.stop[-1]) == last
    assert np.all(np.diff(seg.start) == round(0.25 * FS))
    assert [r[0] for r in seg.rejected] == [pytest.approx(2.0)]


def test_too_short_names_the_longest_stretch_without_a_stick() -> None:
    rec = _record(3.0)
    with pytest.raises(TooShortError, match=r'longest stretch without a stick 0\.3 s'):
        sliding_segments(rec, 0.25, first=round(2.7 * FS))


@pytest.mark.parametrize(
    ('starts', 'stops', 'n', 'expected'),
    [
        ((), (), 30, list(range(2, 28, SLIP_STRIDE))),  # no stick phase: the whole record
        ((10, 20), (15, 25), 40, list(range(27, 38, SLIP_STRIDE))),  # short gaps left out
        ((0, 70), (20, 80), 80, list(range(22, 68, SLIP_STRIDE))),  # a long slip between
        ((5, 15), (10, 20), 30, []),  # stick-slip only
    ],
)
def test_slip_samples_are_the_long_stretches_without_a_stick(
    starts: tuple[int, ...], stops: tuple[int, ...], n: int, expected: list[int]
) -> None:
    # stretches of at least 11 samples, 2 samples kept off their ends
    phases = (np.asarray(starts, np.int64), np.asarray(stops, np.int64)) if starts else None
    assert slip_samples(n, phases, 11, 2).tolist() == expected


def test_slip_samples_are_at_most_slip_max() -> None:
    # a record of 10 x SLIP_MAX x SLIP_STRIDE samples without a stick: thinned evenly
    idx = slip_samples(10 * SLIP_MAX * SLIP_STRIDE, None, 10, 0)
    assert idx.size <= SLIP_MAX
    assert np.ptp(np.diff(idx)) == 0


@pytest.mark.parametrize('phase', [0.3, 2.0, 4.5])
def test_a_sliding_start_moves_to_its_swings_slip_speed_peak(phase: float) -> None:
    # the chamber swings at its mode (Tab. 1: 73.7 Hz), M_t = 20 + 15*sin(omega*t + p)
    # [N m] with 0.05 N m white noise: w1 = M_t'/C1 swings by 15*omega/C1 = 2.97 rad/s
    rig = RigParams(0.0109, 0.04034, 2338.6, 0.0315, 4.0, 5975.0, 8000.0, 0.08)
    fs = 10_000.0
    n = 4000
    t = np.arange(n) / fs
    omega = np.sqrt(rig.C1 / rig.I1)
    rng = np.random.default_rng(3)
    m = 20.0 + 15.0 * np.sin(omega * t + phase) + 0.05 * rng.standard_normal(n)
    starts = np.asarray([500, 1500, 2500], dtype=np.int64)
    # the shaft at 2.5 rad/s: the swing reaches it (a brief stick each cycle), and the
    # slip speed w2 - w1 peaks where cos(omega*t + p) = -1
    rec = RigRecord(t, m, np.zeros(n), np.full(n, 2.5))
    got = slip_peak_starts(rec, starts, rig, 1000)
    # within one sample of the peak that follows each start, one period at most later
    period = 2.0 * np.pi / omega * fs
    peak = (np.pi - phase) / omega * fs  # first sample where cos(omega t + p) = -1
    want = starts + np.mod(peak - starts, period)
    assert np.all(np.abs(got - want) <= 1.0)
    assert np.all((got >= starts) & (got < starts + period))
    # a reach shorter than the period bounds the move
    assert np.all(slip_peak_starts(rec, starts, rig, 20) < starts + 20)
    # the shaft at 3.5 rad/s: the swing never reaches it, the phase does not end, and
    # the starts stay
    fast = RigRecord(t, m, np.zeros(n), np.full(n, 3.5))
    assert np.array_equal(slip_peak_starts(fast, starts, rig, 1000), starts)


def test_a_long_stick_phase_gets_a_stuck_start_every_block() -> None:
    # stick phases of 20 ms every 50 ms, then a rest of 1.2 s (a stop), then more: the
    # rest holds starts 0.25 s apart (no segment from a stuck start runs on through
    # more than two blocks of it), each from that phase with its dwell so far
    n = round(3.0 * FS)
    t = np.arange(n) / FS
    rec = RigRecord(t, np.full(n, 10.0), np.zeros(n), np.zeros(n))
    short = [(round(x * FS), round((x + 0.02) * FS)) for x in np.arange(0.05, 1.0, 0.05)]
    rest = (round(1.0 * FS), round(2.2 * FS))
    after = [(round(x * FS), round((x + 0.02) * FS)) for x in np.arange(2.25, 2.9, 0.05)]
    phases = [*short, rest, *after]
    runs = (
        np.array([a for a, _ in phases], np.int64),
        np.array([b for _, b in phases], np.int64),
        np.array([a / FS for a, _ in phases]),
    )
    seg = make_segments(rec, RigParams.tab1(), block_time=0.25, runs=runs)
    inside = (seg.start >= rest[0]) & (seg.start < rest[1])
    starts = seg.start[inside] / FS
    assert starts.size == 4  # 1.003, 1.253, 1.503, 1.753 s
    assert np.allclose(np.diff(starts), 0.25)
    assert np.all(seg.run_start[inside] == rest[0]) and np.all(seg.run_stop[inside] == rest[1])
    # the dwell grows with the start (its clock from the phase's onset)
    dwell = seg.stick_time[inside]
    assert dwell[0] > 0.0 and np.allclose(dwell - dwell[0], starts - starts[0])
