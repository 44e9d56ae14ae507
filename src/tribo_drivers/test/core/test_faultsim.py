"""The DAQ fault test (short version; bench/bench_daq.py runs the full 60 s one)."""

from __future__ import annotations

from tribo_drivers.core.faultsim import run_daq_fault_scenario


def test_daq_fault_scenario_over_pty() -> None:
    # 4 s at 10 kHz over a pty: 1 % corrupted frames, 0.2 % frames with a lost byte,
    # 10 garbage bursts, one unplug/replug; the u32 index wraps during the run.
    r = run_daq_fault_scenario(
        duration=4.0, corrupt_fraction=0.01, drop_fraction=0.002, garbage_bursts=10, unplugs=1
    )
    report = '\n'.join(r.lines())
    assert r.sent_intact > 20_000, report  # the emulator really streamed
    assert r.sent_uncertain < 0.15 * r.sent_intact, report  # few frames near an open
    assert r.sent_damaged > 100, report  # and really damaged frames
    assert r.unplugs == 1 and r.reconnects == 1 and r.disconnects == 1, report
    assert r.intact_missing == 0, report  # every intact frame published ...
    assert r.delivered == r.delivered_unique, report  # ... exactly once
    assert r.invented == 0 and r.value_errors == 0, report  # nothing invented or altered
    # every published frame was sent intact, or damaged on a byte its twin frame restores
    assert r.delivered_unique <= r.sent_intact + r.sent_uncertain + r.recovered, report
    assert r.delivered + r.lost_counted == r.span, report  # every lost one in the counters
    assert r.crc_errors > 0 and r.gaps > 0, report
