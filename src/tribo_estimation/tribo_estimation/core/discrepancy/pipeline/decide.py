"""Step 4 of the pipeline: the decision rules.

Every rule compares a statistic with its distribution under "nothing missing" for
this record (:mod:`.null`); no threshold is tuned:

- **Adequate**: a model passes every adequacy statistic of every record (bounds at
  ``Policy.alpha``) and none of its added form's parameters sits at a bound of its
  box (a form at its bound cannot reach what the record asks for: a form mismatch).
- **Resolves**: an adequate form also lowers a statistic the current model fails by
  more than the null law's tolerance of it (the replicas' spread): a form that only
  nudges a statistic from just above its bound to just below explains nothing the
  noise could not, and is neither a name nor a member of a set.
- **Named**: exactly one family has an adequate form that resolves. The name is the
  family, with the form that fitted.
- **Cannot tell apart**: several families have adequate forms that resolve; the record does not
  decide between them. The answer is the set, each member's evidence and the
  experiment that separates them.
- **Partial**: no family is adequate, but some lower the torsion-moment statistic
  by more than the null law allows (their improvement is not noise). Partial
  explanations are never names; those whose statistics lie within the null law's
  tolerance of the best are one set ("explains the same part").
- **Unexplained**: the current model is inadequate and no family is adequate.

None of these is applied when a record's null law is not self-consistent
(:meth:`.null.NullLaw.self_consistent`: its replicas are refitted beyond their own
noise); the record is then unexplained, by the caller (:mod:`.run`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .. import candidates as cand_lib
from ..candidates import SUGGEST_LONGER, SUGGEST_MORE, SUGGEST_SPEED
from .null import NullLaw
from .screen import FormFit, Model

#: Kinds of decision.
NOTHING_MISSING = 'nothing_missing'
NAMED = 'named'
CANNOT_TELL_APART = 'cannot_tell_apart'
UNEXPLAINED = 'unexplained'
INSTRUMENT = 'instrument'
KINDS: tuple[str, ...] = (NOTHING_MISSING, NAMED, CANNOT_TELL_APART, UNEXPLAINED, INSTRUMENT)


@dataclass(frozen=True)
class Decision:
    """The outcome of one round of the decision rules (module docstring).

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`.
    named : FormFit or None
        The named family's fit (kind ``named``).
    alternatives : tuple of FormFit
        The families the record cannot tell apart (best form of each), or the set
        of the best partial explanations.
    partial : tuple of FormFit
        Families that explain part of the mismatch (best form each), best first.
    reason : str
        One sentence why.
    experiment : str
        The experiment that would decide ('' if none is needed).
    """

    kind: str
    named: FormFit | None
    alternatives: tuple[FormFit, ...]
    partial: tuple[FormFit, ...]
    reason: str
    experiment: str = ''


def best_per_family(fits: Sequence[FormFit]) -> list[FormFit]:
    """Return each family's best form: adequate first, then not at a bound, then by cost."""
    best: dict[str, FormFit] = {}
    for f in fits:
        key = (not f.adequate, bool(f.bounded), f.model.fit.cost)
        old = best.get(f.family)
        if old is None or key < (not old.adequate, bool(old.bounded), old.model.fit.cost):
            best[f.family] = f
    return sorted(best.values(), key=lambda f: f.model.fit.cost)


def _torque_log(model: Model) -> npt.NDArray[np.float64]:
    """Return the log torsion-moment statistic of every record of a model."""
    return np.log(np.asarray([a['torsion_moment'] for a in model.adequacy], dtype=np.float64))


def _tolerance(laws: Sequence[NullLaw]) -> npt.NDArray[np.float64]:
    """Return each record's tolerance of the torsion-moment statistic (log)."""
    return np.asarray([law.tolerance('torsion_moment') for law in laws], dtype=np.float64)


def indistinguishable(a: Model, b: Model, laws: Sequence[NullLaw]) -> bool:
    """Tell whether two models' torsion-moment statistics differ by less than noise allows.

    In every record the difference of the log statistics lies within the null law's
    tolerance (:meth:`.null.NullLaw.tolerance`).

    Parameters
    ----------
    a, b : Model
        Two models of the same records.
    laws : sequence of NullLaw
        The records' null laws.

    Returns
    -------
    bool
        True when the records cannot tell the two apart.
    """
    return bool(np.all(np.abs(_torque_log(a) - _torque_log(b)) <= _tolerance(laws)))


def improves(better: Model, current: Model, laws: Sequence[NullLaw]) -> bool:
    """Tell whether ``better`` lowers the torsion-moment statistic beyond noise in a record."""
    return bool(np.any(_torque_log(current) - _torque_log(better) > _tolerance(laws)))


def resolves(better: Model, current: Model, laws: Sequence[NullLaw]) -> bool:
    """Tell whether ``better`` lowers a failing statistic of ``current`` beyond noise.

    In some record, a statistic beyond its bound for ``current`` is lower for
    ``better`` by more than the null law's tolerance of it
    (:meth:`.null.NullLaw.tolerance`, log ratio).

    Parameters
    ----------
    better, current : Model
        Two models of the same records.
    laws : sequence of NullLaw
        The records' null laws.

    Returns
    -------
    bool
        True when the change is larger than what noise varies the failing statistic by.
    """
    for a_cur, a_new, law in zip(current.adequacy, better.adequacy, laws, strict=True):
        for name in law.failing(a_cur):
            now, then = a_new[name], a_cur[name]
            if now > 0.0 and math.isfinite(then) and math.log(then / now) > law.tolerance(name):
                return True
    return False


def explained(fit: FormFit, current: Model, laws: Sequence[NullLaw]) -> float:
    """Return the share of the current model's excess that a form removes [-].

    ``(A_cur^2 - A^2)/(A_cur^2 - c^2)`` on the torsion-moment statistic A (c: the null
    law's centre), the worst record.

    Parameters
    ----------
    fit : FormFit
        The form's fit.
    current : Model
        The current model.
    laws : sequence of NullLaw
        The records' null laws.

    Returns
    -------
    float
        The share, 1 = down to what noise leaves.
    """
    shares = []
    for a_cur, a_new, law in zip(current.adequacy, fit.model.adequacy, laws, strict=True):
        c = law.centre('torsion_moment')
        x0 = a_cur['torsion_moment'] ** 2
        x1 = a_new['torsion_moment'] ** 2
        excess = x0 - c * c
        shares.append((x0 - x1) / excess if excess > 0 else 0.0)
    return float(min(shares)) if shares else math.nan


def experiment(families: Sequence[str], single_speed: bool) -> str:
    """Return the experiment that would separate (or decide) a set of families.

    Parameters
    ----------
    families : sequence of str
        The families.
    single_speed : bool
        Every record ran at one drive speed.

    Returns
    -------
    str
        The experiment, or '' for an empty set.
    """
    wanted = []
    for fam in families:
        for form in cand_lib.forms(fam):
            wanted.append(form.suggest)
    if not wanted:
        return ''
    if single_speed and SUGGEST_SPEED in wanted:
        return SUGGEST_SPEED
    for s in (SUGGEST_SPEED, SUGGEST_LONGER, SUGGEST_MORE):
        if s in wanted:
            return s
    return wanted[0]


def decide(
    fits: Sequence[FormFit],
    current: Model,
    laws: Sequence[NullLaw],
    *,
    single_speed: bool,
) -> Decision:
    """Apply the decision rules to one round's fits (module docstring).

    Parameters
    ----------
    fits : sequence of FormFit
        The refined forms of the round.
    current : Model
        The current model (inadequate: the caller checked).
    laws : sequence of NullLaw
        The records' null laws.
    single_speed : bool
        Every record ran at one drive speed (for the suggested experiment).

    Returns
    -------
    Decision
        The round's decision.
    """
    per_family = best_per_family(fits)
    within = [f for f in per_family if f.adequate]
    adequate = [f for f in within if resolves(f.model, current, laws)]
    if len(adequate) == 1:
        f = adequate[0]
        return Decision(
            NAMED,
            f,
            (),
            tuple(g for g in per_family if g is not f and improves(g.model, current, laws)),
            f'{f.family} ({f.form}) explains the mismatch down to the noise, and no other '
            'family of the library does',
        )
    if adequate:
        fams = [f.family for f in adequate]
        return Decision(
            CANNOT_TELL_APART,
            None,
            tuple(adequate),
            tuple(adequate),
            f'{", ".join(fams)} each explain the mismatch down to the noise: this record '
            'cannot tell them apart',
            experiment(fams, single_speed),
        )
    partial = [f for f in per_family if improves(f.model, current, laws)]
    if not partial:
        why = 'no family fitted lowers the mismatch beyond what noise allows'
        if within:
            why += (
                f'; {", ".join(f.family for f in within)} bring the model within the '
                'bounds, by less than noise varies the failing statistic: this record '
                'cannot decide'
            )
        return Decision(UNEXPLAINED, None, (), (), why)
    top = partial[0]
    same = tuple(f for f in partial if indistinguishable(f.model, top.model, laws))
    mismatch = [f for f in partial if f.bounded and not f.failing]
    why = (
        f'no family explains the mismatch down to the noise; {top.family} explains '
        f'{100 * explained(top, current, laws):.0f} % of the excess'
    )
    if len(same) > 1:
        why += f' and cannot be told apart from {", ".join(f.family for f in same[1:])}'
    if mismatch:
        why += (
            '; '
            + ', '.join(f'{f.family} fits with {", ".join(f.bounded)} at a bound' for f in mismatch)
            + ' (its form does not match)'
        )
    return Decision(
        UNEXPLAINED,
        None,
        same,
        tuple(partial),
        why,
        experiment([f.family for f in same], single_speed) if len(same) > 1 else '',
    )


def carried(
    decision: Decision, kept: Sequence[tuple[FormFit, Model]], laws: Sequence[NullLaw]
) -> Decision:
    """Return a round's decision with the forms kept tentatively in earlier rounds.

    A form kept for the next round (the one partial explanation a round singled out)
    stays the record's partial explanation when the next round finds nothing that
    lowers the mismatch further: the round's "no family lowers the mismatch" is said
    of the model with it, not of the record.

    Parameters
    ----------
    decision : Decision
        The round's decision.
    kept : sequence of (FormFit, Model)
        The forms kept in earlier rounds, in order, each with the model it was added to.
    laws : sequence of NullLaw
        The records' null laws.

    Returns
    -------
    Decision
        ``decision`` itself unless it is unexplained with no partial explanation of its
        own after kept forms; then unexplained with the kept forms as the set and the
        partial explanations, and the share of the excess each explains.
    """
    if decision.kind != UNEXPLAINED or decision.partial or not kept:
        return decision
    forms = tuple(f for f, _ in kept)
    shares = '; '.join(
        f'{f.family} explains {100 * explained(f, before, laws):.0f} % of the excess'
        for f, before in kept
    )
    them = 'them' if len(forms) > 1 else 'it'
    return Decision(
        UNEXPLAINED,
        None,
        forms,
        forms,
        f'no family explains the mismatch down to the noise; {shares}, and with {them} in '
        f'the model {decision.reason}',
    )


__all__ = [
    'CANNOT_TELL_APART',
    'INSTRUMENT',
    'KINDS',
    'NAMED',
    'NOTHING_MISSING',
    'UNEXPLAINED',
    'Decision',
    'best_per_family',
    'carried',
    'decide',
    'experiment',
    'explained',
    'improves',
    'indistinguishable',
    'resolves',
]
