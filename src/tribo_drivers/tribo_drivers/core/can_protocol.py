"""CAN sensor-module frames, decoded with cantools from ``config/tribo.dbc``.

All frames are classic CAN, 11-bit IDs, signals little-endian (Intel byte order):

====== ================= ===== ===================================================== =========
ID     message           bytes layout (byte offsets)                                 rate
====== ================= ===== ===================================================== =========
0x101  Accelerometer     8     0-1 u16 seq; 2-3, 4-5, 6-7 i16 accel_0..2, 0.25 rad/s^2 3333.3/s
0x102  ShaftSpeed        6     0-1 u16 seq; 2-5 i32 speed, 1e-4 rad/s                1000/s
0x103  ForceTemperature  6     0-1 u16 seq; 2-3 u16 normal_force 0.5 N;             100/s
                               4-5 i16 oil_temperature 0.01 degC (published in K)
====== ================= ===== ===================================================== =========

The rates are the modules' nominal frame rates. The DBC states them per message with
the float attribute ``TriboFrameRate`` [frames/s] (``config/tribo.dbc`` does), or with the
usual ``GenMsgCycleTime`` [ms]; the table's values apply where the DBC states neither.
The driver derives its sample clocks, block sizes and gap estimates from these rates.

The accelerometer frame carries three consecutive samples (oldest first), so its sample rate
is 3 x 3333.3 = 10 kHz, the rate of w1' in the paper's rig model (Equ. 1-2).  ``seq`` counts
frames and wraps at 65536; :class:`tribo_drivers.core.gaps.IndexTracker` unwraps it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from tribo_drivers.errors import ConfigError, FrameError

ACCEL_ID = 0x101
SPEED_ID = 0x102
FORCE_TEMP_ID = 0x103
ZERO_CELSIUS = 273.15  # K


@dataclass(frozen=True)
class CanStreamSpec:
    """What one CAN frame type carries.

    channels: output channel -> (DBC signal names in sample order, SI unit, additive offset
    applied after DBC scaling, e.g. +273.15 for degC -> K); samples_per_frame: samples of
    each channel per frame; frame_rate: nominal frames per second [1/s].
    """

    frame_id: int
    message: str
    channels: Mapping[str, tuple[tuple[str, ...], str, float]]
    samples_per_frame: int
    frame_rate: float

    @property
    def sample_rate(self) -> float:
        """Samples per second of each channel [Hz]."""
        return self.frame_rate * self.samples_per_frame


DEFAULT_SPECS: dict[int, CanStreamSpec] = {
    ACCEL_ID: CanStreamSpec(
        ACCEL_ID,
        'Accelerometer',
        {'angular_acceleration': (('accel_0', 'accel_1', 'accel_2'), 'rad/s^2', 0.0)},
        3,
        10_000.0 / 3.0,
    ),
    SPEED_ID: CanStreamSpec(
        SPEED_ID, 'ShaftSpeed', {'speed': (('speed',), 'rad/s', 0.0)}, 1, 1000.0
    ),
    FORCE_TEMP_ID: CanStreamSpec(
        FORCE_TEMP_ID,
        'ForceTemperature',
        {
            'normal_force': (('normal_force',), 'N', 0.0),
            'oil_temperature': (('oil_temperature',), 'K', ZERO_CELSIUS),
        },
        1,
        100.0,
    ),
}


FRAME_RATE_ATTRIBUTE = 'TriboFrameRate'


def dbc_frame_rate(msg: object, spec: CanStreamSpec, path: Path) -> float:
    """Return the frame rate [1/s] of a DBC message (a cantools message).

    The rate is the message attribute ``TriboFrameRate``, else 1000/``GenMsgCycleTime``
    [ms], else the spec's nominal rate.

    Raises
    ------
    ConfigError
        An attribute is not a finite number >= 0.
    """
    attrs = getattr(getattr(msg, 'dbc', None), 'attributes', None) or {}
    where = f'DBC {path} frame 0x{spec.frame_id:03X} ({spec.message})'
    if FRAME_RATE_ATTRIBUTE in attrs:
        rate = attrs[FRAME_RATE_ATTRIBUTE].value
        if isinstance(rate, bool) or not isinstance(rate, int | float):
            raise ConfigError(f'{where}: {FRAME_RATE_ATTRIBUTE} must be a number, got {rate!r}')
        if not (math.isfinite(rate) and rate >= 0):
            raise ConfigError(f'{where}: {FRAME_RATE_ATTRIBUTE} must be > 0 frames/s, got {rate}')
        if rate > 0:  # 0 is the attribute's "not stated" default
            return float(rate)
    cycle = getattr(msg, 'cycle_time', None)
    if cycle:
        if cycle < 0:
            raise ConfigError(f'{where}: GenMsgCycleTime must be > 0 ms, got {cycle}')
        return 1000.0 / float(cycle)
    return spec.frame_rate


@dataclass(frozen=True)
class CanSample:
    """One decoded frame: frame_id, raw u16 seq, channel -> samples (SI, oldest first)."""

    frame_id: int
    seq: int
    values: Mapping[str, tuple[float, ...]]


class CanCodec:
    """Decodes (and, for emulators, encodes) the sensor frames using a DBC file."""

    def __init__(self, dbc: str | Path, specs: Mapping[int, CanStreamSpec] | None = None) -> None:
        import cantools

        path = Path(dbc)
        self.db: Any = None
        try:
            self.db = cantools.database.load_file(str(path))
        except FileNotFoundError as exc:
            raise ConfigError(f'DBC file not found: {path}') from exc
        except Exception as exc:  # cantools raises many parser exception types
            raise ConfigError(f'cannot parse DBC file {path}: {exc}') from exc
        if not hasattr(self.db, 'get_message_by_frame_id'):
            raise ConfigError(f'{path} is not a CAN database (DBC/KCD/SYM)')
        self.specs = dict(specs or DEFAULT_SPECS)
        self._messages: dict[int, Any] = {}
        for fid, spec in self.specs.items():
            try:
                msg = self.db.get_message_by_frame_id(fid)
            except KeyError as exc:
                raise ConfigError(f'DBC {path} has no frame 0x{fid:03X} ({spec.message})') from exc
            self.specs[fid] = spec = replace(spec, frame_rate=dbc_frame_rate(msg, spec, path))
            names = {s.name for s in msg.signals}
            needed = {'seq'} | {sig for sigs, _, _ in spec.channels.values() for sig in sigs}
            missing = needed - names
            if missing:
                raise ConfigError(f'DBC {path} frame 0x{fid:03X} lacks signals {sorted(missing)}')
            self._messages[fid] = msg

    def decode(self, frame_id: int, data: bytes | bytearray) -> CanSample | None:
        """Decode one frame (None for IDs not in the specs); SI units."""
        msg = self._messages.get(frame_id)
        if msg is None:
            return None
        if len(data) != msg.length:
            raise FrameError(
                f'CAN frame 0x{frame_id:03X} has {len(data)} bytes, DBC says {msg.length}'
            )
        try:
            sig = msg.decode(bytes(data), decode_choices=False)
        except Exception as exc:  # cantools DecodeError
            raise FrameError(f'cannot decode CAN frame 0x{frame_id:03X}: {exc}') from exc
        spec = self.specs[frame_id]
        values = {
            ch: tuple(float(sig[s]) + offset for s in sigs)
            for ch, (sigs, _, offset) in spec.channels.items()
        }
        return CanSample(frame_id, int(sig['seq']), values)

    def encode(self, frame_id: int, seq: int, values: Mapping[str, tuple[float, ...]]) -> bytes:
        """Encode one frame from SI values (emulators, tests)."""
        spec = self.specs[frame_id]
        signals: dict[str, float] = {'seq': seq % 65536}
        for ch, (sigs, _, offset) in spec.channels.items():
            vals = values[ch]
            if len(vals) != len(sigs):
                raise FrameError(f'{ch} needs {len(sigs)} samples per frame, got {len(vals)}')
            for s, v in zip(sigs, vals, strict=True):
                signals[s] = float(v) - offset
        try:
            return bytes(self._messages[frame_id].encode(signals, scaling=True, strict=True))
        except Exception as exc:  # cantools EncodeError: out of range
            raise FrameError(f'cannot encode CAN frame 0x{frame_id:03X}: {exc}') from exc
