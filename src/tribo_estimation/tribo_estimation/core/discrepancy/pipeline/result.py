"""The result of the missing-physics pipeline (``discrepancy.json``).

Rms values are of the torsion-moment residual (measured - simulated) [N m]; the
adequacy statistics are dimensionless (:mod:`.null`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from .. import candidates as cand_lib
from ..fitting import Problem, SimulatedRecord
from .decide import CANNOT_TELL_APART, NAMED
from .describe import Unexplained
from .null import NullLaw
from .policy import Policy
from .screen import FormFit

if TYPE_CHECKING:
    import pandas as pd

    from tribo_estimation.core.record import InputFindings


@dataclass(frozen=True)
class Effect:
    """A family's fit as the result reports it (named, a set member or a partial one).

    Parameters
    ----------
    family : str
        The effect family.
    form : str
        The form that fitted (candidate name).
    params : dict of str to float
        Its fitted parameters (SI, ``units``).
    se : dict of str to float
        Their standard errors (SI).
    units : dict of str to str
        Parameter units.
    rms : tuple of float
        Per record, the torsion-moment residual rms with it [N m].
    statistic : tuple of float
        Per record, its torsion-moment adequacy statistic [-].
    explained : float
        Share of the excess over noise it removes [-] (1: all).
    failing : tuple of str
        Adequacy statistics it fails (``name@record``).
    bounded : tuple of str
        Its parameters at a bound (a form mismatch).
    """

    family: str
    form: str
    params: dict[str, float]
    se: dict[str, float]
    units: dict[str, str]
    rms: tuple[float, ...]
    statistic: tuple[float, ...]
    explained: float
    failing: tuple[str, ...] = ()
    bounded: tuple[str, ...] = ()

    @classmethod
    def of(cls, fit: FormFit, rms: tuple[float, ...], explained: float) -> Effect:
        """Build the report of a form's fit."""
        c = cand_lib.get(fit.form)
        return cls(
            fit.family,
            fit.form,
            fit.params,
            {n: fit.model.fit.se.get(n, math.nan) for n in c.param_names},
            c.units(),
            rms,
            tuple(a['torsion_moment'] for a in fit.model.adequacy),
            explained,
            fit.failing,
            fit.bounded,
        )

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form."""
        return {
            'family': self.family,
            'form': self.form,
            'effect': self.family,
            'params': dict(self.params),
            'se': dict(self.se),
            'units': dict(self.units),
            'rms': list(self.rms),
            'statistic': list(self.statistic),
            'explained': self.explained,
            'failing': list(self.failing),
            'at_bound': list(self.bounded),
        }


@dataclass(frozen=True)
class RecordReport:
    """What the pipeline found about one record.

    Parameters
    ----------
    baseline : dict of str to float
        The baseline's values (mu0, mu_inf, instrument terms; SI).
    final : dict of str to float
        The final model's values.
    rms_baseline, rms_final : float
        Torsion-moment residual rms [N m].
    noise_floor : float
        The torsion moment's white noise level [N m].
    statistics_baseline, statistics_final : dict of str to float
        Adequacy statistics [-].
    null : NullLaw
        The record's null law.
    noise : dict of str to object
        The measured noise (:meth:`.noise.NoiseModel.as_dict`).
    instrument : dict of str to object
        The identified instrument chain.
    drive : dict of str to object
        The measured drive profile.
    drift_outlier : bool
        The stick kinematics drift beyond their null law (rig or instrument change).
    unexplained : tuple of Unexplained
        Where and how large what the final model leaves is (empty when adequate).
    localisation : dict of str to object
        Residual statistics by localising variable, baseline and final.
    rejected : tuple of (float, str)
        Parts of the record no segment starts in: time [s] and reason.
    """

    baseline: dict[str, float]
    final: dict[str, float]
    rms_baseline: float
    rms_final: float
    noise_floor: float
    statistics_baseline: dict[str, float]
    statistics_final: dict[str, float]
    null: NullLaw
    noise: dict[str, object]
    instrument: dict[str, object]
    drive: dict[str, object]
    drift_outlier: bool
    unexplained: tuple[Unexplained, ...] = ()
    localisation: dict[str, object] = field(default_factory=dict)
    rejected: tuple[tuple[float, str], ...] = ()

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form."""
        return {
            'baseline': {'params': dict(self.baseline), 'rms': self.rms_baseline,
                         'statistics': dict(self.statistics_baseline)},
            'final': {'params': dict(self.final), 'rms': self.rms_final,
                      'statistics': dict(self.statistics_final)},
            'noise_floor': self.noise_floor,
            'null': self.null.as_dict(),
            'noise': dict(self.noise),
            'instrument': dict(self.instrument),
            'drive': dict(self.drive),
            'instrument_change': self.drift_outlier,
            'unexplained': [u.as_dict() for u in self.unexplained],
            'localisation': dict(self.localisation),
            'rejected_segments': [{'time': t, 'reason': why} for t, why in self.rejected],
        }  # fmt: skip


@dataclass(frozen=True)
class Traces:
    """Arrays behind the plots of one record: its problem, baseline and final simulations."""

    problem: Problem
    baseline: SimulatedRecord
    final: SimulatedRecord


@dataclass(frozen=True, eq=False)
class MissingPhysics:
    """The result of :func:`.run.find_missing_physics`.

    Parameters
    ----------
    verdict : str
        One of :data:`.decide.KINDS`.
    reason : str
        One sentence why.
    experiment : str
        The experiment that would decide ('' if none is needed).
    named : tuple of Effect
        The named effects, in the order added (verdict ``named``).
    alternatives : tuple of Effect
        The families the records cannot tell apart (verdict ``cannot_tell_apart``,
        or the set of the best partial explanations).
    partial : tuple of Effect
        Families that explain part of the mismatch, best first.
    records : tuple of RecordReport
        Per record.
    rounds : tuple of tuple of Effect
        Every refined form of every round.
    policy : Policy
        The rules and budget used.
    run_time : float
        Wall time [s].
    simulations : int
        Simulations of the records' fits (the replicas' own not counted).
    traces : tuple of Traces
        Per record, the arrays behind the plots.
    inputs : tuple of InputFindings
        Per record, what the input checks found (empty: none ran).
    sources : tuple of str
        Per record, where it came from.
    """

    verdict: str
    reason: str
    experiment: str
    named: tuple[Effect, ...]
    alternatives: tuple[Effect, ...]
    partial: tuple[Effect, ...]
    records: tuple[RecordReport, ...]
    rounds: tuple[tuple[Effect, ...], ...]
    policy: Policy
    run_time: float
    simulations: int
    traces: tuple[Traces, ...] = field(default=(), repr=False)
    inputs: tuple[InputFindings, ...] = ()
    sources: tuple[str, ...] = ()

    FILES = ('discrepancy.json',)

    @property
    def added(self) -> tuple[str, ...]:
        """The named families, in the order added."""
        return tuple(e.family for e in self.named)

    @property
    def joint(self) -> bool:
        """Whether several records were fitted jointly."""
        return len(self.records) > 1

    def finding(self) -> str:
        """Return the verdict in one line.

        Named effects come with their values, a set with the experiment that would
        decide; an unexplained set with each member's own torque residual rms and the
        share of the excess it explains.
        """
        rms = ', '.join(f'{r.rms_baseline:.3g} -> {r.rms_final:.3g}' for r in self.records)
        tail = f'; torque residual RMS {rms} N m'
        if self.verdict == NAMED:
            parts = []
            for e in self.named:
                vals = ', '.join(
                    f'{k} = {v:.4g} {e.units.get(k, "").strip("-")}'.rstrip()
                    for k, v in e.params.items()
                )
                parts.append(f'{e.family} ({vals})')
            return 'found ' + '; '.join(parts) + tail
        if self.alternatives:
            names = ', '.join(e.family for e in self.alternatives)
            extra = f'; {self.experiment} would decide' if self.experiment else ''
            if self.verdict == CANNOT_TELL_APART:
                return f'cannot tell apart: {{{names}}}{extra}{tail}'
            # nothing is added to the model: each member's own residual says how far it gets
            base = ', '.join(f'{r.rms_baseline:.3g}' for r in self.records)
            reach = ''.join(
                f'; with {e.family} {", ".join(f"{v:.3g}" for v in e.rms)} '
                f'({100 * e.explained:.0f} % of the excess)'
                for e in self.alternatives
            )
            return f'not explained: {{{names}}}{extra}; torque residual RMS {base} N m{reach}'
        return f'{self.verdict.replace("_", " ")}: {self.reason}{tail}'

    def summary(self) -> dict[str, object]:
        """Return the headline numbers.

        Returns
        -------
        dict
            ``verdict``, ``added`` (comma-joined families), ``records``, and per the
            first record the torque residual rms of the baseline and the final model
            [N m] and the number of unexplained findings.
        """
        first = self.records[0]
        return {
            'verdict': self.verdict,
            'added': ','.join(self.added),
            'records': len(self.records),
            'rms_baseline': first.rms_baseline,
            'rms_final': first.rms_final,
            'unexplained': len(first.unexplained),
        }

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready report (``discrepancy.json``)."""
        first = self.records[0]
        out: dict[str, object] = {
            'verdict': self.verdict,
            'finding': self.finding(),
            'reason': self.reason,
            'experiment': self.experiment,
            'added': [e.as_dict() for e in self.named],
            'cannot_tell_apart': [e.as_dict() for e in self.alternatives],
            'partial': [e.as_dict() for e in self.partial],
            'baseline': {'rms': first.rms_baseline, 'params': dict(first.baseline)},
            'final': {'rms': first.rms_final, 'params': dict(first.final)},
            'noise_floor': first.noise_floor,
            'unexplained': [u.as_dict() for u in first.unexplained],
            'instrument': dict(first.instrument),
            'drive': dict(first.drive),
            'records': [r.as_dict() for r in self.records],
            'rounds': [[e.as_dict() for e in rnd] for rnd in self.rounds],
            'settings': {**self.policy.as_dict(), 'run_time_s': self.run_time,
                         'simulations': self.simulations, 'records': len(self.records)},
        }  # fmt: skip
        if len(self.inputs) == 1:
            out['input'] = self.inputs[0].summary()
        if self.sources:
            out['sources'] = list(self.sources)
        return out

    def rows(self) -> list[dict[str, object]]:
        """Return one row per reported effect and parameter.

        Returns
        -------
        list of dict
            ``role`` (named, cannot_tell_apart, partial), ``effect``, ``form``,
            ``param``, ``value``, ``se``, ``unit`` and the share of the excess it
            explains.
        """
        rows: list[dict[str, object]] = []
        for role, effects in (
            ('named', self.named),
            ('cannot_tell_apart', self.alternatives if self.verdict == CANNOT_TELL_APART else ()),
            ('partial', self.partial if self.verdict != CANNOT_TELL_APART else ()),
        ):
            for e in effects:
                for name, value in e.params.items():
                    rows.append({
                        'role': role, 'effect': e.family, 'form': e.form, 'param': name,
                        'value': float(value), 'se': float(e.se.get(name, math.nan)),
                        'unit': e.units.get(name, ''), 'explained': e.explained,
                    })  # fmt: skip
        return rows

    def to_frame(self) -> pd.DataFrame:
        """Return :meth:`rows` as a pandas DataFrame."""
        import pandas as pd

        cols = ('role', 'effect', 'form', 'param', 'value', 'se', 'unit', 'explained')
        return pd.DataFrame(self.rows(), columns=list(cols))

    def write(self, directory: str | os.PathLike[str]) -> list[Path]:
        """Write ``discrepancy.json`` (strict JSON) into ``directory``; return the paths."""
        from ..report import write_json

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        return [write_json(self.as_dict(), d / 'discrepancy.json')]

    def plot(self, directory: str | os.PathLike[str]) -> list[Path]:
        """Draw the figures of the first record into ``directory``; return the paths."""
        from ..plots import write_plots

        Path(directory).mkdir(parents=True, exist_ok=True)
        return list(write_plots(self, Path(directory)))


__all__ = ['Effect', 'MissingPhysics', 'RecordReport', 'Traces']
