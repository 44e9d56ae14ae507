"""Sample stamps (core/timing.py SampleClock): USB jitter removed, host clock steps followed."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_drivers.core.timing import SampleClock


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
