"""The scenario space: every random draw of a scenario, with its documented range.

``draw(seed)`` returns a :class:`.spec.ScenarioSpec`; nothing is simulated. Each part
(rig, sample rate and duration, drive, instrument, hidden effect, user config) draws
from its own child of ``numpy.random.SeedSequence(seed)``, so fixing the drive kind or
the family of a seed leaves its other parts as they were. LU(a, b) is log-uniform,
U(a, b) uniform; rpm = 2 pi/60 rad/s.

**Rig** (Tab. 1 of the paper, ``config/rig.yaml``): I1 = 0.0109 kg m^2 x LU(0.5, 2),
C1 = 2338.6 N m/rad x LU(0.5, 2), redrawn until the chamber frequency
sqrt(C1/I1)/(2 pi) lies in 40-150 Hz; K1 from the damping ratio LU(0.001, 0.02)
(Tab. 1: 0.004). I2 = 0.0315 kg m^2 x LU(0.5, 2), C2 = 5975 N m/rad x LU(0.5, 2), K2
from the damping ratio LU(0.05, 0.4) (Tab. 1: 0.146). F_N = 8000 N x LU(0.3, 1.5),
R = 0.08 m x U(0.8, 1.25) (F_N R mu0 about 15-250 N m), mu0 U(0.08, 0.2),
mu_inf/mu0 U(0.6, 0.95), k LU(1, 5) s/rad. Rig class label: chamber frequency
'fn<60', 'fn60-100', 'fn>100' Hz.

**Sample rate** one of 2, 2.5, 5, 10, 12.8, 20 kHz; **duration** U(4, 8) s.

**Drive** w0(t) from rest at test time 0, a sum of transitions (linear or raised
cosine); speeds 3-80 rpm, levels LU(3, 80) rpm. Kinds (weights):

- ``constant`` (0.25): ramp of U(0.2, 1) s, the record starts U(1, 2.5) s after it
  (the rig has settled into its limit cycle);
- ``startup`` (0.15): the record contains the start from rest: the motor starts at
  record time 0 (half of the records) or U(0.1, 0.8) s later, ramp LU(0.05, 1.5) s;
- ``steps`` (0.2): 1-4 speed steps inside the record (level ratio LU(1.3, 3) up or
  down, transition LU(10, 200) ms, at least 0.3 s apart);
- ``sweep`` (0.15): a linear sweep between two levels (ratio >= 1.5) lasting LU(2, 12) s
  that starts before or inside the record and ends inside or after it;
- ``stop`` (0.1): ramp down in U(0.1, 1) s, dwell at rest U(0.2, 1.5) s, ramp up in
  U(0.1, 1) s to the old level (60 %) or a new one;
- ``combination`` (0.15): a start-up in the record or a settled start, then 2-3 of
  step / sweep / stop.

The user's ``nominal_speed`` is the level at the record start (the target level of
a start-up; a sweep: its mean over the record or its start value, half each);
``ramp_time`` is given for start-up records only.

**Instrument**, each channel independently: gain error U(-3, 3) %; offset torque
U(-0.3, 0.3) N m, acceleration U(-0.5, 0.5) rad/s^2, speed U(-0.05, 0.05) rad/s;
lag: torsion amplifier none (40 %) or LU(0.1, 2) ms, accelerometer none (60 %) or
LU(0.1, 0.3) ms, tachometer none (15 %) or LU(0.3, 8) ms; a quarter of the torque and
speed lags second order (damping ratio U(0.5, 0.9)) instead of first; white noise
torque LU(0.01, 0.1) N m, acceleration LU(0.5, 10) rad/s^2, speed LU(0.001, 0.02)
rad/s; coloured noise on a quarter of the channels (AR(1) with corner LU(2, 200) Hz
or 1/f above 0.1 Hz; std LU(0.3, 2) x the white noise); mains hum on 35 % of the
records (50 or 60 Hz, +-0.02 %), on each channel with probability 0.6: fundamental
LU(0.2, 3) x the white noise, harmonics 2-5 each with probability 0.5 at LU(0.05, 0.5)
x the fundamental, random phases; spikes on 15 % of the records (per channel with
probability 0.5: 1-10 spikes of LU(10, 100) x the white noise, 1-3 samples wide).

**User config** (the RIG.yaml a lab passes, keys of ``config/rig.yaml``): I1, K1, C1
as a free-decay identification gives them (each within U(-1, 1) %); I2, K2, C2 design
values, off by 10-25 % (random sign, each) on 40 % of the records (label
``config_shaft`` = 'off'), else within 2 %; F_N, R within 1 %; mu0, mu_inf x U(0.8,
1.25) (a rough guess, mu_inf < mu0 kept); k within 5 % (identified, 85 %) or the
paper's preset 2 s/rad (label ``config_k``); noise_torque/accel/speed on 70 % of the
records, the true white noise x LU(0.5, 2).

**Hidden effect** (weights: none 0.25, a library family 0.6, outside the library
0.15; families and forms uniform). ``w_ref`` = max(nominal speed, 1 rad/s),
``FRm`` = F_N R mu0 [N m]. Library families (canonical names) and their forms
(first = the library's own form, whose parameters the bench compares):

- ``dwell_time_stiction``: mu_s = mu0 + g (1 - exp(-t_stick/tau)), g LU(3e-4, 0.03),
  tau LU(2 ms, 0.5 s); mu0 + b ln(1 + t_stick/t0), b LU(1e-4, 0.01), t0 LU(0.5, 20) ms;
  mu0 + c (t_stick/1 s)^n, c LU(3e-4, 0.03), n U(0.2, 0.6).
- ``frictional_lag``: first-order lag of mu, tau LU(0.2, 8) ms; pure time delay
  LU(0.2, 4) ms; rate and state, mu + b ln(theta (|v| + v_r)/D_c) with the aging law
  theta' = 1 - (|v| + v_r) theta/D_c, b LU(2e-4, 5e-3), D_c LU(1e-3, 2e-2) rad,
  v_r = 0.05 rad/s.
- ``viscous_friction``: c v, c = r FRm/w_ref, r LU(1e-4, 0.03); c sgn(v)|v|^n,
  n U(0.4, 2), c = r FRm/w_ref^n.
- ``stribeck_shape``: exp(-(k|v|)^delta), |ln delta| LU(0.03, 0.9) either sign;
  1/(1 + (|v|/v_s)^2) and exp(-(|v|/v_s)^2), v_s = LU(0.3, 3)/k.
- ``friction_drift``: linear, relative change of mu0 over the record LU(1e-3, 0.05)
  either sign, of mu_inf that times U(0.3, 1.2); saturating exponential of the same
  size, tau LU(1, 20) s; a smooth random function of test time, 3 sines of LU(0.05,
  0.5) Hz with rms LU(1e-3, 0.03) (mu_inf x U(0.5, 1) of it).
- ``drive_speed_ripple``: a sine A sin(2 pi f t + p), A = LU(1e-3, 0.05) w_ref,
  f LU(0.3, 500) Hz; with 1-3 harmonics (f LU(0.3, 200) Hz, each U(0.1, 0.7) of the
  fundamental); locked to the motor angle, w0 (1 + a sin(m phi0 + p)), m 1-12 per
  revolution (plus a second harmonic on half), a LU(1e-3, 0.05).
- ``bearing_friction``: M_b w1/sqrt(w1^2 + (0.01 rad/s)^2), M_b = LU(1e-4, 0.02) FRm;
  M_b tanh(w1/w_r), w_r LU(0.005, 0.05) rad/s; the same plus c_b w1,
  c_b = M_b x LU(0.1, 1) s/rad.
- ``torque_offset``: measured torque + b' t, b' LU(1e-3, 0.1) N m/s either sign;
  + D (1 - exp(-t/tau)) (thermal), D LU(0.01, 0.5) N m either sign, tau LU(1, 20) s
  (t = test time).
- ``torque_sensor_lag``: the torque channel's whole lag (the torsion amplifier lag
  of the instrument is then none), first order tau LU(0.2, 8) ms or second order
  (w = 1/tau, damping ratio U(0.5, 1)).

Outside the library (never to be named): ``normal_force_ripple`` F_N (1 + a sin(2 pi
f t + p)), a LU(1e-3, 0.03), f LU(3, 60) Hz; ``drive_backlash`` a dead band of full
width LU(0.05, 1) x FRm/C2 in the belt deflection; ``c1_drift`` the torsion element's
stiffness C1 changes linearly by LU(2e-3, 0.03) (either sign) over the record (the
torque channel keeps its calibration C1 phi1 at the record start);
``belt_hardening`` C2 d (1 + beta (d/d_ref)^2), beta LU(0.01, 0.3), d_ref = FRm/C2;
``chamber_bearing_stiffness`` an extra C_b phi1 on the chamber under load (absent in
a free decay), C_b = LU(2e-3, 0.05) C1.

The magnitude of a drawn effect is measured by :func:`.generate.generate`
(``Truth.effect_snr``): the rms of the change of the measured torsion moment it
causes (mean removed), over the white torque noise, with the record simulated again
without it and restarted from the record's state at every stick onset and at least
every 50 ms (so a changed period does not accumulate into a phase drift).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .errors import InvalidRequestError
from .layout import BEARING_W_REG
from .spec import (
    ChannelSpec,
    DriveSpec,
    EffectSpec,
    InstrumentSpec,
    RigTruth,
    ScenarioSpec,
    Transition,
)

RPM = 2.0 * math.pi / 60.0
TAB1 = {'I1': 0.0109, 'K1': 0.04034, 'C1': 2338.6, 'I2': 0.0315, 'K2': 4.0, 'C2': 5975.0}
SAMPLE_RATES = (2000.0, 2500.0, 5000.0, 10000.0, 12800.0, 20000.0)
DURATION_RANGE = (4.0, 8.0)
SPEED_RANGE_RPM = (3.0, 80.0)

DRIVE_KINDS: dict[str, float] = {
    'constant': 0.25,
    'startup': 0.15,
    'steps': 0.2,
    'sweep': 0.15,
    'stop': 0.1,
    'combination': 0.15,
}

#: Library families and their forms (the first is the library's own).
LIBRARY_FORMS: dict[str, tuple[str, ...]] = {
    'dwell_time_stiction': ('exp_saturation', 'logarithmic', 'power_law'),
    'frictional_lag': ('first_order', 'time_delay', 'rate_state'),
    'viscous_friction': ('linear', 'power_law'),
    'stribeck_shape': ('stretched_exp', 'rational', 'gaussian'),
    'friction_drift': ('linear', 'saturating', 'random_smooth'),
    'drive_speed_ripple': ('sine', 'harmonics', 'angle_locked'),
    'bearing_friction': ('coulomb', 'coulomb_tanh', 'coulomb_viscous'),
    'torque_offset': ('linear', 'exponential'),
    'torque_sensor_lag': ('first_order', 'second_order'),
}
#: Effects outside the library and their forms.
OUTSIDE_FORMS: dict[str, tuple[str, ...]] = {
    'normal_force_ripple': ('sine',),
    'drive_backlash': ('dead_band',),
    'c1_drift': ('linear',),
    'belt_hardening': ('cubic',),
    'chamber_bearing_stiffness': ('linear',),
}
CATEGORY_WEIGHTS = {'none': 0.25, 'library': 0.6, 'out_of_library': 0.15}

#: Regularising speed of the rate-and-state form [rad/s].
RATE_STATE_VR = 0.05


def lu(rng: np.random.Generator, a: float, b: float) -> float:
    """Return a log-uniform draw in [a, b].

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    a, b : float
        Bounds (> 0).

    Returns
    -------
    float
        The draw.
    """
    return float(math.exp(rng.uniform(math.log(a), math.log(b))))


def _u(rng: np.random.Generator, a: float, b: float) -> float:
    return float(rng.uniform(a, b))


def _pm(rng: np.random.Generator) -> float:
    return 1.0 if rng.random() < 0.5 else -1.0


def _choice(rng: np.random.Generator, weights: dict[str, float]) -> str:
    names = list(weights)
    p = np.array([weights[n] for n in names])
    return names[int(rng.choice(len(names), p=p / p.sum()))]


# --- rig -------------------------------------------------------------------------------


def draw_rig(rng: np.random.Generator) -> RigTruth:
    """Draw the rig around Tab. 1 (ranges in the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.

    Returns
    -------
    RigTruth
        The simulated rig.
    """
    while True:
        I1 = TAB1['I1'] * lu(rng, 0.5, 2.0)
        C1 = TAB1['C1'] * lu(rng, 0.5, 2.0)
        if 40.0 <= math.sqrt(C1 / I1) / (2.0 * math.pi) <= 150.0:
            break
    K1 = 2.0 * lu(rng, 0.001, 0.02) * math.sqrt(C1 * I1)
    I2 = TAB1['I2'] * lu(rng, 0.5, 2.0)
    C2 = TAB1['C2'] * lu(rng, 0.5, 2.0)
    K2 = 2.0 * lu(rng, 0.05, 0.4) * math.sqrt(C2 * I2)
    F_N = 8000.0 * lu(rng, 0.3, 1.5)
    R = 0.08 * _u(rng, 0.8, 1.25)
    mu0 = _u(rng, 0.08, 0.2)
    mu_inf = mu0 * _u(rng, 0.6, 0.95)
    k = lu(rng, 1.0, 5.0)
    return RigTruth(I1, K1, C1, I2, K2, C2, F_N, R, mu0, mu_inf, k)


def rig_class(rig: RigTruth) -> str:
    """Return the rig's class label from its chamber frequency.

    Parameters
    ----------
    rig : RigTruth
        The rig.

    Returns
    -------
    str
        'fn<60', 'fn60-100' or 'fn>100'.
    """
    f = rig.f_chamber
    return 'fn<60' if f < 60.0 else 'fn60-100' if f <= 100.0 else 'fn>100'


# --- drive -----------------------------------------------------------------------------


def _level(rng: np.random.Generator) -> float:
    return lu(rng, *SPEED_RANGE_RPM) * RPM


def _new_level(rng: np.random.Generator, w: float) -> float:
    """Return a level a ratio LU(1.3, 3) up or down from ``w``, inside 3-80 rpm."""
    lo, hi = SPEED_RANGE_RPM[0] * RPM, SPEED_RANGE_RPM[1] * RPM
    r = lu(rng, 1.3, 3.0)
    up = rng.random() < 0.5
    w2 = w * r if up else w / r
    if not lo <= w2 <= hi:
        w2 = w / r if up else w * r
    return min(max(w2, lo), hi)


def _shape(rng: np.random.Generator, p_cosine: float = 0.7) -> str:
    return 'cosine' if rng.random() < p_cosine else 'linear'


class _Profile:
    """Builder of a drive profile: transitions appended in time order."""

    def __init__(self) -> None:
        self.rows: list[Transition] = []
        self.level = 0.0
        self.moves: list[str] = []

    def ramp(self, start: float, duration: float, to: float, shape: str) -> float:
        self.rows.append(Transition(start, duration, to - self.level, shape))
        self.level = to
        return start + duration

    def speed(self, t: float) -> float:
        w = 0.0
        for tr in self.rows:
            x = (t - tr.start) / tr.duration
            if x <= 0.0:
                continue
            if x >= 1.0:
                w += tr.delta
            elif tr.shape == 'linear':
                w += tr.delta * x
            else:
                w += tr.delta * 0.5 * (1.0 - math.cos(math.pi * x))
        return w


def draw_drive(rng: np.random.Generator, duration: float, kind: str | None = None) -> DriveSpec:
    """Draw the drive profile and the record's place in it (kinds in the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    duration : float
        Record duration [s].
    kind : str or None
        Fix the kind (one of :data:`DRIVE_KINDS`); None: drawn.

    Returns
    -------
    DriveSpec
        The profile.

    Raises
    ------
    InvalidRequestError
        For an unknown kind.
    """
    drawn = _choice(rng, DRIVE_KINDS)
    if kind is None:
        kind = drawn
    if kind not in DRIVE_KINDS:
        raise InvalidRequestError(f'unknown drive kind {kind!r} (known: {", ".join(DRIVE_KINDS)})')
    pr = _Profile()
    w_a = _level(rng)
    startup = kind == 'startup' or (kind == 'combination' and rng.random() < 0.5)
    ramp_time: float | None = None
    if startup:
        t_motor = 0.0 if rng.random() < 0.5 else _u(rng, 0.1, 0.8)
        ramp_time = lu(rng, 0.05, 1.5)
        cursor = pr.ramp(t_motor, ramp_time, w_a, _shape(rng, 0.5))
        record_start = 0.0
        pr.moves.append('startup')
    else:
        tr = _u(rng, 0.2, 1.0)
        cursor = pr.ramp(0.0, tr, w_a, 'linear')
        record_start = cursor + _u(rng, 1.0, 2.5)
        cursor = record_start
        pr.moves.append('warm')
    end = record_start + duration
    sweep_nominal = 'mean' if rng.random() < 0.5 else 'start'
    if kind == 'steps':
        moves = ['step'] * int(rng.integers(1, 5))
    elif kind == 'sweep':
        moves = ['sweep']
    elif kind == 'stop':
        moves = ['stop']
    elif kind == 'combination':
        pool = ['step', 'sweep', 'stop']
        n = int(rng.integers(1, 3)) if startup else int(rng.integers(2, 4))
        moves = [pool[int(rng.integers(0, 3))] for _ in range(n)]
        if not startup and len(set(moves)) == 1:
            moves[-1] = pool[(pool.index(moves[0]) + 1) % 3]
    else:
        moves = []
    for i, mv in enumerate(moves):
        left = len(moves) - i
        room = max(end - 0.3 - cursor, 0.4)
        gap = _u(rng, 0.3, max(0.35, room / left))
        start = cursor + gap
        if mv == 'step':
            cursor = pr.ramp(start, lu(rng, 0.01, 0.2), _new_level(rng, pr.level), _shape(rng))
        elif mv == 'sweep':
            ts = lu(rng, 2.0, 12.0)
            to = _new_level(rng, pr.level)
            while max(to, pr.level) / min(to, pr.level) < 1.5:
                to = _new_level(rng, pr.level)
            if i == 0 and not startup:  # the first move may begin before the record
                start = max(record_start + _u(rng, -0.8 * ts, 0.6 * duration), pr.rows[0].duration)
            cursor = pr.ramp(start, ts, to, 'linear')
        else:
            w_before = pr.level
            t_down = pr.ramp(start, _u(rng, 0.1, 1.0), 0.0, _shape(rng))
            t_up = t_down + _u(rng, 0.2, 1.5)
            back = w_before if rng.random() < 0.6 else _level(rng)
            cursor = pr.ramp(t_up, _u(rng, 0.1, 1.0), back, _shape(rng))
        pr.moves.append(mv)
    if startup:
        nominal = w_a
    elif 'sweep' in moves and sweep_nominal == 'mean':
        ts_grid = np.linspace(record_start, end, 200)
        nominal = float(np.mean([pr.speed(float(t)) for t in ts_grid]))
    else:
        nominal = pr.speed(record_start)
    return DriveSpec(
        kind=kind,
        transitions=tuple(pr.rows),
        record_start=record_start,
        nominal_speed=nominal,
        ramp_time=ramp_time,
        moves=tuple(pr.moves),
    )


# --- instrument ------------------------------------------------------------------------


def _hum(rng: np.random.Generator, white: float) -> tuple[tuple[float, ...], ...]:
    """Return (amplitudes, phases) of the hum harmonics 1-5 on one channel."""
    fund = lu(rng, 0.2, 3.0) * white
    amps = [fund]
    for _h in range(2, 6):
        amps.append(fund * lu(rng, 0.05, 0.5) if rng.random() < 0.5 else 0.0)
    phases = tuple(float(p) for p in rng.uniform(0.0, 2.0 * math.pi, 5))
    return tuple(amps), phases


def _channel(
    rng: np.random.Generator,
    *,
    noise: tuple[float, float],
    offset: float,
    p_lag: float,
    lag: tuple[float, float],
    p_second: float,
    hum: float,
    spikes: bool,
) -> ChannelSpec:
    white = lu(rng, *noise)
    gain = 1.0 + _u(rng, -0.03, 0.03)
    off = _u(rng, -offset, offset)
    order, tau, zeta = 0, 0.0, 0.0
    if rng.random() < p_lag:
        tau = lu(rng, *lag)
        order = 2 if rng.random() < p_second else 1
        zeta = _u(rng, 0.5, 0.9) if order == 2 else 0.0
    coloured, level, corner = 'none', 0.0, 0.0
    if rng.random() < 0.25:
        coloured = 'ar1' if rng.random() < 0.5 else 'pink'
        level = lu(rng, 0.3, 2.0) * white
        corner = lu(rng, 2.0, 200.0) if coloured == 'ar1' else 0.1
    amps: tuple[float, ...] = ()
    phases: tuple[float, ...] = ()
    hum_freq = 0.0
    if hum > 0.0 and rng.random() < 0.6:
        amps, phases = _hum(rng, white)
        hum_freq = hum
    n_spikes, scale = 0, 0.0
    if spikes and rng.random() < 0.5:
        n_spikes = int(rng.integers(1, 11))
        scale = lu(rng, 10.0, 100.0)
    return ChannelSpec(
        gain, off, order, tau, zeta, white, coloured, level, corner, hum_freq, amps, phases,
        n_spikes, scale,
    )  # fmt: skip


def draw_instrument(rng: np.random.Generator) -> InstrumentSpec:
    """Draw the three channels' instrument chains (ranges in the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.

    Returns
    -------
    InstrumentSpec
        The chains.
    """
    hum = 0.0
    if rng.random() < 0.35:
        hum = (50.0 if rng.random() < 0.5 else 60.0) * (1.0 + _u(rng, -2e-4, 2e-4))
    spikes = rng.random() < 0.15
    torque = _channel(rng, noise=(0.01, 0.1), offset=0.3, p_lag=0.6, lag=(1e-4, 2e-3),
                      p_second=0.25, hum=hum, spikes=spikes)  # fmt: skip
    accel = _channel(rng, noise=(0.5, 10.0), offset=0.5, p_lag=0.4, lag=(1e-4, 3e-4),
                     p_second=0.0, hum=hum, spikes=spikes)  # fmt: skip
    speed = _channel(rng, noise=(0.001, 0.02), offset=0.05, p_lag=0.85, lag=(3e-4, 8e-3),
                     p_second=0.25, hum=hum, spikes=spikes)  # fmt: skip
    return InstrumentSpec(torque, accel, speed)


# --- hidden effect ---------------------------------------------------------------------


def _effect_category(rng: np.random.Generator, family: str | None) -> tuple[str, str]:
    """Return (category, name) drawn or fixed by ``family``."""
    cat = _choice(rng, CATEGORY_WEIGHTS)
    lib = list(LIBRARY_FORMS)
    out = list(OUTSIDE_FORMS)
    lib_pick = lib[int(rng.integers(0, len(lib)))]
    out_pick = out[int(rng.integers(0, len(out)))]
    if family is None:
        return cat, {'none': 'none', 'library': lib_pick, 'out_of_library': out_pick}[cat]
    if family == 'none':
        return 'none', 'none'
    if family in LIBRARY_FORMS:
        return 'library', family
    if family == 'out_of_library':
        return 'out_of_library', out_pick
    if family.startswith('out_of_library:') and family.split(':', 1)[1] in OUTSIDE_FORMS:
        return 'out_of_library', family.split(':', 1)[1]
    known = ['none', *LIBRARY_FORMS, 'out_of_library', *(f'out_of_library:{n}' for n in out)]
    raise InvalidRequestError(f'unknown family {family!r} (known: {", ".join(known)})')


def draw_effect(
    rng: np.random.Generator,
    rig: RigTruth,
    drive: DriveSpec,
    duration: float,
    family: str | None = None,
) -> EffectSpec:
    """Draw the hidden effect, its form and parameters (module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    rig : RigTruth
        The rig (scales of the magnitudes).
    drive : DriveSpec
        The drive (reference speed).
    duration : float
        Record duration [s].
    family : str or None
        Fix the family: 'none', a library family, 'out_of_library' or
        'out_of_library:<name>'; None: drawn.

    Returns
    -------
    EffectSpec
        The effect.

    Raises
    ------
    InvalidRequestError
        For an unknown family.
    """
    cat, name = _effect_category(rng, family)
    if cat == 'none':
        return EffectSpec('none', 'none', 'none')
    forms = LIBRARY_FORMS[name] if cat == 'library' else OUTSIDE_FORMS[name]
    form = forms[int(rng.integers(0, len(forms)))]
    w_ref = max(drive.nominal_speed, 1.0)
    frm = rig.F_N * rig.R * rig.mu0
    p: dict[str, float] = {}
    comps: list[tuple[float, float, float]] = []
    lib: dict[str, float] = {}
    if name == 'dwell_time_stiction':
        if form == 'exp_saturation':
            p = {'gain': lu(rng, 3e-4, 0.03), 'tau': lu(rng, 2e-3, 0.5)}
            lib = {'stiction_gain': p['gain'], 'stiction_tau': p['tau']}
        elif form == 'logarithmic':
            p = {'b': lu(rng, 1e-4, 0.01), 't0': lu(rng, 5e-4, 0.02)}
        else:
            p = {'c': lu(rng, 3e-4, 0.03), 'n': _u(rng, 0.2, 0.6)}
    elif name == 'frictional_lag':
        if form == 'first_order':
            p = {'tau': lu(rng, 2e-4, 8e-3)}
            lib = {'lag_tau': p['tau']}
        elif form == 'time_delay':
            p = {'delay': lu(rng, 2e-4, 4e-3)}
        else:
            p = {'b': lu(rng, 2e-4, 5e-3), 'D_c': lu(rng, 1e-3, 2e-2), 'v_r': RATE_STATE_VR}
    elif name == 'viscous_friction':
        r = lu(rng, 1e-4, 0.03)
        if form == 'linear':
            p = {'c': r * frm / w_ref}
            lib = {'viscous': p['c']}
        else:
            n = _u(rng, 0.4, 2.0)
            p = {'c': r * frm / w_ref**n, 'n': n}
    elif name == 'stribeck_shape':
        if form == 'stretched_exp':
            p = {'delta': math.exp(_pm(rng) * lu(rng, 0.03, 0.9))}
            lib = {'stribeck_shape': p['delta'] - 1.0}
        else:
            p = {'v_s': lu(rng, 0.3, 3.0) / rig.k}
    elif name == 'friction_drift':
        rel0 = _pm(rng) * lu(rng, 1e-3, 0.05)
        rel_inf = rel0 * _u(rng, 0.3, 1.2)
        if form == 'linear':
            p = {
                'rate_mu0': rel0 * rig.mu0 / duration,
                'rate_mu_inf': rel_inf * rig.mu_inf / duration,
            }
            lib = {'drift_mu0': p['rate_mu0'], 'drift_mu_inf': p['rate_mu_inf']}
        elif form == 'saturating':
            p = {
                'A_mu0': rel0 * rig.mu0,
                'A_mu_inf': rel_inf * rig.mu_inf,
                'tau': lu(rng, 1.0, 20.0),
            }
        else:
            rms = lu(rng, 1e-3, 0.03)
            a = rng.normal(size=3)
            a *= rms / math.sqrt(0.5 * float(np.sum(a * a)))
            for i in range(3):
                comps.append((float(a[i]), lu(rng, 0.05, 0.5), _u(rng, 0.0, 2.0 * math.pi)))
            p = {'rms': rms, 'ratio_mu_inf': _u(rng, 0.5, 1.0)}
    elif name == 'drive_speed_ripple':
        if form == 'sine':
            p = {'amp': lu(rng, 1e-3, 0.05) * w_ref, 'freq': lu(rng, 0.3, 500.0),
                 'phase': _u(rng, 0.0, 2.0 * math.pi)}  # fmt: skip
            comps = [(p['amp'], 1.0, p['phase'])]
            lib = {'ripple_amp': p['amp'], 'ripple_freq': p['freq']}
        elif form == 'harmonics':
            p = {'amp': lu(rng, 1e-3, 0.05) * w_ref, 'freq': lu(rng, 0.3, 200.0)}
            comps = [(p['amp'], 1.0, _u(rng, 0.0, 2.0 * math.pi))]
            for h in range(2, 2 + int(rng.integers(1, 4))):
                comps.append((p['amp'] * _u(rng, 0.1, 0.7), float(h), _u(rng, 0.0, 2.0 * math.pi)))
        else:
            order = float(rng.integers(1, 13))
            p = {'rel_amp': lu(rng, 1e-3, 0.05), 'per_rev': order}
            comps = [(p['rel_amp'], order, _u(rng, 0.0, 2.0 * math.pi))]
            if rng.random() < 0.5:
                comps.append((p['rel_amp'] * _u(rng, 0.1, 0.7), 2.0 * order,
                              _u(rng, 0.0, 2.0 * math.pi)))  # fmt: skip
    elif name == 'bearing_friction':
        mb = lu(rng, 1e-4, 0.02) * frm
        if form == 'coulomb':
            p = {'M_b': mb, 'w_r': BEARING_W_REG}
            lib = {'bearing_moment': mb}
        elif form == 'coulomb_tanh':
            p = {'M_b': mb, 'w_r': lu(rng, 0.005, 0.05)}
        else:
            p = {'M_b': mb, 'w_r': lu(rng, 0.005, 0.05), 'c_b': mb * lu(rng, 0.1, 1.0)}
    elif name == 'torque_offset':
        if form == 'linear':
            p = {'rate': _pm(rng) * lu(rng, 1e-3, 0.1)}
            lib = {'torque_offset_drift': p['rate']}
        else:
            p = {'D': _pm(rng) * lu(rng, 0.01, 0.5), 'tau': lu(rng, 1.0, 20.0)}
    elif name == 'torque_sensor_lag':
        tau = lu(rng, 2e-4, 8e-3)
        if form == 'first_order':
            p = {'tau': tau}
            lib = {'torque_lag_tau': tau}
        else:
            p = {'tau': tau, 'zeta': _u(rng, 0.5, 1.0)}
    elif name == 'normal_force_ripple':
        p = {'a': lu(rng, 1e-3, 0.03), 'freq': lu(rng, 3.0, 60.0), 'phase': _u(rng, 0.0, 6.283)}
    elif name == 'drive_backlash':
        p = {'width': lu(rng, 0.05, 1.0) * frm / rig.C2}
    elif name == 'c1_drift':
        rel = _pm(rng) * lu(rng, 2e-3, 0.03)
        p = {'rate': rel / duration, 'start': drive.record_start}
    elif name == 'belt_hardening':
        p = {'beta': lu(rng, 0.01, 0.3), 'd_ref': frm / rig.C2}
    else:  # chamber_bearing_stiffness
        p = {'C_b': lu(rng, 2e-3, 0.05) * rig.C1}
    return EffectSpec(cat, name, form, p, tuple(comps), lib)


# --- the user's config -----------------------------------------------------------------


def draw_user_rig(
    rng: np.random.Generator, rig: RigTruth, drive: DriveSpec, instrument: InstrumentSpec
) -> tuple[dict[str, float], dict[str, str]]:
    """Draw the RIG.yaml a lab would pass for this record, and its labels.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    rig : RigTruth
        The true rig.
    drive : DriveSpec
        The drive (nominal speed, ramp).
    instrument : InstrumentSpec
        The instrument (true white noise levels).

    Returns
    -------
    tuple
        ``(user_rig, labels)``: the keys of ``config/rig.yaml`` (SI) and the labels
        ``config_shaft`` ('ok'/'off') and ``config_k`` ('identified'/'preset').
    """
    u: dict[str, float] = {}
    for key in ('I1', 'K1', 'C1'):
        u[key] = getattr(rig, key) * (1.0 + _u(rng, -0.01, 0.01))
    shaft_off = rng.random() < 0.4
    for key in ('I2', 'K2', 'C2'):
        err = _pm(rng) * _u(rng, 0.10, 0.25) if shaft_off else _u(rng, -0.02, 0.02)
        u[key] = getattr(rig, key) * (1.0 + err)
    u['F_N'] = rig.F_N * (1.0 + _u(rng, -0.01, 0.01))
    u['R'] = rig.R * (1.0 + _u(rng, -0.01, 0.01))
    mu0 = rig.mu0 * _u(rng, 0.8, 1.25)
    mu_inf = rig.mu_inf * _u(rng, 0.8, 1.25)
    if mu_inf >= mu0:
        mu_inf = 0.9 * mu0
    u['mu0'] = mu0
    u['mu_inf'] = mu_inf
    preset = rng.random() < 0.15
    u['k'] = 2.0 if preset else rig.k * (1.0 + _u(rng, -0.05, 0.05))
    u['nominal_speed'] = drive.nominal_speed
    if drive.ramp_time is not None:
        u['ramp_time'] = drive.ramp_time
    if rng.random() < 0.7:
        u['noise_torque'] = instrument.torque.noise * lu(rng, 0.5, 2.0)
        u['noise_accel'] = instrument.accel.noise * lu(rng, 0.5, 2.0)
        u['noise_speed'] = instrument.speed.noise * lu(rng, 0.5, 2.0)
    labels = {
        'config_shaft': 'off' if shaft_off else 'ok',
        'config_k': 'preset' if preset else 'identified',
    }
    return u, labels


# --- labels and the whole draw ---------------------------------------------------------


def _lag_label(ch: ChannelSpec) -> str:
    if ch.lag_order == 0:
        return 'none'
    ms = ch.lag_tau * 1e3
    size = '<1ms' if ms < 1.0 else '1-4ms' if ms < 4.0 else '>=4ms'
    return f'{size}' + (' 2nd' if ch.lag_order == 2 else '')


def instrument_labels(ins: InstrumentSpec) -> dict[str, str]:
    """Return the instrument condition labels.

    Parameters
    ----------
    ins : InstrumentSpec
        The chains.

    Returns
    -------
    dict[str, str]
        ``speed_lag``, ``torque_lag``, ``accel_lag``, ``hum``, ``coloured_noise``,
        ``spikes``, ``torque_noise`` ('<0.03', '0.03-0.06', '>0.06' N m).
    """
    chans = (ins.torque, ins.accel, ins.speed)
    n = ins.torque.noise
    return {
        'speed_lag': _lag_label(ins.speed),
        'torque_lag': _lag_label(ins.torque),
        'accel_lag': _lag_label(ins.accel),
        'hum': 'yes' if any(c.hum_freq > 0 for c in chans) else 'no',
        'coloured_noise': 'yes' if any(c.coloured != 'none' for c in chans) else 'no',
        'spikes': 'yes' if any(c.spikes > 0 for c in chans) else 'no',
        'torque_noise': '<0.03' if n < 0.03 else '0.03-0.06' if n < 0.06 else '>0.06',
    }


def draw(
    seed: int,
    *,
    duration: float | None = None,
    kind: str | None = None,
    family: str | None = None,
) -> ScenarioSpec:
    """Draw one scenario's specification (cheap: nothing is simulated).

    Parameters
    ----------
    seed : int
        Seed (>= 0); the same seed and options give the same specification.
    duration : float or None
        Record duration [s] (1-60); None: drawn U(4, 8).
    kind : str or None
        Drive kind (:data:`DRIVE_KINDS`); None: drawn.
    family : str or None
        Hidden effect: 'none', a library family (:data:`LIBRARY_FORMS`),
        'out_of_library' or 'out_of_library:<name>'; None: drawn.

    Returns
    -------
    ScenarioSpec
        The specification.

    Raises
    ------
    InvalidRequestError
        For a negative seed, a duration outside 1-60 s, an unknown kind or family.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InvalidRequestError(f'seed must be an integer >= 0, got {seed!r}')
    if duration is not None and not (math.isfinite(duration) and 1.0 <= duration <= 60.0):
        raise InvalidRequestError(f'duration must be 1-60 s, got {duration!r}')
    ss = np.random.SeedSequence(seed)
    r_rig, r_time, r_drive, r_ins, r_eff, r_user = (np.random.default_rng(s) for s in ss.spawn(6))
    rig = draw_rig(r_rig)
    fs = SAMPLE_RATES[int(r_time.integers(0, len(SAMPLE_RATES)))]
    drawn_duration = _u(r_time, *DURATION_RANGE)
    dur = drawn_duration if duration is None else float(duration)
    drive = draw_drive(r_drive, dur, kind)
    ins = draw_instrument(r_ins)
    eff = draw_effect(r_eff, rig, drive, dur, family)
    if eff.name == 'torque_sensor_lag':  # the effect is the torque channel's whole lag
        t = ins.torque
        ins = InstrumentSpec(
            dataclasses.replace(t, lag_order=0, lag_tau=0.0, lag_zeta=0.0), ins.accel, ins.speed
        )
    user, user_labels = draw_user_rig(r_user, rig, drive, ins)
    labels = {
        'rig': rig_class(rig),
        'fs': f'{fs / 1000:g}kHz',
        'drive': drive.kind,
        **instrument_labels(ins),
        **user_labels,
        'category': eff.category,
        'family': eff.truth_name,
        'form': f'{eff.name}:{eff.form}' if eff.category != 'none' else 'none',
        'duration': '<6s' if dur < 6.0 else '>=6s',
    }
    request = {
        k: str(v)
        for k, v in (('duration', duration), ('kind', kind), ('family', family))
        if v is not None
    }
    return ScenarioSpec(seed, dur, fs, rig, drive, ins, eff, user, labels, request)
