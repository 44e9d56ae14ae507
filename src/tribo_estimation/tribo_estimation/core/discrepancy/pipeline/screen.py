"""Step 3 of the pipeline: fit every form of every candidate family on top of the current model.

Each form (one registered :class:`..candidates.Candidate`; a family's forms share its
``family``) is nested in the current model: its parameters zero (or at their lower
bound for time constants) give the current model back. For each form:

1. **Screen**: a short fit from each of its start points (the default, the nested
   start and those computed from the current residual, e.g. a ripple's frequency
   from a spectral line) on every k-th time block (about ``Policy.screen_seconds`` of
   each record, at least half its blocks). A *profiled* parameter
   (``Candidate.profile``, a time constant forming a curved valley with the
   levels) is held at each start value, and a parabola in its logarithm through
   the best point and its neighbours places it before it is freed.
2. **Refine**: each family's forms whose screened fit has the lowest whole-record
   cost (``Policy.refine`` of them per family) are refitted on the whole record.
3. **Judge**: the refined fit's adequacy statistics (:func:`.null.adequacy`) and
   the parameters at a bound of their box (a form that cannot reach what the record
   asks for: a form mismatch, never a name).

The current model's own parameters stay free in every fit.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ...lsq import parabola_vertex_log
from .. import candidates as cand_lib
from ..candidates import Candidate, ParamSpec, StartContext
from ..stats import stick_durations
from .ensemble import Ensemble, Fit, at_bound, own, plain
from .null import Adequacy, NullLaw, adequacy
from .policy import Policy, Progress

#: Parabola refinements of a profiled parameter.
_PROFILE_STEPS = 3


@dataclass(frozen=True)
class Model:
    """A model of the ensemble: its added forms and fitted values.

    Parameters
    ----------
    forms : tuple of str
        The added forms (candidate names), in the order added.
    fit : Fit
        Its fit (all values, cost, standard errors).
    adequacy : tuple of Adequacy
        Per record, its adequacy statistics.
    """

    forms: tuple[str, ...]
    fit: Fit
    adequacy: tuple[Adequacy, ...]

    @property
    def values(self) -> dict[str, float]:
        """All values of the model (SI)."""
        return self.fit.values

    def params(self) -> list[ParamSpec]:
        """Return the parameters of its added forms."""
        return [p for f in self.forms for p in cand_lib.get(f).params]


@dataclass(frozen=True)
class FormFit:
    """One form fitted on top of the current model.

    Parameters
    ----------
    family : str
        Its effect family.
    form : str
        The form (candidate name).
    model : Model
        The current model plus this form, refitted.
    failing : tuple of str
        Adequacy statistics beyond their null bound, over the records
        (``name@record``; empty: adequate).
    bounded : tuple of str
        The form's parameters at a bound of their box.
    """

    family: str
    form: str
    model: Model
    failing: tuple[str, ...]
    bounded: tuple[str, ...]

    @property
    def adequate(self) -> bool:
        """True when the model passes every adequacy statistic and no parameter is at a bound."""
        return not self.failing and not self.bounded

    @property
    def params(self) -> dict[str, float]:
        """The form's fitted parameters (SI)."""
        return {n: self.model.values[n] for n in cand_lib.get(self.form).param_names}

    def torque(self) -> float:
        """Return the worst record's torsion-moment adequacy statistic [-]."""
        return max(a['torsion_moment'] for a in self.model.adequacy)


def judge(ens: Ensemble, forms: tuple[str, ...], fit: Fit) -> Model:
    """Return the model of a fit with its adequacy statistics.

    Parameters
    ----------
    ens : Ensemble
        The records.
    forms : tuple of str
        The model's added forms.
    fit : Fit
        Its fit.

    Returns
    -------
    Model
        The model.
    """
    # judged from the segments' corrected starts (:meth:`..fitting.Problem.refined`)
    sims = [pb.refined(v) for pb, v in zip(ens.problems, ens.split(fit.values), strict=True)]
    return Model(
        forms,
        fit,
        tuple(adequacy(pb, s) for pb, s in zip(ens.problems, sims, strict=True)),
    )


def failing(model: Model, laws: Sequence[NullLaw]) -> tuple[str, ...]:
    """Return the adequacy statistics of a model beyond their records' null bounds.

    Parameters
    ----------
    model : Model
        The model.
    laws : sequence of NullLaw
        One null law per record.

    Returns
    -------
    tuple of str
        ``statistic@record`` for every failing statistic.
    """
    out: list[str] = []
    for i, (a, law) in enumerate(zip(model.adequacy, laws, strict=True)):
        out.extend(f'{n}@{i}' for n in law.failing(a))
    return tuple(out)


def start_context(ens: Ensemble, current: Model) -> StartContext:
    """Return what the forms see to choose start values (the first record's residuals).

    Parameters
    ----------
    ens : Ensemble
        The records.
    current : Model
        The current model.

    Returns
    -------
    StartContext
        Residuals, drive speed level and angle, stick durations and the
        friction-moment scale.
    """
    pb = ens.problems[0]
    sim = pb.simulate(ens.split(current.values)[0])
    rec = pb.record
    cov = sim.covered
    stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
    return StartContext(
        time=rec.time[cov],
        fs=rec.fs,
        torque=(rec.torsion_moment - sim.torsion_moment)[cov],
        speed=(rec.speed - sim.speed)[cov],
        nominal_speed=pb.drive_estimate.level,
        stick_durations=stick_durations(stick[cov], rec.fs),
        friction_moment_scale=float(np.median(np.abs(rec.torsion_moment))),
        drive_angle=pb.drive_estimate.angle(rec.time[cov]),
    )


def screen_form(
    ens: Ensemble,
    current: Model,
    form: Candidate,
    ctx: StartContext,
    policy: Policy,
) -> Fit:
    """Screen one form's start points on a subset of the blocks; return the best screened fit.

    Parameters
    ----------
    ens : Ensemble
        The records.
    current : Model
        The current model.
    form : Candidate
        The form.
    ctx : StartContext
        The current residuals (data-driven start values).
    policy : Policy
        Budgets.

    Returns
    -------
    Fit
        The best screened fit (values of all parameters).
    """
    # screening frees the levels (mu0, mu_inf) and the effects' parameters; k and the
    # instrument terms stay at the start (fewer parameters: more iterations per budget),
    # the refinement frees them
    specs = [
        p for p in ens.specs([*current.params(), *form.params])
        if plain(p.name) in ('mu0', 'mu_inf') or '@' not in p.name
    ]  # fmt: skip
    held = form.profile
    free = [p for p in specs if p.name != held]
    folds = ens.screen_folds(policy.screen_seconds)
    best: Fit | None = None
    profile: list[tuple[float, float]] = []
    starts = [{**current.values, **pt} for pt in form.start_points(ctx)]
    # the baseline's k may have absorbed part of the effect (k and a friction-law effect
    # trade at one drive speed): the default start once more from RIG.yaml's k
    config_k = {
        own('k', i): pb.k
        for i, pb in enumerate(ens.problems)
        if abs(math.log(current.values.get(own('k', i), pb.k) / pb.k)) > 0.1
    }
    if config_k:
        starts.append({**current.values, **form.default_start(), **config_k})
    for start in starts:
        fo = ens.fit(
            free if held else specs, start, max_nfev=policy.screen_nfev, fold=0, folds=folds
        )
        if held:
            profile.append((float(start[held]), fo.cost))
        if best is None or fo.cost < best.cost:
            best = fo
    assert best is not None
    if held:
        spec = next(p for p in form.params if p.name == held)
        for _ in range(_PROFILE_STEPS):
            xv = parabola_vertex_log(profile)
            if xv is None or any(abs(math.log(v) - xv) < 0.02 for v, _ in profile):
                break
            value = min(max(math.exp(xv), spec.lower), spec.upper)
            fo = ens.fit(
                free, {**best.values, held: value}, max_nfev=policy.screen_nfev, fold=0,
                folds=folds,
            )  # fmt: skip
            profile.append((value, fo.cost))
            if fo.cost < best.cost:
                best = fo
    return best


def screen(
    ens: Ensemble,
    current: Model,
    laws: Sequence[NullLaw],
    policy: Policy,
    say: Progress,
    *,
    exclude: Sequence[str] = (),
    deadline: float = math.inf,
) -> list[FormFit]:
    """Screen and refine every form of the families not yet in the model (module docstring).

    Parameters
    ----------
    ens : Ensemble
        The records.
    current : Model
        The current model.
    laws : sequence of NullLaw
        Each record's null law (the adequacy bounds).
    policy : Policy
        Budgets and families.
    say : Progress
        Receiver of progress messages.
    exclude : sequence of str
        Families not screened (those already in the model).
    deadline : float
        ``time.perf_counter()`` after which no further form is screened or refined
        (none at all when it has passed before the screening).

    Returns
    -------
    list of FormFit
        The refined forms, best whole-record cost first.
    """
    names = policy.families if policy.families is not None else cand_lib.families()
    ctx = start_context(ens, current)
    screened: list[tuple[float, Candidate, Fit]] = []
    for fam in names:
        if fam in exclude:
            continue
        for form in cand_lib.forms(fam):
            if _time.perf_counter() > deadline:
                say(f'time budget spent: {form.name} and later forms not screened')
                break
            fo = screen_form(ens, current, form, ctx, policy)
            whole = ens.cost(fo.values)
            screened.append((whole, form, fo))
            say(f'screen {form.name:<26s} cost {whole:.4g} (current {current.fit.cost:.4g})')
    screened.sort(key=lambda e: e[0])
    # every family's best screened forms (``Policy.refine`` of them) are refined: the
    # screening's short fits rank the forms of a family, not the families (a form whose
    # effect the baseline's k absorbed screens far worse than it fits)
    chosen: list[tuple[float, Candidate, Fit]] = []
    count: dict[str, int] = {}
    for entry in screened:
        fam = entry[1].family_name
        if count.get(fam, 0) < policy.refine:
            chosen.append(entry)
            count[fam] = count.get(fam, 0) + 1
    out: list[FormFit] = []
    for whole, form, fo in chosen:
        if _time.perf_counter() > deadline:
            say(f'time budget spent: {form.name} and later forms not refined')
            break
        specs = ens.specs([*current.params(), *form.params])
        fit = ens.fit(specs, fo.values, max_nfev=policy.fit_nfev)
        if fit.cost > whole:  # the refinement may stop early: keep the better
            fit = Fit(fo.values, whole, fit.nfev, fit.converged, fit.se)
        model = judge(ens, (*current.forms, form.name), fit)
        ff = FormFit(
            form.family_name,
            form.name,
            model,
            failing(model, laws),
            tuple(at_bound(form.params, fit.values, policy.bound_margin)),
        )
        out.append(ff)
        say(
            f'refit  {form.name:<26s} torque statistic {ff.torque():.3f}'
            + (f', fails {", ".join(ff.failing)}' if ff.failing else ', adequate')
            + (f', at bound: {", ".join(ff.bounded)}' if ff.bounded else '')
        )
    out.sort(key=lambda f: f.model.fit.cost)
    return out


def forms_of(fits: Sequence[FormFit], family: str) -> list[FormFit]:
    """Return the fits of one family's forms."""
    return [f for f in fits if f.family == family]


def values_of(values: Mapping[str, float], names: Sequence[str]) -> dict[str, float]:
    """Return the named values (SI)."""
    return {n: float(values[n]) for n in names}


__all__ = [
    'FormFit',
    'Model',
    'failing',
    'forms_of',
    'judge',
    'screen',
    'screen_form',
    'start_context',
    'values_of',
]
