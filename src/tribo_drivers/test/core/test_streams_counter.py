"""The counter stream (core/streams.py) over a pty: handshake, checksums, gaps, back-off."""

from __future__ import annotations

import time

import pytest

from tribo_drivers.core.emulators import CounterEmulator
from tribo_drivers.core.reconnect import Backoff
from tribo_drivers.core.streams import CounterStream, CountMessage
from tribo_drivers.core.transports import SerialTransport


def collect(stream: CounterStream, n: int, timeout: float) -> list[CountMessage]:
    out: list[CountMessage] = []
    end = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < end:
        out += stream.poll(0.02)
    return out


def test_counter_over_pty_handshake_checksums_and_gaps() -> None:
    # 50 ms dwells; every 4th line has a wrong checksum; the first DWELL is not answered.
    emu = CounterEmulator(1000, time_scale=1.0, bad_checksum_every=4, ignore_dwell_commands=1)
    emu.start()
    stream = CounterStream(SerialTransport(emu.path, 115200), dwell_ms=50, ack_timeout=0.3)
    try:
        got = collect(stream, 12, 10.0)
        got += stream.close()
    finally:
        emu.close()
    assert stream.acked_dwell_ms == 50
    assert emu.dwell_ms == 50
    assert sum(c.startswith(b'$DWELL,50*') for c in emu.commands) == 2  # one retry
    sent = {r.seq: r for r in emu.sent}
    assert len(got) >= 10
    for msg in got:  # every published dwell is exactly what was sent
        rec = sent[msg.seq]
        assert (msg.counts, msg.t_end, msg.live_time) == (rec.counts, rec.t_end, rec.live_time)
        assert msg.t_start == pytest.approx(rec.t_end - 0.05, abs=1e-9)
    seqs = [m.seq for m in got]
    bad_inside = [s for s in emu.bad if seqs[0] < s < seqs[-1]]
    assert stream.counters.crc_errors >= len(bad_inside) >= 2
    # each checksum-failed dwell is a lost dwell in the gap counter
    assert stream.counters.lost == seqs[-1] - seqs[0] + 1 - len(seqs)
    assert stream.counters.lost == len(bad_inside)


def test_counter_without_ack_backs_off() -> None:
    emu = CounterEmulator(1000, ignore_dwell_commands=1000)
    emu.start()
    stream = CounterStream(
        SerialTransport(emu.path, 115200),
        dwell_ms=100,
        ack_timeout=0.1,
        ack_retries=2,
        backoff=Backoff(0.2, 2.0, 1.0),
    )
    try:
        t_end = time.monotonic() + 1.2
        while time.monotonic() < t_end:
            stream.poll(0.02)
    finally:
        stream.close()
        emu.close()
    assert stream.counters.connected is False
    assert 'no $ACK,DWELL,100' in stream.counters.last_error
    # each attempt costs 0.2 s of handshake plus 0, .2, .4 s back-off: 2-4 attempts in 1.2 s
    assert 2 <= stream.open_attempts <= 4
