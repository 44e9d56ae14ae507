"""Identifiability of candidate effects: can this record (or these records) decide.

One place for the verdict used by the offline workflow (:func:`.select.run_discrepancy`,
:func:`.joint.run_joint_discrepancy`) and the live monitor (:mod:`.monitor`):

* :func:`gauss_newton`: linearised standard errors and correlations of an
  output-error fit at its solution (the Jacobian of the weighted residual vector);
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
from typing import Protocol

import numpy as np
import numpy.typing as npt

from tribo_estimation.errors import InvalidParameterError

from .candidates import ParamSpec
from .fitting import CHANNELS, Problem
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


class ResidualModel(Protocol):
    """What :func:`gauss_newton` needs: the weighted residual vector of a value mapping."""

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        ...

    def residuals(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """Return the weighted residual vector (-) of ``values`` on the selected segments."""
        ...

    def residual_blocks(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.int64]:
        """Return the time block of every element of :meth:`residuals` (-1: none)."""
        ...


def sample_blocks(problem: Problem) -> npt.NDArray[np.int64]:
    """Return the time block of every sample of a record (-1: in no segment).

    Parameters
    ----------
    problem : Problem
        The record's fit problem (its segments carry the blocks).

    Returns
    -------
    numpy.ndarray of int64
        One block index per sample.
    """
    seg = problem.segments
    out = np.full(problem.record.time.size, -1, dtype=np.int64)
    for a, b, blk in zip(seg.start, seg.stop, seg.block, strict=True):
        out[int(a) : int(b)] = int(blk)
    return out


def problem_residual_blocks(
    problem: Problem, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
) -> npt.NDArray[np.int64]:
    """Return the time block of every element of the weighted residual vector.

    The layout of :meth:`.fitting.Problem.residual_vector`: the weighted channels one
    after the other, each over the samples the simulation covers.

    Parameters
    ----------
    problem : Problem
        The record's fit problem (weights set).
    values : Mapping[str, float]
        Model values (SI) of the simulation.
    seg_mask : numpy.ndarray of bool or None
        Segments simulated (None: all).

    Returns
    -------
    numpy.ndarray of int64
        One block index per residual element.
    """
    cov = problem.simulate(values, seg_mask).covered
    blocks = sample_blocks(problem)[cov]
    n_ch = sum(1 for c in CHANNELS if problem.weights.get(c, 0.0) > 0)
    return np.tile(blocks, n_ch)


class ProblemResiduals:
    """:class:`ResidualModel` of one record's :class:`.fitting.Problem`."""

    def __init__(self, problem: Problem) -> None:
        """Wrap ``problem``."""
        self.problem = problem

    @property
    def fs(self) -> float:
        """Sample rate of the record [Hz]."""
        return self.problem.record.fs

    def residuals(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """Return the weighted residual vector (-) (:meth:`.fitting.Problem.residual_vector`).

        Parameters
        ----------
        values : Mapping[str, float]
            Model values (SI).
        seg_mask : numpy.ndarray of bool or None
            Segments simulated (None: all).

        Returns
        -------
        FloatArray
            The weighted residuals.
        """
        return self.problem.residual_vector(self.problem.simulate(values, seg_mask))

    def residual_blocks(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.int64]:
        """Return the time block of every residual element (:func:`problem_residual_blocks`).

        Parameters
        ----------
        values : Mapping[str, float]
            Model values (SI).
        seg_mask : numpy.ndarray of bool or None
            Segments simulated (None: all).

        Returns
        -------
        numpy.ndarray of int64
            One block index per residual element.
        """
        return problem_residual_blocks(self.problem, values, seg_mask)


@dataclass(frozen=True)
class GaussNewton:
    """Linearised uncertainty of an output-error fit at its solution.

    ``names`` the fitted parameters; ``values`` and their standard errors
    ``se`` in the parameters' SI units; ``corr`` their correlation matrix (-),
    rows/columns in the order of ``names``; ``dead`` the parameters the
    simulated channels do not depend on at all (zero Jacobian column);
    ``model_error`` the parameters whose standard error is set by the scatter
    between time blocks (model error) rather than by the noise; ``profiled`` those
    whose standard error comes from the curvature of their cost profile
    (:meth:`with_profile_se`).
    """

    names: tuple[str, ...]
    values: tuple[float, ...]
    se: tuple[float, ...]
    corr: FloatArray
    dead: tuple[str, ...]
    model_error: tuple[str, ...] = ()
    profiled: tuple[str, ...] = ()

    def with_profile_se(self, profile_se: Mapping[str, float]) -> GaussNewton:
        """Return a copy whose standard errors are at least the profile's.

        Parameters
        ----------
        profile_se : Mapping[str, float]
            Standard error [SI] of a parameter from the curvature of its cost profile
            (:meth:`.select.scoring.Selector.fit_best`), by name.

        Returns
        -------
        GaussNewton
            The copy; ``profiled`` names the parameters whose profile error is larger.
        """
        se = list(self.se)
        raised = []
        for i, n in enumerate(self.names):
            p = profile_se.get(n)
            if p is not None and math.isfinite(p) and p > se[i]:
                se[i] = float(p)
                raised.append(n)
        return replace(self, se=tuple(se), profiled=(*self.profiled, *raised))


def gauss_newton(
    problem: ResidualModel | Problem,
    specs: Sequence[ParamSpec],
    values: Mapping[str, float],
    seg_mask: npt.NDArray[np.bool_] | None = None,
    *,
    corr_time: float = 1e-3,
    robust: bool = True,
) -> GaussNewton:
    """Gauss-Newton covariance of an output-error fit (:meth:`.fitting.Problem.fit`).

    The Jacobian J of the weighted residual vector (``problem.residuals``) by
    forward differences in the optimiser's coordinates (value/scale, or log for
    time constants); covariance ``s^2*(J^T J)^-1*c`` with s^2 the residual
    variance per sample and ``c = corr_time*fs`` (>= 1): residuals of a model
    mismatch are correlated over about ``corr_time`` [s], so only one sample in
    c counts (as the selection's BIC does). A singular J^T J gives
    correlations of +-1 (NaN entries become 1). ``seg_mask`` selects segments.

    ``robust``: the model-error term. A model mismatch leaves residuals correlated
    over far longer than ``corr_time`` (a whole stick-slip cycle, a drift), which the
    noise count above does not see: the block-robust (sandwich) covariance
    ``A^-1 (sum_b g_b g_b^T) A^-1 * (G-1)/G``, ``A = J^T J``, of the leverage-corrected
    block scores ``g_b = (I - A_b A^-1)^-1 J_b^T r_b`` (``A_b = J_b J_b^T``) of the G
    time blocks (``problem.residual_blocks``), estimates the scatter of the parameters
    from how the residual's projection varies between the blocks, whatever its
    correlation within a block. The leverage correction is the block jackknife of the
    linearised fit (each block's score as if the fit had not seen it): with about a
    dozen blocks the plain sandwich ``G/(G-1)`` understates the scatter, most for a
    parameter a few blocks dominate (a drift: the record's ends; over 20 seeds of a
    torque-offset drift 0.4x of config/rig.yaml the plain term left the errors at 1.5
    stated SE rms, the corrected one at 1.3). Each standard error is the larger of
    the two (``model_error`` names the parameters where the block term is larger);
    the correlations are those of the noise term (the structure of J).

    Parameters
    ----------
    problem : ResidualModel or Problem
        The residual model (a :class:`.fitting.Problem` is wrapped).
    specs : Sequence[ParamSpec]
        The fitted parameters.
    values : Mapping[str, float]
        The fit's solution (SI), with every value the simulation needs.
    seg_mask : numpy.ndarray of bool or None
        Segments used (None: all).
    corr_time : float
        Residual correlation time of the noise term [s].
    robust : bool
        Include the block-robust model-error term.

    Returns
    -------
    GaussNewton
        Values, standard errors (SI), correlations, dead and model-error parameters.
    """
    if isinstance(problem, Problem):
        problem = ProblemResiduals(problem)
    base = dict(values)

    def coord(p: ParamSpec, v: float) -> float:
        return math.log(max(v, p.lower)) if p.log else v / p.scale

    def value(p: ParamSpec, x: float) -> float:
        return math.exp(x) if p.log else x * p.scale

    r0 = problem.residuals(base, seg_mask)
    cols = []
    for p in specs:
        x = coord(p, float(base[p.name]))
        h = 1e-3 * max(1.0, abs(x))
        vals = dict(base)
        hi = coord(p, p.upper)
        xs = x + h if x + h <= hi else x - h
        vals[p.name] = value(p, xs)
        cols.append((problem.residuals(vals, seg_mask) - r0) / (xs - x))
    J = np.vstack(cols)
    m, k = r0.size, len(specs)
    s2 = float(r0 @ r0) / max(m - k, 1)
    inflation = max(1.0, corr_time * problem.fs)
    a_inv = np.asarray(np.linalg.pinv(J @ J.T), dtype=np.float64)
    cov = a_inv * s2 * inflation
    d = np.sqrt(np.abs(np.diag(cov)))
    d_model = np.zeros_like(d)
    if robust:
        d_model = _block_robust_sd(J, r0, a_inv, problem.residual_blocks(base, seg_mask))
    with np.errstate(invalid='ignore', divide='ignore'):
        corr = cov / np.outer(d, d)
    corr = np.where(np.isfinite(corr), corr, 1.0)
    dead_mask = ~np.any(J != 0.0, axis=1)
    corr[dead_mask, :] = 1.0
    corr[:, dead_mask] = 1.0
    se = []
    for p, dx in zip(specs, np.maximum(d, d_model), strict=True):
        v = float(base[p.name])
        se.append(abs(v) * float(dx) if p.log else float(dx) * p.scale)
    return GaussNewton(
        names=tuple(p.name for p in specs),
        values=tuple(float(base[p.name]) for p in specs),
        se=tuple(se),
        corr=np.asarray(corr, dtype=np.float64),
        dead=tuple(p.name for p, dd in zip(specs, dead_mask, strict=True) if dd),
        model_error=tuple(
            p.name for p, a, b in zip(specs, d, d_model, strict=True) if b > a and not b <= 0
        ),
    )


def _block_robust_sd(
    jac: FloatArray,
    r0: FloatArray,
    a_inv: FloatArray,
    blocks: npt.NDArray[np.int64],
) -> FloatArray:
    """Return the block-robust (sandwich) standard deviations in the fit coordinates.

    Parameters
    ----------
    jac : FloatArray
        Jacobian, one row per parameter, one column per residual element.
    r0 : FloatArray
        Weighted residual vector at the solution (-).
    a_inv : FloatArray
        Pseudo-inverse of ``jac @ jac.T``.
    blocks : numpy.ndarray of int64
        Time block of every residual element (-1: none).

    Returns
    -------
    FloatArray
        One standard deviation per parameter (zeros with fewer than 3 blocks).
    """
    k = jac.shape[0]
    out = np.zeros(k)
    if blocks.size != r0.size:
        return out
    ids = np.unique(blocks[blocks >= 0])
    g_n = ids.size
    if g_n < 3:
        return out
    meat = np.zeros((k, k))
    eye = np.eye(k)
    for b in ids:
        m = blocks == b
        g = jac[:, m] @ r0[m]
        # the block's own leverage: its residual is the fit's, which it pulled
        # towards itself; (I - A_b A^-1)^-1 g_b is its score had it been left out
        a_b = jac[:, m] @ jac[:, m].T
        try:
            g = np.linalg.solve(eye - a_b @ a_inv, g)
        except np.linalg.LinAlgError:
            pass  # a block that alone determines a parameter: its plain score
        meat += np.outer(g, g)
    cov = a_inv @ meat @ a_inv * ((g_n - 1.0) / g_n)
    return np.asarray(np.sqrt(np.abs(np.diag(cov))), dtype=np.float64)


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
      blocks, marked "model error" in the reason) must not exceed ``max_rel_se`` (-).

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
