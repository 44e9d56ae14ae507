"""The rig's parameters, once: Tab. 1 defaults, units, plausible bounds (no rclpy).

Every user of a rig parameter reads this table: :meth:`RigParams.tab1
<tribo_estimation.core.model.RigParams.tab1>`, the RIG.yaml loader
(:mod:`tribo_estimation.core.config`), the nodes that take the RIG.yaml names
as ROS parameters (``sim_rig``, ``friction_estimator``, ``model_monitor``,
``live_bridge``) and the parameter table in ``docs/parameters.md``.

Where: ``tribo_estimation.core`` owns the rig model (Equ. 1-8); ``tribo_drivers``
(the simulated rig) and ``tribo_bringup`` (the bridge) already depend on
``tribo_estimation`` in their package.xml, so they reach this module without a
new dependency or an import circle. The generic :class:`ParamSpec` type is in
:mod:`tribo_common.paramspec` (below every package, standard library only).

Bounds are plausibility limits that catch unit mistakes (rpm for rad/s, kN for
N, mm for m), inclusive; strictly positive quantities (inertias, stiffnesses,
radius) have a small positive lower bound. ``F_N = 0`` is allowed (open
contact: free decay); the friction estimator and the model monitor refuse it
themselves (no friction to fit).
"""

from __future__ import annotations

from tribo_common.paramspec import ParamSpec, spec_table

#: Every rig parameter (the RIG.yaml top-level numbers), Tab. 1 defaults.
RIG_SPEC: dict[str, ParamSpec] = spec_table(
    (
        ParamSpec('I1', 'kg m^2', 0.0109, 1e-6, 100.0, 'chamber inertia I1 (Tab. 1)'),
        ParamSpec('K1', 'N m s/rad', 0.04034, 0.0, 1e4, 'chamber viscous damping K1 (Tab. 1)'),
        ParamSpec('C1', 'N m/rad', 2338.6, 1e-3, 1e8, 'torsion element stiffness C1 (Tab. 1)'),
        ParamSpec('I2', 'kg m^2', 0.0315, 1e-6, 100.0, 'drive shaft inertia I2 (Tab. 1)'),
        ParamSpec('K2', 'N m s/rad', 4.0, 0.0, 1e4, 'drive viscous damping K2 (Tab. 1)'),
        ParamSpec('C2', 'N m/rad', 5975.0, 1e-3, 1e8, 'drive stiffness C2 (Tab. 1)'),
        ParamSpec(
            'F_N',
            'N',
            8000.0,
            0.0,
            1e6,
            'total normal force over all friction pairs F_N (0: contact open, free decay)',
        ),
        ParamSpec('R', 'm', 0.08, 1e-4, 10.0, 'effective friction radius R'),
        ParamSpec('mu0', '-', 0.13, 0.0, 2.0, 'static friction coefficient mu0 (Equ. 8)'),
        ParamSpec('mu_inf', '-', 0.10, 0.0, 2.0, 'high-speed friction coefficient mu_inf (Equ. 8)'),
        ParamSpec('k', 's/rad', 2.0, 0.0, 1e3, 'Stribeck decay constant k (Equ. 8)'),
        ParamSpec(
            'nominal_speed',
            'rad/s',
            3.14159,
            -100.0,
            100.0,
            'nominal drive speed w0, rad/s not rpm (30 rpm = 3.14159 rad/s)',
        ),
        ParamSpec('ramp_time', 's', 0.5, 0.0, 3600.0, 'linear start-up ramp of the drive speed'),
        ParamSpec('noise_torque', 'N m', 0.05, 0.0, 1e3, 'torsion moment noise, std per sample'),
        ParamSpec(
            'noise_accel',
            'rad/s^2',
            2.0,
            0.0,
            1e5,
            'chamber angular acceleration noise, std per sample',
        ),
        ParamSpec('noise_speed', 'rad/s', 0.005, 0.0, 100.0, 'shaft speed noise, std per sample'),
    )
)

#: Fields of :class:`tribo_estimation.core.model.RigParams` (Tab. 1 and contact).
RIG_FIELDS: tuple[str, ...] = ('I1', 'K1', 'C1', 'I2', 'K2', 'C2', 'F_N', 'R')

#: Keys every RIG.yaml must give.
RIG_REQUIRED: tuple[str, ...] = (*RIG_FIELDS, 'mu0', 'mu_inf', 'k', 'nominal_speed')

#: Numeric keys a RIG.yaml may give (absent: 0, i.e. no ramp, no noise).
RIG_OPTIONAL: tuple[str, ...] = ('ramp_time', 'noise_torque', 'noise_accel', 'noise_speed')

#: Rig parameters of the estimating nodes (the friction estimator, the model monitor).
ESTIMATOR_RIG_KEYS: tuple[str, ...] = (*RIG_REQUIRED, 'ramp_time')


def rig_specs(names: tuple[str, ...]) -> tuple[ParamSpec, ...]:
    """Return the specs of ``names`` (rig parameter names), in that order."""
    return tuple(RIG_SPEC[n] for n in names)


def tab1_value(name: str) -> float:
    """Tab. 1 (default) value of the rig parameter ``name`` in its SI unit."""
    return float(RIG_SPEC[name].default)  # type: ignore[arg-type]


__all__ = [
    'ESTIMATOR_RIG_KEYS',
    'RIG_FIELDS',
    'RIG_OPTIONAL',
    'RIG_REQUIRED',
    'RIG_SPEC',
    'rig_specs',
    'tab1_value',
]
