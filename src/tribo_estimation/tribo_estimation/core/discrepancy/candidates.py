"""The library of candidate effects (pluggable).

Each candidate is one *form* of an effect family: a named, parameterised, *nested*
extension of the paper's rig model (Equ. 1-8) whose parameters map onto fields of
:class:`tribo_estimation.core.model.Extensions`; all parameters zero give back the
baseline. A candidate carries bounds, a typical scale (for the optimiser), start
values (possibly computed from the data: e.g. the ripple frequency from a
spectral line), the localising variable whose residual pattern it is expected to
explain and its family (the forms of one family answer to one name: a friction
drift linear or saturating is a friction drift).

Register a new candidate with :func:`register`; the pipeline
(:mod:`.pipeline`) screens every form of every family. New candidates go in one
module each under :mod:`.effects` (auto-discovered: importing this module imports
that package).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from tribo_estimation.core.measurement import MeasurementTransform, register_transform
from tribo_estimation.errors import InvalidParameterError, UnknownCandidateError

from .stats import FloatArray

#: Experiments that decide an effect a record cannot separate (``Candidate.suggest``).
SUGGEST_SPEED = 'a second drive speed or a speed step'
SUGGEST_LONGER = 'a longer record'
SUGGEST_MORE = 'a longer record (more stick-slip cycles)'

#: Localising variables (names used by :mod:`.localise` and the plots).
LOCALISERS: tuple[str, ...] = (
    'preceding_stick_duration',
    'phase',
    'slip_speed',
    'test_time',
    'spectrum',
    'breakaway',
    'chamber_speed',
    'shaft_angle',
)


@dataclass(frozen=True)
class ParamSpec:
    """One candidate parameter = one ``Extensions`` field.

    ``lower``/``upper`` bound the fit, ``scale`` is its typical magnitude (the
    optimiser works on value/scale), ``log`` fits log(value) (for strictly
    positive time constants). ``unit`` is the SI unit of the value.
    """

    name: str
    unit: str
    lower: float
    upper: float
    scale: float
    initial: float
    log: bool = False

    def __post_init__(self) -> None:
        """Check the bounds, the initial value and the scale."""
        if not (self.lower <= self.initial <= self.upper):
            raise InvalidParameterError(
                f'parameter {self.name}: initial {self.initial} outside '
                f'[{self.lower}, {self.upper}]'
            )
        if self.scale <= 0:
            raise InvalidParameterError(
                f'parameter {self.name}: scale must be > 0, got {self.scale}'
            )
        if self.log and self.lower <= 0:
            raise InvalidParameterError(f'parameter {self.name}: log scaling needs lower > 0')


@dataclass(frozen=True)
class StartContext:
    """What a candidate may look at to choose its start values.

    Arrays are the baseline's residuals (measured - simulated) over the whole
    record: ``torque`` (N m), ``speed`` (rad/s); ``time`` (s), ``fs`` (Hz);
    ``nominal_speed`` (rad/s); ``stick_durations`` (s, complete stick phases of
    the baseline simulation); ``friction_moment_scale`` (N m); ``drive_angle`` (rad,
    the drive profile's angle at ``time`` from its first knot).
    """

    time: FloatArray
    fs: float
    torque: FloatArray
    speed: FloatArray
    nominal_speed: float
    stick_durations: FloatArray
    friction_moment_scale: float
    drive_angle: FloatArray


StartFn = Callable[[StartContext], list[dict[str, float]]]

#: A form's change of the friction levels with test time: ``(values, t)`` -> the changes
#: of mu0 and mu_inf [-] and their rates [1/s] at the times ``t`` [s]
#: (:attr:`Candidate.levels`).
LevelsFn = Callable[
    [Mapping[str, float], FloatArray], tuple[FloatArray, FloatArray, FloatArray, FloatArray]
]


def _no_starts(_ctx: StartContext) -> list[dict[str, float]]:
    return []


@dataclass(frozen=True)
class Candidate:
    """A named candidate effect.

    ``params`` are the fitted ``Extensions`` fields; ``localiser`` the variable
    its residual signature shows against (one of :data:`LOCALISERS`);
    ``starts`` computes extra data-driven start points (each a full mapping of
    parameter name to value) tried besides the defaults; ``demo_effects`` the
    ``Extensions`` values hidden in the rig by ``tribo demo --effect NAME`` when
    there is no ``config/rig_hidden_NAME.yaml`` (None: that file must exist);
    ``measurement`` the effect's measurement hook (a
    :class:`~tribo_estimation.core.measurement.MeasurementTransform` that turns the
    simulated into the measured torsion moment; None for an effect on the dynamics);
    ``equation`` the effect's term in the equations (Markdown text for the table of
    ``docs/physics.md`` section 8, :func:`candidate_table`); ``suggest`` the
    experiment that decides the effect when a record cannot
    (:func:`.pipeline.decide.experiment`); ``profile`` a
    log-scaled shape parameter (a time constant) that the selection's start screening
    holds fixed at each start value (a profile of the cost over it, refined by a
    parabola in log): free, it forms a curved valley with the levels along which the
    least-squares fit crawls (dwell-time stiction: mu0, gain and tau trade along the
    breakaway threshold ``mu_s(t_stick)``; '' = none).
    """

    name: str
    description: str
    params: tuple[ParamSpec, ...]
    localiser: str
    starts: StartFn = field(default=_no_starts)
    demo_effects: Mapping[str, float] | None = None
    measurement: MeasurementTransform | None = None
    equation: str = ''
    suggest: str = SUGGEST_MORE
    profile: str = ''
    family: str = ''
    levels: LevelsFn | None = None

    def __post_init__(self) -> None:
        """Check the localiser, the profiled parameter and that parameter names are unique."""
        if self.localiser not in LOCALISERS:
            raise InvalidParameterError(
                f'candidate {self.name}: unknown localiser {self.localiser!r}'
            )
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise InvalidParameterError(f'candidate {self.name}: duplicate parameter names {names}')
        if self.profile and not any(p.name == self.profile and p.log for p in self.params):
            raise InvalidParameterError(
                f'candidate {self.name}: profile {self.profile!r} is not one of its '
                f'log-scaled parameters {names}'
            )

    @property
    def family_name(self) -> str:
        """The effect family this form belongs to (its own name when it is the only form)."""
        return self.family or self.name

    @property
    def param_names(self) -> tuple[str, ...]:
        """The ``Extensions`` field names this candidate fits."""
        return tuple(p.name for p in self.params)

    def default_start(self) -> dict[str, float]:
        """Return the default start values."""
        return {p.name: p.initial for p in self.params}

    def nested_start(self) -> dict[str, float]:
        """Return the start closest to the current model.

        Every parameter at zero, or at its lower bound for log-scaled time constants
        (a lag of 0.2 ms ~ none).
        """
        return {
            p.name: (p.lower if p.log else min(max(0.0, p.lower), p.upper)) for p in self.params
        }

    def start_points(self, ctx: StartContext | None) -> list[dict[str, float]]:
        """Default start, the nested start and the data-driven ones, clipped to the bounds."""
        pts = [self.default_start()]
        if self.nested_start() != pts[0]:
            pts.append(self.nested_start())
        if ctx is not None:
            for extra in self.starts(ctx):
                pt = self.default_start()
                pt.update(extra)
                pts.append(self.clip(pt))
        return pts

    def clip(self, values: Mapping[str, float]) -> dict[str, float]:
        """Clip parameter values to their bounds (names must be known)."""
        out: dict[str, float] = {}
        for p in self.params:
            v = float(values[p.name])
            out[p.name] = min(max(v, p.lower), p.upper)
        return out

    def to_unit(self, values: Mapping[str, float]) -> FloatArray:
        """Map values to the optimiser's scaled coordinates."""
        x = []
        for p in self.params:
            v = float(values[p.name])
            x.append(math.log(max(v, p.lower)) if p.log else v / p.scale)
        return np.asarray(x, dtype=np.float64)

    def from_unit(self, x: FloatArray) -> dict[str, float]:
        """Inverse of :meth:`to_unit`."""
        return {
            p.name: (math.exp(float(xi)) if p.log else float(xi) * p.scale)
            for p, xi in zip(self.params, x, strict=True)
        }

    def units(self) -> dict[str, str]:
        """Parameter name -> SI unit."""
        return {p.name: p.unit for p in self.params}


_REGISTRY: dict[str, Candidate] = {}


def register(candidate: Candidate, *, replace: bool = False) -> Candidate:
    """Add a candidate to the library (``replace`` to overwrite a name)."""
    if candidate.name in _REGISTRY and not replace:
        raise InvalidParameterError(f'candidate {candidate.name!r} is already registered')
    _REGISTRY[candidate.name] = candidate
    register_transform(candidate.name, candidate.measurement)
    return candidate


def get(name: str) -> Candidate:
    """Return the registered candidate called ``name``."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise UnknownCandidateError(
            f'unknown candidate effect {name!r}; known: {sorted(_REGISTRY)}'
        ) from None


def names() -> tuple[str, ...]:
    """Names of the registered candidates, in registration order."""
    return tuple(_REGISTRY)


def families() -> tuple[str, ...]:
    """Names of the effect families, in registration order of their first form."""
    return tuple(dict.fromkeys(c.family_name for c in _REGISTRY.values()))


def forms(family: str) -> tuple[Candidate, ...]:
    """Return the forms (candidates) of one effect family, in registration order.

    Raises
    ------
    UnknownCandidateError
        If no candidate belongs to ``family``.
    """
    out = tuple(c for c in _REGISTRY.values() if c.family_name == family)
    if not out:
        raise UnknownCandidateError(
            f'unknown effect family {family!r}; known: {sorted(families())}'
        )
    return out


def level_forms() -> tuple[Candidate, ...]:
    """Return the registered forms that change the friction levels with test time."""
    return tuple(c for c in _REGISTRY.values() if c.levels is not None)


def all_candidates() -> tuple[Candidate, ...]:
    """Return the registered candidates, in registration order."""
    return tuple(_REGISTRY.values())


def _cell(text: str) -> str:
    """Escape a Markdown table cell (pipes, also inside code spans)."""
    return text.replace('|', '\\|')


def _bound(value: float) -> str:
    """Format a parameter bound compactly."""
    return f'{value:g}'


def candidate_table() -> str:
    """Render the candidate table of ``docs/physics.md`` section 8 from the registry.

    One row per registered candidate (registration order): name and side (dynamics
    or measurement), parameters with unit and fit bounds, equation, localiser, and
    the experiment that decides it when a record cannot.

    Returns
    -------
    str
        Markdown table (ending with a newline).
    """
    rows = [
        '| candidate | parameters [unit] (fit bounds) | equation | localiser | '
        'if the record cannot separate it |',
        '|---|---|---|---|---|',
    ]
    for c in all_candidates():
        side = ' (measurement)' if c.measurement is not None else ''
        params = ', '.join(
            f'`{p.name}` [{p.unit}] ({_bound(p.lower)} .. {_bound(p.upper)}'
            f'{", log" if p.log else ""})'
            for p in c.params
        )
        cells = [
            f'`{c.name}`{side}',
            params,
            c.equation or c.description,
            c.localiser.replace('_', ' '),
            c.suggest,
        ]
        rows.append('| ' + ' | '.join(_cell(x) for x in cells) + ' |')
    return '\n'.join(rows) + '\n'


# --------------------------------------------------------- one module per candidate
# (at the end: the modules import ``Candidate``/``register`` from this module)
from . import effects as _effects  # noqa: E402, F401
