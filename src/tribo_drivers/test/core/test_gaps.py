"""Gap accounting, block batching, timestamp estimator, back-off schedule."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from tribo_drivers.core.daq_protocol import DaqScaling
from tribo_drivers.core.gaps import BlockBatcher, IndexTracker
from tribo_drivers.core.reconnect import Backoff
from tribo_drivers.core.streams import DaqStream
from tribo_drivers.core.timing import SampleClock
from tribo_drivers.errors import ConfigError, TransportError


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


def test_sample_clock_removes_usb_jitter() -> None:
    fs = 10_000.0
    rng = np.random.default_rng(11)
    true_offset = 1000.0
    drift = 30e-6  # device clock 30 ppm slow: true time = offset + n/fs * (1 + drift)
    clk = SampleClock(fs)
    errs = []
    n = 0
    for _ in range(4000):  # 4000 reads of ~50 samples = 20 s
        n += int(rng.integers(30, 70))
        t_true = true_offset + n / fs * (1 + drift)
        latency = 0.0005 + rng.exponential(0.002)  # USB: >= 0.5 ms, heavy tail, mean 2.5 ms
        clk.observe(t_true + latency, n)
        errs.append(clk.time_of(n) - t_true)
    e = np.array(errs[500:])
    raw_jitter = 0.002  # std of the latency
    # stamps lag by about the minimum latency (0.5 ms) and their jitter is far below USB's:
    assert abs(np.median(e) - 0.0005) < 0.0005  # tolerance: the constant minimum latency
    assert np.std(e) < raw_jitter / 5  # at least 5x less jitter than the raw receive times


def test_sample_clock_follows_host_clock_step() -> None:
    clk = SampleClock(1000.0, step_timeout=1.0)
    for k in range(100):
        clk.observe(10.0 + k * 0.01, k * 10)
    # host clock jumps 5 s ahead: the estimate re-anchors after step_timeout
    for k in range(100, 400):
        clk.observe(15.0 + k * 0.01, k * 10)
    assert clk.time_of(3990) == pytest.approx(15.0 + 3.99, abs=1e-3)


def test_backoff_schedule() -> None:
    b = Backoff(0.1, 2.0, 1.0)
    assert [b.delay(k) for k in range(7)] == [0.0, 0.1, 0.2, 0.4, 0.8, 1.0, 1.0]
    with pytest.raises(ConfigError):
        Backoff(0.0)
    with pytest.raises(ConfigError):
        Backoff(1.0, 2.0, 0.5)


class DeadTransport:
    """A port that never opens (device absent)."""

    is_open = False

    def __init__(self) -> None:
        self.attempts = 0

    def open(self) -> None:
        self.attempts += 1
        raise TransportError('no such device /dev/ttyUSB9')

    def close(self) -> None:
        pass

    def read(self, timeout: float) -> bytes:
        raise TransportError('not open')

    def write(self, data: bytes) -> None:
        raise TransportError('not open')

    def describe(self) -> str:
        return 'dead'


def test_reconnect_backs_off_without_busy_loop() -> None:
    tr = DeadTransport()
    s = DaqStream(tr, DaqScaling(), backoff=Backoff(0.05, 2.0, 0.2))
    t_end = time.monotonic() + 1.0
    while time.monotonic() < t_end:
        assert s.poll(0.01) == []  # never raises
    # delays 0, .05, .1, .2, .2, ... -> about 6-7 attempts in 1 s; a busy loop would do
    # thousands.  Bound generous for a loaded machine, still far from busy looping.
    assert 3 <= tr.attempts <= 9
    assert s.counters.connected is False
    assert 'ttyUSB9' in s.counters.last_error


def test_stop_interrupts_backoff_wait() -> None:
    s = DaqStream(DeadTransport(), DaqScaling(), backoff=Backoff(5.0, 2.0, 5.0))
    s.poll(0.01)  # first attempt fails, next wait would be 5 s
    threading.Timer(0.1, s.stop).start()
    t0 = time.monotonic()
    s.poll(0.01)
    assert time.monotonic() - t0 < 2.0  # interrupted long before the 5 s back-off
