"""Form ``torque_offset_thermal`` of the family ``torque_offset`` (measurement side).

A saturating (thermal) zero drift of the torsion-moment channel:
``M_t += D*(1 - exp(-t/tau))`` (D [N m], tau [s], t the record's time), through the
family's measurement transform (:class:`.torque_offset.SensorOffset`).
"""

from __future__ import annotations

from ..candidates import SUGGEST_LONGER, Candidate, ParamSpec, register

CANDIDATE = register(
    Candidate(
        'torque_offset_thermal',
        'saturating (thermal) zero drift of the torsion-moment channel (measurement side): '
        'M_t += D*(1 - exp(-t/tau))',
        (
            ParamSpec('torque_thermal', 'N m', -1e3, 1e3, 0.01, 0.0),
            ParamSpec('torque_thermal_tau', 's', 0.05, 1e4, 1.0, 3.0, log=True),
        ),
        'test_time',
        lambda _ctx: [{'torque_thermal_tau': tau} for tau in (0.3, 1.0, 10.0)],
        demo_effects={'torque_thermal': 0.5, 'torque_thermal_tau': 3.0},
        equation='`M_t,meas = M_t + D*(1 - exp(-t/tau))` (D = `torque_thermal`, '
        'tau = `torque_thermal_tau`)',
        suggest=SUGGEST_LONGER,
        profile='torque_thermal_tau',
        family='torque_offset',
    )
)
