"""Model selection: which missing effect explains the gap.

Forward selection over the candidate library (:mod:`.candidates`):

1. Fit the baseline (the paper's model, Equ. 1-8: ``mu0``, ``mu_inf`` free) by
   output error over the segments (:mod:`.fitting`).
2. For each candidate not yet in the model, fit the current model's
   parameters plus the candidate's (nested: all candidates start from the
   current model) on the whole record, and by cross validation: the time
   blocks are split into folds, each fold is predicted by a fit to the others.
3. Score: held-out cost (cross validation) and the Bayesian information
   criterion ``BIC = n_eff*ln(cost) + p*ln(n_eff)`` of the whole-record fit,
   with ``n_eff`` the number of compared samples thinned to one per
   ``corr_time`` (residuals of a model mismatch are correlated over about a
   millisecond; counting every 0.1 ms sample would overstate the evidence).
4. A candidate is eligible only if it improves clearly: held-out cost lower
   by at least ``min_gain`` (relative) AND ``delta_BIC <= -bic_threshold``.
   The eligible candidate with the lowest BIC is added, unless one with fewer
   parameters fits practically as well (whole-record cost within
   ``parsimony``; e.g. a torque-offset drift vs equal drifts of mu0 and
   mu_inf, which predict the same signals); the model is polished, and the
   next round starts from it. Repeat until no candidate is eligible.
   Every candidate's identifiability (:mod:`.identify`: standard errors and
   correlations of its round-1 fit with mu0/mu_inf and the instrument model,
   stick-duration and drive-speed spread, record length) is judged; a candidate
   this record cannot separate is never added: it is reported in ``blocked``
   as not identifiable, with the experiment that would decide it.
5. Describe what remains (:func:`.unexplained.describe_unexplained`): spectral lines, a
   phase-concentrated excess, a trend, a shaft-angle dependence, each with
   where / how large / which frequency, rather than forcing a name; and
   optionally propose a data-driven term (sparse regression, :mod:`.sparse`).

Modules: :mod:`.results` (settings and result types), :mod:`.scoring` (cost,
held-out cost, BIC), :mod:`.baseline` (instrument model, baseline fit, the facts and
verdicts of identifiability), :mod:`.unexplained` (what remains), :mod:`.run`
(:func:`run_discrepancy`).
"""

from __future__ import annotations

from ..localise import variable
from .baseline import (
    baseline_starts,
    block_speeds,
    drive_report,
    fit_baseline,
    instrument_record,
    judge_candidates,
    record_facts,
    start_context,
)
from .results import (
    AddedEffect,
    CandidateScore,
    DiscrepancyResult,
    ModelScore,
    Progress,
    SelectionSettings,
    Traces,
    Unexplained,
)
from .run import run_discrepancy
from .unexplained import describe_unexplained, propose_terms

__all__ = [
    'AddedEffect',
    'CandidateScore',
    'DiscrepancyResult',
    'ModelScore',
    'Progress',
    'SelectionSettings',
    'Traces',
    'Unexplained',
    'baseline_starts',
    'block_speeds',
    'describe_unexplained',
    'drive_report',
    'fit_baseline',
    'instrument_record',
    'judge_candidates',
    'propose_terms',
    'record_facts',
    'run_discrepancy',
    'start_context',
    'variable',
]
