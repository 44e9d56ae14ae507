"""Compiled (numba) equations of motion and event-accurate stick/slip integrator.

This module is the ONE place where the rig's equations of motion are written
(paper Equ. 1-3, 6, 8 as corrected in ``docs/physics.md``). Everything else
(:mod:`.model` Python wrappers, :mod:`.simulate`, :mod:`.reference`, the block fits,
the simulated rig driver, the discrepancy workflow) calls these functions.

Symbols (paper naming: K = viscous damping, C = torsional stiffness):

- body 1 = test chamber (angle ``phi1`` [rad], speed ``w1`` [rad/s]),
- body 2 = drive shaft (``phi2``, ``w2``), driven through the belt by ``phi0(t)``, ``w0(t)``,
- slip speed ``v = w2 - w1`` [rad/s]; friction moment ``+M`` on the chamber, ``-M`` on the shaft.

Equations::

    I1*w1' = -K1*w1 - C1*phi1 - M_b(w1) + M                      (1)
    I2*w2' = -K2*(w2 - w0) - C2*(phi2 - phi0) - M                (2)
    sliding:  M = F_N*R*dir*mu + viscous*v                       (3), (8)
    sticking: w1 = w2 = w, M = M_stick                           (6)

with ``M_b`` the (regularised) bearing Coulomb moment of the extension set
(zero in the paper's model). ``M_stick`` generalises Equ. 6 to any external
moments ``Q1`` (chamber) and ``Q2`` (shaft): ``M_stick = (I1*Q2 - I2*Q1)/(I1 + I2)``.

A package with one job per module (``from tribo_estimation.core import kernel as kn``
gives every name):

- :mod:`.layout`: the flat vectors' indices and sizes (``P_*``/``NP``, ``OUT_*``/``N_CH``)
  and the state table ``STATE_SLOTS`` from which ``S_*``/``NS`` and ``Y_*``/``NY``
  derive (and how an effect adds a state variable),
- :mod:`.equations`: drive, friction law and right-hand side (Equ. 1-3, 6, 8), the
  effects' state rates (``effect_rates``) and their restart at breakaway,
- :mod:`.state`: the integrated state ``y`` as a tuple of ``NY`` floats (the only
  tuple builders: read/write ``s``, set one entry, the RK4 stage sums),
- :mod:`.step`: the RK4 step and its step-size control,
- :mod:`.events`: switching events and their location,
- :mod:`.integrate`: the integrator (:func:`integrate`, :func:`integrate_logged`),
- :mod:`.cachecheck`: drops the package's numba caches when ``layout.py`` or a source
  holding compiled code changed (both are compiled into functions of other files).

Flat-array interface (no Python objects, callable from other ``@njit`` code):

- parameter vector ``p`` (length :data:`NP`, indices ``P_*``),
- state vector ``s`` (length :data:`NS`, indices ``S_*``), updated in place,
- :func:`integrate` ``(p, s, n_out, dt, n_sub, out) -> n_events`` writes
  :data:`N_CH` output channels (indices ``OUT_*``) for ``n_out`` samples.

Integration: classical RK4 at a fixed step ``h = dt/n_sub`` aligned to the
output instants. Switching events (slip end ``v = 0``, slip-speed peak for the
paper's deceleration rule, breakaway ``|M_stick| = F_N*R*mu_s``) are detected
per step and located by Illinois (regula falsi) iteration on the RK4 solution
restarted from the step start, to a time tolerance of ``EVENT_TOL`` times the
step; the step is then restarted from the event. Outputs are therefore sampled
at the exact instants ``t_base + i*dt``.
"""

from __future__ import annotations

# importing .cachecheck first drops stale numba caches before any compiled function loads
from .cachecheck import purge_stale_caches
from .equations import (
    bearing_moment,
    breakaway_state,
    chamber_moment,
    derivatives,
    drive_angle,
    drive_angle_array,
    drive_speed,
    drive_speed_array,
    effect_rates,
    friction_coefficient,
    friction_coefficient_array,
    friction_levels,
    piece_angle,
    shaft_moment,
    slip_friction_moment,
    static_coefficient,
    stick_moment,
)
from .events import EV_BREAKAWAY, EV_NONE, EV_PEAK, EV_SLIP_END, EVENT_TOL
from .integrate import integrate, integrate_logged
from .layout import (
    BEARING_REG_SPEED,
    D_M,
    D_ZERO,
    N_CH,
    ND,
    NP,
    NS,
    NY,
    OUT_ACCEL,
    OUT_FRICTION,
    OUT_SLIP,
    OUT_SPEED,
    OUT_STICK,
    OUT_TORSION,
    OUT_W1,
    P_BEARING,
    P_BEARING_REG,
    P_C1,
    P_C2,
    P_DRIFT_MU0,
    P_DRIFT_MUINF,
    P_FN,
    P_I1,
    P_I2,
    P_K,
    P_K1,
    P_K2,
    P_LAG_TAU,
    P_MU0,
    P_MUINF,
    P_R,
    P_RAMP,
    P_RIP2_AMP,
    P_RIP2_PHASE,
    P_RIP_AMP,
    P_RIP_FREQ,
    P_RIP_PHASE,
    P_RIPA2_PHASE,
    P_RIPA2_REL,
    P_RIPA_ANGLE0,
    P_RIPA_ORDER,
    P_RIPA_PHASE,
    P_RIPA_REL,
    P_SHAPE,
    P_ST_GAIN,
    P_ST_LOG,
    P_ST_TAU,
    P_T_DRIVE,
    P_VISC,
    P_W0,
    P_W0_COS,
    P_W0_OMEGA,
    P_W0_RATE,
    S_DIR,
    S_FINITE,
    S_LAG,
    S_PEAK,
    S_PHI1,
    S_PHI2,
    S_SENSOR,
    S_STUCK,
    S_T,
    S_TSTICK,
    S_VMAX,
    S_W1,
    S_W2,
    STATE_SLOTS,
    Y_LAG,
    Y_PHI1,
    Y_PHI2,
    Y_SLOTS,
    Y_W1,
    Y_W2,
    Y_ZERO,
    StateSlot,
    state_index,
    y_index,
)
from .step import STEP_RATE, slip_rate, substeps_for

__all__ = [
    'BEARING_REG_SPEED',
    'D_M',
    'D_ZERO',
    'EVENT_TOL',
    'EV_BREAKAWAY',
    'EV_NONE',
    'EV_PEAK',
    'EV_SLIP_END',
    'ND',
    'NP',
    'NS',
    'NY',
    'N_CH',
    'OUT_ACCEL',
    'OUT_FRICTION',
    'OUT_SLIP',
    'OUT_SPEED',
    'OUT_STICK',
    'OUT_TORSION',
    'OUT_W1',
    'P_BEARING',
    'P_BEARING_REG',
    'P_C1',
    'P_C2',
    'P_DRIFT_MU0',
    'P_DRIFT_MUINF',
    'P_FN',
    'P_I1',
    'P_I2',
    'P_K',
    'P_K1',
    'P_K2',
    'P_LAG_TAU',
    'P_MU0',
    'P_MUINF',
    'P_R',
    'P_RAMP',
    'P_RIP2_AMP',
    'P_RIP2_PHASE',
    'P_RIPA2_PHASE',
    'P_RIPA2_REL',
    'P_RIPA_ANGLE0',
    'P_RIPA_ORDER',
    'P_RIPA_PHASE',
    'P_RIPA_REL',
    'P_RIP_AMP',
    'P_RIP_FREQ',
    'P_RIP_PHASE',
    'P_SHAPE',
    'P_ST_GAIN',
    'P_ST_LOG',
    'P_ST_TAU',
    'P_T_DRIVE',
    'P_VISC',
    'P_W0',
    'P_W0_COS',
    'P_W0_OMEGA',
    'P_W0_RATE',
    'STATE_SLOTS',
    'STEP_RATE',
    'S_DIR',
    'S_FINITE',
    'S_LAG',
    'S_PEAK',
    'S_PHI1',
    'S_PHI2',
    'S_SENSOR',
    'S_STUCK',
    'S_T',
    'S_TSTICK',
    'S_VMAX',
    'S_W1',
    'S_W2',
    'Y_LAG',
    'Y_PHI1',
    'Y_PHI2',
    'Y_SLOTS',
    'Y_W1',
    'Y_W2',
    'Y_ZERO',
    'StateSlot',
    'bearing_moment',
    'breakaway_state',
    'chamber_moment',
    'derivatives',
    'drive_angle',
    'drive_angle_array',
    'drive_speed',
    'drive_speed_array',
    'effect_rates',
    'friction_coefficient',
    'friction_coefficient_array',
    'friction_levels',
    'integrate',
    'integrate_logged',
    'piece_angle',
    'purge_stale_caches',
    'shaft_moment',
    'slip_friction_moment',
    'slip_rate',
    'state_index',
    'static_coefficient',
    'stick_moment',
    'substeps_for',
    'y_index',
]
