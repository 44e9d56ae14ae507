"""Settings and results of the missing-physics selection (:mod:`.run`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from tribo_estimation.errors import InvalidParameterError

from .. import candidates as cand_lib
from ..fitting import Problem, SimulatedRecord
from ..identify import Identifiability
from ..sparse import SparseTerm

#: Receiver of one-line progress messages.
Progress = Callable[[str], None]


@dataclass(frozen=True)
class SelectionSettings:
    """Settings of the selection.

    ``min_gain`` relative decrease of the held-out cost needed to accept (-; the
    detection limit: a candidate below it is reported "too small for this record to
    decide"; the controls and out-of-library records of the benchmark matrix stay
    below 1.5 %);
    ``bic_threshold`` required BIC decrease (-; 10 = 'very strong' evidence);
    ``max_effects`` most effects added; ``folds`` cross-validation folds;
    ``block_time`` length of a cross-validation block [s]; ``corr_time``
    residual correlation time for the BIC sample count [s]; ``max_nfev``
    evaluations per whole-record fit; ``candidates`` names to try (None = all
    registered); ``propose_terms`` run the sparse regression on what remains;
    ``torsion_lag`` identify the torsion amplifier's lag as part of the instrument
    model and compensate it (:func:`.fitting.identify_torsion_lag`; off: the lag is
    left to the ``torque_sensor_lag`` candidate); ``max_block_loss`` the largest
    relative cost increase (-) of any time block that a named effect may cause (an
    effect of the library improves the whole record; one that trades a block for
    the others absorbs a mismatch that changes during the record).

    Raises
    ------
    InvalidParameterError
        If a setting is out of range.
    """

    min_gain: float = 0.05
    bic_threshold: float = 10.0
    max_effects: int = 3
    folds: int = 2
    block_time: float = 0.25
    corr_time: float = 1e-3
    max_nfev: int = 60
    screen_nfev: int = 15
    cv_nfev: int = 15
    parsimony: float = 0.03
    candidates: tuple[str, ...] | None = None
    propose_terms: bool = True
    torsion_lag: bool = True
    max_block_loss: float = 0.1

    def __post_init__(self) -> None:
        """Check the ranges."""
        if not 0.0 <= self.min_gain < 1.0:
            raise InvalidParameterError(f'min_gain must be in [0, 1), got {self.min_gain}')
        if self.folds < 2:
            raise InvalidParameterError(f'folds must be >= 2, got {self.folds}')
        if self.max_effects < 0:
            raise InvalidParameterError(f'max_effects must be >= 0, got {self.max_effects}')
        if not self.max_block_loss >= 0.0:
            raise InvalidParameterError(f'max_block_loss must be >= 0, got {self.max_block_loss}')
        for name in ('block_time', 'corr_time'):
            if not getattr(self, name) > 0:
                raise InvalidParameterError(f'{name} must be > 0 s, got {getattr(self, name)}')


@dataclass(frozen=True)
class ModelScore:
    """A fitted model and its scores.

    ``effects`` the added candidates; ``params`` all values (SI); ``cost`` whole-record
    weighted cost (-) and ``rms`` torque residual rms (N m); ``cv_cost`` / ``cv_rms``
    the same held out (cross validation); ``bic`` (-); ``n_params`` parameter count;
    ``block_cost`` the whole-record fit's cost per time block (-; NaN: not covered).
    """

    effects: tuple[str, ...]
    params: dict[str, float]
    cost: float
    rms: float
    cv_cost: float
    cv_rms: float
    bic: float
    n_params: int
    block_cost: tuple[float, ...] = ()


@dataclass(frozen=True)
class CandidateScore:
    """One candidate's score in one round (relative to the current model).

    ``gain`` relative decrease of the held-out cost (-); ``delta_bic`` (-);
    ``block_loss`` the largest relative cost increase of a time block (-; <= 0: no
    block worse; :func:`.scoring.worst_block_loss`).
    """

    effect: str
    model: ModelScore
    gain: float
    delta_bic: float
    accepted: bool
    block_loss: float = float('nan')

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form.

        Returns
        -------
        dict[str, object]
            Effect, its parameters, rms and held-out rms [N m], held-out cost, gain,
            delta BIC and whether it was accepted.
        """
        return {
            'effect': self.effect,
            'params': {k: self.model.params[k] for k in cand_lib.get(self.effect).param_names},
            'rms': self.model.rms,
            'cv_rms': self.model.cv_rms,
            'cv_cost': self.model.cv_cost,
            'gain': self.gain,
            'delta_bic': self.delta_bic,
            'block_loss': self.block_loss,
            'accepted': self.accepted,
        }


@dataclass(frozen=True)
class AddedEffect:
    """An accepted effect.

    Fitted parameters (SI, ``units``), torque residual rms before/after (N m, whole
    record), held-out rms before/after (N m), delta BIC (-) and the localiser name.
    """

    effect: str
    params: dict[str, float]
    units: dict[str, str]
    rms_before: float
    rms_after: float
    cv_rms_before: float
    cv_rms_after: float
    delta_bic: float
    localiser: str


@dataclass(frozen=True)
class Unexplained:
    """Residual structure no candidate explains.

    ``kind`` one of 'spectral_line', 'phase', 'trend', 'time', 'shaft_angle',
    'broadband', 'instrument' (the stick kinematics drift: the rig or a sensor
    changes during the record); ``where`` says where it concentrates; ``size`` its
    magnitude (N m: line amplitude, phase excess rms, trend change over the record,
    excess rms of the worst time block, angle-harmonic amplitude; for 'instrument'
    the torque residual's rms it leaves); ``frequency`` Hz for lines (else None).
    """

    kind: str
    where: str
    size: float
    frequency: float | None = None
    details: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form.

        Returns
        -------
        dict[str, object]
            Kind, where, size [N m], unit, frequency [Hz] and the details.
        """
        return {
            'kind': self.kind,
            'where': self.where,
            'size': self.size,
            'unit': 'N m',
            'frequency': self.frequency,
            **dict(self.details.items()),
        }


@dataclass(frozen=True)
class Traces:
    """Arrays behind the plots: measured channels, baseline and final simulations."""

    problem: Problem
    baseline: SimulatedRecord
    final: SimulatedRecord


@dataclass(frozen=True)
class DiscrepancyResult:
    """Outcome of :func:`.run.run_discrepancy` (see :mod:`..report` for the JSON)."""

    baseline: ModelScore
    added: tuple[AddedEffect, ...]
    final: ModelScore
    unexplained: tuple[Unexplained, ...]
    noise_floor: float
    rounds: tuple[tuple[CandidateScore, ...], ...]
    proposed_terms: tuple[SparseTerm, ...]
    localisation_before: dict[str, Any]
    localisation_after: dict[str, Any]
    settings: dict[str, Any]
    traces: Traces
    instrument: dict[str, Any] = field(default_factory=dict)
    drive: dict[str, Any] = field(default_factory=dict)
    identifiable: dict[str, Identifiability] = field(default_factory=dict)
    blocked: tuple[str, ...] = ()
    inconsistent: tuple[str, ...] = ()


__all__ = [
    'AddedEffect',
    'CandidateScore',
    'DiscrepancyResult',
    'ModelScore',
    'Progress',
    'SelectionSettings',
    'Traces',
    'Unexplained',
]
