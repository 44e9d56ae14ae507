"""ChannelAligner: any interleaving gives one aligned stream; gaps and restarts are explicit."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.align import (
    CHANNELS,
    AlignedChunk,
    AlignEvent,
    ChannelAligner,
    GapEvent,
    RestartEvent,
)
from tribo_estimation.errors import EstimationError

FS = 10_000.0


def _signals(n: int) -> dict[str, np.ndarray]:
    # distinct, index-coded values so misalignment by one sample is visible
    idx = np.arange(n, dtype=float)
    return {'torsion_moment': idx, 'angular_acceleration': -idx, 'speed': idx + 0.5}


def _blocks(
    sig: dict[str, np.ndarray], sizes: dict[str, int], start: int = 0, t0: float = 100.0
) -> list[tuple[str, int, float, np.ndarray]]:
    out = []
    for name in CHANNELS:
        data = sig[name]
        step = sizes[name]
        for i in range(0, data.shape[0], step):
            out.append((name, start + i, t0 + (start + i) / FS, data[i : i + step]))
    return out


def _collect(aligner: ChannelAligner, blocks: list, flush: bool = True) -> list[AlignEvent]:
    events: list[AlignEvent] = []
    for name, first, stamp, data in blocks:
        events.extend(aligner.push(name, first, FS, stamp, data))
    if flush:
        events.extend(aligner.flush())
    return events


def _concat(events: list[AlignEvent]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    chunks = [e for e in events if isinstance(e, AlignedChunk)]
    idx = np.concatenate([np.arange(c.first_index, c.end_index) for c in chunks])
    return (
        idx,
        np.concatenate([c.torsion for c in chunks]),
        np.concatenate([c.accel for c in chunks]),
        np.concatenate([c.speed for c in chunks]),
    )


def test_random_interleaving_gives_exact_alignment() -> None:
    n = 5000
    sig = _signals(n)
    blocks = _blocks(sig, {'torsion_moment': 37, 'angular_acceleration': 100, 'speed': 251})
    rng = np.random.default_rng(1)
    # shuffle between channels but keep each channel's own order (as a transport does)
    per = {c: [b for b in blocks if b[0] == c] for c in CHANNELS}
    order = []
    while any(per.values()):
        c = rng.choice([k for k, v in per.items() if v])
        order.append(per[c].pop(0))
    events = _collect(ChannelAligner(), order)
    assert not [e for e in events if not isinstance(e, AlignedChunk)]
    idx, tq, ac, sp = _concat(events)
    np.testing.assert_array_equal(idx, np.arange(n))  # every sample once, in order
    np.testing.assert_array_equal(tq, idx)
    np.testing.assert_array_equal(ac, -idx)
    np.testing.assert_array_equal(sp, idx + 0.5)
    first = next(e for e in events if isinstance(e, AlignedChunk))
    assert first.t0 == pytest.approx(100.0, abs=1e-12)


def test_chunk_time_follows_stamp() -> None:
    sig = _signals(1000)
    events = _collect(ChannelAligner(), _blocks(sig, dict.fromkeys(CHANNELS, 100), t0=5.0))
    for e in events:
        assert isinstance(e, AlignedChunk)
        # stamp of index i is 5 + i/fs (exact up to float rounding)
        assert e.t0 == pytest.approx(5.0 + e.first_index / FS, abs=1e-9)


def test_gap_in_one_channel_is_reported_not_bridged() -> None:
    n = 3000
    sig = _signals(n)
    blocks = _blocks(sig, dict.fromkeys(CHANNELS, 100))
    # accel loses samples 1000..1299 (three blocks)
    blocks = [b for b in blocks if not (b[0] == 'angular_acceleration' and 1000 <= b[1] < 1300)]
    events = _collect(ChannelAligner(), blocks)
    gaps = [e for e in events if isinstance(e, GapEvent)]
    assert len(gaps) == 1
    assert (gaps[0].start_index, gaps[0].end_index) == (1000, 1300)
    assert gaps[0].channels == ('angular_acceleration',)
    idx, tq, ac, _ = _concat(events)
    expected = np.r_[np.arange(1000), np.arange(1300, n)]
    np.testing.assert_array_equal(idx, expected)
    np.testing.assert_array_equal(tq, expected)
    np.testing.assert_array_equal(ac, -expected)
    # the gap event comes between the chunks around it
    kinds = [type(e).__name__ for e in events]
    gi = kinds.index('GapEvent')
    before = [e for e in events[:gi] if isinstance(e, AlignedChunk)]
    assert before[-1].end_index == 1000


def test_overlapping_gaps_merge_into_consecutive_events() -> None:
    n = 4000
    sig = _signals(n)
    blocks = _blocks(sig, dict.fromkeys(CHANNELS, 100))
    blocks = [
        b
        for b in blocks
        if not (b[0] == 'angular_acceleration' and 1000 <= b[1] < 1500)
        and not (b[0] == 'speed' and 1200 <= b[1] < 1800)
    ]
    events = _collect(ChannelAligner(), blocks)
    gaps = [e for e in events if isinstance(e, GapEvent)]
    covered = set()
    for g in gaps:
        covered.update(range(g.start_index, g.end_index))
    assert covered == set(range(1000, 1800))
    idx, *_ = _concat(events)
    assert not set(idx.tolist()) & covered


def test_silent_channel_becomes_a_gap_with_bounded_buffer() -> None:
    n = 20_000
    sig = _signals(n)
    blocks = _blocks(sig, dict.fromkeys(CHANNELS, 100))
    # speed goes silent after 2000 samples and never comes back
    blocks = [b for b in blocks if not (b[0] == 'speed' and b[1] >= 2000)]
    blocks.sort(key=lambda b: b[1])  # channels interleaved in time, as from a live rig
    aligner = ChannelAligner(max_skew=5000)
    events = _collect(aligner, blocks, flush=False)
    gaps = [e for e in events if isinstance(e, GapEvent)]
    assert gaps and gaps[0].start_index == 2000 and gaps[0].channels == ('speed',)
    buffered = sum(b.data.shape[0] for c in aligner._ch.values() for b in c.blocks)
    # never more than max_skew samples per channel held back
    assert buffered <= 3 * 5000


def test_restart_emits_event_and_realigns() -> None:
    sig = _signals(2000)
    first = _blocks(sig, dict.fromkeys(CHANNELS, 100))
    second = _blocks(sig, dict.fromkeys(CHANNELS, 100), t0=500.0)
    # channels restart at different moments: torsion restarts while the others
    # still send their old stream's tail
    old_tail = [b for b in first if b[1] >= 1500]
    old_head = [b for b in first if b[1] < 1500]
    order = old_head + [b for b in old_tail if b[0] == 'torsion_moment']
    order += [b for b in second if b[0] == 'torsion_moment']
    order += [b for b in old_tail if b[0] != 'torsion_moment']
    order += [b for b in second if b[0] != 'torsion_moment']
    aligner = ChannelAligner()
    events = _collect(aligner, order)
    restarts = [e for e in events if isinstance(e, RestartEvent)]
    assert len(restarts) == 1 and restarts[0].channel == 'torsion_moment'
    ri = events.index(restarts[0])
    after = [e for e in events[ri:] if isinstance(e, AlignedChunk)]
    idx, tq, ac, _ = _concat(after)
    np.testing.assert_array_equal(idx, np.arange(2000))
    np.testing.assert_array_equal(ac, -tq)  # channels of the same epoch, same index
    assert after[0].t0 == pytest.approx(500.0)
    assert aligner.dropped_samples > 0


@pytest.mark.parametrize(
    ('kwargs', 'word'),
    [
        ({'channel': 'nope'}, 'unknown channel'),
        ({'sample_rate': 0.0}, 'sample_rate'),
        ({'stamp': float('nan')}, 'stamp'),
        ({'first_index': -1}, 'negative'),
    ],
)
def test_bad_blocks_raise_named_errors(kwargs: dict, word: str) -> None:
    args = {'channel': 'speed', 'first_index': 0, 'sample_rate': FS, 'stamp': 0.0}
    args.update(kwargs)
    with pytest.raises(EstimationError, match=word):
        ChannelAligner().push(
            args['channel'], args['first_index'], args['sample_rate'], args['stamp'], np.zeros(3)
        )


def test_mismatched_rates_raise() -> None:
    a = ChannelAligner()
    a.push('speed', 0, FS, 0.0, np.zeros(3))
    with pytest.raises(EstimationError, match='sample_rate'):
        a.push('torsion_moment', 0, 1000.0, 0.0, np.zeros(3))
