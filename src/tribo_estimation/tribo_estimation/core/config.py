"""RIG.yaml loader: rig, friction law, drive profile, extensions and noise.

Top-level keys (SI): ``I1, K1, C1, I2, K2, C2, F_N, R, mu0, mu_inf, k, nominal_speed``
(kg m^2, N m s/rad, N m/rad, kg m^2, N m s/rad, N m/rad, N, m, -, -, s/rad, rad/s).
Optional: ``ramp_time`` [s], ``noise_torque`` [N m], ``noise_accel`` [rad/s^2],
``noise_speed`` [rad/s] (absent: 0), ``effects`` (mapping of :class:`model.Extensions`
fields). Units, bounds and Tab. 1 defaults: :data:`tribo_estimation.core.rigspec.RIG_SPEC`.
A missing or unknown key, a non-numeric or out-of-range value raises an
:class:`EstimationError` naming the key and the file.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from tribo_common.yamlio import check_keys, load_yaml
from tribo_estimation.core.model import DriveProfile, Extensions, FrictionLaw, RigParams
from tribo_estimation.core.rigspec import RIG_OPTIONAL, RIG_REQUIRED, RIG_SPEC
from tribo_estimation.core.simulate import NoiseSpec
from tribo_estimation.errors import (
    ConfigFileError,
    InvalidParameterError,
    MissingKeyError,
)

#: Keys, units and plausible ranges: the one rig spec (:mod:`tribo_estimation.core.rigspec`).
REQUIRED_KEYS: tuple[str, ...] = RIG_REQUIRED
OPTIONAL_KEYS: tuple[str, ...] = (*RIG_OPTIONAL, 'effects')

#: Plausibility ranges (inclusive) that catch unit mistakes: key -> (low, high, unit).
RANGES: dict[str, tuple[float, float, str]] = {
    s.name: (float(s.lower), float(s.upper), s.unit)
    for s in RIG_SPEC.values()
    if s.lower is not None and s.upper is not None
}


@dataclass(frozen=True)
class RigConfig:
    """Everything a RIG.yaml describes."""

    rig: RigParams
    friction: FrictionLaw
    drive: DriveProfile
    extensions: Extensions
    noise: NoiseSpec
    source: str = '<dict>'


def _number(data: Mapping[str, object], key: str, source: str) -> float:
    val = data[key]
    if isinstance(val, bool) or not isinstance(val, int | float):
        raise InvalidParameterError(f'{source}: key {key!r} must be a number, got {val!r}')
    x = float(val)
    if not math.isfinite(x):
        raise InvalidParameterError(f'{source}: key {key!r} must be finite, got {val!r}')
    spec = RIG_SPEC.get(key)
    problem = spec.violation(x) if spec is not None else None
    if spec is not None and problem:
        raise InvalidParameterError(f'{source}: key {key!r} {problem} ({spec.description})')
    return x


def rig_config_from_dict(data: object, source: str = '<dict>') -> RigConfig:
    """Build a :class:`RigConfig` from a parsed RIG.yaml mapping."""
    if not isinstance(data, Mapping):
        raise ConfigFileError(f'{source}: expected a mapping of keys, got {type(data).__name__}')
    for key in REQUIRED_KEYS:
        if key not in data:
            raise MissingKeyError(f'{source}: missing key {key!r}')
    check_keys(data, (*REQUIRED_KEYS, *OPTIONAL_KEYS), source, InvalidParameterError)
    v = {k: _number(data, k, source) for k in (*REQUIRED_KEYS, *OPTIONAL_KEYS[:4]) if k in data}
    effects = data.get('effects') or {}
    if not isinstance(effects, Mapping):
        raise InvalidParameterError(f'{source}: key "effects" must be a mapping')
    names = {f.name for f in dataclasses.fields(Extensions)}
    check_keys(effects, names, source, InvalidParameterError, 'effect')
    try:
        eff = {str(k): _number(effects, k, f'{source}: effects') for k in effects}
        rig = RigParams.from_mapping(v)
        friction = FrictionLaw(v['mu0'], v['mu_inf'], v['k'])
        drive = DriveProfile(v['nominal_speed'], v.get('ramp_time', 0.0))
        ext = Extensions(**eff)
        noise = NoiseSpec(
            v.get('noise_torque', 0.0), v.get('noise_accel', 0.0), v.get('noise_speed', 0.0)
        )
    except InvalidParameterError as exc:
        raise InvalidParameterError(f'{source}: {exc}') from exc
    return RigConfig(rig, friction, drive, ext, noise, source)


def load_rig_config(path: str | Path) -> RigConfig:
    """Read a RIG.yaml file (see the module docstring for the keys)."""
    p = Path(path)
    data = load_yaml(p, ConfigFileError, 'rig config')
    if data is None:
        raise ConfigFileError(f'{p}: empty rig config')
    return rig_config_from_dict(data, str(p))
