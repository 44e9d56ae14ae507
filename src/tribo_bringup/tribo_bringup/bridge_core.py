"""Pure-Python core of the live bridge (no rclpy): down-sampling, stick flags, JSON schemas.

The rig streams run at 10 kHz; a live view needs a few hundred points per
second. :class:`Downsampler` cuts a SampleBlock stream into bins of
``factor`` samples aligned on the absolute sample index (so the bins do not
depend on how the driver blocks the stream) and gives per bin the mean,
minimum, maximum, first sample and least-squares slope. A gap in the first
indices closes the open bin early (it reports how many samples it holds), so
no point ever mixes samples from both sides of a gap.

:class:`StickDetector` flags stick phases from the bins: the slope of the
torsion moment ``C1*phi1`` [N m] is ``C1*w1``, so ``w1 = slope/C1``; the discs
stick when the chamber moves with the shaft, ``w1 = w2`` (physics notes,
section 1, Equ. 6 condition ``v = w2 - w1 = 0``).

Messages are plain dicts ready for JSON; non-finite numbers become ``null``
(JSON has no NaN).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from tribo_bringup.errors import ConfigError
from tribo_common import topics

if TYPE_CHECKING:
    from tribo_common.msgconv import StampedMessage

NS_PER_S = 1_000_000_000

#: Down-sampling modes: ``minmax`` (value = bin mean, with min/max envelope) or
#: ``decimate`` (value = first sample of the bin; min/max still reported).
MODES = ('minmax', 'decimate')


@dataclass(frozen=True)
class BinPoint:
    """One down-sampled point of a SampleBlock stream.

    Attributes
    ----------
    index
        index of the first sample of the bin [samples since stream start].
    stamp_ns
        time of the first sample of the bin [ns].
    n
        samples in the bin (less than the factor only next to a gap or a restart).
    mean, minimum, maximum, first
        bin statistics in the stream's unit.
    slope
        least-squares slope over the bin [unit/s] (NaN for a 1-sample bin).
    """

    index: int
    stamp_ns: int
    n: int
    mean: float
    minimum: float
    maximum: float
    first: float
    slope: float


def _slope(values: npt.NDArray[np.float64], fs: float) -> float:
    n = values.size
    if n < 2:
        return math.nan
    x = np.arange(n, dtype=np.float64) - 0.5 * (n - 1)
    return float(np.dot(x, values - values.mean()) / np.dot(x, x) * fs)


@dataclass
class Downsampler:
    """Bins of ``factor`` samples aligned on ``index % factor == 0``.

    Parameters
    ----------
    rate
        target output rate [Hz]; the factor is ``max(1, round(fs/rate))``
        with ``fs`` the stream's sample rate (known from the first block).
    """

    rate: float
    factor: int = 0
    fs: float = 0.0
    _buf: npt.NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    _buf_index: int = 0
    _buf_stamp_ns: int = 0
    _next_index: int | None = None

    def __post_init__(self) -> None:
        """Refuse a down-sampling rate [Hz] that is not > 0 and finite."""
        if not (math.isfinite(self.rate) and self.rate > 0):
            raise ConfigError(f'down-sampling rate must be > 0 Hz, got {self.rate}')

    def reset(self) -> None:
        """Forget the open bin (e.g. while no client is listening)."""
        self._buf = np.empty(0)
        self._next_index = None

    def push(
        self, first_index: int, stamp_ns: int, sample_rate: float, data: npt.ArrayLike
    ) -> list[BinPoint]:
        """Add one block; returns the bins it completes (in index order).

        Parameters
        ----------
        first_index
            index of the block's first sample [samples].
        stamp_ns
            time of the block's first sample [ns].
        sample_rate
            sample rate [Hz] (> 0).
        data
            the samples.
        """
        if not (math.isfinite(sample_rate) and sample_rate > 0):
            raise ConfigError(f'sample_rate must be > 0 Hz, got {sample_rate}')
        values = np.asarray(data, dtype=np.float64)
        out: list[BinPoint] = []
        if sample_rate != self.fs:
            out += self._flush()
            self.fs = float(sample_rate)
            self.factor = max(1, round(self.fs / self.rate))
        elif self._next_index is not None and first_index != self._next_index:
            out += self._flush()  # gap or restart: close the open bin
        if self._buf.size == 0:
            self._buf = values.copy()
            self._buf_index = int(first_index)
            self._buf_stamp_ns = int(stamp_ns)
        else:
            self._buf = np.concatenate((self._buf, values))
        self._next_index = int(first_index) + values.size
        out += self._complete_bins()
        return out

    def _point(self, start: int, stop: int) -> BinPoint:
        seg = self._buf[start:stop]
        stamp = self._buf_stamp_ns + round(start * NS_PER_S / self.fs)
        return BinPoint(
            index=self._buf_index + start,
            stamp_ns=stamp,
            n=int(seg.size),
            mean=float(seg.mean()),
            minimum=float(seg.min()),
            maximum=float(seg.max()),
            first=float(seg[0]),
            slope=_slope(seg, self.fs),
        )

    def _complete_bins(self) -> list[BinPoint]:
        f = self.factor
        pos = 0
        end = self._buf.size
        out: list[BinPoint] = []
        while True:
            # next boundary after the bin that starts at buffer position pos
            absolute = self._buf_index + pos
            stop = pos + (f - absolute % f)
            if stop > end:
                break
            out.append(self._point(pos, stop))
            pos = stop
        if pos:
            self._buf_stamp_ns += round(pos * NS_PER_S / self.fs)
            self._buf_index += pos
            self._buf = self._buf[pos:]
        return out

    def _flush(self) -> list[BinPoint]:
        if self._buf.size == 0:
            return []
        point = self._point(0, self._buf.size)
        self._buf = np.empty(0)
        return [point]


@dataclass(frozen=True)
class StickPoint:
    """Stick/slip state of one bin.

    Attributes
    ----------
    index
        first sample index of the bin [samples].
    stamp_ns
        time of the bin's first sample [ns].
    w1
        chamber speed from the torsion slope, slope/C1 [rad/s].
    w2
        mean shaft speed in the bin [rad/s].
    stick
        True when ``|w1 - w2| <= tolerance``.
    """

    index: int
    stamp_ns: int
    w1: float
    w2: float
    stick: bool


@dataclass
class StickDetector:
    """Join torsion-moment bins and shaft-speed bins by index and flag sticking.

    Parameters
    ----------
    C1
        torsion element stiffness [N m/rad] (> 0).
    tolerance
        largest |w1 - w2| counted as sticking [rad/s] (>= 0).
    keep
        bins kept waiting for their partner stream before being dropped.
    """

    C1: float
    tolerance: float
    keep: int = 400
    _torsion: dict[int, BinPoint] = field(default_factory=dict)
    _speed: dict[int, BinPoint] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Refuse C1 [N m/rad] <= 0 or a negative stick tolerance [rad/s]."""
        if not (math.isfinite(self.C1) and self.C1 > 0):
            raise ConfigError(f'C1 must be > 0 N m/rad, got {self.C1}')
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0):
            raise ConfigError(f'stick tolerance must be >= 0 rad/s, got {self.tolerance}')

    def add_torsion(self, points: Iterable[BinPoint]) -> list[StickPoint]:
        """Add torsion-moment bins [N m]; returns the bins now known on both streams."""
        return self._add(points, self._torsion, self._speed, torsion_first=True)

    def add_speed(self, points: Iterable[BinPoint]) -> list[StickPoint]:
        """Add shaft-speed bins [rad/s]; returns the bins now known on both streams."""
        return self._add(points, self._speed, self._torsion, torsion_first=False)

    def _add(
        self,
        points: Iterable[BinPoint],
        mine: dict[int, BinPoint],
        other: dict[int, BinPoint],
        *,
        torsion_first: bool,
    ) -> list[StickPoint]:
        out: list[StickPoint] = []
        for p in points:
            q = other.pop(p.index, None)
            if q is None:
                mine[p.index] = p
                continue
            tor, spd = (p, q) if torsion_first else (q, p)
            if tor.n != spd.n:
                continue  # bins cut differently by a gap: not comparable
            w1 = tor.slope / self.C1
            w2 = spd.mean
            stick = math.isfinite(w1) and abs(w1 - w2) <= self.tolerance
            out.append(StickPoint(tor.index, tor.stamp_ns, w1, w2, stick))
        for store in (mine, other):
            if len(store) > self.keep:
                for k in sorted(store)[: len(store) - self.keep]:
                    del store[k]
        return out


# --- JSON -------------------------------------------------------------------


def finite_or_none(x: float) -> float | None:
    """``x`` as float, or None (JSON null) when NaN or infinite."""
    v = float(x)
    return v if math.isfinite(v) else None


def bin_message(p: BinPoint, unit: str, mode: str) -> dict[str, object]:
    """JSON message of one down-sampled point (see :data:`SAMPLES_SCHEMA`)."""
    value = p.first if mode == 'decimate' else p.mean
    return {
        't': p.stamp_ns / NS_PER_S,
        'index': p.index,
        'n': p.n,
        'value': finite_or_none(value),
        'min': finite_or_none(p.minimum),
        'max': finite_or_none(p.maximum),
        'unit': unit,
    }


def stick_message(p: StickPoint) -> dict[str, object]:
    """JSON message of one stick flag (see :data:`STICK_SCHEMA`)."""
    return {
        't': p.stamp_ns / NS_PER_S,
        'index': p.index,
        'w1': finite_or_none(p.w1),
        'w2': finite_or_none(p.w2),
        'slip_speed': finite_or_none(p.w2 - p.w1),
        'stick': 1 if p.stick else 0,
    }


def _num(desc: str) -> dict[str, object]:
    return {'type': ['number', 'null'], 'description': desc}


SAMPLES_SCHEMA: dict[str, Any] = {
    'title': 'tribo.DownsampledSamples',
    'type': 'object',
    'description': 'One bin of a 10 kHz SampleBlock stream (min/max envelope and mean).',
    'properties': {
        't': {'type': 'number', 'description': 'time of the first sample of the bin [s]'},
        'index': {'type': 'integer', 'description': 'index of the first sample of the bin'},
        'n': {'type': 'integer', 'description': 'samples in the bin'},
        'value': _num('bin mean (minmax mode) or first sample (decimate mode) [unit]'),
        'min': _num('smallest sample in the bin [unit]'),
        'max': _num('largest sample in the bin [unit]'),
        'unit': {'type': 'string', 'description': 'SI unit of value/min/max'},
    },
}

STICK_SCHEMA: dict[str, Any] = {
    'title': 'tribo.StickPhase',
    'type': 'object',
    'description': 'Stick/slip flag per bin: stick when |w1 - w2| <= tolerance.',
    'properties': {
        't': {'type': 'number', 'description': 'time of the first sample of the bin [s]'},
        'index': {'type': 'integer', 'description': 'index of the first sample of the bin'},
        'w1': _num('chamber speed from the torsion-moment slope / C1 [rad/s]'),
        'w2': _num('mean shaft speed [rad/s]'),
        'slip_speed': _num('slip speed v = w2 - w1 [rad/s]'),
        'stick': {'type': 'integer', 'description': '1 while sticking, 0 while slipping'},
    },
}

#: FrictionEstimate fields: name -> (JSON type, description with unit).
FRICTION_FIELDS: dict[str, tuple[str, str]] = {
    't_start': ('number', 'block start [s]'),
    't_end': ('number', 'block end [s]'),
    'first_index': ('integer', 'index of the first sample of the block'),
    'mu0': ('number', 'static friction coefficient mu0 [-] (Equ. 8)'),
    'mu0_se': ('number', 'standard error of mu0 [-]'),
    'mu_inf': ('number', 'asymptotic friction coefficient mu_inf [-] (Equ. 8)'),
    'mu_inf_se': ('number', 'standard error of mu_inf [-]'),
    'k': ('number', 'Stribeck decay constant k [s/rad]'),
    'k_se': ('number', 'standard error of k [s/rad]'),
    'moment_min': ('number', 'torsion moment minimum over the block [N m]'),
    'moment_max': ('number', 'torsion moment maximum over the block [N m]'),
    'moment_mean': ('number', 'torsion moment mean over the block [N m]'),
    'motion': ('string', 'stick-slip, slip-slip or steady'),
    'n_sticks': ('integer', 'stick phases (>= 2 ms) in the block'),
    'stick_fraction': ('number', 'fraction of the block spent sticking [-]'),
    'rms_residual': ('number', 'RMS of the torsion-moment fit residual [N m]'),
    'quality': ('string', 'ok or ;-separated flags'),
}

#: WearState fields: name -> (JSON type, description with unit).
WEAR_FIELDS: dict[str, tuple[str, str]] = {
    't': ('number', 'test time at the end of the dwell [s]'),
    'tagged_volume': ('number', 'tagged wear volume V_I [m^3]'),
    'tagged_volume_se': ('number', 'standard error of V_I [m^3]'),
    'wear_volume': ('number', 'total wear volume V_W = V_I*k_A [m^3] (Equ. 9)'),
    'wear_volume_se': ('number', 'standard error of V_W [m^3]'),
    'wear_height': ('number', 'mean wear height h [m]'),
    'wear_height_se': ('number', 'standard error of h [m]'),
    'wear_rate': ('number', 'current wear rate dV_W/dt [m^3/s]'),
    'wear_rate_se': ('number', 'standard error of the wear rate [m^3/s]'),
    'running_in_volume': ('number', 'running-in volume [m^3]'),
    'running_in_volume_se': ('number', 'standard error of the running-in volume [m^3]'),
    'progressive_rate': ('number', 'progressive wear rate [m^3/s]'),
    'progressive_rate_se': ('number', 'standard error of the progressive rate [m^3/s]'),
    'oil_mixed': ('boolean', 'oil circuit mixed (early readings unreliable before)'),
    'quality': ('string', 'ok or ;-separated flags'),
}

#: DetectorCounts fields: name -> (JSON type, description with unit).
COUNTS_FIELDS: dict[str, tuple[str, str]] = {
    'seq': ('integer', 'dwell sequence number'),
    't_start': ('number', 'test time at the start of the dwell [s]'),
    't_end': ('number', 'test time at the end of the dwell [s]'),
    'counts': ('integer', 'registered counts'),
    'live_time': ('number', 'live time of the counter [s]'),
}

#: ModelDiscrepancy fields (the live model monitor): name -> (JSON type, description with unit).
DISCREPANCY_FIELDS: dict[str, tuple[str, str]] = {
    't_start': ('number', 'window start [s]'),
    't_end': ('number', 'window end [s]'),
    'n_samples': ('integer', 'samples in the window'),
    'mu0': ('number', 'baseline mu0 of the window [-] (Equ. 8)'),
    'mu_inf': ('number', 'baseline mu_inf of the window [-] (Equ. 8)'),
    'drive_speed': ('number', 'drive speed w0 used [rad/s]'),
    'residual_rms': ('number', 'torsion-moment residual rms of the baseline [N m]'),
    'residual_rms_accel': ('number', 'acceleration residual rms of the baseline [rad/s^2]'),
    'noise_floor': ('number', 'noise floor of the torsion-moment residual [N m]'),
    'ratio': ('number', 'residual rms / noise floor [-]'),
    'concentration': ('string', 'where the residual concentrates (stick, slip, ..., uniform)'),
    'concentration_share': ('number', 'share of the residual energy there [-]'),
    'candidate': ('string', 'named effect family, or the best partial explanation ("" = none)'),
    'candidate_rms': ('number', 'torsion-moment residual rms with the candidate [N m]'),
    'identifiable': ('boolean', 'whether the window names the candidate (verdict named)'),
    'identifiable_reason': ('string', 'the verdict in one line'),
    'processing_time': ('number', 'wall time spent on the window [s]'),
    'quality': ('string', 'ok or ;-separated flags'),
}

#: Uncertainty bands added to the JSON messages: name -> (value, se, description).
#: The band is value -/+ BAND_K standard errors.
BAND_K = 2.0
FRICTION_BANDS: dict[str, tuple[str, str]] = {
    'mu0': ('mu0', 'mu0_se'),
    'mu_inf': ('mu_inf', 'mu_inf_se'),
}
WEAR_BANDS: dict[str, tuple[str, str]] = {
    'wear_volume': ('wear_volume', 'wear_volume_se'),
    'wear_height': ('wear_height', 'wear_height_se'),
}


def _schema(
    title: str, fields: Mapping[str, tuple[str, str]], bands: Iterable[str]
) -> dict[str, object]:
    props: dict[str, Any] = {
        'stamp': {'type': 'number', 'description': 'header stamp [s]'},
    }
    for name, (kind, desc) in fields.items():
        props[name] = {'type': [kind, 'null'] if kind == 'number' else kind, 'description': desc}
    for name in bands:
        props[f'{name}_lo'] = _num(f'{name} - {BAND_K:g} standard errors')
        props[f'{name}_hi'] = _num(f'{name} + {BAND_K:g} standard errors')
    return {'title': title, 'type': 'object', 'properties': props}


FRICTION_SCHEMA = _schema('tribo_msgs/FrictionEstimate', FRICTION_FIELDS, FRICTION_BANDS)
WEAR_SCHEMA = _schema('tribo_msgs/WearState', WEAR_FIELDS, WEAR_BANDS)
COUNTS_SCHEMA = _schema('tribo_msgs/DetectorCounts', COUNTS_FIELDS, ())
DISCREPANCY_SCHEMA = _schema('tribo_msgs/ModelDiscrepancy', DISCREPANCY_FIELDS, ())


def stamp_ns_of(msg: StampedMessage) -> int:
    """Return the header stamp [ns] of a message (rclpy or rosbags)."""
    stamp = msg.header.stamp
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def record_message(
    msg: StampedMessage,
    fields: Mapping[str, tuple[str, str]],
    bands: Mapping[str, tuple[str, str]],
) -> dict[str, object]:
    """Convert a FrictionEstimate / WearState / DetectorCounts / ModelDiscrepancy to a JSON dict.

    Works for rclpy and rosbags message objects (attribute access only).
    Adds ``<name>_lo``/``<name>_hi`` = value -/+ BAND_K * se for the bands.
    """
    out: dict[str, Any] = {'stamp': stamp_ns_of(msg) / NS_PER_S}
    for name, (kind, _desc) in fields.items():
        v = getattr(msg, name)
        if kind == 'number':
            out[name] = finite_or_none(v)
        elif kind == 'integer':
            out[name] = int(v)
        elif kind == 'boolean':
            out[name] = bool(v)
        else:
            out[name] = str(v)
    for name, (value, se) in bands.items():
        v, s = float(getattr(msg, value)), float(getattr(msg, se))
        out[f'{name}_lo'] = finite_or_none(v - BAND_K * s)
        out[f'{name}_hi'] = finite_or_none(v + BAND_K * s)
    return out


#: SampleBlock topics served down-sampled (schema :data:`SAMPLES_SCHEMA`), as Foxglove
#: channel names: the root-namespace names of :data:`tribo_common.topics.SAMPLE_STREAMS`
#: (a bridge in a namespace serves its rig's topics under these channel names).
SAMPLE_TOPICS = tuple(t.resolve() for t in topics.SAMPLE_STREAMS)
#: Derived channel of stick flags (schema :data:`STICK_SCHEMA`).
STICK_TOPIC = '/live/stick'


@dataclass(frozen=True)
class RecordTopic:
    """A full-rate topic: message type name, fields, uncertainty bands, JSON schema."""

    type_name: str
    fields: Mapping[str, tuple[str, str]]
    bands: Mapping[str, tuple[str, str]]
    schema: Mapping[str, Any]


RECORD_TOPICS: dict[str, RecordTopic] = {
    topics.FRICTION_ESTIMATE.resolve(): RecordTopic(
        'FrictionEstimate', FRICTION_FIELDS, FRICTION_BANDS, FRICTION_SCHEMA
    ),
    topics.NVCT_WEAR.resolve(): RecordTopic('WearState', WEAR_FIELDS, WEAR_BANDS, WEAR_SCHEMA),
    topics.NVCT_COUNTS.resolve(): RecordTopic('DetectorCounts', COUNTS_FIELDS, {}, COUNTS_SCHEMA),
    topics.MODEL_DISCREPANCY.resolve(): RecordTopic(
        'ModelDiscrepancy', DISCREPANCY_FIELDS, {}, DISCREPANCY_SCHEMA
    ),
}


def channel_schemas() -> dict[str, Mapping[str, object]]:
    """Every channel the bridge serves with its JSON schema."""
    out: dict[str, Mapping[str, Any]] = {t: SAMPLES_SCHEMA for t in SAMPLE_TOPICS}
    out[STICK_TOPIC] = STICK_SCHEMA
    out.update({t: r.schema for t, r in RECORD_TOPICS.items()})
    return out
