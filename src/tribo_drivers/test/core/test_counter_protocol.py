"""Radiation counter line protocol (core/counter_protocol.py)."""

from __future__ import annotations

import pytest

from tribo_drivers.core import counter_protocol as cp
from tribo_drivers.errors import ChecksumError, FrameError, ProtocolError


def test_checksum_known_nmea_sentence() -> None:
    # Widely published NMEA 0183 example: the XOR checksum of this GGA sentence is 0x47.
    line = '$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47'
    assert cp.parse_sentence(line)[0] == 'GPGGA'


def test_cnt_example_and_round_trip() -> None:
    body = 'CNT,1,1000,1000,523,998'
    xor = 0
    for ch in body:
        xor ^= ord(ch)
    assert cp.format_cnt(1, 1000, 1000, 523, 998) == f'${body}*{xor:02X}\r\n'.encode()
    rec = cp.parse_cnt(cp.format_cnt(7, 12_500, 500, 42, 499))
    assert rec == cp.CountRecord(7, 12.5, 0.5, 42, 0.499)
    assert rec.t_start == pytest.approx(12.0, abs=1e-12)


def test_bad_lines_raise_specific_errors() -> None:
    good = cp.format_cnt(1, 1000, 1000, 5, 990).decode().strip()
    with pytest.raises(ChecksumError):
        cp.parse_cnt(good[:-2] + ('00' if good[-2:] != '00' else '01'))
    with pytest.raises(FrameError, match='checksum'):
        cp.parse_cnt(good.split('*')[0])
    with pytest.raises(FrameError, match='live time'):
        cp.parse_cnt(cp.format_cnt(1, 1000, 1000, 5, 1001))
    with pytest.raises(ProtocolError):
        cp.parse_ack_dwell(cp.format_sentence('ACK,OTHER,5'))
    assert cp.parse_dwell(cp.format_dwell(250)) == 250
    assert cp.parse_ack_dwell(cp.format_ack_dwell(250)) == 250


def test_line_splitter_resyncs_after_garbage() -> None:
    sp = cp.LineSplitter(max_line=64)
    lines = sp.feed(b'x' * 500 + b'\r\n' + cp.format_cnt(1, 1, 1, 1, 1)[:10])
    lines += sp.feed(cp.format_cnt(1, 1, 1, 1, 1)[10:])
    assert sp.overflows >= 1
    assert cp.parse_cnt(lines[-1]).seq == 1
