"""The drawn specification of a scenario: rig, drive, instrument, hidden effect, user config.

All values SI (REP-103): kg m^2, N m s/rad, N m/rad, N, m, rad/s, s, N m, rad/s^2.
The dataclasses are frozen; :meth:`ScenarioSpec.as_dict` gives the JSON form that
``truth.json`` and the record cache key use.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field

#: Version of the generator: part of the cache path. Change it whenever a draw or the
#: simulation changes what a seed produces.
GENERATOR_VERSION = 'g1'


@dataclass(frozen=True)
class RigTruth:
    """The rig as simulated (Equ. 1-8; paper naming K = damping, C = stiffness).

    ``I1, I2`` [kg m^2], ``K1, K2`` [N m s/rad], ``C1, C2`` [N m/rad], ``F_N`` [N],
    ``R`` [m], ``mu0, mu_inf`` [-], ``k`` [s/rad].
    """

    I1: float
    K1: float
    C1: float
    I2: float
    K2: float
    C2: float
    F_N: float
    R: float
    mu0: float
    mu_inf: float
    k: float

    @property
    def f_chamber(self) -> float:
        """Return the chamber's natural frequency sqrt(C1/I1)/(2 pi) [Hz]."""
        return math.sqrt(self.C1 / self.I1) / (2.0 * math.pi)

    @property
    def zeta1(self) -> float:
        """Return the chamber's damping ratio K1/(2 sqrt(C1 I1)) [-]."""
        return self.K1 / (2.0 * math.sqrt(self.C1 * self.I1))

    @property
    def zeta2(self) -> float:
        """Return the drive's damping ratio K2/(2 sqrt(C2 I2)) [-]."""
        return self.K2 / (2.0 * math.sqrt(self.C2 * self.I2))


@dataclass(frozen=True)
class Transition:
    """One change of the drive speed from rest at test time 0.

    ``start`` [s] (test time), ``duration`` [s] (> 0), ``delta`` speed change [rad/s],
    ``shape`` 'linear' or 'cosine' (raised cosine: zero acceleration at both ends).
    """

    start: float
    duration: float
    delta: float
    shape: str


@dataclass(frozen=True)
class DriveSpec:
    """The motor's speed profile w0(t) (sum of transitions) and where the record lies in it.

    ``kind`` one of :data:`.space.DRIVE_KINDS`; ``record_start`` test time of the first
    sample [s] (0: the record begins with the motor's start); ``nominal_speed`` the
    profile's nominal value a user would configure [rad/s]; ``ramp_time`` the start-up
    ramp a user would configure [s] (None: not a start-up record); ``moves`` the order
    of the profile's parts (e.g. ('warm', 'step', 'sweep')).
    """

    kind: str
    transitions: tuple[Transition, ...]
    record_start: float
    nominal_speed: float
    ramp_time: float | None
    moves: tuple[str, ...]


@dataclass(frozen=True)
class ChannelSpec:
    """The instrument chain of one channel: true value -> measured value.

    ``measured = gain*filter(true) + offset + white + coloured + hum + spikes``.
    ``gain`` [-]; ``offset`` [unit of the channel]; ``lag_order`` 0 (none), 1
    (``tau*y' + y = x``) or 2 (``y'' + 2 zeta w y' + w^2 y = w^2 x``, w = 1/tau);
    ``lag_tau`` [s]; ``lag_zeta`` [-]; ``noise`` white noise std per sample; ``coloured``
    'none', 'ar1' (first-order low-passed noise, corner ``coloured_corner`` [Hz]) or
    'pink' (1/f power above 0.1 Hz), of std ``coloured_level``; mains hum
    ``hum_freq`` [Hz] (0: none) with amplitudes ``hum_amps`` of harmonics 1, 2, ...
    and phases ``hum_phases`` [rad]; ``spikes`` isolated spikes of about
    ``spike_scale`` (times the white noise).
    """

    gain: float
    offset: float
    lag_order: int
    lag_tau: float
    lag_zeta: float
    noise: float
    coloured: str = 'none'
    coloured_level: float = 0.0
    coloured_corner: float = 0.0
    hum_freq: float = 0.0
    hum_amps: tuple[float, ...] = ()
    hum_phases: tuple[float, ...] = ()
    spikes: int = 0
    spike_scale: float = 0.0


@dataclass(frozen=True)
class InstrumentSpec:
    """The three channels' chains: torsion moment [N m], acceleration [rad/s^2], speed [rad/s]."""

    torque: ChannelSpec
    accel: ChannelSpec
    speed: ChannelSpec


@dataclass(frozen=True)
class EffectSpec:
    """The hidden effect.

    ``category`` 'none', 'library' or 'out_of_library'; ``name`` the family ('none',
    a library family, or the out-of-library effect's name); ``form`` its functional
    form; ``params`` its parameters (SI, names documented in :mod:`.space`);
    ``components`` rows (amplitude, frequency or order, phase) of a ripple or a smooth
    random drift; ``library_params`` the parameters under the library's names when
    the form is the library's own (else empty).
    """

    category: str
    name: str
    form: str
    params: dict[str, float] = field(default_factory=dict)
    components: tuple[tuple[float, float, float], ...] = ()
    library_params: dict[str, float] = field(default_factory=dict)

    @property
    def own_form(self) -> bool:
        """Return whether the form is the library candidate's own (parameters comparable)."""
        return bool(self.library_params)

    @property
    def truth_name(self) -> str:
        """Return 'none', the family, or 'out_of_library:<name>'."""
        if self.category == 'out_of_library':
            return f'out_of_library:{self.name}'
        return self.name


@dataclass(frozen=True)
class ScenarioSpec:
    """Everything one seed draws (cheap; :func:`.generate.generate` simulates it).

    ``duration`` [s], ``fs`` sample rate [Hz], ``user_rig`` the RIG.yaml a lab would
    pass (keys of ``config/rig.yaml``), ``labels`` condition labels (rig class, fs,
    drive kind, instrument conditions, effect family, form; the record adds its motion
    and the effect's magnitude bin).
    """

    seed: int
    duration: float
    fs: float
    rig: RigTruth
    drive: DriveSpec
    instrument: InstrumentSpec
    effect: EffectSpec
    user_rig: dict[str, float]
    labels: dict[str, str]
    request: dict[str, str] = field(default_factory=dict)
    version: str = GENERATOR_VERSION

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form (every field; tuples become lists).

        Returns
        -------
        dict[str, object]
            The specification.
        """
        d = asdict(self)
        d['rig']['f_chamber_hz'] = self.rig.f_chamber
        d['rig']['zeta1'] = self.rig.zeta1
        d['rig']['zeta2'] = self.rig.zeta2
        return d

    def digest(self) -> str:
        """Return a hash of the whole specification (hex, 16 characters).

        Returns
        -------
        str
            The first 16 hex digits of the SHA-256 of the canonical JSON form.
        """
        text = json.dumps(self.as_dict(), sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def cache_name(self) -> str:
        """Return the record's file name in the cache: ``<seed>.npz`` for a default draw.

        A draw with a fixed duration, drive kind or family gets ``<seed>-<digest>.npz``.

        Returns
        -------
        str
            File name.
        """
        if not self.request:
            return f'{self.seed}.npz'
        return f'{self.seed}-{self.digest()[:10]}.npz'
