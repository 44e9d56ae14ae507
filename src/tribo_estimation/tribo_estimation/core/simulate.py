"""Simulator of the stick-slip rig: outputs as the rig's sensors see them, plus truth.

Wraps the compiled event-accurate kernel (:func:`tribo_estimation.core.kernel.integrate`)
and adds the measurement side: torsion moment ``C1*phi1`` [N m] (through the
measurement transforms of the effects, :mod:`tribo_estimation.core.measurement`:
offset, offset drift, first-order sensor lag),
chamber angular acceleration ``w1'`` [rad/s^2], shaft speed ``w2`` [rad/s], and
optional seeded Gaussian noise. Continuation: ``simulate(..., initial=r.final_state)``
chunk by chunk reproduces one long call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.measurement import apply_measurement_transforms
from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    RigState,
    pack_params,
)
from tribo_estimation.core.record import RigRecord
from tribo_estimation.errors import InvalidParameterError, SimulationError


@dataclass(frozen=True)
class NoiseSpec:
    """Standard deviations of white Gaussian measurement noise per sample.

    torque [N m], accel [rad/s^2], speed [rad/s].
    """

    torque: float = 0.0
    accel: float = 0.0
    speed: float = 0.0

    def __post_init__(self) -> None:
        """Check that every standard deviation is finite and >= 0."""
        for name in ('torque', 'accel', 'speed'):
            val = getattr(self, name)
            if not (math.isfinite(val) and val >= 0.0):
                raise InvalidParameterError(f'NoiseSpec.{name} must be >= 0, got {val!r}')


@dataclass(frozen=True, eq=False, kw_only=True)
class SimResult(RigRecord):
    """Simulated rig record: the measured channels of a :class:`RigRecord` plus the truth.

    Measured channels (:class:`~tribo_estimation.core.record.RigRecord`): ``time``
    [s], ``torsion_moment`` [N m], ``angular_acceleration`` [rad/s^2], ``speed``
    (shaft, w2) [rad/s], ``fs`` [Hz]. Truth (noise-free): ``friction_moment`` M
    [N m], ``slip_speed`` v = w2 - w1 [rad/s], ``stick`` (bool), ``chamber_speed`` w1
    [rad/s]. ``final_state`` is the state at ``time[-1] + 1/fs`` (start of the next
    chunk); ``n_events`` the number of located switching events, ``event_times`` [s]
    and ``event_kinds`` their exact instants and kinds (``kernel.EV_*``; ``-EV_SLIP_END``
    = slip ended without sticking, i.e. reversal).
    """

    friction_moment: np.ndarray
    slip_speed: np.ndarray
    stick: np.ndarray
    chamber_speed: np.ndarray
    final_state: RigState
    n_events: int
    event_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    event_kinds: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    source: str = 'simulation'

    def extra_columns(self) -> dict[str, np.ndarray]:
        """Return the truth a rig CSV carries after the four channels.

        Returns
        -------
        dict of str to numpy.ndarray
            ``friction_moment`` [N m], ``slip_speed`` [rad/s], ``stick`` (1.0 sticking).
        """
        return {
            'friction_moment': self.friction_moment,
            'slip_speed': self.slip_speed,
            'stick': self.stick.astype(np.float64),
        }


def _rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(seed)


def simulate(
    rig: RigParams,
    friction: FrictionLaw,
    drive: DriveProfile,
    duration: float,
    fs: float = 10_000.0,
    *,
    initial: RigState | None = None,
    t0: float | None = None,
    extensions: Extensions | None = None,
    noise: NoiseSpec | None = None,
    seed: int | np.random.Generator | None = None,
    substeps: int | None = None,
) -> SimResult:
    """Simulate the rig (Equ. 1-3, 6, 8) for ``duration`` seconds at ``fs`` Hz.

    ``n = round(duration*fs)`` samples are produced at ``t0 + i/fs``. The start
    state is ``initial`` (default: at rest and sticking); its time is replaced by
    ``t0`` when ``t0`` is given (default: ``initial.t`` or 0 s). Test time (for
    the drive ramp and the friction drift) is the absolute time. ``substeps``
    RK4 steps per sample (default: :func:`kernel.substeps_for`).
    """
    if not (math.isfinite(duration) and duration > 0.0):
        raise InvalidParameterError(f'duration must be > 0 s, got {duration!r}')
    if not (math.isfinite(fs) and fs > 0.0):
        raise InvalidParameterError(f'fs must be > 0 Hz, got {fs!r}')
    n = round(duration * fs)
    if n < 1:
        raise InvalidParameterError(f'duration {duration} s at fs {fs} Hz gives no sample')
    ext = extensions if extensions is not None else Extensions()
    state = initial if initial is not None else RigState.at_rest()
    s = state.to_vector()
    if t0 is not None:
        if not math.isfinite(t0):
            raise InvalidParameterError(f't0 must be finite, got {t0!r}')
        s[kn.S_T] = t0
    p = pack_params(rig, friction, drive, ext)
    dt = 1.0 / fs
    n_sub = substeps if substeps is not None else kn.substeps_for(p, dt)
    if n_sub < 1:
        raise InvalidParameterError(f'substeps must be >= 1, got {n_sub}')
    out = np.empty((kn.N_CH, n))
    t_start = float(s[kn.S_T])
    cap = n // 4 + 64
    ev_time = np.empty(cap)
    ev_kind = np.empty(cap, dtype=np.int64)
    n_events = int(kn.integrate_logged(p, s, n, dt, n_sub, out, ev_time, ev_kind))
    n_log = min(n_events, cap)
    if not np.all(np.isfinite(out[: kn.N_CH, :])) or not np.all(np.isfinite(s[list(kn.S_FINITE)])):
        raise SimulationError(
            'simulation diverged (non-finite state); check the rig parameters and step'
        )
    time = np.asarray(t_start + np.arange(n) * dt, dtype=np.float64)
    # measurement side: the registered measurement transforms of the effects
    # (core.measurement; e.g. sensor lag, then offset), carrying the sensor state
    torsion, s[kn.S_SENSOR] = apply_measurement_transforms(
        ext, time, out[kn.OUT_TORSION].copy(), dt, state=float(s[kn.S_SENSOR])
    )
    accel = out[kn.OUT_ACCEL].copy()
    speed = out[kn.OUT_SPEED].copy()
    if noise is not None and (noise.torque > 0.0 or noise.accel > 0.0 or noise.speed > 0.0):
        rng = _rng(seed)
        torsion = torsion + rng.normal(0.0, noise.torque, n) if noise.torque > 0 else torsion
        accel = accel + rng.normal(0.0, noise.accel, n) if noise.accel > 0 else accel
        speed = speed + rng.normal(0.0, noise.speed, n) if noise.speed > 0 else speed
    return SimResult(
        time=time,
        torsion_moment=torsion,
        angular_acceleration=accel,
        speed=speed,
        friction_moment=out[kn.OUT_FRICTION].copy(),
        slip_speed=out[kn.OUT_SLIP].copy(),
        stick=out[kn.OUT_STICK] > 0.5,
        chamber_speed=out[kn.OUT_W1].copy(),
        final_state=RigState.from_vector(s),
        n_events=n_events,
        fs=fs,
        event_times=ev_time[:n_log].copy(),
        event_kinds=ev_kind[:n_log].copy(),
    )


def free_decay_state(phi1_0: float, w1_0: float = 0.0, t: float = 0.0) -> RigState:
    """Return the initial state of a free-decay record (use with ``F_N = 0``).

    Parameters
    ----------
    phi1_0 : float
        Chamber deflection [rad].
    w1_0 : float
        Chamber speed at release [rad/s].
    t : float
        Time of the state [s].

    Returns
    -------
    RigState
        Chamber deflected and released, no contact.
    """
    return RigState(t=t, phi1=phi1_0, w1=w1_0, stuck=False, slip_dir=1, peak_passed=True)


def simulate_free_decay(
    rig: RigParams,
    phi1_0: float,
    duration: float,
    fs: float = 10_000.0,
    *,
    noise: NoiseSpec | None = None,
    seed: int | np.random.Generator | None = None,
) -> SimResult:
    """Simulate the free decay of the chamber alone (Equ. 7).

    Contact opened (F_N = 0), drive at rest, chamber released from ``phi1_0`` at t = 0.

    Parameters
    ----------
    rig : RigParams
        The rig (its F_N is replaced by 0).
    phi1_0 : float
        Initial chamber deflection [rad] (non-zero).
    duration : float
        Record length [s].
    fs : float
        Sample rate [Hz].
    noise : NoiseSpec, optional
        Measurement noise.
    seed : int or numpy.random.Generator, optional
        Seed of the noise.

    Returns
    -------
    SimResult
        The record.

    Raises
    ------
    InvalidParameterError
        ``phi1_0`` is zero or not finite.
    """
    if not (math.isfinite(phi1_0) and phi1_0 != 0.0):
        raise InvalidParameterError(f'phi1_0 must be a non-zero angle [rad], got {phi1_0!r}')
    open_rig = RigParams(
        I1=rig.I1, K1=rig.K1, C1=rig.C1, I2=rig.I2, K2=rig.K2, C2=rig.C2, F_N=0.0, R=rig.R
    )
    return simulate(
        open_rig,
        FrictionLaw(0.0, 0.0),
        DriveProfile(0.0),
        duration,
        fs,
        initial=free_decay_state(phi1_0),
        noise=noise,
        seed=seed,
    )
