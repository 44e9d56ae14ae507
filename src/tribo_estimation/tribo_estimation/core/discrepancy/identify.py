"""Identifiability of candidate effects: can this record (or these records) decide.

One place for the verdict used by the offline workflow (:func:`.select.run_discrepancy`,
:func:`.joint.run_joint_discrepancy`) and the live monitor (:mod:`.monitor`):

* :func:`gauss_newton` (:mod:`.linearised`, re-exported here): linearised standard
  errors and correlations of an output-error fit at its solution;
* :func:`identifiability`: the verdict for one candidate from those numbers and
  physical checks on the record (spread of the stick durations for dwell-time
  stiction, spread of the drive speeds for speed-dependent effects, record length
  for drifts), with the reason and the experiment that would decide it;
* :func:`record_facts` / :func:`assess`: the physical facts of a fitted record and
  the verdict of every candidate of a selection round.

The baseline is the paper's friction law (Equ. 8: mu0, mu_inf); the instrument
model (speed-sensor lag and offset) is included in the correlation check when it is
part of the linearisation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from tribo_estimation.errors import InvalidParameterError

from .candidates import ParamSpec
from .linearised import (
    GaussNewton,
    ProblemResiduals,
    ResidualModel,
    gauss_newton,
)
from .stats import FloatArray

#: Baseline parameters an effect must be separable from (Equ. 8).
BASELINE_NAMES: tuple[str, ...] = ('mu0', 'mu_inf')
#: Instrument-model parameters (speed sensor) also checked for correlation.
INSTRUMENT_NAMES: tuple[str, ...] = ('speed_lag_tau', 'speed_offset')

#: Candidates whose signature depends on the slip or drive speed.
SPEED_DEPENDENT: frozenset[str] = frozenset(
    {'viscous_friction', 'frictional_lag', 'dwell_time_stiction', 'bearing_friction'}
)
#: Candidates that change with test time (need record length).
DRIFTS: frozenset[str] = frozenset({'friction_drift', 'torque_offset'})

SUGGEST_SPEED = 'a second drive speed or a speed step'
SUGGEST_LONGER = 'a longer record'
SUGGEST_MORE = 'a longer record (more stick-slip cycles)'


def suggestion(candidate: str) -> str:
    """Return the experiment that would decide ``candidate`` when a record cannot.

    Parameters
    ----------
    candidate : str
        Candidate name.

    Returns
    -------
    str
        A second drive speed (speed-dependent effects), a longer record (drifts) or
        more stick-slip cycles.
    """
    if candidate in SPEED_DEPENDENT:
        return SUGGEST_SPEED
    if candidate in DRIFTS:
        return SUGGEST_LONGER
    return SUGGEST_MORE


@dataclass(frozen=True)
class Identifiability:
    """Verdict of :func:`identifiability`.

    ``ok``, a one-line ``reason`` and, when not ok, the experiment that would decide it
    (``suggest``; also named in the reason).
    """

    ok: bool
    reason: str
    suggest: str = ''

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form.

        Returns
        -------
        dict[str, object]
            ``ok``, ``reason`` and ``suggest``.
        """
        return {'ok': self.ok, 'reason': self.reason, 'suggest': self.suggest}


@dataclass(frozen=True)
class RecordFacts:
    """Physical facts of a fitted record (or several) for :func:`identifiability`.

    ``stick_durations`` complete stick phases [s]; ``drive_speeds`` mean drive speed
    per time block (and record) [rad/s]; ``duration`` total length of the records [s].
    """

    stick_durations: FloatArray
    drive_speeds: FloatArray
    duration: float


def _base(name: str) -> str:
    """Parameter name without a per-record suffix (``mu0@1`` -> ``mu0``)."""
    return name.split('@', 1)[0]


def identifiability(
    candidate: str,
    param_names: Sequence[str],
    gn: GaussNewton,
    stick_durations_s: FloatArray,
    *,
    drive_speeds: FloatArray | None = None,
    duration: float | None = None,
    max_rel_se: float = 0.2,
    max_correlation: float = 0.999,
    min_spread: float = 0.1,
    min_drift_duration: float = 0.5,
    gain: float | None = None,
    decisive_gain: float = 0.9,
    min_gain: float = 0.0,
) -> Identifiability:
    """Judge whether this record separates ``candidate`` from baseline and instrument.

    The baseline is mu0, mu_inf of Equ. 8, the instrument model the speed-sensor terms.
    Honest checks on what the fit gives (``gn``: :func:`gauss_newton` of the fit of
    mu0, mu_inf (per record: ``mu0@i``), optionally the speed-sensor terms, and the
    candidate's ``param_names``):

    * for ``dwell_time_stiction`` the spread of the stick durations
      ``stick_durations_s`` [s]: the effect only shows as a dependence of the
      breakaway on the preceding stick time, so if (p90 - p10) / median is
      below ``min_spread`` (-; at one constant drive speed every stick lasts as
      long as the next) it is confounded with mu0 -- unless the candidate's fit
      itself is decisive: it removed at least ``decisive_gain`` (-) of the
      baseline's cross-validated cost (``gain``): then mu0 demonstrably did not
      absorb it (stiction raises only the breakaway threshold, not the sliding
      curve of Equ. 8, so it can show at one speed);
    * for drifts (``friction_drift``, ``torque_offset``) the record ``duration`` [s]
      must reach ``min_drift_duration``;
    * a parameter the simulation does not depend on is not identifiable;
    * the correlation of a candidate parameter with mu0/mu_inf or the instrument
      terms above ``max_correlation`` (-): the record cannot tell the effect from a
      change of the friction law or of the sensor;
    * the relative standard error of every candidate parameter (the correlations
      inflate it; with the model-error term of :func:`gauss_newton`: a fit that
      leaves a systematic residual is as uncertain as its scatter between time
      blocks, marked "model error" in the reason) must not exceed ``max_rel_se`` (-);
    * the candidate must lower the baseline's cross-validated cost by at least
      ``min_gain`` (-, the selection's detection limit): an effect pinned down by its
      standard errors but smaller than that against the noise is one this record
      cannot decide (a longer record, more cycles or a lower noise would).

    ``drive_speeds`` [rad/s] (per block or record) only shapes the reason of a
    speed-dependent effect that fails (one speed: "all at 3.14 rad/s").

    Parameters
    ----------
    candidate : str
        Candidate name.
    param_names : Sequence[str]
        Its parameters in ``gn``.
    gn : GaussNewton
        Linearisation of the candidate's fit.
    stick_durations_s : FloatArray
        Complete stick phases [s].
    drive_speeds : FloatArray or None
        Mean drive speed per block or record [rad/s].
    duration : float or None
        Record length [s].
    max_rel_se, max_correlation, min_spread, min_drift_duration : float
        Limits (see above).
    gain : float or None
        The candidate's cross-validated relative cost reduction [-].
    decisive_gain : float
        Gain that overrules the stick-duration proxy [-].
    min_gain : float
        Smallest gain of a decidable effect [-] (0: no such check).

    Returns
    -------
    Identifiability
        The verdict with its reason and, when not ok, the deciding experiment.

    Raises
    ------
    InvalidParameterError
        If ``gn`` lacks mu0/mu_inf or a candidate parameter.
    """
    idx = {n: i for i, n in enumerate(gn.names)}
    have_base = {_base(n) for n in gn.names}
    missing = [n for n in (*BASELINE_NAMES, *param_names) if n not in have_base and n not in idx]
    if missing:
        raise InvalidParameterError(
            f'identifiability: the fit lacks {missing} (has {list(gn.names)})'
        )
    suggest = suggestion(candidate)
    decide = f'({suggest} would decide it)'
    speed_txt = ''
    if drive_speeds is not None:
        ds = np.asarray(drive_speeds, dtype=np.float64)
        ds = ds[np.isfinite(ds)]
        if ds.size and float(np.mean(ds)) > 0:
            lo_w, hi_w = float(np.min(ds)), float(np.max(ds))
            if (hi_w - lo_w) / float(np.mean(ds)) < min_spread:
                speed_txt = f' (all at one drive speed, {lo_w:.3g}-{hi_w:.3g} rad/s)'
    decided_by_fit = gain is not None and math.isfinite(gain) and gain >= decisive_gain
    if candidate == 'dwell_time_stiction' and not decided_by_fit:
        d = np.asarray(stick_durations_s, dtype=np.float64)
        d = d[np.isfinite(d)]
        if d.size < 3:
            return Identifiability(
                False,
                f'only {d.size} complete stick phases: dwell-time stiction needs >= 3 {decide}',
                suggest,
            )
        lo, med, hi = (float(v) for v in np.percentile(d, (10.0, 50.0, 90.0)))
        if med <= 0 or (hi - lo) / med < min_spread:
            return Identifiability(
                False,
                f'all sticks last {1e3 * lo:.1f}-{1e3 * hi:.1f} ms: dwell-time stiction is '
                f'confounded with mu0 {decide}',
                suggest,
            )
    if candidate in DRIFTS and duration is not None and duration < min_drift_duration:
        return Identifiability(
            False,
            f'the record lasts {duration:.2g} s (< {min_drift_duration:g} s): a drift of '
            f'{candidate} is confounded with mu0/mu_inf {decide}',
            suggest,
        )
    dead = [n for n in param_names if n in gn.dead]
    if dead:
        return Identifiability(
            False, f'the record does not depend on {", ".join(dead)} here {decide}', suggest
        )
    others = [n for n in gn.names if _base(n) in (*BASELINE_NAMES, *INSTRUMENT_NAMES)]
    worst, pair = 0.0, ('', '')
    for pn in param_names:
        for bn in others:
            c = abs(float(gn.corr[idx[pn], idx[bn]]))
            if c > worst:
                worst, pair = c, (pn, bn)
    corr_txt = f'correlation of {pair[0]} with {pair[1]} {worst:.3f}'
    if worst > max_correlation:
        what = 'the instrument model' if _base(pair[1]) in INSTRUMENT_NAMES else 'the friction law'
        return Identifiability(
            False,
            f'{corr_txt} (> {max_correlation:g}): {candidate} is confounded with {what} '
            f'in this record{speed_txt} {decide}',
            suggest,
        )
    parts = []
    for pn in param_names:
        v, se = gn.values[idx[pn]], gn.se[idx[pn]]
        rel = se / abs(v) if v != 0 else math.inf
        src = ', profile' if pn in gn.profiled else ', model error' if pn in gn.model_error else ''
        parts.append(f'{pn} = {v:.4g} +- {se:.2g} ({100 * rel:.0f} %{src})')
        if not rel <= max_rel_se:
            return Identifiability(
                False,
                f'{parts[-1]} exceeds {100 * max_rel_se:g} %: this record cannot pin '
                f'{candidate} down{speed_txt}; {corr_txt} {decide}',
                suggest,
            )
    if gain is not None and math.isfinite(gain) and gain < min_gain:
        more = 'a longer record or a lower noise'
        return Identifiability(
            False,
            f'{"; ".join(parts)}, but it lowers the held-out cost by only {100 * gain:.1f} % '
            f'(< {100 * min_gain:g} %): too small against the noise for this record to decide '
            f'({more} would decide it)',
            more,
        )
    return Identifiability(True, f'{"; ".join(parts)} (1 SE); {corr_txt}')


def fit_stability(
    candidate: str,
    param_names: Sequence[str],
    gn: GaussNewton,
    first: Mapping[str, float],
    *,
    max_se: float = 3.0,
    max_rel: float = 0.1,
) -> Identifiability | None:
    """Judge whether a converged fit agrees with the selection round's first fit.

    The selection scores every candidate with a fit of a limited budget and then
    polishes the accepted one to convergence (:func:`.select.run_discrepancy`). When
    a candidate parameter moved between the two by more than ``max_se`` standard
    errors of the converged fit (``gn``, :func:`gauss_newton` at it) and by more than
    ``max_rel`` (-) of its value, the cost has no single well-defined minimum the fit
    settles in (or it crawls along a valley): the fit is unstable, and an unstable
    fit does not identify the effect. The relative floor keeps a linearised standard
    error that understates the scatter (a stick-slip record's cost is not quadratic
    far below the noise) from calling a small refinement unstable.

    Parameters
    ----------
    candidate : str
        Candidate name.
    param_names : Sequence[str]
        Its parameters in ``gn``.
    gn : GaussNewton
        Linearisation at the converged fit.
    first : Mapping[str, float]
        The first fit's values (SI).
    max_se : float
        Largest move in standard errors [-].
    max_rel : float
        Largest relative move [-].

    Returns
    -------
    Identifiability or None
        A "not identifiable" verdict with its reason and suggestion, or None when the
        two fits agree.
    """
    idx = {n: i for i, n in enumerate(gn.names)}
    for pn in param_names:
        if pn not in idx or pn not in first:
            continue
        v, se = gn.values[idx[pn]], gn.se[idx[pn]]
        v0 = float(first[pn])
        move = abs(v - v0)
        n_se = move / se if se > 0 else math.inf
        if n_se > max_se and move > max_rel * max(abs(v), abs(v0)):
            suggest = suggestion(candidate)
            return Identifiability(
                False,
                f'unstable fit: {pn} = {v0:.4g} in the selection round but {v:.4g} +- '
                f'{se:.2g} converged ({n_se:.0f} SE, {100 * move / max(abs(v), abs(v0)):.0f} % '
                f'apart): this record does not pin {candidate} down ({suggest} would '
                'decide it)',
                suggest,
            )
    return None


def per_record(spec: ParamSpec, i: int) -> ParamSpec:
    """``spec`` renamed for record ``i`` of a joint fit (``mu0`` -> ``mu0@i``)."""
    return replace(spec, name=f'{spec.name}@{i}')


__all__ = [
    'BASELINE_NAMES',
    'DRIFTS',
    'INSTRUMENT_NAMES',
    'SPEED_DEPENDENT',
    'GaussNewton',
    'Identifiability',
    'ProblemResiduals',
    'RecordFacts',
    'ResidualModel',
    'fit_stability',
    'gauss_newton',
    'identifiability',
    'per_record',
    'suggestion',
]
