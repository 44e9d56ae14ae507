"""Declaring node parameters with descriptors, units and range checks.

rclpy checks integer/float ranges itself but its message does not say what
the parameter means; :func:`declare` adds a unit-bearing description, also
checks exclusive bounds (e.g. an inertia must be > 0) and raises
:class:`ParameterError` naming the parameter, the value and the allowed range.

:func:`declare_spec` / :func:`declare_specs` declare parameters from their
:class:`~tribo_common.paramspec.ParamSpec` (the one table of name, unit,
default, bounds, description): every node declares its parameters that way.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator, Mapping
from typing import TypeVar, cast

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from tribo_common.paramspec import ParamSpec


class ParameterError(ValueError):
    """A node parameter is out of range or of the wrong type."""


#: Value types of a declared ROS parameter (the default's type fixes the parameter's).
DeclaredValue = bool | int | float | str | list[str]
_V = TypeVar('_V', bound=DeclaredValue)


def declare(
    node: Node,
    name: str,
    default: _V,
    description: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_exclusive: bool = False,
    read_only: bool = False,
) -> _V:
    """Declare one parameter and return its (checked) value.

    Parameters
    ----------
    node
        The node that owns the parameter.
    name
        Parameter name.
    default
        Default value (its type fixes the parameter type), in the unit of ``description``.
    description
        Meaning with the SI unit, e.g. ``'chamber inertia I1 [kg m^2]'``.
    low, high
        Inclusive range, in the parameter's unit (``low`` exclusive when ``low_exclusive``).
    low_exclusive
        Whether ``low`` itself is refused (e.g. an inertia must be > 0).
    read_only
        Whether the parameter cannot change after start.

    Returns
    -------
    _V
        The value the node starts with (default or override), of the default's type.

    Raises
    ------
    ParameterError
        The override has the wrong type, is not finite or is out of range.
    """
    desc = ParameterDescriptor(description=description, read_only=read_only)
    if isinstance(default, bool):
        pass
    elif isinstance(default, int) and (low is not None or high is not None):
        desc.integer_range = [
            IntegerRange(
                from_value=int(low if low is not None else -(2**63)),
                to_value=int(high if high is not None else 2**63 - 1),
                step=1,
            )
        ]
    elif isinstance(default, float) and (low is not None or high is not None):
        desc.floating_point_range = [
            FloatingPointRange(
                from_value=float(low if low is not None else -math.inf),
                to_value=float(high if high is not None else math.inf),
                step=0.0,
            )
        ]
    try:
        if isinstance(default, list):
            value = cast(_V, _declare_strings(node, name, default, desc))
        else:
            value = cast(_V, node.declare_parameter(name, default, desc).value)
    except InvalidParameterValueException as exc:
        raise ParameterError(
            f'parameter {name!r} ({description}): value out of range [{low}, {high}]: {exc}'
        ) from exc
    except InvalidParameterTypeException as exc:
        found = re.search(r"to '(.*)' of type '(\w+)'", str(exc))
        given = f'{found.group(1)!r} ({found.group(2).lower()})' if found else str(exc)
        raise ParameterError(
            f'parameter {name!r} ({description}) must be of type {type(default).__name__}, '
            f'got {given}'
        ) from None
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(float(value)):
            raise ParameterError(f'parameter {name!r} ({description}) must be finite, got {value}')
        if low is not None and (value < low or (low_exclusive and value == low)):
            rel = '>' if low_exclusive else '>='
            raise ParameterError(
                f'parameter {name!r} ({description}) must be {rel} {low}, got {value}'
            )
        if high is not None and value > high:
            raise ParameterError(
                f'parameter {name!r} ({description}) must be <= {high}, got {value}'
            )
    return value


def _declare_strings(
    node: Node, name: str, default: list[str], desc: ParameterDescriptor
) -> list[str]:
    """Declare a list-of-strings parameter (type STRING_ARRAY) and return its value.

    An empty list carries no element type: rclpy would declare ``[]`` as a byte array
    (and then refuse every list of strings), and a parameter file's ``[]`` reaches the
    node as a value without a type. The parameter is therefore declared by its type
    alone; when it has no value then (no override, or ``[]`` in a parameter file) it
    is set to ``default``, and ``desc.read_only`` applies from then on.

    Parameters
    ----------
    node
        The node that owns the parameter.
    name
        Parameter name.
    default
        The value when none is given (``[]`` in a parameter file also gives it).
    desc
        The descriptor (description, read_only).

    Returns
    -------
    list of str
        The value the node starts with.

    Raises
    ------
    ParameterError
        The default cannot be set.
    """
    writable = ParameterDescriptor(description=desc.description, read_only=False)
    param = node.declare_parameter(name, Parameter.Type.STRING_ARRAY, writable)
    if param.type_ == Parameter.Type.NOT_SET:
        (result,) = node.set_parameters([Parameter(name, Parameter.Type.STRING_ARRAY, default)])
        if not result.successful:
            raise ParameterError(f'parameter {name!r}: cannot set {default!r}: {result.reason}')
    if desc.read_only:
        final = ParameterDescriptor(
            description=desc.description, read_only=True, type=writable.type
        )
        node.set_descriptor(name, final)
    return [str(v) for v in node.get_parameter(name).value]


def declare_spec(node: Node, spec: ParamSpec) -> DeclaredValue:
    """Declare the parameter ``spec`` describes and return its checked value.

    The descriptor carries ``spec.label`` (description with the unit), the
    inclusive range (``FloatingPointRange``/``IntegerRange``) and ``read_only``;
    a string list is returned as a list.

    Raises
    ------
    ParameterError
        The value given for the parameter violates the spec.
    """
    default: DeclaredValue
    if spec.type == 'float':
        default = float(spec.default)  # type: ignore[arg-type]
    elif spec.type == 'str_list':
        default = list(spec.default)  # type: ignore[arg-type]
    else:
        default = spec.default  # type: ignore[assignment]
    value = declare(
        node,
        spec.name,
        default,
        spec.label,
        low=spec.lower,
        high=spec.upper,
        read_only=spec.read_only,
    )
    problem = spec.violation(value)
    if problem:
        raise ParameterError(f'parameter {spec.name!r} ({spec.label}) {problem}')
    return value


class DeclaredParams(Mapping[str, DeclaredValue]):
    """The checked values of a node's declared parameters, read with their type.

    A read-only mapping name -> value whose typed getters (:meth:`number`,
    :meth:`integer`, :meth:`text`, :meth:`flag`, :meth:`strings`) narrow the value
    and name the parameter when its type is not the one the node expects.
    """

    def __init__(self, values: Mapping[str, DeclaredValue]) -> None:
        self._values = dict(values)

    def __getitem__(self, name: str) -> DeclaredValue:
        """Return the value of parameter ``name``."""
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        """Iterate over the parameter names."""
        return iter(self._values)

    def __len__(self) -> int:
        """Return the number of parameters."""
        return len(self._values)

    def _typed(self, name: str, kinds: tuple[type, ...], what: str) -> DeclaredValue:
        value = self._values[name]
        if isinstance(value, bool) and bool not in kinds:
            raise ParameterError(f'parameter {name!r} is {value!r}, expected {what}')
        if not isinstance(value, kinds):
            raise ParameterError(f'parameter {name!r} is {value!r}, expected {what}')
        return value

    def number(self, name: str) -> float:
        """Return parameter ``name`` as a float (an integer value is widened)."""
        return float(cast(float, self._typed(name, (float, int), 'a number')))

    def integer(self, name: str) -> int:
        """Return parameter ``name`` as an integer."""
        return cast(int, self._typed(name, (int,), 'an integer'))

    def text(self, name: str) -> str:
        """Return parameter ``name`` as a string."""
        return cast(str, self._typed(name, (str,), 'a string'))

    def flag(self, name: str) -> bool:
        """Return parameter ``name`` as a boolean."""
        return cast(bool, self._typed(name, (bool,), 'true or false'))

    def numbers(self, names: Iterable[str]) -> dict[str, float]:
        """Return the parameters ``names`` as floats, by name."""
        return {name: self.number(name) for name in names}

    def strings(self, name: str) -> list[str]:
        """Return parameter ``name`` as a list of strings."""
        return list(cast(list[str], self._typed(name, (list,), 'a list of strings')))


def declare_specs(node: Node, specs: Iterable[ParamSpec]) -> DeclaredParams:
    """Declare every parameter of ``specs``.

    Returns
    -------
    DeclaredParams
        Parameter name -> checked value, with typed getters.
    """
    return DeclaredParams({s.name: declare_spec(node, s) for s in specs})
