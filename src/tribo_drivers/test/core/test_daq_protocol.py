"""DAQ frame protocol: CRC, golden frame, resynchronisation, vectorised == scalar."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_drivers.core.daq_protocol import (
    FRAME_SIZE,
    DaqDecoder,
    DaqScaling,
    crc16_ccitt_false,
    crc16_rows,
    decode_buffer,
    decode_scalar,
    encode_frames,
)
from tribo_drivers.errors import ConfigError


def crc_bitwise(data: bytes) -> int:
    """Independent bit-by-bit CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection)."""
    crc = 0xFFFF
    for byte in data:
        for bit in range(7, -1, -1):
            fb = ((crc >> 15) & 1) ^ ((byte >> bit) & 1)
            crc = (crc << 1) & 0xFFFF
            if fb:
                crc ^= 0x1021
    return crc


UNIT = DaqScaling(offset=(0.0, 0.0, 0.0), gain=(1.0, 1.0, 1.0))


def test_crc_check_value() -> None:
    # The catalogue check value of CRC-16/CCITT-FALSE for ASCII "123456789".
    assert crc16_ccitt_false(b'123456789') == 0x29B1
    assert crc_bitwise(b'123456789') == 0x29B1


def test_crc_rows_equals_scalar() -> None:
    rng = np.random.default_rng(3)
    rows = rng.integers(0, 256, (200, 16), dtype=np.uint8)
    vec = crc16_rows(rows)
    assert [int(v) for v in vec] == [crc_bitwise(r.tobytes()) for r in rows]


def golden_frame() -> bytes:
    body = bytes(
        [
            0x78, 0x56, 0x34, 0x12,  # u32 sample_index = 0x12345678 (little-endian)
            0xE8, 0x03, 0x00, 0x00,  # i32 torque_raw = 1000
            0xFE, 0xFF, 0xFF, 0xFF,  # i32 accel_raw = -2
            0x04, 0x03, 0x02, 0x01,  # i32 speed_raw = 0x01020304 = 16909060
        ]
    )  # fmt: skip
    crc = crc_bitwise(body)
    return b'\xa5\x5a' + body + bytes([crc & 0xFF, crc >> 8])  # sync | body | u16 crc (LE)


def test_golden_frame_encode_and_decode() -> None:
    frame = golden_frame()
    assert len(frame) == FRAME_SIZE
    assert encode_frames([0x12345678], [1000], [-2], [0x01020304]) == frame
    scaling = DaqScaling(offset=(200.0, 10.0, 16909000.0), gain=(0.5, 0.25, 1e-3))
    samples, consumed = decode_buffer(frame, scaling)
    assert consumed == FRAME_SIZE
    assert samples.sample_index.tolist() == [0x12345678]
    # (raw - offset) * gain computed by hand; exact in binary floating point
    assert samples.torsion_moment.tolist() == [(1000 - 200) * 0.5]
    assert samples.angular_acceleration.tolist() == [(-2 - 10) * 0.25]
    assert samples.speed[0] == pytest.approx(60 * 1e-3, rel=1e-12)  # rounding of 1e-3 only
    assert samples.crc_errors == 0


def frames(n: int, start: int = 0) -> bytes:
    idx = np.arange(start, start + n)
    return encode_frames(idx, idx * 3, -idx, idx % 7)


def test_resync_after_garbage_and_lost_byte() -> None:
    good = bytearray(frames(10))
    del good[4 * FRAME_SIZE + 7]  # frame 4 loses a byte
    cut = 5 * FRAME_SIZE + FRAME_SIZE - 1  # end of frame 5 (frame 4 is one byte short)
    buf = b'\x00\xa5\x5a\x13' + bytes(good[:cut]) + b'\xa5\x5a\xa5garbage' + bytes(good[cut:])
    samples, _ = decode_buffer(buf, UNIT)
    assert samples.sample_index.tolist() == [0, 1, 2, 3, 5, 6, 7, 8, 9]
    assert samples.torsion_moment.tolist() == [0.0, 3.0, 6.0, 9.0, 15.0, 18.0, 21.0, 24.0, 27.0]


@pytest.mark.parametrize('lost', [FRAME_SIZE - 1, FRAME_SIZE])
def test_frames_sharing_one_byte_are_both_decoded(lost: int) -> None:
    # Frame k ends with CRC high byte 0xA5, the first byte of frame k + 1.  Whichever copy of
    # that byte the line loses, both frames pass the CRC on the shared byte; both are real.
    idx = np.arange(200_000)
    raw = np.frombuffer(encode_frames(idx, idx * 3, -idx, idx % 7), dtype=np.uint8)
    k = int(np.flatnonzero(raw.reshape(-1, FRAME_SIZE)[:, FRAME_SIZE - 1] == 0xA5)[0])
    buf = bytearray(frames(6, start=k - 2))
    del buf[2 * FRAME_SIZE + lost]  # frame k's last byte, or frame k + 1's first
    want = list(range(k - 2, k + 4))
    samples, _ = decode_buffer(bytes(buf), UNIT)
    assert samples.sample_index.tolist() == want
    assert samples.torsion_moment.tolist() == [3.0 * i for i in want]
    assert [r[1] for r in decode_scalar(bytes(buf), UNIT)] == want
    dec = DaqDecoder(UNIT)  # byte by byte: each frame waits for the bytes that may overlap it
    got = [i for b in bytes(buf) for i in dec.feed(bytes([b])).sample_index.tolist()]
    got += dec.flush().sample_index.tolist()
    assert got == want
    assert dec.stats.discarded_bytes == 0


def test_overlapping_frame_without_the_next_index_is_dropped() -> None:
    # The same shared byte, but the overlapping frame is not the next sample: only the earlier
    # frame is taken (a valid frame inside an accepted one is taken only as its successor).
    idx = np.arange(200_000)
    raw = np.frombuffer(encode_frames(idx, idx * 3, -idx, idx % 7), dtype=np.uint8)
    k = int(np.flatnonzero(raw.reshape(-1, FRAME_SIZE)[:, FRAME_SIZE - 1] == 0xA5)[0])
    buf = frames(1, start=k) + frames(1, start=k + 500)[1:] + frames(2, start=k + 501)
    samples, _ = decode_buffer(buf, UNIT)
    assert samples.sample_index.tolist() == [k, k + 501, k + 502]
    assert [r[1] for r in decode_scalar(buf, UNIT)] == [k, k + 501, k + 502]


def test_crc_errors_counted_once_per_corrupted_frame() -> None:
    buf = bytearray(frames(50))
    for k in (3, 17, 30, 31, 49):
        buf[k * FRAME_SIZE + 9] ^= 0x40  # payload bit flip: sync intact, CRC wrong
    samples, _ = decode_buffer(bytes(buf), UNIT)
    assert len(samples) == 45
    assert samples.crc_errors == 5


def corrupted_stream(seed: int, n: int = 3000) -> bytes:
    rng = np.random.default_rng(seed)
    out = bytearray()
    raw = frames(n)
    for k in range(n):
        f = bytearray(raw[k * FRAME_SIZE : (k + 1) * FRAME_SIZE])
        u = rng.random()
        if u < 0.05:
            f[int(rng.integers(0, FRAME_SIZE))] ^= int(rng.integers(1, 256))
        elif u < 0.08:
            del f[int(rng.integers(0, FRAME_SIZE))]
        elif u < 0.1:
            g = bytearray(rng.integers(0, 256, int(rng.integers(1, 40)), dtype=np.uint8))
            g[0:2] = b'\xa5\x5a'
            out += g
        out += f
    return bytes(out)


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_vectorised_equals_scalar(seed: int) -> None:
    buf = corrupted_stream(seed)
    scaling = DaqScaling(offset=(1.0, 2.0, 3.0), gain=(0.1, 0.2, 0.3))
    samples, _ = decode_buffer(buf, scaling)
    ref = decode_scalar(buf, scaling)
    assert samples.sample_index.tolist() == [r[1] for r in ref]
    np.testing.assert_array_equal(samples.torsion_moment, [r[2] for r in ref])
    np.testing.assert_array_equal(samples.angular_acceleration, [r[3] for r in ref])
    np.testing.assert_array_equal(samples.speed, [r[4] for r in ref])
    assert len(ref) > 2500  # most frames survive 10 % damage


def test_streaming_chunks_equal_whole_buffer() -> None:
    buf = corrupted_stream(5)
    whole, _ = decode_buffer(buf, UNIT)
    dec = DaqDecoder(UNIT)
    rng = np.random.default_rng(9)
    got: list[int] = []
    pos = 0
    while pos < len(buf):
        step = int(rng.integers(1, 97))  # chunk boundaries anywhere, also inside sync words
        got += dec.feed(buf[pos : pos + step]).sample_index.tolist()
        pos += step
    got += dec.flush().sample_index.tolist()
    assert got == whole.sample_index.tolist()
    assert dec.stats.crc_errors == whole.crc_errors
    assert dec.pending_bytes < FRAME_SIZE


def test_scaling_rejects_bad_values() -> None:
    with pytest.raises(ConfigError, match='gain'):
        DaqScaling(gain=(1.0, 0.0, 1.0))
    with pytest.raises(ConfigError, match='finite'):
        DaqScaling(offset=(float('nan'), 0.0, 0.0))
