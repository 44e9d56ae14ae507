"""CAN sensor frames (core/can_protocol.py): golden frames, bad frames, DBC frame rates."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from tribo_drivers.core.can_protocol import ACCEL_ID, FORCE_TEMP_ID, SPEED_ID, CanCodec
from tribo_drivers.errors import ConfigError, FrameError


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


def test_bad_frames_and_dbc(codec: CanCodec, dbc: Path, tmp_path: Path) -> None:
    with pytest.raises(FrameError, match='0x102 has 3 bytes'):
        codec.decode(SPEED_ID, b'\x00\x01\x02')
    with pytest.raises(ConfigError, match='not found'):
        CanCodec(tmp_path / 'missing.dbc')
    bad = tmp_path / 'bad.dbc'
    bad.write_text(dbc.read_text().replace('BO_ 259 ForceTemperature', 'BO_ 260 ForceTemperature'))
    with pytest.raises(ConfigError, match='0x103'):
        CanCodec(bad)


def test_frame_rates_come_from_the_dbc(dbc: Path, dbc_with: Callable[[str], Path]) -> None:
    shipped = CanCodec(dbc)
    assert shipped.specs[ACCEL_ID].sample_rate == pytest.approx(10_000.0, rel=1e-12)
    # TriboFrameRate [frames/s] wins; GenMsgCycleTime [ms] is the fallback; else nominal
    path = dbc_with(
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
    bad = dbc_with(
        'BA_DEF_ BO_ "TriboFrameRate" FLOAT -10 1000000;\nBA_ "TriboFrameRate" BO_ 258 -5;',
    )
    with pytest.raises(ConfigError, match=r'0x102 \(ShaftSpeed\): TriboFrameRate must be > 0'):
        CanCodec(bad)
