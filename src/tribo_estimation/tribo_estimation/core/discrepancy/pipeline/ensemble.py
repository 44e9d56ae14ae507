"""One or several records fitted as one model: shared effect, own friction and instruments.

:class:`Ensemble` holds one :class:`..fitting.Problem` per record. A model's values
are one mapping: the names an effect adds are shared by every record (one contact,
one physics), the friction levels ``mu0``, ``mu_inf`` (Equ. 8) and the free
instrument terms are each record's own, named ``name@i`` (unless the friction is
shared: ``shared_friction``, records of one contact at several drive speeds). A
single record is an ensemble of one, so the single-record, joint and live workflows
run the same code. The solver is the package's bounded Levenberg-Marquardt
(:func:`tribo_estimation.core.lsq.levenberg_marquardt`) on value/scale coordinates
(log for time constants).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.errors import InvalidParameterError

from ..candidates import ParamSpec
from ..fitting import K_DECAY, MU0, MU_INF, Problem, SimulatedRecord
from ..fitting.problem import scaled_fit

FloatArray = npt.NDArray[np.float64]

#: The friction law of the baseline (Equ. 8): its levels and decay constant.
LEVELS: tuple[ParamSpec, ParamSpec, ParamSpec] = (MU0, MU_INF, K_DECAY)


def own(name: str, i: int) -> str:
    """Return record ``i``'s name of a per-record parameter (``mu0`` -> ``mu0@i``)."""
    return f'{name}@{i}'


def plain(name: str) -> str:
    """Return a parameter name without its record suffix (``mu0@1`` -> ``mu0``)."""
    return name.partition('@')[0]


@dataclass(frozen=True)
class Fit:
    """A fitted model of an ensemble.

    Parameters
    ----------
    values : dict of str to float
        All values (shared and ``name@i``; SI units).
    cost : float
        Mean squared weighted residual over the records' samples [-].
    nfev : int
        Simulations the fit took.
    converged : bool
        Whether the solver stopped on a convergence test.
    se : dict of str to float
        Standard errors of the free values from the solver's Jacobian (SI).
    """

    values: dict[str, float]
    cost: float
    nfev: int
    converged: bool
    se: dict[str, float]


class Ensemble:
    """Records fitted together (see the module docstring).

    Parameters
    ----------
    problems : sequence of Problem
        One fit problem per record (weights and free instrument terms set).
    shared_friction : bool
        One friction law for all records.
    """

    def __init__(self, problems: Sequence[Problem], *, shared_friction: bool = False) -> None:
        if not problems:
            raise InvalidParameterError('a fit needs at least one record')
        self.problems = list(problems)
        self.shared_friction = bool(shared_friction) and len(self.problems) > 1

    @property
    def n(self) -> int:
        """Number of records."""
        return len(self.problems)

    # ------------------------------------------------------------------ names
    def own_specs(self) -> list[ParamSpec]:
        """Return the per-record parameters: friction levels and free instrument terms."""
        out: list[ParamSpec] = []
        if self.shared_friction:
            out.extend(LEVELS)
        for i, pb in enumerate(self.problems):
            each = [*pb.free_instrument] if self.shared_friction else [*LEVELS, *pb.free_instrument]
            out.extend(replace(p, name=own(p.name, i)) for p in each)
        return out

    def specs(self, effect: Sequence[ParamSpec] = ()) -> list[ParamSpec]:
        """Return every fitted parameter of the baseline plus an effect's (shared)."""
        return [*self.own_specs(), *effect]

    def split(self, values: Mapping[str, float]) -> list[dict[str, float]]:
        """Return each record's values (``name@i`` -> ``name``; shared names as they are).

        Parameters
        ----------
        values : mapping of str to float
            Ensemble values.

        Returns
        -------
        list of dict
            One mapping per record.
        """
        out: list[dict[str, float]] = [{} for _ in self.problems]
        for k, v in values.items():
            base, _, idx = k.partition('@')
            if idx:
                i = int(idx)
                if 0 <= i < self.n:
                    out[i][base] = float(v)
            else:
                for d in out:
                    d.setdefault(k, float(v))
        return out

    def join(self, per_record: Sequence[Mapping[str, float]]) -> dict[str, float]:
        """Return ensemble values from per-record mappings (friction and instrument own).

        Parameters
        ----------
        per_record : sequence of mapping
            One value mapping per record.

        Returns
        -------
        dict of str to float
            The ensemble's values.
        """
        own_names = {p.name for p in LEVELS} if not self.shared_friction else set()
        out: dict[str, float] = {}
        for i, (pb, vals) in enumerate(zip(self.problems, per_record, strict=True)):
            mine = own_names | {p.name for p in pb.free_instrument}
            for k, v in vals.items():
                if k in mine:
                    out[own(k, i)] = float(v)
                else:
                    out.setdefault(k, float(v))
        if self.shared_friction:
            for p in LEVELS:
                out[p.name] = float(np.mean([float(v[p.name]) for v in per_record]))
        return out

    # ------------------------------------------------------------- simulation
    def simulate(self, values: Mapping[str, float]) -> list[SimulatedRecord]:
        """Simulate every record with the model ``values``."""
        return [pb.simulate(v) for pb, v in zip(self.problems, self.split(values), strict=True)]

    def residuals(
        self, values: Mapping[str, float], fold: int | None = None, folds: int = 2
    ) -> FloatArray:
        """Return the stacked weighted residual vectors of the records [-].

        Parameters
        ----------
        values : mapping of str to float
            Ensemble values.
        fold : int or None
            Only the time blocks ``b % folds == fold`` (None: all).
        folds : int
            Number of folds.

        Returns
        -------
        FloatArray
            The residuals.
        """
        parts = []
        for pb, v in zip(self.problems, self.split(values), strict=True):
            mask = None if fold is None else (pb.segments.block % folds) == fold
            parts.append(pb.residual_vector(pb.simulate(v, mask)))
        return np.concatenate(parts)

    def cost(self, values: Mapping[str, float]) -> float:
        """Return the mean squared weighted residual per sample over the records [-]."""
        total = 0.0
        n = 0
        for pb, sim in zip(self.problems, self.simulate(values), strict=True):
            v = pb.residual_vector(sim)
            total += float(v @ v)
            n += int(np.count_nonzero(sim.covered))
        return total / max(n, 1)

    def screen_folds(self, seconds: float) -> int:
        """Return the folds whose first holds about ``seconds`` of each record (at least 2)."""
        longest = max(float(pb.record.time[-1] - pb.record.time[0]) for pb in self.problems)
        return max(2, round(longest / max(seconds, 1e-9)))

    def n_evals(self) -> int:
        """Return the simulations run so far (all records)."""
        return sum(pb.n_evals for pb in self.problems)

    # -------------------------------------------------------------------- fit
    def fit(
        self,
        free: Sequence[ParamSpec],
        start: Mapping[str, float],
        *,
        max_nfev: int,
        fold: int | None = None,
        folds: int = 2,
    ) -> Fit:
        """Fit the ``free`` parameters by least squares of the output error.

        Parameters
        ----------
        free : sequence of ParamSpec
            The fitted parameters (names as in the values: shared or ``name@i``).
        start : mapping of str to float
            Start values, with every value the simulations need (others stay fixed).
        max_nfev : int
            Most simulation rounds (each simulates every record).
        fold : int or None
            Fit only the time blocks of one fold (None: all).
        folds : int
            Number of folds (the blocks ``b % folds == fold`` are fitted).

        Returns
        -------
        Fit
            The fitted values, cost and standard errors.
        """
        fixed = {k: float(v) for k, v in start.items()}
        if not free:
            return Fit(fixed, self.cost(fixed), 1, True, {})
        values, sse, nfev, converged, se = scaled_fit(
            lambda v: self.residuals(v, fold, folds), free, fixed, max_nfev
        )
        n = sum(
            int(np.count_nonzero(pb.segments.sample_mask(pb.record.time.size)))
            for pb in self.problems
        )
        return Fit(values, sse / max(n, 1), nfev, converged, se)


def at_bound(specs: Sequence[ParamSpec], values: Mapping[str, float], margin: float) -> list[str]:
    """Return the parameters whose value lies within ``margin`` of a bound.

    The distance is measured in the solver's coordinates (value/scale, or log for
    time constants) relative to the width of the box [-]. A parameter at a bound
    means the form cannot reach what the record asks for: a form mismatch.

    Parameters
    ----------
    specs : sequence of ParamSpec
        The parameters to check.
    values : mapping of str to float
        Fitted values (SI).
    margin : float
        Relative distance counted as "at the bound" [-].

    Returns
    -------
    list of str
        Their names.
    """
    out = []
    for p in specs:
        v = float(values[p.name])
        if p.log:
            lo, hi, x = math.log(p.lower), math.log(p.upper), math.log(max(v, p.lower))
        else:
            lo, hi, x = p.lower, p.upper, v
        width = hi - lo
        if width <= 0:
            continue
        # a bound at zero is the nested model (no effect), not a mismatch
        near_lo = (x - lo) / width < margin and not (not p.log and p.lower == 0.0)
        near_hi = (hi - x) / width < margin
        if near_lo or near_hi:
            out.append(p.name)
    return out


__all__ = ['LEVELS', 'Ensemble', 'Fit', 'at_bound', 'own', 'plain']
