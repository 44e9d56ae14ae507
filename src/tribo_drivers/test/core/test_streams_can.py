"""The CAN stream (core/streams.py CanStream): python-can virtual bus, slcan on a pty, DBC rates."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import can
import numpy as np
import pytest

from tribo_drivers.core.can_protocol import ACCEL_ID, FORCE_TEMP_ID, SPEED_ID, CanCodec
from tribo_drivers.core.emulators import CanEmulator, SlcanPtyDevice, default_can_signal
from tribo_drivers.core.gaps import SampleBlock
from tribo_drivers.core.streams import CanStream
from tribo_drivers.core.transports import CanTransport


def run_stream(stream: CanStream, emu: CanEmulator, duration: float) -> list[SampleBlock]:
    blocks: list[SampleBlock] = []
    emu.start()
    end = time.monotonic() + duration
    while time.monotonic() < end:
        blocks += stream.poll(0.02)
    emu.stop()
    for _ in range(20):
        blocks += stream.poll(0.02)
    blocks += stream.close()
    return blocks


def check_blocks(blocks: list[SampleBlock], emu: CanEmulator) -> None:
    by = {ch: [b for b in blocks if b.channel == ch] for ch in
          ('angular_acceleration', 'speed', 'normal_force', 'oil_temperature')}  # fmt: skip
    for ch, fid, per in (('angular_acceleration', ACCEL_ID, 3), ('speed', SPEED_ID, 1),
                         ('normal_force', FORCE_TEMP_ID, 1)):  # fmt: skip
        idx = np.concatenate([np.arange(b.first_index, b.next_index) for b in by[ch]])
        data = np.concatenate([b.data for b in by[ch]])
        sent = np.array(emu.sent[fid])
        frames = np.unique(idx // per)
        assert np.array_equal(frames, sent[: frames.size])  # exactly what was sent, in order
        want = np.concatenate([np.asarray(default_can_signal(fid, int(q))[ch]) for q in frames])
        np.testing.assert_allclose(data, want, rtol=1e-12, atol=1e-9)  # DBC scale rounding
        assert np.unique(idx).size == idx.size
    temps = np.concatenate([b.data for b in by['oil_temperature']])
    assert np.all((temps > 273.15 + 39.9) & (temps < 273.15 + 41.0))  # kelvin, not degC
    specs = emu.codec.specs  # the rates the DBC states (shipped: 1 kHz and 10 kHz)
    assert by['speed'][0].sample_rate == specs[SPEED_ID].sample_rate
    assert by['angular_acceleration'][0].sample_rate == pytest.approx(
        specs[ACCEL_ID].sample_rate, rel=1e-12
    )


def test_virtual_bus_with_lost_frames(codec: CanCodec) -> None:
    channel = f'tribo_test_{time.monotonic_ns()}'
    tx = can.Bus(interface='virtual', channel=channel)
    stream = CanStream(CanTransport('virtual', channel), codec)
    stream.poll(0.01)  # opens the bus before the emulator starts sending
    emu = CanEmulator(
        codec,
        lambda fid, data: tx.send(can.Message(arbitration_id=fid, data=data, is_extended_id=False)),
        start_seq=65_000,  # crosses the u16 wrap
        skip={(SPEED_ID, 65_000 + k) for k in (100, 101, 300)},
    )
    try:
        blocks = run_stream(stream, emu, 1.0)
    finally:
        tx.shutdown()
    assert stream.counters.lost == 3  # three skipped speed frames, nothing else
    assert stream.counters.gaps == 2
    check_blocks(blocks, emu)
    speed = [b for b in blocks if b.channel == 'speed']
    assert speed[-1].next_index > 65_536  # unwrapped past the u16 wrap


def test_slcan_on_pty(codec: CanCodec) -> None:
    dev = SlcanPtyDevice()
    dev.start()
    rates = {ACCEL_ID: 300.0, SPEED_ID: 200.0, FORCE_TEMP_ID: 50.0}
    emu = CanEmulator(codec, dev.send, rates=rates)
    stream = CanStream(CanTransport('slcan', dev.path, 500_000, sleep_after_open=0.0), codec)
    try:
        for _ in range(50):
            stream.poll(0.01)
            if dev.is_open:
                break
        assert dev.is_open and dev.bitrate_code == 'S6'  # python-can opened at 500 kbit/s
        blocks = run_stream(stream, emu, 1.0)
    finally:
        dev.close()
    assert stream.counters.lost == 0
    check_blocks(blocks, emu)


def test_stream_follows_the_dbc_rates(dbc_with: Callable[[str], Path]) -> None:
    """A module at half the nominal rate (stated in the DBC): the stream's sample clock and
    gap estimate follow it: 1 s of frames gives 250 speed samples and no false loss."""
    path = dbc_with(
        'BA_DEF_ BO_ "TriboFrameRate" FLOAT 0 1000000;\n'
        'BA_ "TriboFrameRate" BO_ 257 500;\n'
        'BA_ "TriboFrameRate" BO_ 258 250;\n'
        'BA_ "TriboFrameRate" BO_ 259 50;',
    )
    codec = CanCodec(path)
    channel = f'tribo_rates_{time.monotonic_ns()}'
    tx = can.Bus(interface='virtual', channel=channel)
    stream = CanStream(CanTransport('virtual', channel), codec)
    stream.poll(0.01)
    emu = CanEmulator(
        codec,
        lambda fid, data: tx.send(can.Message(arbitration_id=fid, data=data, is_extended_id=False)),
    )
    assert emu.rates == {ACCEL_ID: 500.0, SPEED_ID: 250.0, FORCE_TEMP_ID: 50.0}
    try:
        blocks = run_stream(stream, emu, 1.0)
    finally:
        tx.shutdown()
    assert stream.counters.lost == 0
    check_blocks(blocks, emu)
    speed = [b for b in blocks if b.channel == 'speed']
    assert speed[0].sample_rate == 250.0
    assert abs(sum(len(b.data) for b in speed) - 250) <= 30  # 1 s of wall time
