"""Sample indices and blocks (core/gaps.py): wraps, gaps, duplicates, restarts, no bridging."""

from __future__ import annotations

import numpy as np

from tribo_drivers.core.gaps import BlockBatcher, IndexTracker


def test_unwrap_u32_across_wrap_with_gaps() -> None:
    t = IndexTracker(bits=32)
    raw = np.array([2**32 - 3, 2**32 - 2, 2**32 - 1, 0, 1, 5, 6], dtype=np.uint32)
    r = t.update(raw)
    assert r.index.tolist() == [2**32 - 3, 2**32 - 2, 2**32 - 1, 2**32, 2**32 + 1, 2**32 + 5,
                                2**32 + 6]  # fmt: skip
    assert r.gap_lost.tolist() == [0, 0, 0, 0, 0, 3, 0]
    assert (t.counters.gaps, t.counters.lost) == (1, 3)
    # continues across calls: 9 follows 6 after two lost samples
    r2 = t.update(np.array([9, 10], dtype=np.uint32))
    assert r2.index.tolist() == [2**32 + 9, 2**32 + 10]
    assert (t.counters.gaps, t.counters.lost) == (2, 5)


def test_duplicates_dropped_and_restart_needs_confirmation() -> None:
    t = IndexTracker(bits=32, confirm_jump=1000)
    t.update([100, 101])
    r = t.update([101, 102, 7_000_000, 103, 104])  # duplicate, then a lone corrupt outlier
    assert r.index.tolist() == [102, 103, 104]
    assert r.keep.tolist() == [False, True, False, True, True]
    assert (t.counters.duplicates, t.counters.outliers, t.counters.lost) == (1, 1, 0)
    r = t.update([3, 4, 5])  # confirmed backward jump: device restart, new epoch
    assert r.index.tolist() == [3, 4, 5]
    assert r.restart.tolist() == [True, False, False]
    assert t.counters.restarts == 1


def test_restart_confirmed_across_calls() -> None:
    t = IndexTracker(bits=32, confirm_jump=1000)
    t.update([500])
    assert t.update([0]).index.size == 0  # held back: unconfirmed
    r = t.update([1])  # its successor confirms the restart
    assert r.index.tolist() == [1] and r.restart.tolist() == [True]


def test_u16_wrap_resolved_by_elapsed_time() -> None:
    t = IndexTracker(bits=16, step=3, confirm_jump=(1 << 15) - 1)
    t.update([65000])
    # 70000 frames later the counter reads (65000 + 70000) % 65536 = 3464; without the
    # elapsed time this would look like a gap of 4000 frames
    r = t.update([(65000 + 70000) % 65536], expected_advance=70000.2)
    assert r.index.tolist() == [(65000 + 70000) * 3]
    assert t.counters.lost == (70000 - 1) * 3
    r = t.update([(65000 + 70001) % 65536])
    assert r.index.tolist() == [(65000 + 70001) * 3]


def stamp(i: int) -> float:
    return i / 1000.0


def test_batcher_never_bridges_gaps() -> None:
    b = BlockBatcher({'x': 'N'}, 1000.0, 4)
    idx = np.array([0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 20], dtype=np.int64)
    blocks = b.push(idx, {'x': idx * 1.0}, stamp)
    got = [(blk.first_index, blk.data.tolist()) for blk in blocks]
    assert got == [(0, [0, 1, 2, 3]), (4, [4, 5]), (9, [9, 10, 11, 12]), (13, [13])]
    assert b.pending == 1  # index 20 waits for more
    more = b.push(np.array([21, 22, 23]), {'x': [21.0, 22.0, 23.0]}, stamp)
    assert [(k.first_index, k.data.tolist()) for k in more] == [(20, [20, 21, 22, 23])]
    assert more[0].stamp == 0.020
    tail = b.push(np.array([24]), {'x': [24.0]}, stamp) + b.flush(stamp)
    assert [(k.first_index, k.data.tolist()) for k in tail] == [(24, [24])]
