"""CAN sensor frames: DBC golden frames, python-can virtual bus, slcan on a pty."""

from __future__ import annotations

import time
from pathlib import Path

import can
import numpy as np
import pytest

from tribo_drivers.core.can_protocol import ACCEL_ID, FORCE_TEMP_ID, SPEED_ID, CanCodec
from tribo_drivers.core.emulators import CanEmulator, SlcanPtyDevice, default_can_signal
from tribo_drivers.core.gaps import SampleBlock
from tribo_drivers.core.streams import CanStream
from tribo_drivers.core.transports import CanTransport
from tribo_drivers.errors import ConfigError, FrameError

DBC = Path(__file__).resolve().parents[3] / 'config' / 'tribo.dbc'


@pytest.fixture(scope='module')
def codec() -> CanCodec:
    return CanCodec(DBC)


def test_golden_frames(codec: CanCodec) -> None:
    accel = bytes(
        [
            0x34, 0x12,  # u16 seq = 0x1234
            0x04, 0x00,  # i16 accel_0 = 4 -> 1.0 rad/s^2
            0xF8, 0xFF,  # i16 accel_1 = -8 -> -2.0 rad/s^2
            0x00, 0x80,  # i16 accel_2 = -32768 -> -8192.0 rad/s^2
        ]
    )  # fmt: skip
    s = codec.decode(ACCEL_ID, accel)
    assert s is not None and s.seq == 0x1234
    assert s.values['angular_acceleration'] == (1.0, -2.0, -8192.0)
    speed = bytes(
        [
            0xFF, 0xFF,  # u16 seq = 65535
            0x40, 0x42, 0x0F, 0x00,  # i32 speed = 1_000_000 -> 100 rad/s (1e-4 rad/s/bit)
        ]
    )  # fmt: skip
    s = codec.decode(SPEED_ID, speed)
    assert s is not None and s.seq == 65535
    assert s.values['speed'][0] == pytest.approx(100.0, rel=1e-12)  # float rounding of 1e-4
    load = bytes(
        [
            0x01, 0x00,  # u16 seq = 1
            0xC8, 0x00,  # u16 normal_force = 200 -> 100.0 N
            0x2E, 0xFB,  # i16 oil_temperature = -1234 -> -12.34 degC -> 260.81 K
        ]
    )  # fmt: skip
    s = codec.decode(FORCE_TEMP_ID, load)
    assert s is not None
    assert s.values['normal_force'] == (100.0,)
    assert s.values['oil_temperature'][0] == pytest.approx(273.15 - 12.34, abs=1e-9)
    assert codec.encode(FORCE_TEMP_ID, 1, s.values) == load
    assert codec.decode(0x7FF, b'') is None  # unknown IDs are ignored


def test_bad_frames_and_dbc(codec: CanCodec, tmp_path: Path) -> None:
    with pytest.raises(FrameError, match='0x102 has 3 bytes'):
        codec.decode(SPEED_ID, b'\x00\x01\x02')
    with pytest.raises(ConfigError, match='not found'):
        CanCodec(tmp_path / 'missing.dbc')
    bad = tmp_path / 'bad.dbc'
    bad.write_text(DBC.read_text().replace('BO_ 259 ForceTemperature', 'BO_ 260 ForceTemperature'))
    with pytest.raises(ConfigError, match='0x103'):
        CanCodec(bad)


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


def _dbc_with(tmp_path: Path, extra: str) -> Path:
    """config/tribo.dbc without its frame-rate attributes, plus ``extra`` lines."""
    lines = [ln for ln in DBC.read_text().splitlines() if 'TriboFrameRate' not in ln]
    path = tmp_path / 'rates.dbc'
    path.write_text('\n'.join(lines) + '\n' + extra + '\n')
    return path


def test_frame_rates_come_from_the_dbc(tmp_path: Path) -> None:
    shipped = CanCodec(DBC)
    assert shipped.specs[ACCEL_ID].sample_rate == pytest.approx(10_000.0, rel=1e-12)
    # TriboFrameRate [frames/s] wins; GenMsgCycleTime [ms] is the fallback; else nominal
    path = _dbc_with(
        tmp_path,
        'BA_DEF_ BO_ "TriboFrameRate" FLOAT 0 1000000;\n'
        'BA_DEF_ BO_ "GenMsgCycleTime" INT 0 65535;\n'
        'BA_DEF_DEF_ "TriboFrameRate" 0;\n'
        'BA_DEF_DEF_ "GenMsgCycleTime" 0;\n'
        'BA_ "TriboFrameRate" BO_ 257 1666.6666666666667;\n'
        'BA_ "GenMsgCycleTime" BO_ 258 4;',
    )
    codec = CanCodec(path)
    assert codec.specs[ACCEL_ID].sample_rate == pytest.approx(5000.0, rel=1e-12)
    assert codec.specs[SPEED_ID].frame_rate == 250.0
    assert codec.specs[FORCE_TEMP_ID].frame_rate == 100.0  # neither stated: nominal
    bad = _dbc_with(
        tmp_path,
        'BA_DEF_ BO_ "TriboFrameRate" FLOAT -10 1000000;\nBA_ "TriboFrameRate" BO_ 258 -5;',
    )
    with pytest.raises(ConfigError, match=r'0x102 \(ShaftSpeed\): TriboFrameRate must be > 0'):
        CanCodec(bad)


def test_stream_follows_the_dbc_rates(tmp_path: Path) -> None:
    """A module at half the nominal rate (stated in the DBC): the stream's sample clock and
    gap estimate follow it: 1 s of frames gives 250 speed samples and no false loss."""
    path = _dbc_with(
        tmp_path,
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
