"""Scores of a model in the selection: whole-record cost, held-out cost, BIC.

The Bayesian information criterion ``BIC = n_eff*ln(cost) + p*ln(n_eff)`` counts
``n_eff`` compared samples thinned to one per ``corr_time`` (residuals of a model
mismatch are correlated over about a millisecond; counting every 0.1 ms sample would
overstate the evidence). The held-out cost comes from cross validation over time
blocks: each fold is predicted by a fit to the others.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from .. import candidates as cand_lib
from ..candidates import ParamSpec
from ..fitting import CHANNELS, MU0, MU_INF, FitOutcome, Problem, SimulatedRecord
from ..localise import torque_residual
from ..stats import FloatArray, rms
from .results import ModelScore, Progress, SelectionSettings


def specs_of(effects: Sequence[str], instrument: Sequence[ParamSpec] = ()) -> list[ParamSpec]:
    """Return the fitted parameters of the baseline plus ``effects``.

    Parameters
    ----------
    effects : Sequence[str]
        Names of the added candidates.
    instrument : Sequence[ParamSpec]
        Instrument parameters refitted with every model
        (:attr:`.fitting.Problem.free_instrument`): an effect's fit must be able to
        move what the baseline's instrument terms absorbed of it.

    Returns
    -------
    list[ParamSpec]
        ``mu0``, ``mu_inf`` (Equ. 8), the instrument's, then every candidate's parameters.
    """
    specs = [MU0, MU_INF, *instrument]
    for e in effects:
        specs.extend(cand_lib.get(e).params)
    return specs


def n_eff(problem: Problem, seg_mask: npt.NDArray[np.bool_] | None, corr_time: float) -> float:
    """Return the effective number of compared samples (one per ``corr_time``).

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    seg_mask : numpy.ndarray of bool or None
        Segments compared (None: all).
    corr_time : float
        Residual correlation time [s].

    Returns
    -------
    float
        Samples divided by ``corr_time*fs`` (at least 1).
    """
    n = int(np.count_nonzero(problem.segments.sample_mask(problem.record.time.size, seg_mask)))
    thin = max(1.0, corr_time * problem.record.fs)
    return max(n / thin, 1.0)


def bic(cost: float, n_eff: float, p: int) -> float:
    """Return the Bayesian information criterion ``n_eff*ln(cost) + p*ln(n_eff)``.

    Parameters
    ----------
    cost : float
        Mean weighted squared residual (-).
    n_eff : float
        Effective sample count (-).
    p : int
        Number of fitted parameters.

    Returns
    -------
    float
        The BIC (-).
    """
    return n_eff * math.log(max(cost, 1e-300)) + p * math.log(n_eff)


def block_costs(problem: Problem, sim: SimulatedRecord) -> FloatArray:
    """Return the mean squared weighted residual (-) of every time block.

    The cost of :meth:`..fitting.Problem.cost` restricted to the samples of each
    cross-validation block; a block the simulation does not cover costs NaN.

    Parameters
    ----------
    problem : Problem
        The record's fit problem (weights set).
    sim : SimulatedRecord
        The model's simulation.

    Returns
    -------
    FloatArray
        One cost per block, in block order.
    """
    seg = problem.segments
    n = problem.record.time.size
    sq = np.zeros(n)
    for c in CHANNELS:
        w = problem.weights.get(c, 0.0)
        if w > 0:
            r = w * (problem.measured(c) - sim.channel(c))
            sq += np.where(np.isfinite(r), r * r, 1e6)
    out = np.full(seg.n_blocks, np.nan)
    for b in range(seg.n_blocks):
        m = seg.sample_mask(n, seg.block == b) & sim.covered
        if np.any(m):
            out[b] = float(np.mean(sq[m]))
    return out


def worst_block_loss(before: Sequence[float], after: Sequence[float]) -> float:
    """Return the largest relative cost increase of a time block (-; <= 0: none worse).

    Parameters
    ----------
    before : Sequence[float]
        Block costs of the current model (-).
    after : Sequence[float]
        Block costs of the candidate model (-), same blocks.

    Returns
    -------
    float
        ``max((after - before) / before)`` over the blocks both cover (-inf if none).
    """
    b = np.asarray(before, dtype=np.float64)
    a = np.asarray(after, dtype=np.float64)
    ok = np.isfinite(a) & np.isfinite(b) & (b > 0)
    if a.shape != b.shape or not np.any(ok):
        return -math.inf
    return float(np.max((a[ok] - b[ok]) / b[ok]))


#: Parabola steps that refine the minimum of a profile (:meth:`Selector.fit_best`).
_PROFILE_REFINE = 6
#: Half-width of the local bracket around a profile's best point [-, in log(value)].
_BRACKET = 0.1
#: Profile points closer than this [-, in log(value)] are the same point.
_SAME_POINT = 0.02


def _near(value: float, screened: Sequence[tuple[float, float, Mapping[str, float]]]) -> bool:
    """Whether ``value`` is within :data:`_SAME_POINT` (log) of a screened profile point."""
    return any(abs(math.log(value / v)) < _SAME_POINT for v, *_ in screened if v > 0)


def _profile_vertex(
    screened: Sequence[tuple[float, float, Mapping[str, float]]], spec: ParamSpec
) -> float | None:
    """Return the minimum of a parabola in log(value) through a profile's best point.

    Parameters
    ----------
    screened : Sequence[tuple[float, float, Mapping[str, float]]]
        (profiled value [SI], cost [-], fitted values) of every screened start.
    spec : ParamSpec
        The profiled (log-scaled) parameter.

    Returns
    -------
    float or None
        The vertex [SI] when the best value has a neighbour on each side and the
        parabola through the three opens upwards; else None.
    """
    fit = _profile_parabola(screened)
    return None if fit is None else min(max(math.exp(fit[0]), spec.lower), spec.upper)


def _profile_parabola(
    screened: Sequence[tuple[float, float, Mapping[str, float]]],
) -> tuple[float, float] | None:
    """Return the vertex (log value) and curvature (-) of a profile's parabola.

    Through the best point and its neighbours in ``(log(value), cost)``; None when
    the best has no neighbour on one side or the parabola does not open upwards.
    """
    pts = sorted({(v, c) for v, c, _ in screened if v > 0 and math.isfinite(c)})
    if len(pts) < 3:
        return None
    k = min(range(len(pts)), key=lambda i: pts[i][1])
    if k == 0 or k == len(pts) - 1:
        return None
    (x0, c0), (x1, c1), (x2, c2) = ((math.log(v), c) for v, c in pts[k - 1 : k + 2])
    # the parabola's vertex through three points (divided differences)
    d01 = (c1 - c0) / (x1 - x0)
    d12 = (c2 - c1) / (x2 - x1)
    curv = (d12 - d01) / (x2 - x0)
    if not curv > 0.0:
        return None
    xv = 0.5 * (x0 + x1) - d01 / (2.0 * curv)
    return min(max(xv, x0), x2), curv


class Selector:
    """State of one selection run: the problem, its cross-validation folds, settings.

    Parameters
    ----------
    problem : Problem
        The record's fit problem (weights set).
    settings : SelectionSettings
        Selection settings (folds, evaluation budgets, ``corr_time``).
    progress : Progress
        Receiver of progress messages.
    """

    def __init__(self, problem: Problem, settings: SelectionSettings, progress: Progress) -> None:
        """Build the folds: time blocks dealt round-robin."""
        self.pb = problem
        self.st = settings
        self.progress = progress
        nb = problem.segments.n_blocks
        self.fold_of_block = np.arange(nb) % settings.folds
        self.fold_masks = [
            np.isin(problem.segments.block, np.flatnonzero(self.fold_of_block == f))
            for f in range(settings.folds)
        ]
        #: standard error [SI] of each profiled parameter from its last profile's
        #: curvature (:meth:`fit_best`), by parameter name
        self.profile_se: dict[str, float] = {}

    def fit_best(
        self,
        specs: Sequence[ParamSpec],
        starts: Sequence[Mapping[str, float]],
        seg_mask: npt.NDArray[np.bool_] | None = None,
        *,
        profile: str = '',
    ) -> dict[str, float]:
        """Screen all starts with a short fit, refine the best one.

        With ``profile`` (a log-scaled parameter of ``specs``, see
        :attr:`..candidates.Candidate.profile`) the screening holds it fixed at each
        start's value: the screened costs are a profile of the cost over it, whose
        minimum a parabola in log(value) through the best start and its neighbours
        locates (screened too; each parabola through the best point and its neighbours,
        until it moves less than 2 %, then once more after bracketing the best point
        by +-10 %) before the refinement frees it.

        Parameters
        ----------
        specs : Sequence[ParamSpec]
            Fitted parameters.
        starts : Sequence[Mapping[str, float]]
            Start values (SI), each with every parameter the simulation needs.
        seg_mask : numpy.ndarray of bool or None
            Segments fitted (None: all).
        profile : str
            Name of the profiled parameter ('' = none).

        Returns
        -------
        dict[str, float]
            The refined values.
        """
        return self.fit_best_outcome(specs, starts, seg_mask, profile=profile).values

    def fit_best_outcome(
        self,
        specs: Sequence[ParamSpec],
        starts: Sequence[Mapping[str, float]],
        seg_mask: npt.NDArray[np.bool_] | None = None,
        *,
        profile: str = '',
        max_nfev: int | None = None,
    ) -> FitOutcome:
        """:meth:`fit_best` returning the refinement's whole :class:`.fitting.FitOutcome`.

        Parameters
        ----------
        specs : Sequence[ParamSpec]
            Fitted parameters.
        starts : Sequence[Mapping[str, float]]
            Start values (SI), each with every parameter the simulation needs.
        seg_mask : numpy.ndarray of bool or None
            Segments fitted (None: all).
        profile : str
            Name of the profiled parameter ('' = none).
        max_nfev : int or None
            Most simulations of the refinement (None: the settings' ``max_nfev``).

        Returns
        -------
        FitOutcome
            The refined fit (values, cost, convergence, standard errors).
        """
        best_vals: dict[str, float] = dict(starts[0])
        best_cost = math.inf
        if len(starts) > 1:
            held = [p for p in specs if p.name == profile]
            free = [p for p in specs if p.name != profile]
            # screen on one fold (half the data) to save time, refine on all; a
            # profile on all (a shape parameter may show in a few time blocks only:
            # dwell-time stiction's tau where a speed step changes the stick durations)
            screen = self.fold_masks[0] if seg_mask is None and not held else seg_mask
            screened: list[tuple[float, float, dict[str, float]]] = []
            # a profile point must converge to be compared: twice the screening budget
            # (the levels start from the baseline's, which absorbed part of the effect)
            budget = self.st.screen_nfev * (2 if held else 1)
            for s in starts:
                fo = self.pb.fit(free, s, seg_mask=screen, max_nfev=budget)
                if held:
                    screened.append((float(s[profile]), fo.cost, fo.values))
                if fo.cost < best_cost:
                    best_cost, best_vals = fo.cost, fo.values
            bracketed = False
            for _ in range(_PROFILE_REFINE if held else 0):
                vertex = _profile_vertex(screened, held[0])
                probes = [] if vertex is None or _near(vertex, screened) else [vertex]
                if not probes and not bracketed:
                    # the start grid is coarse (its parabola is lopsided): bracket the
                    # best point by +-10 % once, and take the parabola again
                    v_best = min(screened, key=lambda e: e[1])[0]
                    probes = [v_best * math.exp(f) for f in (-_BRACKET, _BRACKET)]
                    probes = [v for v in probes if not _near(v, screened)]
                    bracketed = True
                if not probes:
                    break
                for v in probes:
                    s = dict(best_vals)
                    s[profile] = min(max(v, held[0].lower), held[0].upper)
                    fo = self.pb.fit(free, s, seg_mask=screen, max_nfev=budget)
                    screened.append((s[profile], fo.cost, fo.values))
                    if fo.cost < best_cost:
                        best_cost, best_vals = fo.cost, fo.values
            if held and seg_mask is None:
                for p in specs:
                    self.profile_se.pop(p.name, None)
                self.profile_se.update(self._profile_se(screened, best_cost, profile))
        return self.pb.fit(
            specs, best_vals, seg_mask=seg_mask, max_nfev=max_nfev or self.st.max_nfev
        )

    def _profile_se(
        self,
        screened: Sequence[tuple[float, float, Mapping[str, float]]],
        cost: float,
        profile: str,
    ) -> dict[str, float]:
        """Return standard errors [SI] from a profile's curvature, by parameter name.

        The profile ``cost(x) ~ c0 + q*(x - x_v)^2`` (x = log value, the other
        parameters re-fitted at each point) raises the residual sum of squares by
        ``n*q*dx^2`` (n compared samples); with the noise variance ``s2 = cost*n/m``
        per residual element (m elements) counted once per ``corr_time`` (as
        :func:`..linearised.gauss_newton`), ``SE(x)^2 = cost*c/(m*q)``. Unlike the
        linearisation it sees the cost's flatness along a curved valley (dwell-time
        stiction: the Jacobian's standard error of tau was 0.1 % where the fits scatter
        by 2-7 %). The other parameters move along the valley with x: each gets
        ``|dp/dx|*SE(x)``, the slope between the vertex's two neighbours.

        Parameters
        ----------
        screened : Sequence[tuple[float, float, Mapping[str, float]]]
            (value [SI], cost [-], values) of the profile points (whole record).
        cost : float
            The profile's lowest cost [-].
        profile : str
            Name of the profiled parameter.

        Returns
        -------
        dict of str to float
            The standard errors [SI] (empty without a parabola).
        """
        fit = _profile_parabola(screened)
        if fit is None:
            return {}
        xv, curv = fit
        n_ch = sum(1 for c in CHANNELS if self.pb.weights.get(c, 0.0) > 0)
        m = n_ch * int(np.count_nonzero(self.pb.segments.sample_mask(self.pb.record.time.size)))
        c = max(1.0, self.st.corr_time * self.pb.record.fs)
        se_x = math.sqrt(cost * c / (max(m, 1) * curv))
        out = {profile: math.exp(xv) * se_x}
        pts = sorted(((v, vals) for v, _, vals in screened if v > 0), key=lambda e: e[0])
        k = min(range(len(pts)), key=lambda i: abs(math.log(pts[i][0]) - xv))
        if 0 < k < len(pts) - 1:
            (v0, p0), (v2, p2) = pts[k - 1], pts[k + 1]
            dx = math.log(v2) - math.log(v0)
            for name in p0:
                if name != profile and name in p2:
                    out[name] = abs(float(p2[name]) - float(p0[name])) / dx * se_x
        return out

    def score(self, effects: tuple[str, ...], values: Mapping[str, float]) -> ModelScore:
        """Score a model: whole-record cost/rms/BIC and the held-out cost/rms.

        Parameters
        ----------
        effects : tuple[str, ...]
            The model's added candidates.
        values : Mapping[str, float]
            Its fitted values (SI).

        Returns
        -------
        ModelScore
            The scores.
        """
        # the held-out refits keep the instrument terms at ``values`` (as every first
        # candidate fit does); the BIC counts them
        specs = specs_of(effects)
        n_params = len(specs_of(effects, self.pb.free_instrument))
        sim = self.pb.simulate(values)
        cost = self.pb.cost(sim)
        ne = n_eff(self.pb, None, self.st.corr_time)
        held_sq = 0.0
        held_n = 0
        held_t: list[FloatArray] = []
        for test_mask in self.fold_masks:
            train_mask = ~test_mask
            if not np.any(test_mask) or not np.any(train_mask):
                continue
            fo = self.pb.fit(specs, values, seg_mask=train_mask, max_nfev=self.st.cv_nfev)
            tsim = self.pb.simulate(fo.values, test_mask)
            v = self.pb.residual_vector(tsim)
            held_sq += float(np.sum(v * v))
            held_n += int(np.count_nonzero(tsim.covered))
            held_t.append(torque_residual(self.pb, tsim)[tsim.covered])
        cv_cost = held_sq / max(held_n, 1)
        cv_rms = rms(np.concatenate(held_t)) if held_t else float('nan')
        return ModelScore(
            effects=effects,
            params=dict(values),
            cost=cost,
            rms=self.pb.torque_rms(sim),
            cv_cost=cv_cost,
            cv_rms=cv_rms,
            bic=bic(cost, ne, n_params),
            n_params=n_params,
            block_cost=tuple(float(x) for x in block_costs(self.pb, sim)),
        )


__all__ = ['Selector', 'bic', 'block_costs', 'n_eff', 'specs_of', 'worst_block_loss']
