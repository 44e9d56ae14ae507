"""One parameter specification: name, unit, default, bounds, description (no rclpy).

A :class:`ParamSpec` describes one configurable value once. The tables built
from it are read by three kinds of user:

* the nodes declare their ROS parameters from it
  (:func:`tribo_common.params.declare_spec`: descriptor with the description
  and unit, ``FloatingPointRange``/``IntegerRange``, ``read_only``, range check);
* the cores' file loaders validate keys and values against it (e.g. the
  RIG.yaml loader, :mod:`tribo_estimation.core.config`);
* the docs table of every parameter is rendered from it (:func:`markdown_table`).

Why this module is in ``tribo_common``: the type is needed both by the ROS
helper :mod:`tribo_common.params` and by rclpy-free cores of the packages
above; ``tribo_common`` is the one package every other one depends on, so
the type lives here and this module imports nothing but the standard library
(the cores may import it, see the "core imports no rclpy" tests). The
tables themselves (e.g. the rig's Tab. 1 spec,
:mod:`tribo_estimation.core.rigspec`) live with the package that owns the
physics.

Bounds are inclusive (as ROS ranges are); a value that must be strictly
positive gets the smallest plausible value as its lower bound.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Literal

#: Parameter types: ROS double, integer, bool, string and string array.
ParamType = Literal['float', 'int', 'bool', 'str', 'str_list']

#: Values a parameter may have (a string list as a tuple: the spec is frozen).
ParamValue = float | int | bool | str | tuple[str, ...]


class SpecError(ValueError):
    """A parameter specification contradicts itself (a programming error, not bad input)."""


def _type_ok(kind: ParamType, value: object) -> bool:
    if kind == 'bool':
        return isinstance(value, bool)
    if kind == 'int':
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == 'float':
        return isinstance(value, int | float) and not isinstance(value, bool)
    if kind == 'str':
        return isinstance(value, str)
    return isinstance(value, list | tuple) and all(isinstance(v, str) for v in value)


@dataclass(frozen=True)
class ParamSpec:
    """One parameter.

    Attributes
    ----------
    name
        the key (ROS parameter name, YAML key).
    unit
        SI unit (``'-'`` dimensionless; ``''`` for text and flags).
    default
        value when none is given (the paper's Tab. 1 for the rig).
    lower, upper
        inclusive bounds of a number (``None``: unbounded).
    description
        meaning, without the unit (:attr:`label` adds it).
    read_only
        the node reads it once at start.
    type
        ``'float'``, ``'int'``, ``'bool'``, ``'str'`` or ``'str_list'``.
    """

    name: str
    unit: str
    default: ParamValue
    lower: float | None = None
    upper: float | None = None
    description: str = ''
    read_only: bool = True
    type: ParamType = 'float'

    def __post_init__(self) -> None:
        """Refuse an empty name, an unknown type, bounds on a non-number or a bad default."""
        if not self.name:
            raise SpecError('ParamSpec: empty name')
        if self.type not in ('float', 'int', 'bool', 'str', 'str_list'):
            raise SpecError(f'ParamSpec {self.name!r}: unknown type {self.type!r}')
        if (self.lower is not None or self.upper is not None) and self.type not in (
            'float',
            'int',
        ):
            raise SpecError(f'ParamSpec {self.name!r}: bounds on a {self.type} parameter')
        if self.lower is not None and self.upper is not None and self.lower > self.upper:
            raise SpecError(f'ParamSpec {self.name!r}: lower {self.lower} > upper {self.upper}')
        problem = self.violation(self.default)
        if problem:
            raise SpecError(f'ParamSpec {self.name!r}: default: {problem}')

    @property
    def label(self) -> str:
        """Description with the unit, e.g. ``'chamber inertia I1 [kg m^2]'``."""
        return f'{self.description} [{self.unit}]' if self.unit else self.description

    def range_text(self) -> str:
        """Return the bounds as text, e.g. ``'[0, 1e+06] N'`` (``''`` if unbounded)."""
        if self.lower is None and self.upper is None:
            return ''
        lo = '-inf' if self.lower is None else f'{self.lower:g}'
        hi = 'inf' if self.upper is None else f'{self.upper:g}'
        return f'[{lo}, {hi}] {self.unit}'.rstrip()

    def violation(self, value: object) -> str | None:
        """Why ``value`` is not allowed (``None`` if it is)."""
        if not _type_ok(self.type, value):
            return f'must be of type {self.type}, got {value!r}'
        if self.type in ('float', 'int'):
            x = float(value)  # type: ignore[arg-type]
            if not math.isfinite(x):
                return f'must be finite, got {value!r}'
            if (self.lower is not None and x < self.lower) or (
                self.upper is not None and x > self.upper
            ):
                return f'= {value!r} outside the plausible range {self.range_text()}'
        return None

    def with_default(self, default: ParamValue) -> ParamSpec:
        """Return the same parameter with another default (checked against the bounds)."""
        return dataclasses.replace(self, default=default)


def spec_table(specs: Iterable[ParamSpec]) -> dict[str, ParamSpec]:
    """Name -> spec, in the given order; a name given twice raises :class:`SpecError`."""
    out: dict[str, ParamSpec] = {}
    for s in specs:
        if s.name in out:
            raise SpecError(f'parameter {s.name!r} specified twice')
        out[s.name] = s
    return out


def markdown_table(specs: Mapping[str, ParamSpec] | Iterable[ParamSpec]) -> str:
    """Render ``specs`` as a Markdown table (name, unit, default, range, description)."""
    items = list(specs.values()) if isinstance(specs, Mapping) else list(specs)
    rows = ['| name | unit | default | range | description |', '|---|---|---|---|---|']
    for s in items:
        default = ', '.join(s.default) if isinstance(s.default, tuple) else repr(s.default)
        rng = s.range_text().removesuffix(s.unit).strip() if s.unit else s.range_text()
        rows.append(f'| `{s.name}` | {s.unit} | {default} | {rng} | {s.description} |')
    return '\n'.join(rows) + '\n'


__all__ = ['ParamSpec', 'ParamType', 'ParamValue', 'SpecError', 'markdown_table', 'spec_table']
