"""Rig model of the disc-on-disc stick-slip tribometer (paper section 2.3-2.4).

Typed parameter objects and Python entry points to the equations of motion.
The equations themselves are written once, as compiled functions in
:mod:`tribo_estimation.core.kernel`; this module only packs the dataclasses into
the kernel's flat vectors and wraps the compiled functions.

Units (SI): inertia kg m^2, damping K N m s/rad, stiffness C N m/rad, force N,
radius m, angle rad, speed rad/s, time s. Paper naming: K = viscous damping,
C = torsional stiffness.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from tribo_estimation.core import kernel as kn
from tribo_estimation.errors import InvalidParameterError


def _check_finite(obj: object) -> None:
    for f in fields(obj):  # type: ignore[arg-type]
        val = getattr(obj, f.name)
        if isinstance(val, bool):
            continue
        if isinstance(val, int | float) and not math.isfinite(float(val)):
            raise InvalidParameterError(
                f'{type(obj).__name__}.{f.name} must be finite, got {val!r}'
            )


def _require(cond: bool, obj: object, name: str, what: str) -> None:
    if not cond:
        raise InvalidParameterError(
            f'{type(obj).__name__}.{name} must be {what}, got {getattr(obj, name)!r}'
        )


@dataclass(frozen=True)
class RigParams:
    """Mechanical parameters of the rig (paper Tab. 1 and section 2.3).

    I1 chamber inertia [kg m^2], K1 chamber damping [N m s/rad], C1 torsion element
    stiffness [N m/rad], I2 drive shaft inertia [kg m^2], K2 drive damping
    [N m s/rad], C2 drive stiffness [N m/rad], F_N total normal force summed over
    all friction pairs [N] (0 = no contact, free decay), R effective friction radius [m].
    """

    I1: float
    K1: float
    C1: float
    I2: float
    K2: float
    C2: float
    F_N: float
    R: float

    def __post_init__(self) -> None:
        """Check that every value is finite and physical (> 0, or >= 0 for K1, K2, F_N)."""
        _check_finite(self)
        for name in ('I1', 'C1', 'I2', 'C2', 'R'):
            _require(getattr(self, name) > 0.0, self, name, '> 0')
        for name in ('K1', 'K2', 'F_N'):
            _require(getattr(self, name) >= 0.0, self, name, '>= 0')

    @classmethod
    def from_mapping(cls, values: Mapping[str, float]) -> RigParams:
        """Build the rig from a mapping holding (at least) the eight field names.

        Parameters
        ----------
        values : Mapping[str, float]
            E.g. RIG.yaml values or node parameters (other keys are ignored), SI.

        Returns
        -------
        RigParams
            The rig.
        """
        return cls(**{f.name: float(values[f.name]) for f in fields(cls)})

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Return the names of the eight fields, in declaration order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def tab1(cls, F_N: float | None = None, R: float | None = None) -> RigParams:
        """Return the paper's Tab. 1 rig with the given contact load and radius.

        Parameters
        ----------
        F_N : float, optional
            Normal force [N] (default: that of
            :data:`tribo_estimation.core.rigspec.RIG_SPEC`, 8 kN).
        R : float, optional
            Friction radius [m] (default: 80 mm).

        Returns
        -------
        RigParams
            The rig.
        """
        from tribo_estimation.core.rigspec import RIG_FIELDS, tab1_value

        v = {name: tab1_value(name) for name in RIG_FIELDS}
        v.update({k: x for k, x in (('F_N', F_N), ('R', R)) if x is not None})
        return cls(**v)

    @property
    def natural_frequency_hz(self) -> float:
        """Undamped natural frequency of the chamber alone, sqrt(C1/I1)/(2 pi) [Hz]."""
        return math.sqrt(self.C1 / self.I1) / (2.0 * math.pi)

    @property
    def fastest_mode_hz(self) -> float:
        """Highest undamped frequency of the rig's motions [Hz] (Equ. 1, 2, 4).

        The largest of the chamber alone sqrt(C1/I1), the shaft alone sqrt(C2/I2)
        (the two while sliding) and the stuck discs on both springs
        sqrt((C1 + C2)/(I1 + I2)), over 2 pi.
        """
        w2 = max(self.C1 / self.I1, self.C2 / self.I2, (self.C1 + self.C2) / (self.I1 + self.I2))
        return math.sqrt(w2) / (2.0 * math.pi)

    @property
    def damping_ratio(self) -> float:
        """Damping ratio of the chamber alone, K1/(2 sqrt(C1 I1)) [-] (Equ. 7)."""
        return self.K1 / (2.0 * math.sqrt(self.C1 * self.I1))


@dataclass(frozen=True)
class FrictionLaw:
    """Friction law of the paper, Equ. 8, with its deceleration rule.

    ``mu(|v|) = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` [-]; static coefficient
    ``mu_s = mu0``; within a sliding phase, after the slip-speed peak,
    ``mu = mu_inf`` until the phase ends. ``k`` in s/rad (paper preset 2).
    """

    mu0: float
    mu_inf: float
    k: float = 2.0

    def __post_init__(self) -> None:
        """Check that mu0, mu_inf and k are finite and >= 0."""
        _check_finite(self)
        _require(self.mu0 >= 0.0, self, 'mu0', '>= 0')
        _require(self.mu_inf >= 0.0, self, 'mu_inf', '>= 0')
        _require(self.k >= 0.0, self, 'k', '>= 0 s/rad')

    def mu(self, v_abs: np.ndarray | float, peak_passed: bool = False) -> np.ndarray:
        """Friction coefficient at slip speed |v| [rad/s] (Equ. 8), vectorised [-]."""
        p = pack_params(RigParams.tab1(), self, DriveProfile(0.0))
        arr = np.atleast_1d(np.asarray(v_abs, dtype=float))
        return kn.friction_coefficient_array(p, 0.0, np.abs(arr), bool(peak_passed))


@dataclass(frozen=True)
class DriveProfile:
    """Drive motor speed profile w0(t) and its integral phi0(t) [rad].

    w0(t) ramps linearly from 0 to ``nominal_speed`` [rad/s] over ``ramp_time`` [s]
    (0 = starts at full speed), then stays constant.
    """

    nominal_speed: float
    ramp_time: float = 0.0

    def __post_init__(self) -> None:
        """Check that the values are finite and the ramp time >= 0."""
        _check_finite(self)
        _require(self.ramp_time >= 0.0, self, 'ramp_time', '>= 0 s')

    def speed(self, t: np.ndarray | float, extensions: Extensions | None = None) -> np.ndarray:
        """w0(t) [rad/s] (with the drive-ripple extension if given)."""
        p = pack_params(RigParams.tab1(), FrictionLaw(0.1, 0.1), self, extensions)
        return kn.drive_speed_array(p, np.atleast_1d(np.asarray(t, dtype=float)))

    def angle(self, t: np.ndarray | float, extensions: Extensions | None = None) -> np.ndarray:
        """phi0(t) [rad] (with the drive-ripple extension if given)."""
        p = pack_params(RigParams.tab1(), FrictionLaw(0.1, 0.1), self, extensions)
        return kn.drive_angle_array(p, np.atleast_1d(np.asarray(t, dtype=float)))


@dataclass(frozen=True)
class Extensions:
    """Model extensions beyond the paper (used by the discrepancy workflow).

    All zero (the default) is exactly the paper's model; each extension is
    nested (its zero value switches it off). Kernel-side (change the dynamics):

    - ``stiction_gain`` [-], ``stiction_tau`` [s]: dwell-time stiction,
      ``mu_s = mu0 + gain*(1 - exp(-t_stick/tau))`` (tau = 0: instantaneous).
    - ``lag_tau`` [s]: frictional lag; the sliding coefficient follows Equ. 8
      through a first-order lag, starting at mu_s at breakaway.
    - ``viscous`` [N m s/rad]: viscous friction in the contact, ``M += viscous*v``.
    - ``drift_mu0``, ``drift_mu_inf`` [1/s]: linear drift of mu0, mu_inf with test time.
    - ``ripple_amp`` [rad/s], ``ripple_freq`` [Hz], ``ripple_phase`` [rad]: drive
      speed ripple ``w0 += amp*sin(2 pi f t + phase)``.
    - ``stribeck_shape`` [-]: generic friction-law shape hook, the offset of the
      Stribeck shape exponent from 1: ``mu = (mu0 - mu_inf)*exp(-(k|v|)**delta) + mu_inf``
      with ``delta = 1 + stribeck_shape`` (0: Equ. 8). Must be > -1.
    - ``ripple2_amp`` [rad/s], ``ripple2_phase`` [rad]: the ripple's second harmonic,
      ``w0 += A_2*sin(4 pi f t + p_2)``.
    - ``ripple_rel`` [-], ``ripple_order`` [-], ``ripple_angle_phase`` [rad]: drive speed
      ripple locked to the drive angle theta (``n`` = ``ripple_order`` per revolution),
      ``w0 += r*w_n*sin(n*theta + p)`` (``w_n`` the ripple-free drive speed);
      ``ripple2_rel`` [-], ``ripple2_angle_phase`` [rad] its second harmonic,
      ``w0 += r2*w_n*sin(2n*theta + p2)``.
    - ``stiction_log`` [-]: logarithmic dwell-time stiction,
      ``mu_s += b*ln(1 + t_stick/stiction_tau)``.
    - ``bearing_moment`` [N m]: Coulomb moment of the chamber support, regularised as
      ``M_b*w1/sqrt(w1^2 + w_reg^2)`` with ``w_reg`` = ``bearing_reg_speed`` [rad/s].

    Measurement-side (applied to the torsion output only):

    - ``torque_offset`` [N m], ``torque_offset_drift`` [N m/s]: sensor offset and its drift.
    - ``torque_lag_tau`` [s]: first-order lag of the torque sensor.
    - ``torque_thermal`` [N m], ``torque_thermal_tau`` [s]: a saturating (thermal) zero
      drift ``D*(1 - exp(-t/tau))``.
    """

    stiction_gain: float = 0.0
    stiction_tau: float = 0.0
    lag_tau: float = 0.0
    viscous: float = 0.0
    drift_mu0: float = 0.0
    drift_mu_inf: float = 0.0
    ripple_amp: float = 0.0
    ripple_freq: float = 0.0
    ripple_phase: float = 0.0
    bearing_moment: float = 0.0
    bearing_reg_speed: float = kn.BEARING_REG_SPEED
    torque_offset: float = 0.0
    torque_offset_drift: float = 0.0
    torque_lag_tau: float = 0.0
    stribeck_shape: float = 0.0
    ripple2_amp: float = 0.0
    ripple2_phase: float = 0.0
    stiction_log: float = 0.0
    torque_thermal: float = 0.0
    torque_thermal_tau: float = 0.0
    ripple_rel: float = 0.0
    ripple_order: float = 0.0
    ripple_angle_phase: float = 0.0
    ripple2_rel: float = 0.0
    ripple2_angle_phase: float = 0.0

    def __post_init__(self) -> None:
        """Check that every value is finite and the time constants >= 0."""
        _check_finite(self)
        for name in (
            'stiction_tau',
            'lag_tau',
            'viscous',
            'ripple_freq',
            'ripple_order',
            'bearing_moment',
            'torque_lag_tau',
            'torque_thermal_tau',
        ):
            _require(getattr(self, name) >= 0.0, self, name, '>= 0')
        _require(self.bearing_reg_speed > 0.0, self, 'bearing_reg_speed', '> 0 rad/s')
        _require(self.stribeck_shape > -1.0, self, 'stribeck_shape', '> -1 (delta > 0)')

    @property
    def is_baseline(self) -> bool:
        """True when every extension is switched off (the paper's model)."""
        return all(
            getattr(self, f.name) == 0.0 for f in fields(self) if f.name != 'bearing_reg_speed'
        )


@dataclass(frozen=True)
class RigState:
    """Complete simulation state, enough to continue a run seamlessly.

    One field per slot of the kernel's state table (:data:`kernel.STATE_SLOTS`, which
    gives each field's slot, unit and kind): t [s], phi1 [rad], w1 [rad/s], phi2 [rad],
    w2 [rad/s]; ``stuck`` sticking flag; ``slip_dir`` sgn(v) of the current sliding
    phase; ``peak_passed`` the deceleration rule flag; ``v_max`` max |v| of the current
    sliding phase [rad/s]; ``stick_time`` duration of the current stick [s]; ``lag``
    lagged friction coefficient [-] (frictional-lag extension); ``sensor_lag``
    torque-sensor filter state [N m] (NaN until the first sample).
    """

    t: float = 0.0
    phi1: float = 0.0
    w1: float = 0.0
    phi2: float = 0.0
    w2: float = 0.0
    stuck: bool = True
    slip_dir: int = 1
    peak_passed: bool = False
    v_max: float = 0.0
    stick_time: float = 0.0
    lag: float = 0.0
    sensor_lag: float = math.nan

    def __post_init__(self) -> None:
        """Check the fields against the state table (finite where required, signs +-1)."""
        for slot in kn.STATE_SLOTS:
            val = getattr(self, slot.name)
            if slot.kind == 'sign':
                if val not in (1, -1):
                    raise InvalidParameterError(
                        f'RigState.{slot.name} must be +1 or -1, got {val!r}'
                    )
            elif slot.kind == 'value' and slot.finite and not math.isfinite(val):
                raise InvalidParameterError(f'RigState.{slot.name} must be finite, got {val!r}')

    @classmethod
    def at_rest(cls, t: float = 0.0) -> RigState:
        """Both bodies at rest, unloaded, sticking, at time t [s]."""
        return cls(t=t)

    def to_vector(self) -> np.ndarray:
        """Kernel state vector (length ``kernel.NS``, slot ``i`` = ``kernel.STATE_SLOTS[i]``)."""
        return np.array([float(getattr(self, slot.name)) for slot in kn.STATE_SLOTS])

    @classmethod
    def from_vector(cls, s: np.ndarray) -> RigState:
        """Inverse of :meth:`to_vector` (flags read ``> 0.5``, signs ``>= 0`` as +1)."""
        values: dict[str, float | bool | int] = {}
        for i, slot in enumerate(kn.STATE_SLOTS):
            x = float(s[i])
            if slot.kind == 'flag':
                values[slot.name] = x > 0.5
            elif slot.kind == 'sign':
                values[slot.name] = 1 if x >= 0.0 else -1
            else:
                values[slot.name] = x
        return cls(**values)  # type: ignore[arg-type]


def pack_params(
    rig: RigParams,
    friction: FrictionLaw,
    drive: DriveProfile,
    extensions: Extensions | None = None,
) -> np.ndarray:
    """Flat kernel parameter vector (indices ``kernel.P_*``) from the dataclasses."""
    ext = extensions if extensions is not None else Extensions()
    p = np.zeros(kn.NP)
    p[kn.P_I1] = rig.I1
    p[kn.P_K1] = rig.K1
    p[kn.P_C1] = rig.C1
    p[kn.P_I2] = rig.I2
    p[kn.P_K2] = rig.K2
    p[kn.P_C2] = rig.C2
    p[kn.P_FN] = rig.F_N
    p[kn.P_R] = rig.R
    p[kn.P_MU0] = friction.mu0
    p[kn.P_MUINF] = friction.mu_inf
    p[kn.P_K] = friction.k
    p[kn.P_W0] = drive.nominal_speed
    p[kn.P_RAMP] = drive.ramp_time
    p[kn.P_ST_GAIN] = ext.stiction_gain
    p[kn.P_ST_TAU] = ext.stiction_tau
    p[kn.P_LAG_TAU] = ext.lag_tau
    p[kn.P_VISC] = ext.viscous
    p[kn.P_DRIFT_MU0] = ext.drift_mu0
    p[kn.P_DRIFT_MUINF] = ext.drift_mu_inf
    p[kn.P_RIP_AMP] = ext.ripple_amp
    p[kn.P_RIP_FREQ] = ext.ripple_freq
    p[kn.P_RIP_PHASE] = ext.ripple_phase
    p[kn.P_BEARING] = ext.bearing_moment
    p[kn.P_BEARING_REG] = ext.bearing_reg_speed
    p[kn.P_SHAPE] = ext.stribeck_shape
    p[kn.P_RIP2_AMP] = ext.ripple2_amp
    p[kn.P_RIP2_PHASE] = ext.ripple2_phase
    if ext.ripple_order > 0.0:  # a ripple locked to the drive angle needs an order
        p[kn.P_RIPA_REL] = ext.ripple_rel
        p[kn.P_RIPA_ORDER] = ext.ripple_order
        p[kn.P_RIPA_PHASE] = ext.ripple_angle_phase
        p[kn.P_RIPA2_REL] = ext.ripple2_rel
        p[kn.P_RIPA2_PHASE] = ext.ripple2_angle_phase
    p[kn.P_ST_LOG] = ext.stiction_log
    return p


def stick_moment(
    rig: RigParams,
    drive: DriveProfile,
    t: float,
    phi1: float,
    w: float,
    phi2: float,
    extensions: Extensions | None = None,
) -> float:
    """Moment that keeps the discs together while sticking, Equ. 6 (corrected) [N m]."""
    p = pack_params(rig, FrictionLaw(0.0, 0.0), drive, extensions)
    return float(kn.stick_moment(p, t, phi1, w, phi2))


def derivatives(
    rig: RigParams,
    friction: FrictionLaw,
    drive: DriveProfile,
    state: RigState,
    extensions: Extensions | None = None,
) -> tuple[float, ...]:
    """Equations of motion (Equ. 1-3, 6, 8) at ``state``.

    Returns the derivative of each integrated state at its index ``kernel.Y_*``
    (``phi1', w1', phi2', w2', lag'`` in rad/s, rad/s^2, rad/s, rad/s^2, 1/s, then any
    effect state's rate), then the friction moment M on the chamber [N m] at
    ``kernel.D_M``.
    """
    p = pack_params(rig, friction, drive, extensions)
    s = state.to_vector()
    y = tuple(float(s[i]) for i in kn.Y_SLOTS)
    d = kn.derivatives(p, state.t, y, state.stuck, float(state.slip_dir), state.peak_passed)
    return tuple(float(x) for x in d)
