"""Several records at once: effect parameters shared, friction law and instruments per record.

A tribologist runs several drive speeds (Fig. 4/5 of the paper) to separate effects
that one record cannot: viscous friction from mu_inf, dwell-time stiction from mu0.
:class:`JointProblem` holds one :class:`.fitting.Problem` per record and stacks their
weighted residual vectors; its parameter map has shared names (the candidate's
parameters) and per-record names suffixed ``@i`` (``mu0@0``, ``mu_inf@1``: Equ. 8 per
record; the drive profile and the speed-sensor model are each record's own: the
profile held from its baseline, the speed-sensor lag and offset, when the baseline
freed them, free per record in every effect's fit). The solver is the project's
bounded Levenberg-Marquardt (:func:`tribo_estimation.core.lsq.levenberg_marquardt`).

:func:`run_joint_discrepancy`: the baseline of every record (:func:`.select.fit_baseline`),
then one round of the selection on the joint fit: every candidate fitted jointly,
scored by the cost decrease and the BIC (no cross validation here: the records are
the replication), judged by :func:`.identify.identifiability` on the joint
linearisation with the pooled stick durations and drive speeds; the best clearly
better AND identifiable candidate is named.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.lsq import levenberg_marquardt
from tribo_estimation.core.model import DriveProfile, RigParams
from tribo_estimation.errors import InvalidParameterError

from . import candidates as cand_lib
from .candidates import ParamSpec
from .fitting import MU0, MU_INF, Problem, Record, begins_at_drive_start, make_segments
from .identify import Identifiability, gauss_newton, identifiability, per_record
from .linearised import problem_residual_blocks
from .localise import torque_residual
from .select import (
    Progress,
    SelectionSettings,
    fit_baseline,
    instrument_record,
    record_facts,
    start_context,
)
from .stats import FloatArray, noise_floor


class JointProblem:
    """Records fitted together (see the module docstring).

    ``problems`` one :class:`.fitting.Problem` per record (their residual weights
    set); ``fixed`` per record the values held fixed (the instrument model).
    """

    def __init__(
        self, problems: Sequence[Problem], fixed: Sequence[Mapping[str, float]] | None = None
    ) -> None:
        if not problems:
            raise InvalidParameterError('a joint fit needs at least one record')
        self.problems = list(problems)
        self.fixed = [dict(f) for f in fixed] if fixed is not None else [{} for _ in problems]
        if len(self.fixed) != len(self.problems):
            raise InvalidParameterError(
                f'{len(self.fixed)} fixed value sets for {len(self.problems)} records'
            )

    @property
    def n(self) -> int:
        """Number of records."""
        return len(self.problems)

    @property
    def fs(self) -> float:
        """Sample rate [Hz] (the lowest of the records: the conservative count)."""
        return min(p.record.fs for p in self.problems)

    def split(self, values: Mapping[str, float]) -> list[dict[str, float]]:
        """Return the per-record value mappings.

        Shared names as they are, ``name@i`` -> ``name`` for record i (names of other
        records dropped), on top of each record's fixed values.

        Parameters
        ----------
        values : Mapping[str, float]
            Joint values.

        Returns
        -------
        list[dict[str, float]]
            One mapping per record.
        """
        out = []
        for i, fx in enumerate(self.fixed):
            d = dict(fx)
            for k, v in values.items():
                base, _, idx = k.partition('@')
                if not idx:
                    d[k] = float(v)
                elif int(idx) == i:
                    d[base] = float(v)
            out.append(d)
        return out

    def residuals(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """Stacked weighted residual vectors of all records (-); ``seg_mask`` must be None."""
        if seg_mask is not None:
            raise InvalidParameterError('a joint fit uses every segment (seg_mask must be None)')
        pairs = zip(self.problems, self.split(values), strict=True)
        return np.concatenate([p.residual_vector(p.simulate(v)) for p, v in pairs])

    def residual_blocks(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.int64]:
        """Return the time block of every element of :meth:`residuals`.

        Blocks are numbered across the records (record i's after record i-1's), so the
        block-robust standard error of :func:`.linearised.gauss_newton` sees them all.

        Parameters
        ----------
        values : Mapping[str, float]
            Joint values (shared and ``name@i``).
        seg_mask : numpy.ndarray of bool or None
            Must be None (a joint fit uses every segment).

        Returns
        -------
        numpy.ndarray of int64
            One block index per residual element (-1: in no segment).

        Raises
        ------
        InvalidParameterError
            If ``seg_mask`` is given.
        """
        if seg_mask is not None:
            raise InvalidParameterError('a joint fit uses every segment (seg_mask must be None)')
        parts = []
        offset = 0
        for p, v in zip(self.problems, self.split(values), strict=True):
            b = problem_residual_blocks(p, v)
            parts.append(np.where(b >= 0, b + offset, -1))
            offset += p.segments.n_blocks
        return np.concatenate(parts).astype(np.int64)

    def specs(self, shared: Sequence[ParamSpec], each: Sequence[ParamSpec]) -> list[ParamSpec]:
        """Return the parameter specs: per record (``@i``) ``each``, the free instrument, shared.

        Each record's free instrument terms are those of its baseline
        (:attr:`.fitting.Problem.free_instrument`).
        """
        own = [per_record(p, i) for i, pb in enumerate(self.problems) for p in pb.free_instrument]
        return [per_record(p, i) for i in range(self.n) for p in each] + own + list(shared)

    def instrument_start(self) -> dict[str, float]:
        """Return the start values of the free instrument terms (``name@i``, SI).

        Each record's baseline values (held in :attr:`fixed`).
        """
        return {
            f'{p.name}@{i}': float(self.fixed[i][p.name])
            for i, pb in enumerate(self.problems)
            for p in pb.free_instrument
        }

    def fit(
        self, specs: Sequence[ParamSpec], start: Mapping[str, float], *, max_nfev: int = 60
    ) -> tuple[dict[str, float], float]:
        """Fit ``specs`` (from :meth:`specs`) by least squares from ``start``.

        Parameters
        ----------
        specs : Sequence[ParamSpec]
            Fitted parameters (shared and ``name@i``).
        start : Mapping[str, float]
            Start values, with every value the simulations need.
        max_nfev : int
            Most residual evaluations.

        Returns
        -------
        tuple[dict[str, float], float]
            The values and the summed squared weighted residual (-).
        """

        def to_x(p: ParamSpec, v: float) -> float:
            v = min(max(v, p.lower), p.upper)
            return math.log(v) if p.log else v / p.scale

        def from_x(x: FloatArray) -> dict[str, float]:
            out = {k: float(v) for k, v in start.items()}
            for p, xi in zip(specs, x, strict=True):
                out[p.name] = math.exp(float(xi)) if p.log else float(xi) * p.scale
            return out

        lo = np.asarray([math.log(p.lower) if p.log else p.lower / p.scale for p in specs])
        hi = np.asarray([math.log(p.upper) if p.log else p.upper / p.scale for p in specs])
        x0 = np.asarray([to_x(p, float(start[p.name])) for p in specs])
        sol = levenberg_marquardt(
            lambda x: self.residuals(from_x(x)),
            x0,
            lo,
            hi,
            max_nfev=max_nfev,
            max_iter=max_nfev,
            ftol=1e-6,
            lam0=1e-3,
        )
        return from_x(sol.x), float(sol.cost)

    def torque_rms(self, values: Mapping[str, float]) -> list[float]:
        """Torsion-moment residual rms per record [N m]."""
        pairs = zip(self.problems, self.split(values), strict=True)
        return [p.torque_rms(p.simulate(v)) for p, v in pairs]

    def n_samples(self, values: Mapping[str, float]) -> int:
        """Return the number of compared samples over all records."""
        return sum(
            int(np.count_nonzero(p.simulate(v).covered))
            for p, v in zip(self.problems, self.split(values), strict=True)
        )


@dataclass(frozen=True)
class JointResult:
    """Outcome of :func:`run_joint_discrepancy` (the ``discrepancy.json`` of a joint run).

    ``named`` the effect added ('' if none); ``params`` its shared values (SI units of
    :mod:`.candidates`); ``per_record`` per record: baseline and final mu0/mu_inf,
    torque rms before/after [N m], noise floor [N m], instrument and mean drive speed
    [rad/s]; ``scores`` per candidate: joint torque rms per record, relative cost
    gain [-], delta BIC [-]; ``identifiable`` the verdicts on the joint fit;
    ``not_identifiable`` candidates that improve clearly but are not identifiable.
    """

    named: str
    params: dict[str, float]
    units: dict[str, str]
    per_record: tuple[dict[str, Any], ...]
    scores: dict[str, dict[str, Any]]
    identifiable: dict[str, Identifiability]
    not_identifiable: tuple[str, ...]
    settings: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form (the ``discrepancy.json`` of a joint run).

        Returns
        -------
        dict[str, object]
            ``joint``, ``added``, ``records``, ``rounds``, ``identifiable``,
            ``not_identifiable`` and ``settings``.
        """
        return {
            'joint': True,
            'added': (
                [{'effect': self.named, 'params': dict(self.params), 'units': dict(self.units)}]
                if self.named
                else []
            ),
            'records': list(self.per_record),
            'rounds': [[{'effect': k, **v} for k, v in self.scores.items()]],
            'identifiable': {k: v.as_dict() for k, v in self.identifiable.items()},
            'not_identifiable': list(self.not_identifiable),
            'settings': dict(self.settings),
        }


def run_joint_discrepancy(
    records: Sequence[Record],
    rig: RigParams,
    drives: Sequence[DriveProfile],
    *,
    k: float = 2.0,
    settings: SelectionSettings | None = None,
    progress: Progress | None = None,
    shared_friction: bool = False,
) -> JointResult:
    """Run the selection on several records at once (see the module docstring).

    The candidate's parameters are shared; mu0/mu_inf (Equ. 8) per record, or shared.

    Parameters
    ----------
    records : Sequence[Record]
        The measured records.
    rig : RigParams
        Rig parameters (Tab. 1, F_N, R), shared.
    drives : Sequence[DriveProfile]
        Nominal drive speed [rad/s] and ramp [s], one per record.
    k : float
        Exponential decay constant of Equ. 8 [s/rad], shared.
    settings : SelectionSettings or None
        Selection settings (None: defaults).
    progress : Progress or None
        Receiver of progress messages.
    shared_friction : bool
        One friction law (mu0, mu_inf) for all records: the records are runs of one
        contact at several drive speeds (the paper's Fig. 4/5), so a level that
        changes with the speed is an effect, not a new friction law. Off: each
        record has its own mu0/mu_inf (the speed contrast between the records is
        then not used; only their information on the effect is pooled).

    Returns
    -------
    JointResult
        The named effect (or none), the scores and verdicts of every candidate.

    Raises
    ------
    InvalidParameterError
        If the numbers of records and drive profiles differ.
    """
    st = settings or SelectionSettings()
    say: Progress = progress or (lambda _msg: None)
    if len(drives) != len(records):
        raise InvalidParameterError(f'{len(drives)} drive profiles for {len(records)} records')
    t_start = _time.perf_counter()
    problems, fixed, bases, sims, instruments = [], [], [], [], []
    drifting: list[int] = []  # records whose stick kinematics drift (rig/instrument)
    for i, (rec, drv) in enumerate(zip(records, drives, strict=True)):
        say(f'record {i}: baseline')
        rec, tq_lag = instrument_record(rec, rig, st, say)
        from_start = begins_at_drive_start(rec, drv.ramp_time, drv.nominal_speed)
        segs = make_segments(rec, rig, block_time=st.block_time, dwell_from_start=from_start)
        pb = Problem(rec, rig, drv, k=k, segments=segs)
        bf = fit_baseline(pb, st, say)
        vals, sim, instr = bf.values, bf.sim, bf.instrument
        if bf.sensor.drifting():
            drifting.append(i)
        instr['torsion_lag_tau'] = tq_lag.report()
        problems.append(pb)
        fixed.append({n: v for n, v in vals.items() if n not in ('mu0', 'mu_inf')})
        bases.append(vals)
        sims.append(sim)
        instruments.append(instr)
    jp = JointProblem(problems, fixed)
    each: list[ParamSpec]
    if shared_friction:
        # one friction law: the joint baseline refits it from the records' mean
        each, law = [], [MU0, MU_INF]
        start = {n: float(np.mean([b[n] for b in bases])) for n in ('mu0', 'mu_inf')}
        base_start, _ = jp.fit(law, start, max_nfev=st.max_nfev)
        base_start = {n: base_start[n] for n in ('mu0', 'mu_inf')}
    else:
        each, law = [MU0, MU_INF], []
        base_start = {f'{n}@{i}': b[n] for i, b in enumerate(bases) for n in ('mu0', 'mu_inf')}
    # each record's instrument terms stay free in every effect's fit (as in the
    # single-record workflow): they start from the record's baseline
    base_start.update(jp.instrument_start())
    r0 = jp.residuals(base_start)
    base_cost = float(r0 @ r0)
    n_all = r0.size
    n_eff = max(n_all / max(1.0, st.corr_time * jp.fs), 1.0)

    def bic(cost: float, p: int) -> float:
        return n_eff * math.log(max(cost / n_all, 1e-300)) + p * math.log(n_eff)

    base_bic = bic(base_cost, len(jp.specs(law, each)))
    base_rms = jp.torque_rms(base_start)
    say(f'joint baseline: torque rms {", ".join(f"{r:.4g}" for r in base_rms)} N m')
    facts = [record_facts(pb, sim) for pb, sim in zip(problems, sims, strict=True)]
    durations = np.concatenate([f[0] for f in facts])
    speeds = np.concatenate([f[1] for f in facts])
    length = sum(f[2] for f in facts)
    ctx = start_context(problems[0], sims[0])
    names = st.candidates if st.candidates is not None else cand_lib.names()
    scores: dict[str, dict[str, Any]] = {}
    fits: dict[str, dict[str, float]] = {}
    verdicts: dict[str, Identifiability] = {}
    for name in names:
        c = cand_lib.get(name)
        specs = jp.specs([*law, *c.params], each)
        trial: tuple[dict[str, float], float] | None = None
        for pt in c.start_points(ctx):
            vals, cost = jp.fit(specs, {**base_start, **pt}, max_nfev=st.screen_nfev)
            if trial is None or cost < trial[1]:
                trial = (vals, cost)
        assert trial is not None
        vals, cost = jp.fit(specs, trial[0], max_nfev=st.max_nfev)
        fits[name] = vals
        gain = (base_cost - cost) / base_cost if base_cost > 0 else 0.0
        d_bic = bic(cost, len(specs)) - base_bic
        gn = gauss_newton(jp, specs, vals, corr_time=st.corr_time)
        verdicts[name] = identifiability(
            name,
            c.param_names,
            gn,
            durations,
            drive_speeds=speeds,
            duration=length,
            gain=gain,
            min_gain=st.min_gain,
        )
        scores[name] = {
            'params': {n: vals[n] for n in c.param_names},
            'rms': jp.torque_rms(vals),
            'gain': gain,
            'delta_bic': d_bic,
        }
        say(
            f'joint {name:<22s} gain {100 * gain:6.1f} %, dBIC {d_bic:10.1f}, '
            f'identifiable: {"yes" if verdicts[name].ok else "no"}: {verdicts[name].reason}'
        )
    better = [
        n for n in names if scores[n]['gain'] >= st.min_gain and scores[n]['delta_bic']
        <= -st.bic_threshold
    ]  # fmt: skip
    best = min(better, key=lambda n: scores[n]['delta_bic']) if better else ''
    # the best explanation must be identifiable, else nothing is named (another
    # candidate would only absorb its signal); nor is anything named when the rig or
    # an instrument changes during a record (its stick kinematics drift)
    named = best if best and verdicts[best].ok and not drifting else ''
    if best and drifting:
        say(f'{best} improves, but records {drifting} have a rig or instrument mismatch '
            '(their stick kinematics drift): not named')  # fmt: skip
    blocked = (best,) if best and not named and not drifting else ()
    final = fits[named] if named else base_start
    final_rms = jp.torque_rms(final)
    per: list[dict[str, Any]] = []
    for i, (pb, v0, v1) in enumerate(
        zip(problems, jp.split(base_start), jp.split(final), strict=True)
    ):
        sim = pb.simulate(v1)
        per.append(
            {
                'record': i,
                'baseline': {'mu0': v0['mu0'], 'mu_inf': v0['mu_inf'], 'rms': base_rms[i]},
                'final': {'mu0': v1['mu0'], 'mu_inf': v1['mu_inf'], 'rms': final_rms[i]},
                'noise_floor': noise_floor(torque_residual(pb, sim)[sim.covered]),
                'drive_speed': pb.drive_estimate.level,
                'instrument': instruments[i],
            }
        )
    c_named = cand_lib.get(named) if named else None
    if named:
        say(f'added {named} (shared by {jp.n} records)')
    return JointResult(
        named=named,
        params={n: fits[named][n] for n in c_named.param_names} if c_named else {},
        units=c_named.units() if c_named else {},
        per_record=tuple(per),
        scores=scores,
        identifiable=verdicts,
        not_identifiable=blocked,
        settings={
            'records': jp.n,
            'min_gain': st.min_gain,
            'bic_threshold': st.bic_threshold,
            'k': k,
            'shared_friction': shared_friction,
            'candidates': list(names),
            'run_time_s': _time.perf_counter() - t_start,
        },
    )


__all__ = ['JointProblem', 'JointResult', 'run_joint_discrepancy']
