"""NVCT.yaml: everything needed to turn detector counts into wear (SI inside).

Keys (units in the key names where they are not SI):

* ``nuclide`` (e.g. ``Co-56``) or ``half_life_days``
* ``days_since_reference``: days from the depth profile's reference date to test start
* ``k_det``: detector coefficient [Bq per count/s] (mixed circuit); optional ``k_det_rel_se``
* ``background_cps`` [1/s] (optional ``background_se_cps``), or a pre-test measurement
  ``background_counts`` + ``background_live_time_s`` (takes precedence)
* ``depth_profile``: layer-removal CSV, path relative to the YAML; optional
  ``profile_model`` (``auto`` = chosen by AIC, ``erfc``, ``exponential``, ``ramp``,
  ``piecewise``), ``profile_knot_spacing_um`` (fixes the piecewise model's bin width),
  ``profile_bootstrap_replicas`` (200; 0 = no profile SE) and ``profile_bootstrap_seed``
* ``pin_area_um2``: activated face of the reference pin [um^2]
* ``tagged_area_um2``: activated (tagged) area A_I of the specimen [um^2]
* ``contact_area_um2`` [um^2], or ``contact`` (ring/liner geometry, see
  :class:`~tribo_nvct.core.contact.RingLinerGeometry`: ``ring_radius_m``,
  ``liner_radius_m``, ``ring_height_m``, optional ``crown_radius_m``,
  ``ring: {E_Pa, nu}``, ``liner: {E_Pa, nu}``) evaluated at ``load_N``
* ``load_N`` [N], ``stroke_m`` [m], ``frequency_hz`` [Hz]
* optional: ``sliding_distance`` (``paper`` = stroke*frequency*duration, default,
  or ``astm_g133`` = 2*stroke*frequency*duration), ``circulation_time_s`` and
  ``oil_circuit`` (``transit_fraction``, ``first_width_fraction``,
  ``dispersion_fraction``, ``deposition_rate_per_s``, ``mixing_tolerance``),
  ``temperature_K`` and ``label`` (metadata for campaign plots, Fig. 12),
  ``window_min`` ([120, 180]: progressive-rate window, paper 3.5).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tribo_common.yamlio import check_keys, load_yaml
from tribo_nvct.core.circuit import OilCircuit
from tribo_nvct.core.contact import ContactResult, Material, RingLinerGeometry
from tribo_nvct.core.counting import Background
from tribo_nvct.core.nuclides import SECONDS_PER_DAY, Nuclide, custom_nuclide, get_nuclide
from tribo_nvct.core.profile import (
    BOOTSTRAP_REPLICAS,
    BOOTSTRAP_SEED,
    PROFILE_MODELS,
    DepthProfile,
    fit_depth_profile,
    read_layer_removal_csv,
)
from tribo_nvct.errors import ContactError, NvctConfigError

UM = 1e-6
UM2 = 1e-12

#: Top-level keys of NVCT.yaml (anything else is refused with the closest match).
KNOWN_KEYS: frozenset[str] = frozenset(
    {
        'nuclide', 'half_life_days', 'days_since_reference', 'k_det', 'k_det_rel_se',
        'background_cps', 'background_se_cps', 'background_counts', 'background_live_time_s',
        'depth_profile', 'profile_knot_spacing_um', 'pin_area_um2', 'tagged_area_um2',
        'contact_area_um2', 'contact', 'load_N', 'stroke_m', 'frequency_hz',
        'sliding_distance', 'circulation_time_s', 'oil_circuit', 'temperature_K', 'label',
        'window_min', 'profile_model', 'profile_bootstrap_replicas', 'profile_bootstrap_seed',
    }
)  # fmt: skip
CONTACT_KEYS = frozenset(
    {'ring_radius_m', 'liner_radius_m', 'ring_height_m', 'crown_radius_m', 'ring', 'liner'}
)
MATERIAL_KEYS = frozenset({'E_Pa', 'nu'})
CIRCUIT_KEYS = frozenset(
    {
        'transit_fraction',
        'first_width_fraction',
        'dispersion_fraction',
        'deposition_rate_per_s',
        'mixing_tolerance',
    }
)

#: Smallest value of a key that must be > 0 (smaller ones underflow in products such
#: as the sliding distance stroke * frequency * time, Equ. 10).
TINY = 1e-30

#: Largest plausible value of a key (in the key's own unit): larger values are
#: unit mistakes or typos (e.g. ``load_N: 1e308``) and are refused.
UPPER: dict[str, float] = {
    'half_life_days': 1e7,
    'days_since_reference': 1e5,
    'k_det': 1e12,
    'k_det_rel_se': 1.0,
    'background_cps': 1e9,
    'background_se_cps': 1e9,
    'background_counts': 1e15,
    'background_live_time_s': 1e9,
    'profile_knot_spacing_um': 1e4,
    'profile_bootstrap_replicas': 1e5,
    'profile_bootstrap_seed': 2.0**63,
    'pin_area_um2': 1e12,
    'tagged_area_um2': 1e12,
    'contact_area_um2': 1e12,
    'load_N': 1e6,
    'stroke_m': 1.0,
    'frequency_hz': 1e4,
    'circulation_time_s': 1e6,
    'temperature_K': 2000.0,
    'ring_radius_m': 10.0,
    'liner_radius_m': 10.0,
    'ring_height_m': 1.0,
    'crown_radius_m': 100.0,
    'E_Pa': 1e13,
    'nu': 0.5,
    'oil_circuit.transit_fraction': 1.0,
    'oil_circuit.first_width_fraction': 10.0,
    'oil_circuit.dispersion_fraction': 10.0,
    'oil_circuit.deposition_rate_per_s': 1e3,
    'oil_circuit.mixing_tolerance': 1.0,
}

#: Most half-lives between the depth profile's reference date and the test (the
#: activity is then 2**-60 = 1e-18 of the reference: nothing left to count).
MAX_HALF_LIVES = 60.0

SLIDING_CONVENTIONS = {
    'paper': 'paper Equ. 10: d_s = stroke * frequency * duration',
    'astm_g133': 'ASTM G133: d_s = 2 * stroke * frequency * duration',
}


@dataclass(frozen=True, eq=False)
class NvctConfig:
    """Validated nVCT configuration (SI units).

    areas in m^2, lengths in m, times in s, activities in Bq.
    """

    nuclide: Nuclide
    reference_offset_s: float
    k_det: float
    k_det_rel_se: float
    background: Background
    profile: DepthProfile
    pin_area: float
    tagged_area: float
    contact_area: float
    load: float
    stroke: float
    frequency: float
    sliding_convention: str = 'paper'
    circuit: OilCircuit | None = None
    contact: ContactResult | None = None
    temperature_K: float = math.nan
    label: str = ''
    window_s: tuple[float, float] = (120 * 60.0, 180 * 60.0)
    fingerprint: str = ''
    source: str = '<config>'
    raw: dict[str, Any] = field(default_factory=dict)

    @property
    def k_A(self) -> float:
        """k_A = contact area / tagged area [-] (paper Equ. 9)."""
        return self.contact_area / self.tagged_area

    @property
    def decay_constant(self) -> float:
        """Return the decay constant lambda [1/s] of the nuclide."""
        return self.nuclide.decay_constant

    def sliding_distance(self, duration_s: float) -> float:
        """d_s [m] after ``duration_s`` [s] under the configured convention (paper Equ. 10)."""
        per_cycle = 2.0 if self.sliding_convention == 'astm_g133' else 1.0
        return per_cycle * self.stroke * self.frequency * duration_s

    @property
    def tagged_activity(self) -> float:
        """Activity of the tagged layer at the reference date, A_I * F(max depth) [Bq]."""
        return self.tagged_area * self.profile.total


def _num(
    d: Mapping[str, object], key: str, src: str, *, lo: float = 0.0, strict: bool = True
) -> float:
    if key not in d:
        raise NvctConfigError(f'{src}: missing key {key!r}')
    return _value(d[key], key, src, lo=lo, strict=strict)


def _value(v: object, key: str, src: str, *, lo: float = 0.0, strict: bool = True) -> float:
    if isinstance(v, str):
        # PyYAML (YAML 1.1) reads 2.0e6 without an exponent sign as a string.
        try:
            v = float(v)
        except ValueError:
            raise NvctConfigError(f'{src}: {key} must be a number, got {v!r}') from None
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise NvctConfigError(f'{src}: {key} must be a number, got {v!r}')
    x = float(v)
    if not math.isfinite(x) or (x <= lo if strict else x < lo):
        rel = '>' if strict else '>='
        raise NvctConfigError(f'{src}: {key} must be finite and {rel} {lo:g}, got {v!r}')
    if strict and lo == 0.0 and x < TINY:
        raise NvctConfigError(f'{src}: {key} = {x:g} is implausibly small (< {TINY:g})')
    hi = UPPER.get(key)
    if hi is not None and x > hi:
        raise NvctConfigError(f'{src}: {key} = {x:g} exceeds the plausible maximum {hi:g}')
    return x


def _material(d: object, name: str, src: str) -> Material:
    if not isinstance(d, dict):
        raise NvctConfigError(f'{src}: contact.{name} must be a mapping with E_Pa and nu')
    check_keys(d, MATERIAL_KEYS, f'{src}: contact.{name}', NvctConfigError)
    try:
        return Material(_num(d, 'E_Pa', src), _value(d.get('nu'), 'nu', src, lo=-1.0))
    except ContactError as exc:
        raise NvctConfigError(f'{src}: contact.{name}: {exc}') from None


def geometry_from_dict(d: Mapping[str, object], src: str = '<contact>') -> RingLinerGeometry:
    """Ring/liner geometry from the ``contact`` mapping of NVCT.yaml."""
    check_keys(d, CONTACT_KEYS, f'{src}: contact', NvctConfigError)
    crown = d.get('crown_radius_m')
    return RingLinerGeometry(
        ring_radius=_num(d, 'ring_radius_m', src),
        liner_radius=_num(d, 'liner_radius_m', src),
        ring_height=_num(d, 'ring_height_m', src),
        ring=_material(d.get('ring'), 'ring', src),
        liner=_material(d.get('liner'), 'liner', src),
        crown_radius=None if crown is None else _value(crown, 'crown_radius_m', src),
    )


def config_from_dict(raw: object, base_dir: Path, source: str = '<config>') -> NvctConfig:
    """Build and validate an :class:`NvctConfig` from the YAML mapping."""
    src = source
    if not isinstance(raw, dict):
        raise NvctConfigError(f'{src}: top level must be a mapping')
    check_keys(raw, KNOWN_KEYS, src, NvctConfigError)
    if 'half_life_days' in raw:
        nuc = custom_nuclide(_num(raw, 'half_life_days', src), str(raw.get('nuclide', 'custom')))
    elif 'nuclide' in raw:
        nuc = get_nuclide(str(raw['nuclide']))
    else:
        raise NvctConfigError(f'{src}: missing key nuclide (or half_life_days)')
    days = _num(raw, 'days_since_reference', src, strict=False)
    if days > MAX_HALF_LIVES * nuc.half_life_days:
        raise NvctConfigError(
            f'{src}: days_since_reference = {days:g} d is more than {MAX_HALF_LIVES:g} '
            f'half-lives of {nuc.name} ({nuc.half_life_days:g} d): nothing left to measure'
        )
    k_det = _num(raw, 'k_det', src)
    k_det_rel_se = _value(raw.get('k_det_rel_se', 0.0), 'k_det_rel_se', src, strict=False)
    if 'background_counts' in raw or 'background_live_time_s' in raw:
        counts = _num(raw, 'background_counts', src, strict=False)
        if counts != int(counts):
            raise NvctConfigError(f'{src}: background_counts must be an integer, got {counts!r}')
        bg = Background.measured(int(counts), _num(raw, 'background_live_time_s', src))
    else:
        bg = Background(
            _num(raw, 'background_cps', src, strict=False),
            _value(raw.get('background_se_cps', 0.0), 'background_se_cps', src, strict=False),
        )
    if 'depth_profile' not in raw:
        raise NvctConfigError(f'{src}: missing key depth_profile')
    prof_path = Path(str(raw['depth_profile']))
    if not prof_path.is_absolute():
        prof_path = base_dir / prof_path
    pin_area = _num(raw, 'pin_area_um2', src) * UM2
    knot = raw.get('profile_knot_spacing_um')
    knot_m = None if knot is None else _value(knot, 'profile_knot_spacing_um', src) * UM
    prof_model = str(raw.get('profile_model', 'auto'))
    if prof_model not in PROFILE_MODELS:
        raise NvctConfigError(
            f'{src}: profile_model must be one of {list(PROFILE_MODELS)}, got {prof_model!r}'
        )
    n_boot = _value(
        raw.get('profile_bootstrap_replicas', BOOTSTRAP_REPLICAS),
        'profile_bootstrap_replicas',
        src,
        strict=False,
    )
    boot_seed = _value(
        raw.get('profile_bootstrap_seed', BOOTSTRAP_SEED),
        'profile_bootstrap_seed',
        src,
        strict=False,
    )
    profile = fit_depth_profile(
        read_layer_removal_csv(prof_path),
        pin_area,
        knot_m,
        model=prof_model,
        bootstrap_replicas=int(n_boot),
        seed=int(boot_seed),
    )
    tagged = _num(raw, 'tagged_area_um2', src) * UM2
    load = _num(raw, 'load_N', src)
    contact_res: ContactResult | None = None
    if 'contact_area_um2' in raw:
        contact_area = _num(raw, 'contact_area_um2', src) * UM2
    elif 'contact' in raw:
        c = raw['contact']
        if not isinstance(c, dict):
            raise NvctConfigError(f'{src}: contact must be a mapping (ring/liner geometry)')
        try:
            contact_res = geometry_from_dict(c, src).contact(load)
        except ContactError as exc:
            raise NvctConfigError(f'{src}: contact: {exc}') from None
        contact_area = contact_res.area
    else:
        raise NvctConfigError(f'{src}: missing key contact_area_um2 (or contact geometry)')
    if tagged > contact_area * (1.0 + 1e-9):
        raise NvctConfigError(
            f'{src}: tagged area {tagged / UM2:.4g} um^2 exceeds the contact area '
            f'{contact_area / UM2:.4g} um^2: the tagged patch must lie inside the contact '
            '(Equ. 9 assumes the whole tagged area wears)'
        )
    conv = str(raw.get('sliding_distance', 'paper')).lower()
    if conv not in SLIDING_CONVENTIONS:
        raise NvctConfigError(
            f'{src}: sliding_distance must be one of {sorted(SLIDING_CONVENTIONS)}, got {conv!r}'
        )
    circuit = None
    if 'circulation_time_s' in raw:
        extra = raw.get('oil_circuit') or {}
        if not isinstance(extra, dict):
            raise NvctConfigError(f'{src}: oil_circuit must be a mapping')
        check_keys(extra, CIRCUIT_KEYS, f'{src}: oil_circuit', NvctConfigError)
        kw: dict[str, float] = {}
        for key, attr in (
            ('transit_fraction', 'transit_fraction'),
            ('first_width_fraction', 'first_width_fraction'),
            ('dispersion_fraction', 'dispersion_fraction'),
            ('deposition_rate_per_s', 'deposition_rate'),
            ('mixing_tolerance', 'mixing_tolerance'),
        ):
            if key in extra:
                kw[attr] = _value(extra[key], f'oil_circuit.{key}', src, strict=False)
        circuit = OilCircuit(_num(raw, 'circulation_time_s', src), **kw)
    window = raw.get('window_min', [120.0, 180.0])
    if (
        not isinstance(window, list | tuple)
        or len(window) != 2
        or not all(isinstance(w, int | float) for w in window)
        or not 0.0 <= float(window[0]) < float(window[1])
    ):
        raise NvctConfigError(f'{src}: window_min must be [start, end] minutes, got {window!r}')
    temp = raw.get('temperature_K')
    fp_src = json.dumps(raw, sort_keys=True, default=str) + prof_path.read_text(encoding='utf-8')
    return NvctConfig(
        nuclide=nuc,
        reference_offset_s=days * SECONDS_PER_DAY,
        k_det=k_det,
        k_det_rel_se=k_det_rel_se,
        background=bg,
        profile=profile,
        pin_area=pin_area,
        tagged_area=tagged,
        contact_area=contact_area,
        load=load,
        stroke=_num(raw, 'stroke_m', src),
        frequency=_num(raw, 'frequency_hz', src),
        sliding_convention=conv,
        circuit=circuit,
        contact=contact_res,
        temperature_K=math.nan if temp is None else _value(temp, 'temperature_K', src),
        label=str(raw.get('label', Path(source).stem)),
        window_s=(float(window[0]) * 60.0, float(window[1]) * 60.0),
        fingerprint=hashlib.sha256(fp_src.encode()).hexdigest()[:16],
        source=source,
        raw=dict(raw),
    )


def load_config(path: str | Path) -> NvctConfig:
    """Read and validate NVCT.yaml."""
    p = Path(path)
    raw = load_yaml(p, NvctConfigError, 'nVCT config')
    return config_from_dict(raw, p.parent, str(p))
