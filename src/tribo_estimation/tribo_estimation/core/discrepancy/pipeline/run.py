"""The pipeline's entry: :func:`find_missing_physics` on one record or several.

``prepare`` (checked record, instrument chain, drive profile) -> ``baseline`` (the
paper's model) -> null law (parametric bootstrap of the baseline) -> ``screen``
(every form of every candidate family) -> ``decide`` (:mod:`.decide`), repeated for
up to ``Policy.max_effects`` effects while a round leaves one partial explanation
that the record singles out; a named model is confirmed against its own null law.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from collections.abc import Mapping, Sequence

import numpy as np

from tribo_estimation.core.model import DriveProfile, RigParams
from tribo_estimation.errors import InvalidParameterError

from .. import candidates as cand_lib
from ..fitting import SHAFT, Record
from ..localise import localise, torque_residual
from ..stats import noise_floor
from .decide import (
    CANNOT_TELL_APART,
    INSTRUMENT,
    NAMED,
    NOTHING_MISSING,
    UNEXPLAINED,
    Decision,
    carried,
    decide,
    explained,
)
from .describe import describe_unexplained, drive_report
from .ensemble import LEVELS, Ensemble, Fit, at_bound
from .null import SELF_ERROR_LIMIT, NullLaw, null_law
from .policy import Policy, Progress, quiet
from .prepare import (
    Prepared,
    fit_record_baseline,
    identify_shaft,
    identify_speed_gain,
    prepare,
    without_hum,
)
from .result import Effect, MissingPhysics, RecordReport, Traces
from .screen import FormFit, Model, failing, judge, screen

#: Most passes of the hum's removal (each takes out what the baseline left of it; they
#: end when no line is significant, :func:`.prepare.without_hum`).
_HUM_PASSES = 6


def _null_laws(
    ens: Ensemble, model: Model, policy: Policy, replicas: int, seed: int
) -> list[NullLaw]:
    """Return each record's null law, bootstrapped from ``model``."""
    laws = []
    for i, (pb, vals, ad) in enumerate(
        zip(ens.problems, ens.split(model.values), model.adequacy, strict=True)
    ):
        free = [*LEVELS, *pb.free_instrument, *model.params()]
        laws.append(
            null_law(
                pb,
                vals,
                free,
                ad.noise,
                replicas=replicas,
                alpha=policy.alpha,
                seed=seed + 1000 * i,
                max_nfev=policy.replica_nfev,
            )
        )
    return laws


def detection_limit(stat: float, bound: float, noise: float) -> float:
    """Return the rms [N m] an effect must add to the torque residual to be seen.

    The statistic is the residual's rms over the noise (:mod:`.null`): an effect whose
    residual ``r`` is independent of the rest raises it from ``stat`` to
    ``sqrt(stat^2 + (r/noise)^2)``, which passes ``bound`` at
    ``r = noise*sqrt(bound^2 - stat^2)``.

    Parameters
    ----------
    stat : float
        The record's torque statistic [-].
    bound : float
        Its null law's bound [-].
    noise : float
        The noise the statistic is divided by [N m].

    Returns
    -------
    float
        The limit [N m] (NaN without a bound).

    Examples
    --------
    >>> round(detection_limit(1.2, 1.3, 0.05), 4)
    0.025
    """
    if not (math.isfinite(bound) and math.isfinite(stat)):
        return math.nan
    return noise * math.sqrt(max(bound * bound - stat * stat, 0.0))


def null_verdict(
    stats: Sequence[float],
    laws: Sequence[NullLaw],
    noises: Sequence[float],
    fails: bool,
    say: Progress = quiet,
) -> Decision | None:
    """Return the verdict the null laws give before any family is screened.

    Unexplained when a law is not self-consistent (:meth:`.null.NullLaw.self_consistent`),
    or when a record's torque statistic lies beyond the noise (above
    :data:`.null.SELF_ERROR_LIMIT`) but within a bound that only replicas refitted
    beyond their own noise reach: the workflow's own error, not the noise, covers it.
    Nothing missing when no statistic fails; otherwise None (the families are screened).

    Parameters
    ----------
    stats : sequence of float
        Each record's torque statistic [-].
    laws : sequence of NullLaw
        Each record's null law.
    noises : sequence of float
        Each record's torque noise [N m].
    fails : bool
        Some statistic of the baseline lies beyond its law's bound.
    say : callable
        Progress messages.

    Returns
    -------
    Decision or None
        The verdict, or None when the baseline is inadequate and the laws usable.
    """
    lost = [law.centre('torsion_moment') for law in laws if not law.self_consistent()]
    bounds = [law.bound('torsion_moment') for law in laws]
    covered = [(s, b) for s, b in zip(stats, bounds, strict=True) if min(s, b) > SELF_ERROR_LIMIT]
    if lost:
        say(f'null law not self-consistent: replicas refitted to {max(lost):.3g} x their noise')
        return Decision(
            UNEXPLAINED, None, (), (),
            'the fit does not recover its own model from this record: records simulated '
            f'from the fitted model are refitted to {max(lost):.3g} x their white noise '
            f'(above {SELF_ERROR_LIMIT:.3g}: the workflow\'s own error exceeds the noise), '
            'so no statistic here can tell a missing effect from the fit\'s error',
        )  # fmt: skip
    if fails:
        return None
    if covered:
        stat, bound = max(covered)
        say(f"null law reached by the fit's error: record {stat:.3g}, replicas up to {bound:.3g}")
        return Decision(
            UNEXPLAINED, None, (), (),
            f'the torque residual, {stat:.3g} x the white noise, lies beyond the noise '
            f'(above {SELF_ERROR_LIMIT:.3g}) but within what the fit leaves on records '
            f'simulated from its own model (up to {bound:.3g} x): the workflow\'s own error, '
            'not the noise, covers it, so no statistic here can tell a missing effect from '
            'the fit\'s error',
        )  # fmt: skip
    # how far "nothing missing" reaches: the record's torque statistic, the largest its
    # own replicas allow, and the smallest residual an effect would have to add
    # (independent of the rest) to cross that bound
    stat = max(stats)
    bound = max(bounds)
    limit = max(detection_limit(s, b, n) for s, b, n in zip(stats, bounds, noises, strict=True))
    return Decision(
        NOTHING_MISSING, None, (), (),
        "the paper's model explains the record as well as records simulated from "
        f'itself (torque residual {stat:.3g} x the white noise; its replicas up to '
        f'{bound:.3g} x: an effect adding less than {limit:.2g} N m rms to the '
        'torque residual would not show)',
    )  # fmt: skip


def _single_speed(ens: Ensemble) -> bool:
    """Tell whether every record ran at one drive speed (within 10 % of the mean)."""
    speeds: list[float] = []
    for pb in ens.problems:
        de = pb.drive_estimate
        speeds.extend(float(v) for v in de.knot_speed)
    s = np.abs(np.asarray(speeds))
    return bool(s.size == 0 or (s.max() - s.min()) <= 0.1 * max(float(s.mean()), 1e-9))


def _effect(fit: FormFit, ens: Ensemble, current: Model, laws: Sequence[NullLaw]) -> Effect:
    sims = ens.simulate(fit.model.values)
    rms = tuple(pb.torque_rms(s) for pb, s in zip(ens.problems, sims, strict=True))
    return Effect.of(fit, rms, explained(fit, current, laws))


def _needed(
    forms: list[FormFit], ens: Ensemble, laws: Sequence[NullLaw], pol: Policy, say: Progress
) -> list[FormFit]:
    """Drop the effects an adequate model does not need (backward elimination).

    An effect kept tentatively in an earlier round explained part of the mismatch;
    once a later effect makes the model adequate, the earlier one is refitted away:
    when the model without it stays adequate, it is not named.

    Parameters
    ----------
    forms : list of FormFit
        The added forms in order; the last one's model is adequate.
    ens : Ensemble
        The records.
    laws : sequence of NullLaw
        The records' null laws.
    pol : Policy
        Budgets (``fit_nfev``, ``bound_margin``).
    say : Progress
        Receiver of progress messages.

    Returns
    -------
    list of FormFit
        The forms the adequate model needs, the last one's model refitted without the
        others.
    """
    kept = list(forms)
    for f in forms[:-1]:
        rest = [g for g in kept if g is not f]
        names = tuple(g.form for g in rest)
        params = [p for g in rest for p in cand_lib.get(g.form).params]
        start = {k: v for k, v in kept[-1].model.values.items()
                 if k not in cand_lib.get(f.form).param_names}  # fmt: skip
        fit = ens.fit(ens.specs(params), start, max_nfev=pol.fit_nfev)
        model = judge(ens, names, fit)
        if not failing(model, laws):
            say(f'{f.family} is not needed once {rest[-1].family} is in the model')
            last = rest[-1]
            bounded = at_bound(cand_lib.get(last.form).params, fit.values, pol.bound_margin)
            rest[-1] = FormFit(last.family, last.form, model, (), tuple(bounded))
            kept = rest
    return kept


def _prepared(
    i: int,
    record: Record,
    rig: RigParams,
    drive: DriveProfile,
    k: float,
    pol: Policy,
    say: Progress,
    previous: Mapping[str, float] | None = None,
) -> tuple[Prepared, dict[str, float]]:
    """Prepare one record, fit its baseline and take out the mains hum (steps 1-2)."""
    prep = prepare(record, rig, drive, k=k, policy=pol)
    vals = fit_record_baseline(prep, pol, say, previous=previous)
    # the baseline absorbs part of a hum line (its segments start from states that
    # carry it): the lines are taken out, the baseline refitted, until none is left
    for _ in range(_HUM_PASSES):
        cleaned = without_hum(prep, vals, pol)
        if cleaned is prep:
            break
        say(f'record {i}: mains hum taken out: {cleaned.problem.hum_lines}')
        prep = cleaned
        vals = fit_record_baseline(cleaned, pol, say, previous=vals)
    return prep, vals


def find_missing_physics(
    records: Sequence[Record],
    rig: RigParams,
    drives: Sequence[DriveProfile],
    *,
    k: float = 2.0,
    policy: Policy | None = None,
    progress: Progress | None = None,
    shared_friction: bool = False,
    null: Sequence[NullLaw] | None = None,
    earlier: Sequence[NullLaw] = (),
    pool: int = 0,
    previous: Sequence[Mapping[str, float]] = (),
) -> MissingPhysics:
    """Find what the rig model misses in one record or several (module docstring).

    Parameters
    ----------
    records : sequence of Record
        The checked records (torsion moment [N m], acceleration [rad/s^2], speed
        [rad/s]); several are fitted jointly (the effect shared, friction levels,
        drive and instruments each record's own).
    rig : RigParams
        Rig parameters (Tab. 1, F_N, R).
    drives : sequence of DriveProfile
        RIG.yaml's drive per record (nominal speed [rad/s], ramp [s]).
    k : float
        Decay constant of Equ. 8 [s/rad].
    policy : Policy or None
        Rules and budget (None: the offline defaults).
    progress : Progress or None
        Receiver of one-line progress messages.
    shared_friction : bool
        Several records of one contact at several drive speeds: one friction law.
    null : sequence of NullLaw or None
        Per record, the null law to judge by, measured before on the same window
        (the live monitor's investigation) instead of bootstrapping it again (None:
        bootstrapped here).
    earlier : sequence of NullLaw
        Per record, replicas of the same process measured on earlier windows of an
        overlapping stream (the live monitor): this call's ``policy.replicas`` fresh
        replicas are pooled with the newest of them (:meth:`.null.NullLaw.pooled`),
        ``pool`` in all. Empty: only the fresh ones.
    pool : int
        Replicas of a pooled law (with ``earlier``).
    previous : sequence of mapping of str to float
        Per record, the baseline of an overlapping window of the same stream (the
        live monitor): the baseline fit starts from its k and its values
        (:func:`.prepare.fit_record_baseline`) instead of the policy's ``k_starts``.
        Empty: the policy's starts.

    Returns
    -------
    MissingPhysics
        The verdict, the named effects or the set the records cannot tell apart, and
        per record what remains.

    Raises
    ------
    InvalidParameterError
        If the numbers of records and drives differ or there is no record.
    """
    pol = policy or Policy()
    say: Progress = progress or quiet
    if len(records) != len(drives) or not records:
        raise InvalidParameterError(f'{len(drives)} drive profiles for {len(records)} records')
    t_start = _time.perf_counter()
    deadline = t_start + pol.time_budget
    preps: list[Prepared] = []
    base_vals: list[dict[str, float]] = []
    for i, (r, d) in enumerate(zip(records, drives, strict=True)):
        prep, vals = _prepared(
            i, r, rig, d, k, pol, say, previous=previous[i] if i < len(previous) else None
        )
        # one record: its shaft identified (several records share one rig, whose joint
        # identification is not built: they keep RIG.yaml's shaft)
        found = identify_shaft(prep, vals, pol, say) if pol.shaft and len(records) == 1 else None
        if found is not None:
            # the whole preparation again on the identified rig: the torsion lag, the
            # sensors' gains and the drive angles read the shaft's I2, K2, C2 too
            shaft_rig, report = found
            again, again_vals = _prepared(i, r, shaft_rig, d, k, pol, say, previous=vals)
            before = prep.problem.torque_rms(prep.problem.simulate(vals))
            after = again.problem.torque_rms(again.problem.simulate(again_vals))
            if after <= before:
                prep = dataclasses.replace(
                    again, instrument={**again.instrument, 'shaft': {**report, 'used': True}}
                )
                # the factors stay free in every later fit (effect forms, the null law's
                # replicas): an effect the shaft took up in the baseline can take it back
                pb = prep.problem
                pb.free_instrument = (*pb.free_instrument, *SHAFT)
                vals = {**again_vals, **{p.name: p.initial for p in SHAFT}}
            else:
                # prepared on the identified rig the record fits worse (its sticks and
                # segments read the rig too): RIG.yaml's shaft is kept
                say(
                    f'record {i}: shaft not used: prepared on it the baseline leaves '
                    f"{after:.4g} N m against {before:.4g} N m on RIG.yaml's"
                )
                prep = dataclasses.replace(
                    prep, instrument={**prep.instrument, 'shaft': {**report, 'used': False}}
                )
        if pol.speed_gain:
            # with the record's own shaft: a baseline far off its record would pull the
            # gain to take up its misfit
            prep, vals = identify_speed_gain(prep, vals, pol, say)
        preps.append(prep)
        base_vals.append(vals)
    ens = Ensemble([p.problem for p in preps], shared_friction=shared_friction)
    start = ens.join(base_vals)
    if ens.shared_friction:
        fit0 = ens.fit(ens.specs(), start, max_nfev=pol.fit_nfev)
    else:
        fit0 = Fit(start, ens.cost(start), 0, True, {})
    baseline = judge(ens, (), fit0)
    if null is not None and len(null) == ens.n:
        laws = list(null)
    else:
        laws = _null_laws(ens, baseline, pol, pol.replicas, pol.seed)
        if len(earlier) == ens.n:
            laws = [law.pooled(old, pool) for law, old in zip(laws, earlier, strict=True)]
    drift = [law.drift_outlier(p.sensor.drift) for law, p in zip(laws, preps, strict=True)]
    fails = failing(baseline, laws)
    say(
        'baseline statistics: '
        + '; '.join(
            ', '.join(f'{n} {a[n]:.3f} (bound {law.bound(n):.3f})' for n in law.samples)
            for a, law in zip(baseline.adequacy, laws, strict=True)
        )
    )
    current = baseline
    rounds: list[tuple[Effect, ...]] = []
    decision: Decision
    added: list[FormFit] = []
    added_to: dict[str, Model] = {}  # per family kept tentatively, the model it was added to
    verdict = null_verdict(
        [a['torsion_moment'] for a in baseline.adequacy], laws,
        [a.noise.torsion_moment.total for a in baseline.adequacy], bool(fails), say,
    )  # fmt: skip
    if verdict is not None:
        decision = verdict
    else:
        say(f'baseline inadequate: {", ".join(fails)}')
        decision = Decision(UNEXPLAINED, None, (), (), 'no family screened')
        for rnd in range(pol.max_effects):
            fits = screen(
                ens, current, laws, pol, say,
                exclude=[f.family for f in added], deadline=deadline,
            )  # fmt: skip
            decision = (
                decide(fits, current, laws, single_speed=_single_speed(ens))
                if fits
                else Decision(UNEXPLAINED, None, (), (), 'no family was fitted')
            )
            screened = {f.family for f in fits}
            wanted = set(pol.families or cand_lib.families()) - {f.family for f in added}
            if decision.kind == NAMED and not wanted <= screened and decision.named is not None:
                # a name says no other family explains the record: every family must
                # have been fitted for that
                decision = Decision(
                    UNEXPLAINED, None, (decision.named,), decision.partial,
                    f'{decision.named.family} explains the mismatch, but the time budget '
                    f'ended before {", ".join(sorted(wanted - screened))} were fitted',
                )  # fmt: skip
            elif decision.kind == UNEXPLAINED and not wanted <= screened:
                # what was not fitted cannot have been found wanting
                decision = dataclasses.replace(
                    decision,
                    reason=f'{decision.reason}; the time budget ended before '
                    f'{", ".join(sorted(wanted - screened))} were fitted',
                )
            # a round that only carries the kept forms ends the search
            kept = carried(decision, [(f, added_to[f.family]) for f in added], laws)
            stalled, decision = kept is not decision, kept
            rounds.append(tuple(_effect(f, ens, current, laws) for f in fits))
            say(f'round {rnd + 1}: {decision.kind}: {decision.reason}')
            if decision.kind in (NAMED, CANNOT_TELL_APART) or stalled:
                break
            singled = len(decision.alternatives) == 1 and decision.alternatives[0].failing
            if not singled or rnd + 1 >= pol.max_effects or _time.perf_counter() > deadline:
                break
            top = decision.alternatives[0]
            say(f'round {rnd + 1}: {top.family} kept tentatively for the next round')
            added.append(top)
            added_to[top.family] = current
            current = top.model
    named: list[FormFit] = []
    if decision.kind == NAMED and decision.named is not None:
        named = _needed([*added, decision.named], ens, laws, pol, say)
        final = named[-1].model
        if pol.confirm_replicas:
            own = _null_laws(ens, final, pol, pol.confirm_replicas, pol.seed + 7)
            still = failing(final, own) + tuple(
                'self-consistency' for law in own if not law.self_consistent()
            )
            if still:
                say(f'not confirmed by its own null law: {", ".join(still)}')
                decision = Decision(
                    UNEXPLAINED, None, (decision.named,), decision.partial,
                    f'{decision.named.family} fits, but its own null law finds '
                    f'{", ".join(still)} beyond noise',
                )  # fmt: skip
                named = []
        if named and any(drift):
            decision = Decision(
                INSTRUMENT, None, (), decision.partial,
                'the stick phases drift apart from the speed channel beyond their null law: '
                'the rig or an instrument changes during the record, which no friction '
                'effect explains',
            )  # fmt: skip
            named = []
    final_model = named[-1].model if named else baseline
    base_sims = ens.simulate(baseline.values)
    final_sims = ens.simulate(final_model.values)
    reports = []
    for i, (pb, prep, law) in enumerate(zip(ens.problems, preps, laws, strict=True)):
        bs, fs_ = base_sims[i], final_sims[i]
        r_final = torque_residual(pb, fs_)[fs_.covered]
        sigma = noise_floor(r_final)
        inadequate = bool(law.failing(final_model.adequacy[i]))
        unexplained = (
            describe_unexplained(pb, fs_, sigma=sigma) if inadequate and pol.describe else []
        )
        reports.append(
            RecordReport(
                baseline=ens.split(baseline.values)[i],
                final=ens.split(final_model.values)[i],
                rms_baseline=pb.torque_rms(bs),
                rms_final=pb.torque_rms(fs_),
                noise_floor=final_model.adequacy[i].noise.torsion_moment.white,
                statistics_baseline=dict(baseline.adequacy[i].values),
                statistics_final=dict(final_model.adequacy[i].values),
                null=law,
                noise=final_model.adequacy[i].noise.as_dict(),
                instrument=dict(prep.instrument),
                drive=drive_report(pb),
                drift_outlier=drift[i],
                unexplained=tuple(unexplained),
                localisation=(
                    {'baseline': localise(pb, bs), 'final': localise(pb, fs_)}
                    if pol.describe
                    else {}
                ),
                rejected=pb.segments.rejected,
            )
        )
    prev = baseline
    named_effects = []
    for f in named:
        named_effects.append(_effect(f, ens, prev, laws))
        prev = f.model
    run_time = _time.perf_counter() - t_start
    result = MissingPhysics(
        verdict=decision.kind,
        reason=decision.reason,
        experiment=decision.experiment,
        named=tuple(named_effects),
        alternatives=tuple(
            _effect(f, ens, added_to.get(f.family, current), laws) for f in decision.alternatives
        ),
        partial=tuple(
            _effect(f, ens, added_to.get(f.family, current), laws) for f in decision.partial
        ),
        records=tuple(reports),
        rounds=tuple(rounds),
        policy=pol,
        run_time=run_time,
        simulations=ens.n_evals(),
        traces=tuple(
            Traces(pb, b, f) for pb, b, f in zip(ens.problems, base_sims, final_sims, strict=True)
        ),
    )
    say(f'{result.finding()} ({run_time:.1f} s, {result.simulations} simulations)')
    return result


__all__ = ['find_missing_physics']
