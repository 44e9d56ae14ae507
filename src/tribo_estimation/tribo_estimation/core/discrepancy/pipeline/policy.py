"""The decision policy: one set of rules, several budgets.

The single-record workflow, the joint fit and the live monitor run the same steps
with the same decision rules (:mod:`.decide`); they differ only in their budget:
how many bootstrap replicas measure the null law, how many simulations a fit may
take, which families are screened and how many forms are refined.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from tribo_estimation.errors import InvalidParameterError

#: Receiver of one-line progress messages.
Progress = Callable[[str], None]


def quiet(_msg: str) -> None:
    """Receive a progress message and drop it."""


@dataclass(frozen=True)
class Policy:
    """Decision rules and budget of the missing-physics pipeline.

    Parameters
    ----------
    alpha : float
        Chance that a model with nothing missing is called inadequate [-]: the
        false-alarm rate of every adequacy decision (shared among the statistics of
        :mod:`.null`), and so a bound on the rate of naming an effect in a record
        with nothing missing; also the rate at which the instrument chain takes a
        torsion-amplifier lag where there is none
        (:func:`..fitting.instrument.identify_torsion_lag`).
    replicas : int
        Bootstrap replicas of the baseline's null law (:func:`.null.null_law`).
    confirm_replicas : int
        Replicas of a named model's own null law (0: the baseline's law decides).
    replica_nfev : int
        Simulations of a replica's refit.
    screen_nfev : int
        Simulations of a screening fit.
    screen_seconds : float
        Record time a screening fit sees [s] (every k-th time block; at least half).
    fit_nfev : int
        Simulations of a refinement on the whole record.
    refine : int
        Forms of each family refined on the whole record, the best screened first.
    families : tuple of str or None
        Families screened (None: the whole library).
    max_effects : int
        Most effects added (rounds of screening).
    bound_margin : float
        Relative distance to a bound (in the solver's coordinates) at which a fitted
        parameter counts as at the bound: a form mismatch [-].
    block_time : float
        Length of a time block [s].
    torsion_lag : bool
        Identify and compensate the torsion amplifier's lag in step 1.
    seed : int
        Seed of the bootstrap replicas' noise.
    time_budget : float
        Wall time after which no further form is screened or refined [s] (inf: none).
    describe : bool
        Describe where the residual concentrates (localisation, spectral lines) for
        the report; the decisions do not use it.
    k_starts : tuple of float
        Factors on RIG.yaml's k (Equ. 8) from which the baseline fit starts [-]:
        1, a third and three times (``docs/physics.md`` section 8).
    shaft : bool
        Identify the shaft's I2, K2, C2 with the baseline of a single record
        (:func:`.prepare.identify_shaft`); they then stay free in every model.
    speed_gain : bool
        Identify the speed channel's gain with the baseline of each record
        (:func:`.prepare.identify_speed_gain`) instead of the stick regression's alone.
    """

    alpha: float = 0.01
    replicas: int = 8
    confirm_replicas: int = 4
    replica_nfev: int = 10
    screen_nfev: int = 15
    screen_seconds: float = 2.0
    fit_nfev: int = 40
    refine: int = 1
    families: tuple[str, ...] | None = None
    max_effects: int = 2
    bound_margin: float = 0.01
    block_time: float = 0.25
    torsion_lag: bool = True
    seed: int = 0
    time_budget: float = math.inf
    describe: bool = True
    k_starts: tuple[float, ...] = (1.0, 1.0 / 3.0, 3.0)
    shaft: bool = True
    speed_gain: bool = True

    def __post_init__(self) -> None:
        """Refuse settings out of range."""
        if not 0.0 < self.alpha < 0.5:
            raise InvalidParameterError(f'alpha must be in (0, 0.5), got {self.alpha}')
        for name in ('replicas', 'replica_nfev', 'screen_nfev', 'fit_nfev'):
            if getattr(self, name) < 2:
                raise InvalidParameterError(f'{name} must be >= 2, got {getattr(self, name)}')
        if self.refine < 1:
            raise InvalidParameterError(f'refine must be >= 1, got {self.refine}')
        if self.confirm_replicas < 0 or self.confirm_replicas == 1:
            raise InvalidParameterError(
                f'confirm_replicas must be 0 or >= 2, got {self.confirm_replicas}'
            )
        if self.max_effects < 0:
            raise InvalidParameterError(f'max_effects must be >= 0, got {self.max_effects}')
        if not 0.0 <= self.bound_margin < 0.5:
            raise InvalidParameterError(
                f'bound_margin must be in [0, 0.5), got {self.bound_margin}'
            )
        if not self.screen_seconds > 0.0:
            raise InvalidParameterError(f'screen_seconds must be > 0 s, got {self.screen_seconds}')
        if not self.block_time > 0.0:
            raise InvalidParameterError(f'block_time must be > 0 s, got {self.block_time}')
        if not self.time_budget > 0.0:
            raise InvalidParameterError(f'time_budget must be > 0 s, got {self.time_budget}')
        if not self.k_starts or not all(f > 0.0 for f in self.k_starts):
            raise InvalidParameterError(f'k_starts must be factors > 0, got {self.k_starts}')

    @classmethod
    def live(cls, time_budget: float = 1.0) -> Policy:
        """Return the live monitor's budget: the same rules, fewer replicas, one effect.

        The baseline starts from RIG.yaml's k only, and neither the shaft nor the speed
        channel's gain is identified with it (a window every hop: the offline run's
        extra baseline fits do not fit the hop).

        The fits keep the offline budgets (a fit stopped early is a different fit, and the
        verdict must not depend on where one runs); the window's wall-time budget stops
        the screening and refinement of further forms.

        Parameters
        ----------
        time_budget : float
            Wall time per window after which no further form is refined [s].

        Returns
        -------
        Policy
            The live policy.
        """
        return cls(
            replicas=3,
            confirm_replicas=0,
            replica_nfev=8,
            max_effects=1,
            time_budget=time_budget,
            describe=False,
            k_starts=(1.0,),
            shaft=False,
            speed_gain=False,
        )

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready settings."""
        return {
            'alpha': self.alpha,
            'replicas': self.replicas,
            'confirm_replicas': self.confirm_replicas,
            'replica_nfev': self.replica_nfev,
            'screen_nfev': self.screen_nfev,
            'screen_seconds': self.screen_seconds,
            'fit_nfev': self.fit_nfev,
            'refine': self.refine,
            'families': list(self.families) if self.families is not None else None,
            'max_effects': self.max_effects,
            'bound_margin': self.bound_margin,
            'block_time': self.block_time,
            'torsion_lag': self.torsion_lag,
            'seed': self.seed,
            'describe': self.describe,
            'k_starts': list(self.k_starts),
            'shaft': self.shaft,
            'speed_gain': self.speed_gain,
        }


__all__ = ['Policy', 'Progress', 'quiet']
