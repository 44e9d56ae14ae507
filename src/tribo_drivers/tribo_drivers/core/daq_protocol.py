"""Binary frame protocol of the serial DAQ (torsion moment, acceleration, speed).

Wire format (little-endian, 20 bytes per frame, streamed at the sample rate, 10 kHz nominal)::

    offset size type  field
    0      2    u8[2] sync         0xA5 0x5A
    2      4    u32   sample_index device sample counter (wraps at 2**32)
    6      4    i32   torque_raw   torsion moment C1*phi1, ADC counts
    10     4    i32   accel_raw    angular acceleration w1', ADC counts
    14     4    i32   speed_raw    shaft speed w2, ADC counts
    18     2    u16   crc          CRC-16/CCITT-FALSE over bytes 2..17

CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR
(check value of the ASCII string ``123456789`` is 0x29B1).

Physical value of channel c: ``(raw_c - offset_c) * gain_c`` with offset in counts and gain in
SI unit per count (N m, rad/s^2, rad/s per count).  The three channels are the measured
quantities of the paper's rig model (torsion moment C1*phi1 and w1' of Equ. 1-2, shaft speed w2
of Equ. 3-4, numbering per ``docs/physics.md``).

The decoder is vectorised with numpy (several million frames per second): it finds every
``A5 5A`` sync candidate in the buffer, checks all CRCs at once and keeps non-overlapping valid
frames, earliest first, which is exactly what a byte-by-byte scanner (:func:`decode_scalar`)
accepts.  Two valid frames may share one byte: when a frame's last byte equals the next
frame's first sync byte (0xA5) and one of the two copies is lost on the line, both frames
still pass the CRC.  A valid frame that overlaps an accepted one is therefore also accepted
when its sample index is the next one (a false frame would have to pass the CRC and carry
exactly that index).  Garbage, corrupted frames and lost bytes therefore cost only the damaged
frames; every intact frame is recovered.  A streaming decoder holds a frame back until every
frame that could overlap it is complete (``2 * FRAME_SIZE - 1`` bytes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from tribo_drivers.errors import ConfigError, FrameError

SYNC = b'\xa5\x5a'
FRAME_SIZE = 20
CRC_START = 2
CRC_END = 18
INDEX_MODULUS = 1 << 32
CHANNELS = ('torsion_moment', 'angular_acceleration', 'speed')
UNITS = {'torsion_moment': 'N m', 'angular_acceleration': 'rad/s^2', 'speed': 'rad/s'}

FRAME_DTYPE = np.dtype(
    [
        ('sync', 'u1', (2,)),
        ('sample_index', '<u4'),
        ('torque_raw', '<i4'),
        ('accel_raw', '<i4'),
        ('speed_raw', '<i4'),
        ('crc', '<u2'),
    ]
)
assert FRAME_DTYPE.itemsize == FRAME_SIZE

_POLY = 0x1021


def _make_byte_table() -> npt.NDArray[np.uint16]:
    table = np.zeros(256, dtype=np.uint16)
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ _POLY) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
        table[byte] = crc
    return table


_TABLE8 = _make_byte_table()
_TABLE8_LIST = [int(v) for v in _TABLE8]


def _make_word_table() -> npt.NDArray[np.uint16]:
    # Register r after 16 more message bits w (big-endian word) is T16[r ^ w]: for a
    # non-reflected CRC whose width equals the chunk width, the update only depends on r ^ w.
    v = np.arange(65536, dtype=np.uint32)
    r = v
    for _ in range(2):
        r = ((r << 8) & 0xFFFF) ^ _TABLE8[(r >> 8) & 0xFF].astype(np.uint32)
    return r.astype(np.uint16)


_TABLE16 = _make_word_table()


def crc16_ccitt_false(data: bytes | bytearray | memoryview, init: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (poly 0x1021, init 0xFFFF, no reflection, no xorout)."""
    crc = init
    table = _TABLE8_LIST
    for byte in bytes(data):
        crc = ((crc << 8) & 0xFFFF) ^ table[(crc >> 8) ^ byte]
    return crc


def crc16_rows(payload: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint16]:
    """CRC-16/CCITT-FALSE of every row of a (n, 2k) uint8 array, vectorised over rows."""
    if payload.ndim != 2 or payload.shape[1] % 2:
        raise FrameError(
            f'crc16_rows needs a 2-D array with an even row length, got {payload.shape}'
        )
    words = np.ascontiguousarray(payload).view('>u2')
    crc = np.full(payload.shape[0], 0xFFFF, dtype=np.uint16)
    for j in range(words.shape[1]):
        crc = _TABLE16[crc ^ words[:, j]]
    return crc


@dataclass(frozen=True)
class DaqScaling:
    """Per-channel scaling: value = (raw - offset) * gain.

    offset: counts for (torsion_moment, angular_acceleration, speed).
    gain: N m/count, rad/s^2/count, rad/s/count.
    """

    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gain: tuple[float, float, float] = (1e-6, 1e-3, 1e-4)

    def __post_init__(self) -> None:
        """Refuse anything but three offsets and three non-zero finite gains."""
        if len(self.offset) != 3 or len(self.gain) != 3:
            raise ConfigError(
                f'DAQ scaling needs 3 offsets and 3 gains, got {len(self.offset)} and '
                f'{len(self.gain)}'
            )
        for name, values in (('offset', self.offset), ('gain', self.gain)):
            if not all(np.isfinite(v) for v in values):
                raise ConfigError(f'DAQ scaling {name} must be finite, got {values}')
        if any(g == 0.0 for g in self.gain):
            raise ConfigError(f'DAQ scaling gain must be non-zero, got {self.gain}')


@dataclass(frozen=True)
class DaqSamples:
    """Frames decoded from one buffer, in stream order.

    sample_index: raw u32 device counter; values in SI (N m, rad/s^2, rad/s).
    crc_errors: sync candidates with a wrong CRC outside any accepted frame.
    discarded_bytes: bytes that were not part of an accepted frame.
    """

    sample_index: npt.NDArray[np.uint32]
    torsion_moment: npt.NDArray[np.float64]
    angular_acceleration: npt.NDArray[np.float64]
    speed: npt.NDArray[np.float64]
    crc_errors: int = 0
    discarded_bytes: int = 0

    def __len__(self) -> int:
        """Return the number of decoded frames."""
        return int(self.sample_index.size)


def encode_frames(
    sample_index: npt.ArrayLike,
    torque_raw: npt.ArrayLike,
    accel_raw: npt.ArrayLike,
    speed_raw: npt.ArrayLike,
) -> bytes:
    """Encode frames (vectorised) for emulators and tests; indices are taken modulo 2**32."""
    idx = np.asarray(sample_index, dtype=np.int64) % INDEX_MODULUS
    n = idx.size
    arr = np.zeros(n, dtype=FRAME_DTYPE)
    arr['sync'] = tuple(SYNC)
    arr['sample_index'] = idx.astype(np.uint32)
    for name, values in (
        ('torque_raw', torque_raw),
        ('accel_raw', accel_raw),
        ('speed_raw', speed_raw),
    ):
        v = np.broadcast_to(np.asarray(values, dtype=np.int64), (n,))
        if np.any((v < -(2**31)) | (v > 2**31 - 1)):
            raise FrameError(f'{name} out of the i32 range')
        arr[name] = v.astype(np.int32)
    raw = arr.view(np.uint8).reshape(n, FRAME_SIZE)
    arr['crc'] = crc16_rows(raw[:, CRC_START:CRC_END])
    return arr.tobytes()


def _scale(
    frames: npt.NDArray[np.void], scaling: DaqScaling
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    out = []
    for c, name in enumerate(('torque_raw', 'accel_raw', 'speed_raw')):
        out.append((frames[name].astype(np.float64) - scaling.offset[c]) * scaling.gain[c])
    return out[0], out[1], out[2]


def _select_frames(
    valid: npt.NDArray[np.int64], index: npt.NDArray[np.uint32]
) -> npt.NDArray[np.int64]:
    """Return the accepted subset of sorted valid frame starts (see the module docstring).

    index: the sample index of every valid frame.  Non-overlapping frames are kept earliest
    first; a frame overlapping the last kept one is kept too if its index is the next one.
    """
    if valid.size < 2 or np.all(np.diff(valid) >= FRAME_SIZE):
        return valid
    keep: list[int] = []
    pos = valid.tolist()
    idx = index.tolist()
    end = -1
    last = -1
    for i, p in enumerate(pos):  # rare path: a valid-looking frame overlaps another one
        if p >= end or (last >= 0 and idx[i] == (idx[last] + 1) % INDEX_MODULUS):
            keep.append(p)
            end = p + FRAME_SIZE
            last = i
    return np.asarray(keep, dtype=np.int64)


def scan_buffer(
    buf: npt.NDArray[np.uint8], final: bool = True
) -> tuple[npt.NDArray[np.int64], int, int]:
    """Return the accepted frame starts in ``buf``, the CRC failures and the consumed length.

    final: decide every complete frame.  Otherwise a frame is decided only when every frame
    that could overlap it is complete (it starts at most ``n - 2 * FRAME_SIZE + 1``), and
    the bytes from the consumed length on are to be scanned again with what follows.  A CRC
    failure is a sync candidate below the consumed length whose CRC is wrong and that does
    not lie inside an accepted frame.
    """
    n = buf.size
    horizon = n - FRAME_SIZE + 1 if final else n - 2 * FRAME_SIZE + 2
    if n < FRAME_SIZE:
        return np.zeros(0, dtype=np.int64), 0, max(horizon, 0)
    head = buf[: n - FRAME_SIZE + 1]
    is_sync = (head == SYNC[0]) & (buf[1 : n - FRAME_SIZE + 2] == SYNC[1])
    cand = np.flatnonzero(is_sync).astype(np.int64)
    if cand.size == 0:
        return cand, 0, max(horizon, 0)
    windows = np.lib.stride_tricks.sliding_window_view(buf, FRAME_SIZE)
    frames = windows[cand]
    stored = frames[:, CRC_END].astype(np.uint16) | (frames[:, CRC_END + 1].astype(np.uint16) << 8)
    ok = crc16_rows(frames[:, CRC_START:CRC_END]) == stored
    index = np.ascontiguousarray(frames[ok, 2:6]).view('<u4').reshape(-1)
    selected = _select_frames(cand[ok], index)
    accepted = selected[selected < horizon]
    resume = 0
    if accepted.size:  # where scanning resumes: after the last frame, or at its overlapping twin
        resume = int(accepted[-1]) + FRAME_SIZE
        if selected.size > accepted.size:
            resume = min(resume, int(selected[accepted.size]))
    consumed = max(resume, horizon, 0)
    rejected = cand[~ok]
    rejected = rejected[rejected < consumed]
    if rejected.size and accepted.size:
        k = np.searchsorted(accepted, rejected, side='right') - 1
        inside = (k >= 0) & (rejected < accepted[np.maximum(k, 0)] + FRAME_SIZE)
        crc_errors = int(np.count_nonzero(~inside))
    else:
        crc_errors = int(rejected.size)
    return accepted, crc_errors, consumed


def decode_buffer(
    data: bytes | bytearray | memoryview | npt.NDArray[np.uint8],
    scaling: DaqScaling,
    final: bool = True,
) -> tuple[DaqSamples, int]:
    """Decode the frames of a buffer; returns the samples and the consumed length.

    final: decode every complete frame (the end of the stream); otherwise the last frames
    wait for the bytes that could still overlap them (see :func:`scan_buffer`).  Bytes from
    the consumed length on should be kept for the next call (see :class:`DaqDecoder`).
    """
    buf = np.frombuffer(data, dtype=np.uint8) if not isinstance(data, np.ndarray) else data
    pos, crc_errors, consumed = scan_buffer(buf, final)
    covered = 0
    if pos.size:  # bytes in accepted frames below the consumed length (twins share one)
        ends = np.minimum(pos + FRAME_SIZE, np.append(pos[1:], consumed))
        covered = int(np.sum(np.clip(np.minimum(ends, consumed) - pos, 0, None)))
    if pos.size:
        windows = np.lib.stride_tricks.sliding_window_view(buf, FRAME_SIZE)
        frames = np.ascontiguousarray(windows[pos]).view(FRAME_DTYPE).reshape(-1)
    else:
        frames = np.zeros(0, dtype=FRAME_DTYPE)
    t, a, s = _scale(frames, scaling)
    samples = DaqSamples(
        sample_index=frames['sample_index'].copy(),
        torsion_moment=t,
        angular_acceleration=a,
        speed=s,
        crc_errors=crc_errors,
        discarded_bytes=consumed - covered,
    )
    return samples, consumed


@dataclass
class DaqDecoderStats:
    """Cumulative decoder counters."""

    frames: int = 0
    crc_errors: int = 0
    discarded_bytes: int = 0


@dataclass
class DaqDecoder:
    """Streaming decoder: feed arbitrary byte chunks, get the frames completed so far."""

    scaling: DaqScaling = field(default_factory=DaqScaling)
    stats: DaqDecoderStats = field(default_factory=DaqDecoderStats)
    _tail: bytes = b''

    def feed(self, chunk: bytes | bytearray | memoryview) -> DaqSamples:
        """Decode ``chunk`` appended to the undecoded tail of earlier chunks.

        The last frame is held back until the bytes that could overlap it have arrived;
        :meth:`flush` decodes it when the line falls idle.
        """
        data = self._tail + bytes(chunk) if self._tail else bytes(chunk)
        return self._decode(data, final=False)

    def flush(self) -> DaqSamples:
        """Decode every complete frame still held (the line is idle or the stream ends)."""
        return self._decode(self._tail, final=True)

    def _decode(self, data: bytes, final: bool) -> DaqSamples:
        samples, consumed = decode_buffer(data, self.scaling, final)
        self._tail = data[consumed:]
        self.stats.frames += len(samples)
        self.stats.crc_errors += samples.crc_errors
        self.stats.discarded_bytes += samples.discarded_bytes
        return samples

    def reset(self) -> None:
        """Drop the partial frame kept from the last chunk (after a reconnect)."""
        self.stats.discarded_bytes += len(self._tail)
        self._tail = b''

    @property
    def pending_bytes(self) -> int:
        """Return the bytes [B] kept for the next feed (an incomplete frame)."""
        return len(self._tail)


def decode_scalar(data: bytes, scaling: DaqScaling) -> list[tuple[int, int, float, float, float]]:
    """Decode ``data`` byte by byte: (position, sample_index, torque, accel, speed) per frame.

    Slow; used to check the vectorised decoder.  At each position it accepts a frame if the
    sync bytes and the CRC match; it then moves to a valid frame with the next sample index
    starting inside the accepted one if there is one, and past the accepted frame otherwise.
    Elsewhere it advances by one byte.
    """
    import struct

    def valid(i: int) -> bool:
        if i + FRAME_SIZE > n or data[i] != SYNC[0] or data[i + 1] != SYNC[1]:
            return False
        (crc,) = struct.unpack_from('<H', data, i + CRC_END)
        return bool(crc16_ccitt_false(data[i + CRC_START : i + CRC_END]) == crc)

    out: list[tuple[int, int, float, float, float]] = []
    i = 0
    n = len(data)
    while i + FRAME_SIZE <= n:
        if not valid(i):
            i += 1
            continue
        idx, tq, ac, sp = struct.unpack_from('<Iiii', data, i + 2)
        out.append(
            (
                i,
                idx,
                (tq - scaling.offset[0]) * scaling.gain[0],
                (ac - scaling.offset[1]) * scaling.gain[1],
                (sp - scaling.offset[2]) * scaling.gain[2],
            )
        )
        twins = [
            j
            for j in range(i + 1, i + FRAME_SIZE)
            if valid(j) and struct.unpack_from('<I', data, j + 2)[0] == (idx + 1) % INDEX_MODULUS
        ]
        i = twins[0] if twins else i + FRAME_SIZE
    return out
