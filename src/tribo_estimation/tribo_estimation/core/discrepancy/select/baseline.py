"""The baseline of one record and the facts the identifiability verdict needs.

:func:`instrument_record` identifies and compensates the torsion amplifier's lag;
:func:`fit_baseline` identifies the speed-sensor model and fits the paper's model
(Equ. 1-8: ``mu0``, ``mu_inf``) with channel weights from its residuals;
:func:`judge_candidates` gives every candidate's identifiability verdict
(:mod:`..identify`) from its fit and the record's facts (:func:`record_facts`);
:func:`drive_report` is the measured drive profile of ``discrepancy.json``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from tribo_estimation.core.model import RigParams

from .. import candidates as cand_lib
from ..candidates import StartContext
from ..fitting import (
    CHANNELS,
    MU0,
    MU_INF,
    SPEED_LAG,
    SPEED_OFFSET,
    Problem,
    Record,
    SimulatedRecord,
    SpeedSensor,
    TorsionLag,
    identify_speed_sensor,
    identify_torsion_lag,
    torsion_compensated_record,
)
from ..identify import GaussNewton, Identifiability, fit_stability, gauss_newton, identifiability
from ..stats import FloatArray, noise_floor, stick_durations
from .results import Progress, SelectionSettings
from .scoring import Selector


def baseline_starts(problem: Problem) -> list[dict[str, float]]:
    """Return start values of the baseline fit.

    ``mu0`` from the torsion moment at the measured breakaways (the peak of each
    segment), ``mu_inf`` a fraction of it (Equ. 8).

    Parameters
    ----------
    problem : Problem
        The record's fit problem.

    Returns
    -------
    list[dict[str, float]]
        Three starts ``{'mu0', 'mu_inf'}`` (-).
    """
    rec = problem.record
    fnr = problem.rig.F_N * problem.rig.R
    seg = problem.segments
    # breakaway ~ the torsion moment's peak in each segment's first half
    peaks = []
    for a, b in zip(seg.start, seg.stop, strict=True):
        peaks.append(float(np.max(np.abs(rec.torsion_moment[a:b]))))
    m_s = float(np.median(peaks)) if peaks else float(np.max(np.abs(rec.torsion_moment)))
    mu0 = max(m_s / fnr, 1e-3) if fnr > 0 else MU0.initial
    return [{'mu0': mu0, 'mu_inf': f * mu0} for f in (0.7, 0.85, 0.95)]


def start_context(problem: Problem, sim: SimulatedRecord) -> StartContext:
    """Return what candidates see to choose their start values.

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    sim : SimulatedRecord
        The baseline simulation.

    Returns
    -------
    StartContext
        The baseline's residuals, nominal drive speed [rad/s], stick durations [s]
        and the friction-moment scale [N m].
    """
    rec = problem.record
    cov = sim.covered
    stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
    return StartContext(
        time=rec.time[cov],
        fs=rec.fs,
        torque=(rec.torsion_moment - sim.torsion_moment)[cov],
        speed=(rec.speed - sim.speed)[cov],
        nominal_speed=problem.drive_estimate.level,
        stick_durations=stick_durations(stick[cov], rec.fs),
        friction_moment_scale=float(np.median(np.abs(rec.torsion_moment))),
    )


def instrument_record(
    record: Record, rig: RigParams, st: SelectionSettings, say: Progress
) -> tuple[Record, TorsionLag]:
    """Identify and compensate the torsion amplifier's lag.

    The instrument model's torsion part, before the segments' states are built
    (:func:`..fitting.identify_torsion_lag`).

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (Tab. 1).
    st : SelectionSettings
        Settings (``torsion_lag`` switches the identification on).
    say : Progress
        Receiver of progress messages.

    Returns
    -------
    tuple[Record, TorsionLag]
        The compensated record and the identification.
    """
    tq = identify_torsion_lag(record, rig, enabled=st.torsion_lag)
    if st.torsion_lag:
        say(
            f'torsion amplifier: lag {1e3 * tq.tau:.3g} +- {1e3 * tq.se:.2g} ms'
            + (' (compensated)' if tq.used > 0.0 else ' (not used)')
        )
    return torsion_compensated_record(record, rig, tq.used), tq


@dataclass(frozen=True)
class BaselineFit:
    """The baseline of one record (:func:`fit_baseline`).

    Parameters
    ----------
    values : dict of str to float
        mu0, mu_inf (Equ. 8) and the instrument model's values (SI).
    sim : SimulatedRecord
        Its simulation.
    instrument : dict of str to object
        The ``instrument`` report of ``discrepancy.json``.
    sensor : SpeedSensor
        The speed-sensor identification from the stick phases (with the drift check
        of the stick kinematics, :meth:`.fitting.SpeedSensor.drifting`).
    """

    values: dict[str, float]
    sim: SimulatedRecord
    instrument: dict[str, object]
    sensor: SpeedSensor


def fit_baseline(pb: Problem, st: SelectionSettings, say: Progress) -> BaselineFit:
    """Fit the baseline of one record.

    The speed-sensor model from the stick phases (held fixed while the starts are
    screened), the paper's model (Equ. 1-8: mu0, mu_inf) from several starts, channel
    weights from its residuals (never above 1/noise floor) and a polished refit (with
    the speed-sensor lag and offset free when the lag is significant; they then stay
    free in every effect's fit: :attr:`.fitting.Problem.free_instrument`).

    Parameters
    ----------
    pb : Problem
        The record's fit problem; its residual weights and free instrument
        parameters are set here.
    st : SelectionSettings
        Settings (evaluation budgets).
    say : Progress
        Receiver of progress messages.

    Returns
    -------
    BaselineFit
        The values (with the instrument model), the simulation, the instrument
        report of ``discrepancy.json`` and the speed-sensor identification.
    """
    sel = Selector(pb, st, say)
    record, rig = pb.record, pb.rig
    # the instrument model (speed-sensor lag and offset) is identified from the stick
    # phases before any fit (friction-free)
    seg = pb.segments
    sensor = identify_speed_sensor(record, rig, seg.stick_phases())
    used = sensor.values()
    speed_lag: dict[str, object] = {
        'value': sensor.tau,
        'se': sensor.tau_se,
        'unit': 's',
        'used': used['speed_lag_tau'],
    }
    speed_offset: dict[str, object] = {
        'value': sensor.offset,
        'se': sensor.offset_se,
        'unit': 'rad/s',
        'used': used['speed_offset'],
    }
    instrument: dict[str, object] = {
        'speed_lag_tau': speed_lag,
        'speed_offset': speed_offset,
        'speed_mismatch_drift': sensor.drift_report(),
        'stick_samples': sensor.n,
    }
    say(
        f'speed sensor: lag {1e3 * sensor.tau:.3g} +- {1e3 * sensor.tau_se:.2g} ms, offset '
        f'{sensor.offset:.3g} +- {sensor.offset_se:.2g} rad/s; stick kinematics drift '
        f'{100 * sensor.drift:.2g} +- {100 * sensor.drift_se:.2g} %'
    )
    say(
        f'{pb.segments.n} segments in {pb.segments.n_blocks} blocks; fitting the baseline '
        '(paper model: mu0, mu_inf)'
    )
    base_vals = sel.fit_best(
        [MU0, MU_INF], [{**sensor.values(), **st0} for st0 in baseline_starts(pb)]
    )
    base_sim = pb.simulate(base_vals)
    floors: dict[str, float] = {}
    for ch in CHANNELS:
        m = pb.measured(ch)[base_sim.covered]
        floors[ch] = max(noise_floor(m), 1e-3 * float(np.std(m)), 1e-12)
    pb.set_residual_weights(base_sim, floors)
    # the instrument model (speed-sensor lag and offset) joins the baseline before
    # any effect is tried.  With a significant speed-sensor lag, lag and offset are
    # refined jointly (the stick regression's lag is ~2 % off and its offset, correlated
    # with it, biased) and stay free in every effect's fit: refined without the missing
    # effect they absorb part of it (a frictional lag moved the offset 0.17 rad/s), and
    # an effect fitted against them held there fails (frictional lag 0.73 vs 0.05 N m)
    lag_free = (SPEED_LAG, SPEED_OFFSET) if used['speed_lag_tau'] > 0.0 else ()
    pb.free_instrument = lag_free
    base_fit = pb.fit([MU0, MU_INF, *lag_free], base_vals, max_nfev=st.max_nfev)
    base_vals = base_fit.values
    for p, entry in zip(lag_free, (speed_lag, speed_offset), strict=False):
        entry['used'] = base_vals[p.name]
        entry['se_joint'] = base_fit.se.get(p.name, math.nan)
    base_sim = pb.simulate(base_vals)
    return BaselineFit(base_vals, base_sim, instrument, sensor)


def block_speeds(pb: Problem) -> list[dict[str, float]]:
    """Return the mean drive speed of every time block.

    Parameters
    ----------
    pb : Problem
        The record's fit problem.

    Returns
    -------
    list[dict[str, float]]
        Per block: ``block`` index, ``t_start`` / ``t_end`` [s], mean drive speed
        ``w0`` [rad/s] of the measured profile.
    """
    de = pb.drive_estimate
    seg = pb.segments
    t = pb.record.time
    blocks = []
    for b in range(seg.n_blocks):
        m = seg.block == b
        t0 = float(t[seg.start[m][0]])
        t1 = float(t[min(int(seg.stop[m][-1]), t.size - 1)])
        blocks.append({'block': float(b), 't_start': t0, 't_end': t1, 'w0': de.mean_speed(t0, t1)})
    return blocks


def drive_report(pb: Problem) -> dict[str, object]:
    """Return the measured drive profile for ``discrepancy.json``.

    Parameters
    ----------
    pb : Problem
        The record's fit problem.

    Returns
    -------
    dict[str, object]
        Level and nominal speed [rad/s], relative mismatch [-] and its warning, the
        knots of the piecewise-linear profile [s, rad/s] and the mean drive speed
        used per time block [rad/s].
    """
    de = pb.drive_estimate
    blocks: list[dict[str, object]] = [
        {'block': int(b['block']), 't_start': b['t_start'], 't_end': b['t_end'], 'w0': b['w0']}
        for b in block_speeds(pb)
    ]
    return {
        'level': de.level,
        'nominal': de.nominal,
        'mismatch': de.mismatch,
        'mismatched': de.mismatched,
        'warning': de.warning() or '',
        'from_record': de.from_record,
        'knot_time': [float(x) for x in de.knot_time],
        'knot_speed': [float(x) for x in de.knot_speed],
        'blocks': blocks,
    }


def record_facts(pb: Problem, sim: SimulatedRecord) -> tuple[FloatArray, FloatArray, float]:
    """Return the physical facts of a fitted record for the identifiability verdict.

    Parameters
    ----------
    pb : Problem
        The record's fit problem.
    sim : SimulatedRecord
        Its baseline simulation (stick phases when the segments have none).

    Returns
    -------
    tuple[FloatArray, FloatArray, float]
        Durations [s] of the complete stick phases, mean drive speed per time block
        [rad/s] and the record length [s].
    """
    seg = pb.segments
    n = pb.record.time.size
    if seg.run_start is not None and seg.run_stop is not None:
        ra, rb = np.unique(np.column_stack([seg.run_start, seg.run_stop]), axis=0).T
        keep = (ra > 0) & (rb < n)
        durations = ((rb[keep] - ra[keep]) / pb.record.fs).astype(np.float64)
    else:
        durations = stick_durations(np.nan_to_num(sim.stick, nan=0.0) > 0.5, pb.record.fs)
    speeds = np.asarray([b['w0'] for b in block_speeds(pb)], dtype=np.float64)
    t = pb.record.time
    return durations, speeds, float(t[-1] - t[0])


def judge_candidates(
    pb: Problem,
    base_sim: SimulatedRecord,
    fits: Mapping[str, Mapping[str, float]],
    *,
    corr_time: float = 1e-3,
    gains: Mapping[str, float] | None = None,
    profile_se: Mapping[str, float] | None = None,
    min_gain: float = 0.0,
) -> dict[str, Identifiability]:
    """Give every candidate's identifiability verdict (:func:`..identify.identifiability`).

    From the Gauss-Newton linearisation of its fit (with the speed-sensor terms when
    the model uses them) and the record's stick durations, drive speeds and length.

    Parameters
    ----------
    pb : Problem
        The record's fit problem.
    base_sim : SimulatedRecord
        The baseline simulation.
    fits : Mapping[str, Mapping[str, float]]
        Candidate name -> its fitted values (mu0, mu_inf, the candidate's parameters
        and the fixed instrument model).
    corr_time : float
        Residual correlation time [s] of the standard errors.
    gains : Mapping[str, float] or None
        Candidate name -> its cross-validated relative cost reduction [-]; a decisive
        fit overrules the stick-duration proxy.
    profile_se : Mapping[str, float] or None
        Parameter name -> standard error [SI] from its cost profile (a floor of the
        linearised one, :meth:`..linearised.GaussNewton.with_profile_se`).
    min_gain : float
        Smallest gain of a decidable effect [-] (the selection's ``min_gain``).

    Returns
    -------
    dict[str, Identifiability]
        The verdict per candidate.
    """
    facts = record_facts(pb, base_sim)
    return {
        name: _judge(
            pb,
            facts,
            name,
            vals,
            corr_time=corr_time,
            gain=None if gains is None else gains.get(name),
            profile_se=profile_se,
            min_gain=min_gain,
        )[0]
        for name, vals in fits.items()
    }


def _judge(
    pb: Problem,
    facts: tuple[FloatArray, FloatArray, float],
    name: str,
    vals: Mapping[str, float],
    *,
    corr_time: float,
    gain: float | None,
    profile_se: Mapping[str, float] | None = None,
    min_gain: float = 0.0,
) -> tuple[Identifiability, GaussNewton]:
    """Return one candidate's verdict and the linearisation of its fit."""
    durations, speeds, length = facts
    c = cand_lib.get(name)
    specs = [MU0, MU_INF, *pb.free_instrument, *c.params]
    gn = gauss_newton(pb, specs, vals, corr_time=corr_time)
    if profile_se:
        gn = gn.with_profile_se(profile_se)
    verdict = identifiability(
        name,
        c.param_names,
        gn,
        durations,
        drive_speeds=speeds,
        duration=length,
        gain=gain,
        min_gain=min_gain,
    )
    return verdict, gn


def judge_converged(
    pb: Problem,
    base_sim: SimulatedRecord,
    name: str,
    first: Mapping[str, float],
    converged: Mapping[str, float],
    *,
    corr_time: float = 1e-3,
    gain: float | None = None,
    profile_se: Mapping[str, float] | None = None,
    min_gain: float = 0.0,
) -> Identifiability:
    """Re-check an accepted candidate's verdict on its converged (polished) fit.

    The verdict of :func:`judge_candidates` at the converged values, and "not
    identifiable" when the converged fit disagrees with the selection round's fit
    (``first``) by many standard errors (:func:`..identify.fit_stability`).

    Parameters
    ----------
    pb : Problem
        The record's fit problem.
    base_sim : SimulatedRecord
        The baseline simulation.
    name : str
        Candidate name.
    first : Mapping[str, float]
        The selection round's fitted values (SI).
    converged : Mapping[str, float]
        The polished fit's values (SI).
    corr_time : float
        Residual correlation time [s] of the standard errors.
    gain : float or None
        The candidate's cross-validated relative cost reduction [-].
    profile_se : Mapping[str, float] or None
        Parameter name -> standard error [SI] from its cost profile.
    min_gain : float
        Smallest gain of a decidable effect [-] (the selection's ``min_gain``).

    Returns
    -------
    Identifiability
        The verdict on the converged fit.
    """
    c = cand_lib.get(name)
    verdict, gn = _judge(
        pb,
        record_facts(pb, base_sim),
        name,
        converged,
        corr_time=corr_time,
        gain=gain,
        profile_se=profile_se,
        min_gain=min_gain,
    )
    unstable = fit_stability(name, c.param_names, gn, first)
    return unstable if unstable is not None and verdict.ok else verdict


__all__ = [
    'BaselineFit',
    'baseline_starts',
    'block_speeds',
    'drive_report',
    'fit_baseline',
    'instrument_record',
    'judge_candidates',
    'judge_converged',
    'record_facts',
    'start_context',
]
