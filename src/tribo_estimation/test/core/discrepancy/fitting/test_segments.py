"""Sliding segments of a record without stick-slip: where they go, what is left out."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.fitting.segments import (
    free_stretches,
    sliding_segments,
)
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
