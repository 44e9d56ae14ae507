"""Simulate a drawn scenario into a measured record (cached on disk).

:func:`generate` builds the compiled model's tables from a
:class:`.spec.ScenarioSpec`, integrates the rig from the motor's start (test time 0)
through the record (:func:`.integrator.integrate`, default ``rtol = 1e-11``: restarted
at every stick onset and every 50 ms from the same states, as a segment-wise fit
restarts its model, a ten times tighter run agrees to below 1e-4 of the noise on every
channel; over a whole record the limit cycle's phase, which nothing restores, drifts
by up to about 1e-3 of the torque noise), applies the instrument chains and, for a
hidden effect, measures its size ``effect_snr`` against a second run without it
(restarted from the first run's state at every stick onset and at least every
50 ms). Records are cached as ``.cache/scenarios/<version>/<seed>.npz`` under the
repository (``TRIBO_SCENARIO_CACHE`` moves the root), so a second call is a file read.
"""

from __future__ import annotations

import json
import math
import os
import time as _time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from . import layout as L  # noqa: N812
from .errors import CacheError, SimulationError
from .instrument import measure
from .integrator import CHATTER, STEP_UNDERFLOW, integrate
from .scenario import Scenario, Truth
from .spec import ChannelSpec, EffectSpec, ScenarioSpec

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Default relative tolerance of the integrator [-].
DEFAULT_RTOL = 1e-11
#: Longest stretch without a restart of the effect-free comparison run [s].
RESTART_EVERY = 0.05
#: Largest integration step [s].
HMAX = 5e-4


def default_cache_dir() -> Path:
    """Return the cache root: ``$TRIBO_SCENARIO_CACHE`` or ``<repo>/.cache/scenarios``.

    Returns
    -------
    Path
        The directory (its ``<version>`` subdirectory holds the records).
    """
    env = os.environ.get('TRIBO_SCENARIO_CACHE')
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / '.cache' / 'scenarios'


@dataclass(frozen=True)
class ModelTables:
    """The compiled model's inputs (:mod:`.layout`): parameters, form codes, tables.

    ``TR`` drive transitions (start, duration, delta, shape), ``RIP`` ripple and ``DR``
    drift components, ``boundaries`` the profile's corner times [s].
    """

    P: FloatArray
    Q: IntArray
    TR: FloatArray
    RIP: FloatArray
    DR: FloatArray
    boundaries: FloatArray


def _set_filter(P: FloatArray, Q: IntArray, ch: ChannelSpec, q: int, pw: int, pz: int) -> None:
    Q[q] = ch.lag_order
    if ch.lag_order:
        P[pw] = 1.0 / ch.lag_tau
        P[pz] = ch.lag_zeta


def model_tables(spec: ScenarioSpec, effect: EffectSpec | None = None) -> ModelTables:
    """Build the compiled model's tables of a scenario.

    Parameters
    ----------
    spec : ScenarioSpec
        The scenario.
    effect : EffectSpec or None
        The hidden effect to build in (None: the scenario's own; pass
        ``EffectSpec('none', 'none', 'none')`` for the model without it).

    Returns
    -------
    ModelTables
        The tables.
    """
    eff = spec.effect if effect is None else effect
    rig = spec.rig
    P = np.zeros(L.NP)
    Q = np.zeros(L.NQ, dtype=np.int64)
    P[L.P_I1], P[L.P_K1], P[L.P_C1] = rig.I1, rig.K1, rig.C1
    P[L.P_I2], P[L.P_K2], P[L.P_C2] = rig.I2, rig.K2, rig.C2
    P[L.P_FN], P[L.P_R] = rig.F_N, rig.R
    P[L.P_MU0], P[L.P_MUINF], P[L.P_K] = rig.mu0, rig.mu_inf, rig.k
    P[L.P_C1CAL] = rig.C1
    ins = spec.instrument
    _set_filter(P, Q, ins.torque, L.Q_TF, L.P_TF_W, L.P_TF_Z)
    _set_filter(P, Q, ins.accel, L.Q_AF, L.P_AF_W, L.P_AF_Z)
    _set_filter(P, Q, ins.speed, L.Q_SF, L.P_SF_W, L.P_SF_Z)
    TR = np.array(
        [(t.start, t.duration, t.delta, 0.0 if t.shape == 'linear' else 1.0)
         for t in spec.drive.transitions],
        dtype=np.float64,
    ).reshape(-1, 4)  # fmt: skip
    bounds = np.unique(np.concatenate((TR[:, 0], TR[:, 0] + TR[:, 1])))
    RIP = np.zeros((0, 3))
    DR = np.zeros((0, 3))
    p = eff.params
    comps = np.array(eff.components, dtype=np.float64).reshape(-1, 3)
    n, form = eff.name, eff.form
    if n == 'dwell_time_stiction':
        Q[L.Q_DWELL] = L.DWELL_FORMS[form]
        a, b = {'exp_saturation': ('gain', 'tau'), 'logarithmic': ('b', 't0'),
                'power_law': ('c', 'n')}[form]  # fmt: skip
        P[L.P_DW_A], P[L.P_DW_B] = p[a], p[b]
    elif n == 'frictional_lag':
        Q[L.Q_LAG] = L.LAG_FORMS[form]
        if form == 'first_order':
            P[L.P_LAG_T] = p['tau']
        elif form == 'time_delay':
            P[L.P_LAG_T] = p['delay']
        else:
            P[L.P_LAG_B], P[L.P_LAG_DC], P[L.P_LAG_VR] = p['b'], p['D_c'], p['v_r']
    elif n == 'viscous_friction':
        Q[L.Q_VISC] = L.VISCOUS_FORMS[form]
        P[L.P_VIS_C] = p['c']
        P[L.P_VIS_N] = p.get('n', 1.0)
    elif n == 'stribeck_shape':
        Q[L.Q_STRIB] = L.STRIBECK_FORMS[form]
        P[L.P_STR_D] = p.get('delta', 1.0)
        P[L.P_STR_VS] = p.get('v_s', 1.0)
    elif n == 'friction_drift':
        Q[L.Q_DRIFT] = L.DRIFT_FORMS[form]
        if form == 'linear':
            P[L.P_DR_A0], P[L.P_DR_AINF] = p['rate_mu0'], p['rate_mu_inf']
        elif form == 'saturating':
            P[L.P_DR_A0], P[L.P_DR_AINF], P[L.P_DR_TAU] = p['A_mu0'], p['A_mu_inf'], p['tau']
        else:
            P[L.P_DR_AINF] = p['ratio_mu_inf']
            DR = comps
    elif n == 'drive_speed_ripple':
        Q[L.Q_RIPPLE] = L.RIPPLE_FORMS[form]
        P[L.P_RIP_F] = p.get('freq', 0.0)
        RIP = comps
    elif n == 'bearing_friction':
        Q[L.Q_BEARING] = L.BEARING_FORMS[form]
        P[L.P_BR_M], P[L.P_BR_WR] = p['M_b'], p['w_r']
        P[L.P_BR_C] = p.get('c_b', 0.0)
    elif n == 'torque_sensor_lag':
        Q[L.Q_TF] = 1 if form == 'first_order' else 2
        P[L.P_TF_W] = 1.0 / p['tau']
        P[L.P_TF_Z] = p.get('zeta', 0.0)
    elif n == 'normal_force_ripple':
        Q[L.Q_FNRIP] = 1
        P[L.P_FNR_A], P[L.P_FNR_F], P[L.P_FNR_P] = p['a'], p['freq'], p['phase']
    elif n == 'drive_backlash':
        Q[L.Q_BELT] = L.BELT_FORMS['drive_backlash']
        P[L.P_BL_B] = p['width']
    elif n == 'belt_hardening':
        Q[L.Q_BELT] = L.BELT_FORMS['belt_hardening']
        P[L.P_BH_BETA], P[L.P_BH_DREF] = p['beta'], p['d_ref']
    elif n == 'c1_drift':
        Q[L.Q_C1DRIFT] = L.C1DRIFT_FORMS['linear']
        P[L.P_C1D_D], P[L.P_C1D_T0] = p['rate'], p['start']
    elif n == 'chamber_bearing_stiffness':
        P[L.P_CB] = p['C_b']
    return ModelTables(P, Q, TR, RIP, DR, bounds)


def initial_state(tab: ModelTables) -> tuple[FloatArray, FloatArray]:
    """Return the state and mode at the motor's start: at rest, undeflected, sticking.

    Parameters
    ----------
    tab : ModelTables
        The model.

    Returns
    -------
    tuple of ndarray
        ``(y0, m0)``.
    """
    y0 = np.zeros(L.NY)
    m0 = np.zeros(L.NM)
    m0[L.STUCK] = 1.0
    m0[L.SDIR] = 1.0
    if tab.Q[L.Q_LAG] == 1:
        y0[L.Z] = tab.P[L.P_MU0]
    elif tab.Q[L.Q_LAG] == 3:  # the state of long rest with the regularising speed
        y0[L.Z] = math.log(tab.P[L.P_LAG_DC] / tab.P[L.P_LAG_VR])
    return y0, m0


def state_scale(spec: ScenarioSpec) -> FloatArray:
    """Return the typical magnitude of each state entry (absolute tolerance = rtol x it).

    Parameters
    ----------
    spec : ScenarioSpec
        The scenario.

    Returns
    -------
    ndarray
        Scales in the units of the state (:mod:`.layout`).
    """
    r = spec.rig
    frm = r.F_N * r.R * r.mu0
    w = max(max(abs(t.delta) for t in spec.drive.transitions), 1.0)
    s = np.empty(L.NY)
    s[L.PHI1] = frm / r.C1
    s[L.W1] = w
    s[L.DEFL] = frm / r.C2
    s[L.W2] = w
    s[L.RHO] = 1e-3
    s[L.Z] = 0.1
    s[L.TF] = frm
    s[L.TFD] = frm * 1e3
    s[L.AF] = frm / r.I1
    s[L.AFD] = frm / r.I1 * 1e3
    s[L.SF] = w
    s[L.SFD] = w * 1e3
    return s


@dataclass(frozen=True)
class Traces:
    """The true (noise-free) channels of one simulation at the record's samples.

    ``torque`` after its channel filter [N m], ``torque_raw`` = C1 phi1 before it,
    ``accel`` [rad/s^2] and ``speed`` [rad/s] after their filters, ``accel_raw`` the
    chamber's acceleration w1' before its filter [rad/s^2], ``stick`` the stick
    flag, ``friction_moment`` [N m], ``states`` (n, NY) and ``modes`` (n, NM), ``info``
    (status, accepted, rejected steps, events).
    """

    torque: FloatArray
    torque_raw: FloatArray
    accel: FloatArray
    speed: FloatArray
    accel_raw: FloatArray
    stick: NDArray[np.bool_]
    friction_moment: FloatArray
    states: FloatArray
    modes: FloatArray
    info: IntArray


def sample_times(spec: ScenarioSpec) -> FloatArray:
    """Return the record's sample times in test time [s].

    Parameters
    ----------
    spec : ScenarioSpec
        The scenario.

    Returns
    -------
    ndarray
        ``record_start + i/fs``.
    """
    n = round(spec.duration * spec.fs)
    return spec.drive.record_start + np.arange(n) / spec.fs


def _channels(tab: ModelTables, Y: FloatArray, ACC: FloatArray) -> tuple[FloatArray, ...]:
    raw = tab.P[L.P_C1CAL] * Y[:, L.PHI1]
    torque = Y[:, L.TF].copy() if tab.Q[L.Q_TF] else raw
    accel = Y[:, L.AF].copy() if tab.Q[L.Q_AF] else ACC
    speed = Y[:, L.SF].copy() if tab.Q[L.Q_SF] else Y[:, L.W2].copy()
    return torque, raw, accel, speed


def simulate_truth(
    spec: ScenarioSpec,
    *,
    effect: EffectSpec | None = None,
    rtol: float = DEFAULT_RTOL,
    restart_from: Traces | None = None,
) -> Traces:
    """Integrate the rig of a scenario and return its true channels at the samples.

    Parameters
    ----------
    spec : ScenarioSpec
        The scenario.
    effect : EffectSpec or None
        Hidden effect (None: the scenario's own).
    rtol : float
        Relative tolerance of the integrator [-].
    restart_from : Traces or None
        A run whose state replaces this run's at its stick onsets and at least every
        :data:`RESTART_EVERY` (this run then covers only the record). For another
        model (``effect``) the state is mapped: the ripple's drive angle leaves the belt
        deflection and the friction memory starts afresh.

    Returns
    -------
    Traces
        The true channels.

    Raises
    ------
    SimulationError
        If the integrator fails (step underflow, event chatter).
    """
    tab = model_tables(spec, effect)
    t_out = sample_times(spec)
    y0, m0 = initial_state(tab)
    t0 = 0.0
    idx = np.zeros(0, dtype=np.int64)
    ry = np.zeros((0, L.NY))
    rm = np.zeros((0, L.NM))
    if restart_from is not None:
        idx = restart_indices(restart_from.stick, spec.fs)
        ry = restart_from.states[idx].copy()
        if effect is not None and effect != spec.effect:  # another model: map the state
            ry[:, L.DEFL] += ry[:, L.RHO]  # phi2 - phi0 without the ripple's angle
            ry[:, L.RHO] = 0.0
            ry[:, L.Z] = initial_state(tab)[0][L.Z]
        rm = restart_from.modes[idx].copy()
        t0 = float(t_out[0])
        y0, m0 = ry[0].copy(), rm[0].copy()
    Y, MODE, ACC, FM, info = integrate(
        tab.P, tab.Q, tab.TR, tab.RIP, tab.DR, y0, m0, t0, t_out, tab.boundaries, idx, ry, rm,
        state_scale(spec), rtol, HMAX,
    )  # fmt: skip
    if info[0] == STEP_UNDERFLOW:
        raise SimulationError(f'seed {spec.seed}: step size underflow (stiff or discontinuous)')
    if info[0] == CHATTER:
        raise SimulationError(f'seed {spec.seed}: stick/slip switching chatters')
    torque, raw, accel, speed = _channels(tab, Y, ACC)
    return Traces(torque, raw, accel, speed, ACC, MODE[:, L.STUCK] > 0.5, FM, Y, MODE, info)


def restart_indices(stick: NDArray[np.bool_], fs: float) -> IntArray:
    """Return the samples at which the comparison run restarts.

    The first sample, every stick onset and enough samples between that no stretch
    exceeds :data:`RESTART_EVERY`.

    Parameters
    ----------
    stick : ndarray of bool
        The stick flag of the reference run.
    fs : float
        Sample rate [Hz].

    Returns
    -------
    ndarray of int
        Sorted sample indices.
    """
    n = stick.size
    onsets = np.flatnonzero(stick[1:] & ~stick[:-1]) + 1
    step = max(int(RESTART_EVERY * fs), 1)
    pts = [0]
    for k in (*onsets.tolist(), n):
        while k - pts[-1] > step:
            pts.append(pts[-1] + step)
        if k < n and k != pts[-1]:
            pts.append(k)
    return np.asarray(pts, dtype=np.int64)


def offset_drift(spec: ScenarioSpec, t: FloatArray) -> FloatArray:
    """Return the hidden torque offset drift at test times ``t`` [N m] (zeros if none).

    Parameters
    ----------
    spec : ScenarioSpec
        The scenario.
    t : ndarray
        Test times [s].

    Returns
    -------
    ndarray
        Offset [N m].
    """
    e = spec.effect
    if e.name != 'torque_offset':
        return np.zeros_like(t)
    if e.form == 'linear':
        return np.asarray(e.params['rate'] * t, dtype=np.float64)
    return np.asarray(e.params['D'] * (1.0 - np.exp(-t / e.params['tau'])), dtype=np.float64)


def _snr(delta: FloatArray, noise: float) -> float:
    d = delta - float(np.mean(delta))
    return float(np.sqrt(np.mean(d * d))) / noise


def motion_label(stick: NDArray[np.bool_], fs: float) -> str:
    """Return the record's motion from its true stick flag.

    'stick-slip' when at least 80 % of its 0.5 s windows hold a stick of >= 1 ms,
    'sliding' (slip-slip or steady) when at most 20 % do, else 'mixed'.

    Parameters
    ----------
    stick : ndarray of bool
        Stick flag per sample.
    fs : float
        Sample rate [Hz].

    Returns
    -------
    str
        The label.
    """
    w = max(int(0.5 * fs), 1)
    need = max(int(1e-3 * fs), 1)
    n_win = max(stick.size // w, 1)
    hit = 0
    for i in range(n_win):
        s = stick[i * w : (i + 1) * w].astype(np.int64)
        if s.size == 0:
            continue
        # longest run of ones in the window
        edges = np.diff(np.concatenate(([0], s, [0])))
        runs = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
        hit += int(runs.size > 0 and int(runs.max()) >= need)
    frac = hit / n_win
    return 'stick-slip' if frac >= 0.8 else 'sliding' if frac <= 0.2 else 'mixed'


def snr_bin(snr: float, category: str) -> str:
    """Return the magnitude label of an effect's size (``effect_snr``).

    Parameters
    ----------
    snr : float
        The effect's rms torque change over the white torque noise [-].
    category : str
        The effect's category ('none' gives 'none').

    Returns
    -------
    str
        '<1', '1-3', '3-10', '10-30' or '>=30'.
    """
    if category == 'none':
        return 'none'
    for edge, name in ((1.0, '<1'), (3.0, '1-3'), (10.0, '3-10'), (30.0, '10-30')):
        if snr < edge:
            return name
    return '>=30'


def _make(
    spec: ScenarioSpec, rtol: float
) -> tuple[dict[str, NDArray[np.generic]], dict[str, object]]:
    """Simulate and measure a scenario; returns the arrays and the metadata."""
    t_start = _time.perf_counter()
    tr = simulate_truth(spec, rtol=rtol)
    t_test = sample_times(spec)
    eff = spec.effect
    sigma = spec.instrument.torque.noise
    gain = spec.instrument.torque.gain
    drift = offset_drift(spec, t_test)
    snr = 0.0
    if eff.name == 'torque_offset':
        snr = _snr(drift, sigma)
    elif eff.name == 'torque_sensor_lag':
        snr = _snr(gain * (tr.torque - tr.torque_raw), sigma)
    elif eff.category != 'none':
        ref = simulate_truth(spec, effect=EffectSpec('none', 'none', 'none'), rtol=rtol,
                             restart_from=tr)  # fmt: skip
        snr = _snr(gain * (tr.torque - ref.torque), sigma)
    ss = np.random.SeedSequence(spec.seed).spawn(7)[6]
    r_t, r_a, r_s = (np.random.default_rng(s) for s in ss.spawn(3))
    ins = spec.instrument
    torque, n_t = measure(tr.torque, ins.torque, t_test, spec.fs, r_t)
    torque += drift
    accel, n_a = measure(tr.accel, ins.accel, t_test, spec.fs, r_a)
    speed, n_s = measure(tr.speed, ins.speed, t_test, spec.fs, r_s)
    arrays: dict[str, NDArray[np.generic]] = {
        'torsion_moment': torque,
        'angular_acceleration': accel,
        'speed': speed,
        'stick': tr.stick.astype(np.uint8),
    }
    meta: dict[str, object] = {
        'digest': spec.digest(),
        'effect_snr': snr,
        'noise_rms': {'torque': n_t, 'accel': n_a, 'speed': n_s},
        'motion': motion_label(tr.stick, spec.fs),
        'gen_seconds': _time.perf_counter() - t_start,
        'steps': int(tr.info[1]),
        'events': int(tr.info[3]),
    }
    return arrays, meta


def _scenario(
    spec: ScenarioSpec,
    arrays: dict[str, NDArray[np.generic]],
    meta: dict[str, object],
    cached: bool,
) -> Scenario:
    e = spec.effect
    snr = float(meta['effect_snr'])  # type: ignore[arg-type]
    noise = meta['noise_rms']
    assert isinstance(noise, dict)
    truth = Truth(
        effect=e.truth_name,
        category=e.category,
        name=e.name,
        form=e.form,
        params=dict(e.params),
        library_params=dict(e.library_params),
        own_form=e.own_form,
        effect_snr=snr,
        noise_rms={str(k): float(v) for k, v in noise.items()},
    )
    labels = {**spec.labels, 'motion': str(meta['motion']), 'magnitude': snr_bin(snr, e.category)}
    n = arrays['torsion_moment'].size
    return Scenario(
        time=np.arange(n) / spec.fs,
        torsion_moment=np.asarray(arrays['torsion_moment'], dtype=np.float64),
        angular_acceleration=np.asarray(arrays['angular_acceleration'], dtype=np.float64),
        speed=np.asarray(arrays['speed'], dtype=np.float64),
        fs=spec.fs,
        spec=spec,
        truth=truth,
        user_rig=dict(spec.user_rig),
        labels=labels,
        stick=np.asarray(arrays['stick']) > 0,
        gen_seconds=float(meta['gen_seconds']),  # type: ignore[arg-type]
        from_cache=cached,
    )


def _read_cache(path: Path, spec: ScenarioSpec) -> Scenario | None:
    """Return the cached scenario, or None if absent or made from another specification."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z['meta']))
            arrays = {k: np.array(z[k]) for k in z.files if k != 'meta'}
    except (OSError, ValueError, KeyError) as exc:
        raise CacheError(f'{path}: unreadable cached record ({exc}); delete it') from exc
    if meta.get('digest') != spec.digest():
        return None
    return _scenario(spec, arrays, meta, True)


def generate(
    spec: ScenarioSpec,
    *,
    cache_dir: Path | None = None,
    use_cache: bool = True,
    rtol: float = DEFAULT_RTOL,
) -> Scenario:
    """Simulate a scenario (or read it from the cache).

    Parameters
    ----------
    spec : ScenarioSpec
        The drawn specification (:func:`.space.draw`).
    cache_dir : Path or None
        Cache root (None: :func:`default_cache_dir`); records live in
        ``<root>/<version>/``.
    use_cache : bool
        Read and write the cache (False: always simulate, write nothing).
    rtol : float
        Relative tolerance of the integrator [-] (records of another tolerance are
        not cached).

    Returns
    -------
    Scenario
        The record with its truth and labels.

    Raises
    ------
    SimulationError
        If the integrator fails.
    CacheError
        If a cached file is unreadable or cannot be written.
    """
    cacheable = use_cache and rtol == DEFAULT_RTOL
    path = (cache_dir or default_cache_dir()) / spec.version / spec.cache_name()
    if cacheable:
        hit = _read_cache(path, spec)
        if hit is not None:
            return hit
    arrays, meta = _make(spec, rtol)
    if cacheable:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f'.{path.name}.{os.getpid()}.tmp.npz')
            np.savez(
                tmp,
                meta=np.array(json.dumps(meta)),
                torsion_moment=arrays['torsion_moment'],
                angular_acceleration=arrays['angular_acceleration'],
                speed=arrays['speed'],
                stick=arrays['stick'],
            )
            os.replace(tmp, path)
        except OSError as exc:
            raise CacheError(f'{path}: cannot write the cached record: {exc}') from exc
    return _scenario(spec, arrays, meta, False)


__all__ = [
    'DEFAULT_RTOL',
    'ModelTables',
    'Traces',
    'default_cache_dir',
    'generate',
    'model_tables',
    'simulate_truth',
]
