"""Steps 1 and 2 of the pipeline: prepare each record, fit the baseline.

``prepare`` turns a checked record into a fit problem: the torsion amplifier's (or the
accelerometer's) lag
is identified from the chamber kinematics and compensated
(:func:`..fitting.identify_torsion_lag`), the accelerometer's gain and zero are
referred to the torsion moment (:func:`..fitting.identify_accel_sensor`), the record
is cut into segments that start in its stick phases, the drive profile is measured from it
(:mod:`tribo_estimation.core.drive`) and the speed sensor's lag and offset are
identified from the stick phases (:func:`..fitting.identify_speed_sensor`).

``fit_baseline`` fits the paper's model (Equ. 1-8: ``mu0``, ``mu_inf``, ``k``) with the
speed sensor held, sets the channel weights from its residuals (never above one
over the channel's noise level), and refits with the chamber's inertia I1 free
(:data:`..fitting.CHAMBER_I1`) and the speed sensor's lag and offset when the lag is
significant; they then stay free in every model of the record
(:attr:`..fitting.Problem.free_instrument`).

``identify_shaft`` identifies the shaft side of the rig (I2, K2, C2 of Equ. 2: design
values, often 10-25 % off) with the baseline; the record is then prepared again on the
identified rig, so every later step (drive angles, segment states, the null law's
replicas, the effect fits) uses it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.stats import chi2

from tribo_estimation.core.model import DriveProfile, RigParams
from tribo_estimation.core.signal import span_medians
from tribo_estimation.errors import EstimationError

from ...lsq import parabola_vertex_log
from ..fitting import (
    CHAMBER_I1,
    CHANNELS,
    HUM_CHANNELS,
    MU0,
    SHAFT,
    SPEED_GAIN_BOUND,
    SPEED_LAG,
    SPEED_OFFSET,
    SPEED_OFFSET_BOUND,
    SPEED_SHAPE,
    Problem,
    Record,
    SimulatedRecord,
    SpeedSensor,
    TorsionLag,
    identify_accel_sensor,
    identify_hum,
    identify_speed_sensor,
    identify_torsion_lag,
    mains_grids,
    speed_offset_bound,
    torsion_compensated_record,
)
from ..stats import noise_floor
from .ensemble import Ensemble, Fit, own
from .policy import Policy, Progress

if TYPE_CHECKING:
    from .null import Adequacy


@dataclass(frozen=True)
class Prepared:
    """One record ready to fit (step 1).

    Parameters
    ----------
    problem : Problem
        The fit problem of the instrument-compensated record.
    torsion_lag : TorsionLag
        The torsion amplifier's identified lag.
    sensor : SpeedSensor
        The speed sensor identified from the stick phases (with the stick
        kinematics' drift, :attr:`..fitting.SpeedSensor.drift`).
    instrument : dict of str to object
        The instrument report of ``discrepancy.json``.
    """

    problem: Problem
    torsion_lag: TorsionLag
    sensor: SpeedSensor
    instrument: dict[str, object] = field(default_factory=dict)


def prepare(
    record: Record,
    rig: RigParams,
    drive: DriveProfile,
    *,
    k: float,
    policy: Policy,
) -> Prepared:
    """Prepare one record: instrument chain, segments, drive profile, speed sensor.

    Parameters
    ----------
    record : Record
        The checked record (torsion moment [N m], acceleration [rad/s^2], speed
        [rad/s]).
    rig : RigParams
        Rig parameters (Tab. 1, F_N, R).
    drive : DriveProfile
        RIG.yaml's drive (nominal speed [rad/s]: a default and a check; ramp [s]).
    k : float
        Decay constant of Equ. 8 [s/rad].
    policy : Policy
        The decision policy (``torsion_lag``, ``block_time``).

    Returns
    -------
    Prepared
        The record's fit problem and its instrument identification.
    """
    tq = identify_torsion_lag(record, rig, enabled=policy.torsion_lag, alpha=policy.alpha)
    rec = torsion_compensated_record(record, rig, tq.used, a2=tq.a2)
    pb = Problem(rec, rig, drive, k=k, block_time=policy.block_time)
    sticks = pb.segments.stick_phases()
    accel = identify_accel_sensor(rec, rig, sticks)
    sensor = identify_speed_sensor(rec, rig, sticks)
    report_gain: dict[str, object] = {'value': sensor.gain, 'se': sensor.gain_se, 'unit': '-'}
    if math.isfinite(sensor.gain_rejected):
        report_gain['rejected'] = sensor.gain_rejected
        report_gain['bound'] = SPEED_GAIN_BOUND
    gain = sensor.gain
    if accel.changes or gain != 1.0:
        # the channels in the torsion moment's frame (a common gain of all three is
        # the torque's calibration: it scales mu0 and mu_inf alike), the accelerometer's
        # zero taken out
        rec = replace(
            rec,
            angular_acceleration=accel.correct(rec.angular_acceleration),
            speed=rec.speed / gain,
        )
        pb = Problem(rec, rig, drive, k=k, block_time=policy.block_time)
        sensor = identify_speed_sensor(rec, rig, pb.segments.stick_phases())
    if sensor.within_bounds():
        # the sticks identified the sensor: they calibrate its slow error too (a gain or
        # offset beyond the bounds says its model misses the phases, and that misfit
        # would be in the phases' errors)
        pb = Problem(
            rec, rig, drive, k=k, block_time=policy.block_time, segments=pb.segments,
            speed_calibration=True,
        )  # fmt: skip
    used = sensor.values()
    instrument: dict[str, object] = {
        'torsion_lag_tau': tq.report(),
        'speed_lag_tau': {
            'value': sensor.tau,
            'se': sensor.tau_se,
            'unit': 's',
            'used': used['speed_lag_tau'],
        },
        'speed_offset': {
            'value': sensor.offset,
            'se': sensor.offset_se,
            'unit': 'rad/s',
            'used': used['speed_offset'],
            **(
                {'rejected': sensor.offset_rejected, 'bound': SPEED_OFFSET_BOUND}
                if math.isfinite(sensor.offset_rejected)
                else {}
            ),
        },
        'speed_mismatch_drift': {'value': sensor.drift, 'se': sensor.drift_se, 'unit': '-'},
        'speed_gain': report_gain,
        'accel_sensor': accel.report(),
        'stick_samples': sensor.n,
    }
    return Prepared(pb, tq, sensor, instrument)


def without_hum(prep: Prepared, values: Mapping[str, float], policy: Policy) -> Prepared:
    """Take the mains hum the baseline leaves out of the record (instrument, not physics).

    The lines of :func:`..fitting.identify_hum` on the baseline's residuals of the
    torsion moment and the shaft speed (the record's channels in the torsion moment's
    frame) are subtracted from the record, so the segments' start states are free of
    them; the problem and the speed sensor are built again from the cleaned record,
    and the lines' frequencies stay linear nuisance terms of its fits
    (:attr:`..fitting.Problem.hum_lines`, what a later pass finds adds to them).
    Unchanged (the same object) without new lines.

    Parameters
    ----------
    prep : Prepared
        The prepared record.
    values : mapping of str to float
        Its baseline's values.
    policy : Policy
        The policy (``alpha``, ``block_time``).

    Returns
    -------
    Prepared
        The record without the hum (``instrument['mains_hum']`` lists the lines of
        every pass).
    """
    pb = prep.problem
    sim = pb.simulate(values)
    res = {
        c: np.where(sim.covered, pb.record.channel(c) - sim.channel(c), np.nan)
        if c in _HUM_JUDGED else np.full(sim.covered.size, np.nan)
        for c in HUM_CHANNELS
    }  # fmt: skip
    # the grid measured by an earlier pass holds: what its lines left is no new grid
    grids = mains_grids(f for fs in pb.hum_lines.values() for f in fs)
    hum = identify_hum(pb.record.time, res, policy.alpha, grids)
    if not hum.lines:
        return prep
    earlier = prep.instrument.get('mains_hum')
    found = [*earlier] if isinstance(earlier, list) else []
    instrument = {**prep.instrument, 'mains_hum': [*found, *hum.report()]}
    rec = hum.remove(pb.record)
    new = Problem(
        rec, pb.rig, pb.drive, k=pb.k, block_time=policy.block_time,
        speed_calibration=pb.speed_calibration,
    )  # fmt: skip
    lines = dict(pb.hum_lines)
    for c, f, _, _ in hum.lines:
        if f not in lines.get(c, ()):
            lines[c] = (*lines.get(c, ()), f)
    new.hum_lines = lines
    sensor = identify_speed_sensor(rec, pb.rig, new.segments.stick_phases())
    return Prepared(new, prep.torsion_lag, sensor, instrument)


#: Channels whose hum is looked for on the baseline's residual: the acceleration's
#: residual carries lines the torsion moment's hum induces through the segments'
#: start states (and its own hum integrates to little chamber speed).
_HUM_JUDGED: tuple[str, ...] = ('torsion_moment', 'speed')


#: Fewest stick phases whose ends give the breakaway moment of :func:`baseline_starts`
#: [-], and the samples before a phase's end its acceleration is the median of [-].
_BREAKAWAY_PHASES = 3
_BREAKAWAY_ACCEL_SAMPLES = 5


def baseline_starts(problem: Problem) -> list[dict[str, float]]:
    """Return start values of the baseline fit.

    ``mu0`` from the friction moment at the measured breakaways: where the stick
    phases are known, the chamber's balance at each phase's last stuck sample,
    ``M = I1*w1' + K1*w + M_t`` (Equ. 1; sticking ends at ``|M| = F_N*R*mu0``, Equ. 6);
    else the peak torsion moment of each segment (which overshoots the breakaway by
    up to ``w*sqrt(C1*I1)`` when the discs break away at speed). ``mu_inf`` a
    fraction of it (Equ. 8).

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
    phases = seg.stick_phases()
    if phases is not None and phases[0].size >= _BREAKAWAY_PHASES:
        rig = problem.rig
        end = phases[1] - 1
        lo = np.maximum(phases[0], end - _BREAKAWAY_ACCEL_SAMPLES)
        accel = span_medians(rec.angular_acceleration, lo, end + 1)
        moment = rec.torsion_moment[end] + rig.I1 * accel + rig.K1 * rec.speed[end]
        m_s = float(np.median(np.abs(moment)))
    else:
        peaks = [
            float(np.max(np.abs(rec.torsion_moment[a:b])))
            for a, b in zip(seg.start, seg.stop, strict=True)
        ]
        m_s = float(np.median(peaks)) if peaks else float(np.max(np.abs(rec.torsion_moment)))
    mu0 = max(m_s / fnr, 1e-3) if fnr > 0 else MU0.initial
    return [{'mu0': mu0, 'mu_inf': f * mu0} for f in (0.7, 0.85, 0.95)]


def fit_record_baseline(
    prep: Prepared, policy: Policy, say: Progress, previous: Mapping[str, float] | None = None
) -> dict[str, float]:
    """Fit one record's baseline (module docstring); sets its weights and free terms.

    Parameters
    ----------
    prep : Prepared
        The prepared record; its problem's weights and free instrument terms are set.
    policy : Policy
        The policy (evaluation budgets, ``k_starts`` on RIG.yaml's k).
    say : Progress
        Receiver of progress messages.
    previous : mapping of str to float or None
        A fitted baseline of the same record before a change of its instrument terms
        (the hum taken out, the shaft identified), or of an overlapping window of the
        same stream: the screen starts from its k only, and from its values too; the
        final fit is also run from its values where they leave less of the judged
        channels than the screen's fit does, and the better of the two kept (the
        screen's weights are not the final fit's: under them a refit can leave the
        earlier valley of k for a worse one).

    Returns
    -------
    dict of str to float
        mu0, mu_inf, k (Equ. 8) and the speed-sensor values (SI).
    """
    pb = prep.problem
    one = Ensemble([pb])
    sensor = prep.sensor.values()
    # k of Equ. 8 from the policy's starts: the config's k (a preset, or another test's) can
    # start the fit in the wrong valley (at a few rpm, k v spans 0.1-10)
    ks = [previous['k']] if previous is not None else [pb.k * f for f in policy.k_starts]
    starts = [{**s, 'k': k} for k in ks for s in baseline_starts(pb)]
    if previous is not None:
        starts.append({n: previous[n] for n in ('mu0', 'mu_inf', 'k')})
    best = _least_cost(one, [{**s, **sensor} for s in starts], policy)
    # the speed sensor, screened from the best start: where the regression's model does
    # not hold (no stick samples, its lag below zero, its gain beyond the bound), its
    # offset and zero, each with lags over the span of a tachometer's (a slow
    # second-order sensor's fit has its own basin); else, with an offset, zero too (the
    # regression's offset is what a sensor slower than the stick phases throws far off,
    # its output there still carrying the slip before, and through the drive angles it
    # moves the whole baseline). Where a trial costs less, or the model does not hold,
    # the offset is fitted from the least cost's
    here = one.split(best.values)[0]
    holds = prep.sensor.consistent()
    if not holds:
        trials = [
            {SPEED_LAG.name: tau, SPEED_OFFSET.name: offset}
            for offset in {here[SPEED_OFFSET.name], 0.0}
            for tau in _LAG_STARTS
        ]
    else:
        trials = [{SPEED_OFFSET.name: 0.0}] if sensor[SPEED_OFFSET.name] != 0.0 else []
    regressed = best
    best = _least_cost(one, [{**here, **t} for t in trials], policy, best)
    offset_set_aside = not holds or best is not regressed
    # a sensor the sticks did not identify is unknown, not absent: the screen's least
    # cost (its budget is short) and the sensor-free start are both fitted in full
    unknown = not prep.sensor.identified()
    firsts = [best, regressed] if unknown and best is not regressed else [best]
    fo = min(
        (one.fit(one.specs(), f.values, max_nfev=policy.fit_nfev) for f in firsts),
        key=lambda f: f.cost,
    )
    values = one.split(fo.values)[0]
    if offset_set_aside:
        regression = (
            f'stick regression: lag {prep.sensor.tau:.3g} s, offset {prep.sensor.offset:.4g} rad/s'
            if not unknown
            else 'no stick phase long enough for the stick regression'
        )
        say(
            f'speed sensor fitted from lag {values[SPEED_LAG.name]:.3g} s, offset '
            f'{values[SPEED_OFFSET.name]:.4g} rad/s ({regression})'
        )
    sensor = {n: values[n] for n in (SPEED_LAG.name, SPEED_OFFSET.name)}
    # the chamber's inertia is free from here on, with the speed sensor's lag, offset and
    # second order when the lag is significant, its offset alone when the regression's
    # was set aside
    lagged = sensor['speed_lag_tau'] > 0.0 or unknown
    # the offset within the physical bound of a tachometer calibrated for this record
    # (at least 1 mrad/s: a record without motion keeps a fit with room)
    bound = max(speed_offset_bound(pb.record), 1e-3)
    offset = replace(SPEED_OFFSET, lower=-bound, upper=bound)
    free_sensor = (
        (SPEED_LAG, offset, SPEED_SHAPE) if lagged
        else (offset,) if offset_set_aside else ()
    )  # fmt: skip
    pb.free_instrument = (*free_sensor, CHAMBER_I1)
    fo = _final_fit(pb, {**values, CHAMBER_I1.name: CHAMBER_I1.initial}, policy)
    values = one.split(fo.values)[0]
    if previous is not None:
        # the earlier baseline, refitted alike, where it leaves less of the judged
        # channels on this record (the screen's channel weights are not the final
        # fit's, and under them the refit can leave the earlier valley of k)
        start = {**values, **{n: float(previous[n]) for n in values if n in previous}}
        ref = _adequacy(pb, values)
        left = _judged(ref, ref)
        if _judged(_adequacy(pb, start), ref) < left:
            again = _final_fit(pb, start, policy)
            if _judged(_adequacy(pb, one.split(again.values)[0]), ref) < left:
                fo, values = again, one.split(again.values)[0]
            else:
                _final_setting(pb, values)
    inst = prep.instrument
    inst['chamber_I1'] = {
        'factor': values[CHAMBER_I1.name],
        'se': fo.se.get(own(CHAMBER_I1.name, 0), math.nan),
        'unit': '-',
    }
    for spec in free_sensor:
        entry = inst.get(spec.name)
        if isinstance(entry, dict):
            entry['used'] = values[spec.name]
            entry['se_joint'] = fo.se.get(own(spec.name, 0), math.nan)
    if lagged:
        inst[SPEED_SHAPE.name] = {
            'value': values.get(SPEED_SHAPE.name, 0.0),
            'se': fo.se.get(own(SPEED_SHAPE.name, 0), math.nan),
            'unit': '-',
        }
    say(
        f'baseline: mu0 = {values["mu0"]:.4f}, mu_inf = {values["mu_inf"]:.4f}, '
        f'k = {values["k"]:.3g} s/rad, '
        f'torque rms {pb.torque_rms(pb.simulate(values)):.4g} N m '
        f'({pb.segments.n} segments)'
    )
    return values


def _final_setting(pb: Problem, values: Mapping[str, float]) -> None:
    """Set the problem's state by a model.

    The drive's open step durations (:meth:`..fitting.Problem.set_transition_durations`)
    and the channel weights (from its residuals, never above one over the channel's
    noise).
    """
    pb.set_transition_durations(values)
    sim = pb.simulate(values)
    pb.set_residual_weights(sim, channel_floors(pb, sim))


def _final_fit(pb: Problem, start: Mapping[str, float], policy: Policy) -> Fit:
    """Fit the baseline with the record's free instrument terms from ``start``.

    The problem's state is set by ``start`` first (:func:`_final_setting`).
    """
    _final_setting(pb, start)
    one = Ensemble([pb])
    return one.fit(one.specs(), one.join([start]), max_nfev=policy.fit_nfev)


#: The channels whose residuals choose between two fits of a baseline (the ones the
#: adequacy statistics judge, :data:`.null.STATISTICS`).
_JUDGED: tuple[str, ...] = ('torsion_moment', 'speed')


def _adequacy(pb: Problem, values: Mapping[str, float]) -> Adequacy:
    """Return a model's adequacy statistics on the record (:func:`.null.adequacy`)."""
    from .null import adequacy

    return adequacy(pb, pb.simulate(values))


def _judged(fit: Adequacy, ref: Adequacy) -> float:
    """Return the summed mean squares of a fit's judged residuals over ``ref``'s noise [-].

    Each judged channel's residual rms (its statistic times the white noise it was
    divided by) over the white noise of ``ref``, one level per channel that both fits
    compared are divided by: free of the fit's channel weights, and of a noise level
    measured on each fit's own residual (a residual far off its record moves its
    second differences too).
    """
    total = 0.0
    for c in _JUDGED:
        rms = fit[c] * fit.noise.channel(c).white
        noise = ref.noise.channel(c).white
        if math.isfinite(rms) and noise > 0.0:
            total += (rms / noise) ** 2
    return total


def _least_cost(
    one: Ensemble, starts: list[dict[str, float]], policy: Policy, best: Fit | None = None
) -> Fit:
    """Screen a record's baseline from each start; return the least cost's fit.

    Each start is fitted with the screening budget (``policy.screen_nfev``) on the
    first fold; ``best`` (an earlier screen's) is kept unless a start costs less.
    """
    for s in starts:
        fo = one.fit(one.specs(), one.join([s]), max_nfev=policy.screen_nfev, fold=0)
        if best is None or fo.cost < best.cost:
            best = fo
    if best is None:
        raise EstimationError('no start to screen the baseline from')
    return best


#: Start lags of a speed sensor the stick regression cannot describe [s]: a factor 4
#: apart over the tachometers' span (a first-order lag to a slow second-order filter).
_LAG_STARTS = (1e-3, 4e-3, 16e-3)

#: Trial steps of the speed channel's gain about the stick regression's, relative [-].
GAIN_STEP = 0.03
#: Most baseline fits of the gain's search before its vertex [-] (the current gain and
#: steps out to the physical bound, SPEED_GAIN_BOUND, from anywhere within it).
_GAIN_TRIALS = 9
#: Standard errors by which the baseline's second-order term of the speed sensor
#: (speed_lag_shape) exceeds 0 for the gain to be searched [-].
_SHAPE_Z = 3.0


def _gain_trial(
    prep: Prepared, values: Mapping[str, float], factor: float, policy: Policy
) -> tuple[float, Problem, dict[str, float]]:
    """Fit the baseline on the record with its speed channel's gain times ``factor``.

    The speed channel is divided by ``factor`` (the drive profile, the segments'
    states and the sensor's offset follow it) and the baseline refitted from
    ``values``; its cost is in the record's frame (the speed channel's weight times
    ``factor``), so trials of different gains compare. Returns the cost, the
    problem and the fitted values.
    """
    pb = prep.problem
    trial = pb.like(replace(pb.record, speed=pb.record.speed / factor))
    trial.weights['speed'] = pb.weights.get('speed', 0.0) * factor
    start = dict(values)
    if SPEED_OFFSET.name in start:
        start[SPEED_OFFSET.name] = start[SPEED_OFFSET.name] / factor
    trial.set_transition_durations(start)
    one = Ensemble([trial])
    fo = one.fit(one.specs(), one.join([start]), max_nfev=policy.fit_nfev)
    return fo.cost, trial, one.split(fo.values)[0]


def identify_speed_gain(
    prep: Prepared, values: Mapping[str, float], policy: Policy, say: Progress
) -> tuple[Prepared, dict[str, float]]:
    """Identify the speed channel's gain with the baseline, on the whole record.

    The stick regression of :func:`..fitting.identify_speed_sensor` sees the stuck
    discs swing at one frequency ``w``, where a second-order sensor's
    ``a2*y''`` is ``-a2*w**2*y``: its gain is off by the factor ``1 - a2*w**2`` and
    cannot tell the two apart. The sliding phases' transients can. Where the baseline
    found a second order (``speed_lag_shape`` beyond 3 standard errors), the baseline is
    refitted (one budget ``policy.fit_nfev`` each) at the current gain, at
    :data:`GAIN_STEP` below and above it, further steps while the least cost is at an
    end (up to the bound), and at the vertex of the parabola through the least cost and its
    neighbours (on log gain, within :data:`..fitting.SPEED_GAIN_BOUND` of 1). The least
    cost in the record's frame is kept if its drop of the weighted sum of squares
    beats the chi-square law of one degree of freedom at ``policy.alpha`` (the gain is
    one more parameter); else the current gain and baseline stay.

    Parameters
    ----------
    prep : Prepared
        The prepared record with its baseline fitted (weights set).
    values : mapping of str to float
        Its baseline's values.
    policy : Policy
        The policy (evaluation budget).
    say : Progress
        Receiver of progress messages.

    Returns
    -------
    tuple of (Prepared, dict)
        The record prepared with the identified gain and its baseline (``prep`` and
        ``values`` themselves when the current gain stays).
    """
    shape = prep.instrument.get(SPEED_SHAPE.name)
    if not (isinstance(shape, dict) and float(shape['value']) > _SHAPE_Z * float(shape['se'])):
        return prep, dict(values)  # no second order: the regression has no a2*y'' to miss
    pb = prep.problem
    entry = prep.instrument.get('speed_gain')
    report = dict(entry) if isinstance(entry, dict) else {}
    g0 = float(report.get('used', report.get('value', 1.0)))
    # the current gain refitted with the trials' budget: like is compared with like
    one = Ensemble([pb])
    fo = one.fit(one.specs(), one.join([dict(values)]), max_nfev=policy.fit_nfev)
    here = one.split(fo.values)[0]
    current = (1.0, pb, here)
    best_cost = fo.cost
    best = current
    points = [(1.0, fo.cost)]
    lo = (1.0 - SPEED_GAIN_BOUND) / g0
    hi = (1.0 + SPEED_GAIN_BOUND) / g0

    def run(factor: float) -> None:
        nonlocal best, best_cost
        try:
            cost, trial, vals = _gain_trial(prep, here, factor, policy)
        except EstimationError:
            return
        points.append((factor, cost))
        if cost < best_cost:
            best, best_cost = (factor, trial, vals), cost

    for f in (1.0 - GAIN_STEP, 1.0 + GAIN_STEP):
        if lo <= f <= hi:
            run(f)
    xv = parabola_vertex_log(points)
    while xv is None and len(points) < _GAIN_TRIALS:
        # the least cost at an end of the trials: one more step beyond it
        f_end = min(points, key=lambda p: p[1])[0]
        f_next = f_end * (1.0 + GAIN_STEP if f_end > 1.0 else 1.0 - GAIN_STEP)
        if f_end == 1.0 or not lo <= f_next <= hi:
            break
        run(f_next)
        xv = parabola_vertex_log(points)
    if xv is not None and all(abs(math.log(f) - xv) > 0.2 * GAIN_STEP for f, _ in points):
        run(min(max(math.exp(xv), lo), hi))
    # the gain is one more parameter of the least squares: its drop of the weighted sum
    # of squares beats the chi-square law of one degree of freedom at policy.alpha, or
    # the current gain stays
    n = int(np.count_nonzero(pb.simulate(here).covered))
    if best is current or not n * (fo.cost - best_cost) > float(chi2.ppf(1.0 - policy.alpha, 1)):
        return prep, dict(values)
    factor, trial, vals = best
    gain = g0 * factor
    sensor = identify_speed_sensor(trial.record, trial.rig, trial.segments.stick_phases())
    sensor = replace(sensor, gain=gain, gain_se=prep.sensor.gain_se)
    instrument = {
        **prep.instrument,
        'speed_gain': {**report, 'used': gain, 'from': 'baseline fit'},
    }
    say(f'speed gain {gain:.4f} from the baseline fit (stick regression {g0:.4f})')
    return Prepared(trial, prep.torsion_lag, sensor, instrument), vals


#: Evaluation budget of the shaft's identification, in the baseline fit's [-].
_SHAFT_NFEV = 4


def identify_shaft(
    prep: Prepared, values: Mapping[str, float], policy: Policy, say: Progress
) -> tuple[RigParams, dict[str, dict[str, float | bool]]] | None:
    """Identify the shaft's I2, K2, C2 with the baseline (Equ. 2).

    The baseline is refitted with the factors of :data:`..fitting.SHAFT` on RIG.yaml's
    I2, K2, C2 free; their standard errors say how well the record pins them. The
    caller prepares the record again on the identified rig (the torsion lag, the
    sensors' gains, the segments' states and the drive angles all read it) and keeps
    the factors free in every later model, the null law's replicas included.

    Parameters
    ----------
    prep : Prepared
        The prepared record (its baseline fitted: weights set).
    values : mapping of str to float
        Its baseline's values.
    policy : Policy
        The policy (evaluation budget).
    say : Progress
        Receiver of progress messages.

    Returns
    -------
    tuple of (RigParams, dict) or None
        The identified rig and its report per parameter (``value``, ``design`` [SI],
        ``se``, ``at_bound``); None when the factors do not lower the baseline's cost.
    """
    pb = prep.problem
    held, weights = pb.free_instrument, dict(pb.weights)
    # the chamber's inertia held at RIG.yaml's: with the stuck discs' (I1 + I2) it trades
    # against I2; the record prepared on the identified shaft fits its own factor
    pb.free_instrument = (*(h for h in held if h is not CHAMBER_I1), *SHAFT)
    try:
        one = Ensemble([pb])
        fixed = {CHAMBER_I1.name: CHAMBER_I1.initial, **{p.name: p.initial for p in SHAFT}}
        start = one.join([{**values, **fixed}])
        before = one.cost(start)
        fo = one.fit(one.specs(), start, max_nfev=_SHAFT_NFEV * policy.fit_nfev)
        if not fo.cost < before:
            return None
        # the weights came from the baseline's residuals, which the shaft changes: set
        # from the new residuals (each channel's level) and fitted once more
        sim = pb.simulate(one.split(fo.values)[0])
        pb.set_residual_weights(sim, channel_floors(pb, sim))
        fo = one.fit(one.specs(), fo.values, max_nfev=_SHAFT_NFEV * policy.fit_nfev)
    finally:
        pb.free_instrument = held
        pb.weights.update(weights)
    got = one.split(fo.values)[0]
    rig = pb.rig_of(got)
    report: dict[str, dict[str, float | bool]] = {}
    for spec, name in zip(SHAFT, ('I2', 'K2', 'C2'), strict=True):
        f = got[spec.name]
        design = float(getattr(pb.rig, name))
        margin = 0.01 * (spec.upper - spec.lower)
        report[name] = {
            'value': float(getattr(rig, name)),
            'design': design,
            'se': fo.se.get(f'{spec.name}@0', math.nan) * design,
            'at_bound': bool(min(f - spec.lower, spec.upper - f) < margin),
        }
    say(
        'shaft identified: '
        + ', '.join(
            f'{n} {float(r["value"]):.4g} ({float(r["value"]) / float(r["design"]):.2f} x design)'
            for n, r in report.items()
        )
    )
    return rig, report


def channel_floors(problem: Problem, sim: SimulatedRecord) -> dict[str, float]:
    """Return the noise level of every compared channel [unit] (the weights' floor).

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    sim : SimulatedRecord
        A model's simulation (its covered samples).

    Returns
    -------
    dict of str to float
        Per :data:`..fitting.CHANNELS`.
    """
    out: dict[str, float] = {}
    for ch in CHANNELS:
        m = problem.measured(ch)[sim.covered]
        out[ch] = max(noise_floor(m), 1e-3 * float(np.std(m)), 1e-12)
    return out


__all__ = [
    'Prepared',
    'baseline_starts',
    'channel_floors',
    'fit_record_baseline',
    'identify_shaft',
    'identify_speed_gain',
    'prepare',
    'without_hum',
]
