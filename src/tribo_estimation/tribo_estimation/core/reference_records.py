"""Realistic rig records from the independent reference simulator (truth for benchmarks).

:func:`make_record` runs :func:`.reference.simulate_reference` (its own equations
of motion, not the fitting kernel) with a drive profile (:class:`.reference.SpeedProfile`:
start-up ramp, speed steps and ramps; drive ripple via the model extensions) and
applies an instrument model per channel (:class:`Channel`), in this order:

1. first-order sensor lag ``tau*y' = x - y`` (time constant ``lag`` [s]), discretised
   exactly for an input that is linear between samples (:func:`first_order_lag`);
2. gain error: ``y *= 1 + gain_error``;
3. offset (+ linear offset drift with record time);
4. white Gaussian noise (``noise`` std) and coloured noise: a stationary AR(1)
   process of std ``colored_noise`` and correlation time ``colored_tau`` [s];
5. spikes: ``spike_rate`` [1/s] single-sample outliers of +-``spike_amp``.

The torsion channel first carries the model's measurement-side extensions
(``torque_lag_tau``, ``torque_offset``, ``torque_offset_drift``, as
:func:`.simulate.simulate` applies them). A record may start mid-test
(``start_offset``: the test is simulated from its start and the first seconds
are dropped), carry epoch time stamps (``time_zero``) or a speed written in rpm
(``speed_in_rpm``; a unit mistake for the input checks).

Channels of the record as a rig CSV holds them: ``time`` [s], ``torsion_moment``
[N m], ``angular_acceleration`` [rad/s^2], ``speed`` (shaft, w2) [rad/s].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from tribo_estimation.core.model import Extensions, FrictionLaw, RigParams
from tribo_estimation.core.reference import (
    SpeedProfile,
    Unmodelled,
    simulate_reference,
    stick_intervals,
)
from tribo_estimation.core.rigio import write_rig_csv
from tribo_estimation.errors import InvalidParameterError

#: Noise per sample of config/rig.yaml at 10 kHz: torsion [N m], accel [rad/s^2], speed [rad/s].
RIG_NOISE: tuple[float, float, float] = (0.05, 2.0, 0.005)


def rpm(x: float) -> float:
    """Speed in rpm -> rad/s."""
    return x * math.pi / 30.0


@dataclass(frozen=True)
class Channel:
    """Instrument model of one channel (units of the channel: N m, rad/s^2 or rad/s).

    ``lag`` first-order time constant [s]; ``gain_error`` relative [-];
    ``offset`` [unit] and ``offset_drift`` [unit/s]; ``noise`` white std [unit];
    ``colored_noise`` std [unit] of an AR(1) process with correlation time
    ``colored_tau`` [s]; ``spike_rate`` [1/s] outliers of ``spike_amp`` [unit].
    """

    lag: float = 0.0
    gain_error: float = 0.0
    offset: float = 0.0
    offset_drift: float = 0.0
    noise: float = 0.0
    colored_noise: float = 0.0
    colored_tau: float = 0.01
    spike_rate: float = 0.0
    spike_amp: float = 0.0

    def __post_init__(self) -> None:
        """Refuse non-finite or negative settings."""
        for name in ('lag', 'gain_error', 'offset', 'offset_drift', 'noise', 'colored_noise',
                     'colored_tau', 'spike_rate', 'spike_amp'):  # fmt: skip
            val = getattr(self, name)
            if not math.isfinite(val):
                raise InvalidParameterError(f'Channel.{name} must be finite, got {val!r}')
        for name in ('lag', 'noise', 'colored_noise', 'spike_rate'):
            if getattr(self, name) < 0.0:
                raise InvalidParameterError(
                    f'Channel.{name} must be >= 0, got {getattr(self, name)}'
                )
        if self.colored_tau <= 0.0:
            raise InvalidParameterError(
                f'Channel.colored_tau must be > 0 s, got {self.colored_tau}'
            )


def rig_channels(
    scale: float = 1.0, *, speed_lag: float = 0.0, torsion_lag: float = 0.0, accel_lag: float = 0.0
) -> tuple[Channel, Channel, Channel]:
    """Build the (torsion, accel, speed) channels of the rig.

    With ``scale`` times the white noise of
    config/rig.yaml (:data:`RIG_NOISE`) and the given lags [s].
    """
    nt, na, ns = RIG_NOISE
    return (
        Channel(lag=torsion_lag, noise=scale * nt),
        Channel(lag=accel_lag, noise=scale * na),
        Channel(lag=speed_lag, noise=scale * ns),
    )


@dataclass(frozen=True)
class RecordSpec:
    """Everything that defines one generated record.

    ``rig``, ``friction``, ``drive`` (w0(t) breakpoints, test time [s] from the drive
    start), ``extensions`` (hidden model effects), ``unmodelled`` (effects outside the
    candidate library: drive backlash, a drifting C1; :class:`.reference.Unmodelled`),
    instrument per channel
    (``torsion``, ``accel``, ``speed``), ``seed`` of all noise, ``duration`` [s] of
    the record, ``fs`` [Hz], ``start_offset`` [s] of test time dropped before the
    record starts, ``time_zero`` [s] first time stamp of the record (epoch
    seconds for a logger clock), ``speed_in_rpm`` writes the speed in rpm,
    ``rtol`` of the integrator.
    """

    rig: RigParams
    friction: FrictionLaw
    drive: SpeedProfile
    extensions: Extensions = field(default_factory=Extensions)
    unmodelled: Unmodelled = field(default_factory=Unmodelled)
    torsion: Channel = field(default_factory=Channel)
    accel: Channel = field(default_factory=Channel)
    speed: Channel = field(default_factory=Channel)
    seed: int = 0
    duration: float = 1.0
    fs: float = 10_000.0
    start_offset: float = 0.0
    time_zero: float = 0.0
    speed_in_rpm: bool = False
    rtol: float = 1e-8

    def __post_init__(self) -> None:
        """Refuse a record spec out of range."""
        for name in ('duration', 'fs'):
            val = getattr(self, name)
            if not (math.isfinite(val) and val > 0.0):
                raise InvalidParameterError(f'RecordSpec.{name} must be > 0, got {val!r}')
        if not (math.isfinite(self.start_offset) and self.start_offset >= 0.0):
            raise InvalidParameterError(
                f'RecordSpec.start_offset must be >= 0 s, got {self.start_offset!r}'
            )
        if not math.isfinite(self.time_zero):
            raise InvalidParameterError(
                f'RecordSpec.time_zero must be finite, got {self.time_zero!r}'
            )


@dataclass(frozen=True)
class RecordTruth:
    """A generated record (measured channels) and its truth.

    Measured: ``time`` [s], ``torsion_moment`` [N m], ``angular_acceleration``
    [rad/s^2], ``speed`` [rad/s] (or rpm with ``spec.speed_in_rpm``).
    Truth at the same samples: ``test_time`` [s] since the drive start, ``w0``
    drive speed [rad/s], ``stick`` mask, ``sticks`` exact stick phases
    ``(start, end)`` in record time [s] (clipped to the record), ``chamber_speed``
    w1 and ``shaft_speed`` w2 [rad/s], ``slip_speed`` [rad/s], ``friction_moment``
    M [N m], clean ``true_torsion`` C1*phi1 [N m].
    """

    spec: RecordSpec
    time: np.ndarray
    torsion_moment: np.ndarray
    angular_acceleration: np.ndarray
    speed: np.ndarray
    test_time: np.ndarray
    w0: np.ndarray
    stick: np.ndarray
    sticks: tuple[tuple[float, float], ...]
    chamber_speed: np.ndarray
    shaft_speed: np.ndarray
    slip_speed: np.ndarray
    friction_moment: np.ndarray
    true_torsion: np.ndarray

    def sticks_between(
        self, t0: float, t1: float, min_duration: float = 0.0
    ) -> list[tuple[float, float]]:
        """List the true stick phases inside a window.

        Phases inside [t0, t1] [s] (record time) of at least
        ``min_duration`` [s]; phases cut by the record ends are left out.
        """
        t_first, t_last = float(self.time[0]), float(self.time[-1])
        return [
            (a, b)
            for a, b in self.sticks
            if a >= t0 and b <= t1 and b - a >= min_duration and a > t_first and b < t_last
        ]


def first_order_lag(x: np.ndarray, dt: float, tau: float, y0: float | None = None) -> np.ndarray:
    """First-order lag ``tau*y' = x - y`` of samples ``x`` at period ``dt`` [s].

    Exact for an input linear between samples (first-order hold):
    ``y[n] = a*y[n-1] + (1 - c)*x[n] + (c - a)*x[n-1]``, ``a = exp(-dt/tau)``,
    ``c = (1 - a)*tau/dt``. ``y0``: output at the first sample (default ``x[0]``,
    settled). ``tau = 0`` returns ``x``.
    """
    xa = np.asarray(x, dtype=float)
    if tau <= 0.0 or xa.size == 0:
        return xa.copy()
    a = math.exp(-dt / tau)
    c = (1.0 - a) * tau / dt
    b = np.array([1.0 - c, c - a])
    den = np.array([1.0, -a])
    y_first = float(xa[0]) if y0 is None else float(y0)
    # state so that y[0] = y_first with x[-1] = x[0]: y[0] = a*y[-1] + (1-a)*x[0]
    y_prev = (y_first - (1.0 - a) * xa[0]) / a
    zi = np.array([a * y_prev + (c - a) * xa[0]])
    y, _ = lfilter(b, den, xa, zi=zi)
    return np.asarray(y)


def _ar1(rng: np.random.Generator, n: int, std: float, dt: float, tau: float) -> np.ndarray:
    """Stationary AR(1) noise of std ``std`` and correlation time ``tau`` [s]."""
    phi = math.exp(-dt / tau)
    e = rng.normal(0.0, std * math.sqrt(1.0 - phi * phi), n)
    e[0] = rng.normal(0.0, std)
    y = lfilter([1.0], [1.0, -phi], e)
    return np.asarray(y)


def apply_channel(
    x: np.ndarray, ch: Channel, dt: float, rng: np.random.Generator, t_rec: np.ndarray
) -> np.ndarray:
    """Apply the instrument model of one channel.

    Order in the module docstring; ``t_rec``
    record time [s] from the first sample (for the offset drift).
    """
    y = first_order_lag(x, dt, ch.lag)
    y = y * (1.0 + ch.gain_error) + ch.offset + ch.offset_drift * t_rec
    n = y.size
    if ch.noise > 0.0:
        y = y + rng.normal(0.0, ch.noise, n)
    if ch.colored_noise > 0.0:
        y = y + _ar1(rng, n, ch.colored_noise, dt, ch.colored_tau)
    if ch.spike_rate > 0.0 and ch.spike_amp != 0.0:
        k = int(rng.poisson(ch.spike_rate * n * dt))
        idx = rng.integers(0, n, k)
        y[idx] += ch.spike_amp * rng.choice([-1.0, 1.0], k)
    return y


def make_record(spec: RecordSpec) -> RecordTruth:
    """Simulate ``spec`` with the reference simulator and apply the instruments.

    The test runs from t = 0 (drive start, everything at rest and sticking) to
    ``start_offset + duration``; the sensor lags run over the whole test, then the
    first ``start_offset`` seconds are dropped. Deterministic for a given spec.
    """
    fs = spec.fs
    dt = 1.0 / fs
    n_rec = round(spec.duration * fs)
    n_skip = round(spec.start_offset * fs)
    sim = simulate_reference(
        spec.rig,
        spec.friction,
        spec.drive,
        (n_skip + n_rec) / fs,
        fs,
        extensions=spec.extensions,
        unmodelled=spec.unmodelled,
        rtol=spec.rtol,
        atol=1e-10,
    )
    ext = spec.extensions
    t_test = sim.time
    torsion = first_order_lag(sim.torsion_moment, dt, ext.torque_lag_tau)
    torsion = torsion + ext.torque_offset + ext.torque_offset_drift * t_test
    rng = np.random.default_rng(spec.seed)
    t_all = t_test - spec.start_offset
    tq = apply_channel(torsion, spec.torsion, dt, rng, t_all)
    ac = apply_channel(sim.angular_acceleration, spec.accel, dt, rng, t_all)
    sp = apply_channel(sim.speed, spec.speed, dt, rng, t_all)
    sl = slice(n_skip, n_skip + n_rec)
    shift = spec.time_zero - spec.start_offset  # record time = test time + shift
    time = t_test[sl] + shift
    ivals = stick_intervals(
        sim.event_times, sim.event_kinds, float(t_test[0]), float(t_test[-1]), True
    )
    t_a, t_b = float(t_test[sl][0]), float(t_test[sl][-1])
    sticks = tuple(
        (max(a, t_a) + shift, min(b, t_b) + shift) for a, b in ivals if b > t_a and a < t_b
    )
    speed = sp[sl] * (30.0 / math.pi) if spec.speed_in_rpm else sp[sl]
    return RecordTruth(
        spec=spec,
        time=time,
        torsion_moment=tq[sl],
        angular_acceleration=ac[sl],
        speed=speed,
        test_time=t_test[sl].copy(),
        w0=spec.drive.speed(t_test[sl]),
        stick=sim.stick[sl].copy(),
        sticks=sticks,
        chamber_speed=sim.chamber_speed[sl].copy(),
        shaft_speed=sim.speed[sl].copy(),
        slip_speed=sim.slip_speed[sl].copy(),
        friction_moment=sim.friction_moment[sl].copy(),
        true_torsion=sim.torsion_moment[sl].copy(),
    )


def write_record_csv(path: str | Path, rec: RecordTruth, *, truth: bool = True) -> None:
    """Write ``rec`` as a rig CSV.

    Via :func:`.rigio.write_rig_csv`; with ``truth`` the
    columns ``friction_moment``, ``slip_speed``, ``stick`` follow the four channels.
    """
    extra = (
        {
            'friction_moment': rec.friction_moment,
            'slip_speed': rec.slip_speed,
            'stick': rec.stick.astype(float),
        }
        if truth
        else None
    )
    s = rec.spec
    meta = {
        'source': 'reference simulator (tribo_estimation.core.reference_records)',
        'fs': f'{s.fs:g}',
        'seed': s.seed,
        'start_offset': f'{s.start_offset:g}',
    }
    write_rig_csv(
        path, rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed,
        extra=extra, metadata=meta,
    )  # fmt: skip
