"""Layout of the kernel's flat vectors: parameters, state, outputs (one definition).

Every module that packs or reads a kernel vector (:mod:`..model`, :mod:`..simulate`,
:mod:`..shooting`, the block fits, the discrepancy fits) imports its indices from
here (through :mod:`tribo_estimation.core.kernel`); no index is written as a number
anywhere else.

- Parameter vector ``p`` (length :data:`NP`, indices ``P_*``): the rig (Tab. 1), the
  friction law (Equ. 8), the drive and the *extension slots* of the candidate
  effects (all zero = the paper's model). :func:`tribo_estimation.core.model.pack_params`
  fills it from ``RigParams``, ``FrictionLaw``, ``DriveProfile`` and ``Extensions``.
- State vector ``s`` (length :data:`NS`, indices ``S_*``): what is carried from one
  call of the integrator to the next (:class:`tribo_estimation.core.model.RigState`).
  Defined by ONE table, :data:`STATE_SLOTS` (per slot: ``RigState`` field name, unit,
  kind, finite or not, integrated or not); ``S_*``, ``NS``, :data:`S_FINITE`, ``Y_*``,
  ``NY``, ``ND`` and ``RigState``'s conversion and checks all derive from it.
- Integrated state ``y`` (a tuple of :data:`NY` floats, indices ``Y_*``): the slots of
  ``s`` marked integrated, in table order (:data:`Y_SLOTS`); the RK4 step advances
  it. The right-hand side returns :data:`ND` floats (the derivative of each entry of
  ``y`` at the same index, then the friction moment at :data:`D_M`). The kernel
  builds these tuples only in :mod:`.state`, for any ``NY``.
- Output channels (:data:`N_CH` rows, indices ``OUT_*``) written per sample.

Adding a state variable for an effect (e.g. a second lag) -- nothing else changes:

1. here: its entry in :data:`STATE_SLOTS` (anywhere; every index follows by name)
   and its index names ``S_NEW = state_index('new')`` and, if integrated,
   ``Y_NEW = y_index('new')``;
2. :func:`tribo_estimation.core.kernel.equations.effect_rates`: its rate,
   ``d = with_entry(d, Y_NEW, ...)`` (``d`` arrives with 0 there, so an inactive
   effect adds nothing), and, if the state restarts when sliding starts, its value in
   :func:`~tribo_estimation.core.kernel.equations.breakaway_state`;
3. its typed field in ``RigState`` (name as in the table; the default is its value
   at rest). ``to_vector``/``from_vector`` and the checks follow the table.

The RK4 step, the event search and the integrator (:mod:`.step`, :mod:`.events`,
:mod:`.integrate`) carry ``y`` whole and address it by ``Y_*`` names; ``model``,
``simulate``, ``shooting`` and the fits size their arrays with ``NS``/``N_CH`` and
address slots by name (states built from measurements, :mod:`..shooting`, start a
new slot at 0). ``test_kernel_state.py`` adds such a state to a copy of the package
in exactly these three places and checks the result. A measurement-side state (a
sensor filter) needs no kernel change: a non-integrated slot with ``finite=False``
(NaN = not started), like ``sensor_lag``, that :mod:`tribo_estimation.core.measurement`
updates. A discrete state of the stick/slip logic (like ``stick_time``) is set by the
event handling in :mod:`.integrate`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from tribo_estimation.errors import InvalidParameterError

# ---------------------------------------------------------------- parameter vector
P_I1 = 0  # chamber inertia [kg m^2]
P_K1 = 1  # chamber viscous damping [N m s/rad]
P_C1 = 2  # torsion element stiffness [N m/rad]
P_I2 = 3  # drive shaft inertia [kg m^2]
P_K2 = 4  # drive damping [N m s/rad]
P_C2 = 5  # drive stiffness [N m/rad]
P_FN = 6  # total normal force [N]
P_R = 7  # effective friction radius [m]
P_MU0 = 8  # static / zero-speed friction coefficient [-]
P_MUINF = 9  # high-speed friction coefficient [-]
P_K = 10  # Stribeck decay constant k [s/rad]
P_W0 = 11  # nominal drive speed [rad/s]
P_RAMP = 12  # start-up ramp time of the drive [s] (0 = step)
P_ST_GAIN = 13  # dwell-time stiction gain [-]
P_ST_TAU = 14  # dwell-time stiction time constant [s]
P_LAG_TAU = 15  # frictional lag time constant [s]
P_VISC = 16  # viscous friction in the contact [N m s/rad]
P_DRIFT_MU0 = 17  # drift of mu0 with test time [1/s]
P_DRIFT_MUINF = 18  # drift of mu_inf with test time [1/s]
P_RIP_AMP = 19  # drive speed ripple amplitude [rad/s]
P_RIP_FREQ = 20  # drive speed ripple frequency [Hz]
P_RIP_PHASE = 21  # drive speed ripple phase [rad]
P_BEARING = 22  # bearing Coulomb moment on the chamber [N m]
P_BEARING_REG = 23  # regularisation speed of the bearing moment [rad/s]
P_W0_RATE = 24  # drive acceleration of a linear drive piece [rad/s^2] (ramp time 0 only)
P_T_DRIVE = 25  # reference time of the linear drive piece [s]: w0(t) = w0 + rate*(t - t_ref)
#: Generic friction-law shape hook: offset of the Stribeck shape exponent from 1 [-],
#: ``mu = (mu0 - mu_inf)*exp(-(k*|v|)**(1 + shape)) + mu_inf``; 0 gives Equ. 8 exactly.
P_SHAPE = 26
P_RIP2_AMP = 27  # amplitude of the drive ripple's second harmonic (2 f) [rad/s]
P_RIP2_PHASE = 28  # phase of the second harmonic [rad]
#: Logarithmic dwell-time stiction: ``mu_s += b*ln(1 + t_stick/t0)`` with ``t0`` =
#: ``P_ST_TAU`` [s] and ``b`` this slot [-] (the Dieterich form).
P_ST_LOG = 29
#: A raised-cosine drive piece (an S-shaped speed transition) adds
#: ``P_W0_COS*cos(P_W0_OMEGA*(t - t_ref))`` to the linear piece's speed: from ``v_a``
#: to ``v_b`` over ``h`` s it is ``w0 = (v_a + v_b)/2``, rate 0, ``P_W0_COS =
#: -(v_b - v_a)/2`` [rad/s] and ``P_W0_OMEGA = pi/h`` [rad/s] (ramp time 0 only).
P_W0_COS = 30
P_W0_OMEGA = 31
#: A drive-speed ripple locked to the drive angle (a gear mesh, a coupling or a pulley
#: out of round): ``w0 += r*w_n(t)*sin(n*theta + p)`` with ``r`` = ``P_RIPA_REL`` [-],
#: ``n`` = ``P_RIPA_ORDER`` (per revolution) [-], ``p`` = ``P_RIPA_PHASE`` [rad] and
#: ``theta`` the ripple-free drive angle from the profile's first knot [rad], which is
#: the piece's own angle plus ``P_RIPA_ANGLE0`` [rad] (set per piece by
#: :func:`tribo_estimation.core.shooting._piece_params`; 0 for a start-up ramp).
P_RIPA_REL = 32
P_RIPA_ORDER = 33
P_RIPA_PHASE = 34
P_RIPA_ANGLE0 = 35
#: The angle-locked ripple's second harmonic: ``w0 += r2*w_n(t)*sin(2*n*theta + p2)``
#: with ``r2`` = ``P_RIPA2_REL`` [-] and ``p2`` = ``P_RIPA2_PHASE`` [rad].
P_RIPA2_REL = 36
P_RIPA2_PHASE = 37
NP = 38

#: Default regularisation speed of the bearing Coulomb moment [rad/s]:
#: ``M_b(w1) = bearing_moment * w1 / sqrt(w1^2 + w_reg^2)``. With ``w_reg = 0.01 rad/s``
#: the equivalent viscous slope ``bearing_moment/w_reg`` stays RK4-stable at
#: 10 kHz for bearing moments up to about 1 N m on the Tab. 1 chamber.
BEARING_REG_SPEED = 0.01

# ---------------------------------------------------------------- state vector
#: How a state slot reads as a :class:`tribo_estimation.core.model.RigState` field:
#: ``'value'`` a float; ``'flag'`` a bool stored as 1.0/0.0 (> 0.5 reads True);
#: ``'sign'`` an int +1/-1 stored as +1.0/-1.0 (>= 0 reads +1).
SlotKind = Literal['value', 'flag', 'sign']


@dataclass(frozen=True)
class StateSlot:
    """One slot of the state vector ``s``: the one entry that defines a state variable.

    Attributes
    ----------
    name : str
        Field name of the slot in :class:`tribo_estimation.core.model.RigState`.
    unit : str
        SI unit of the value (``'-'`` dimensionless, ``''`` for flags and signs).
    kind : SlotKind
        How the float in ``s`` converts to the field (``'value'``, ``'flag'``, ``'sign'``).
    finite : bool
        True if the value must be finite in every valid state; False for
        measurement-side slots that hold NaN until started.
    integrated : bool
        True if the RK4 step advances it (it is then an entry of ``y``, with its
        derivative at the same index of the right-hand side's result).
    description : str
        What the slot holds.
    """

    name: str
    unit: str
    kind: SlotKind
    finite: bool
    integrated: bool
    description: str


#: The state table: slot ``i`` of ``s`` is ``STATE_SLOTS[i]``. Every index (``S_*``,
#: ``Y_*``), size (``NS``, ``NY``, ``ND``) and conversion (``RigState.to_vector``,
#: ``from_vector``, its checks) derives from it.
STATE_SLOTS: tuple[StateSlot, ...] = (
    StateSlot('t', 's', 'value', True, False, 'test time'),
    StateSlot('phi1', 'rad', 'value', True, True, 'chamber angle'),
    StateSlot('w1', 'rad/s', 'value', True, True, 'chamber speed'),
    StateSlot('phi2', 'rad', 'value', True, True, 'shaft angle'),
    StateSlot('w2', 'rad/s', 'value', True, True, 'shaft speed'),
    StateSlot('lag', '-', 'value', True, True, 'lagged friction coefficient (frictional lag)'),
    StateSlot('stuck', '', 'flag', True, False, 'True while the discs stick'),
    StateSlot('slip_dir', '', 'sign', True, False, 'sgn(v) of the current sliding phase'),
    StateSlot('peak_passed', '', 'flag', True, False, '|v| passed its peak (deceleration rule)'),
    StateSlot('v_max', 'rad/s', 'value', True, False, 'max |v| in the current sliding phase'),
    StateSlot('stick_time', 's', 'value', True, False, 'duration of the current stick phase'),
    StateSlot('sensor_lag', 'N m', 'value', False, False, 'torque-sensor lag filter state'),
)


def state_index(name: str) -> int:
    """Return the index in ``s`` of the state slot ``name`` (a ``RigState`` field name).

    Parameters
    ----------
    name : str
        Slot name (``StateSlot.name``).

    Returns
    -------
    int
        Index ``S_*`` in the state vector.

    Raises
    ------
    InvalidParameterError
        If the table has no slot of that name.
    """
    for i, slot in enumerate(STATE_SLOTS):
        if slot.name == name:
            return i
    raise InvalidParameterError(f'kernel state table has no slot {name!r}')


NS = len(STATE_SLOTS)
S_T = state_index('t')  # time [s]
S_PHI1 = state_index('phi1')  # chamber angle [rad]
S_W1 = state_index('w1')  # chamber speed [rad/s]
S_PHI2 = state_index('phi2')  # shaft angle [rad]
S_W2 = state_index('w2')  # shaft speed [rad/s]
S_LAG = state_index('lag')  # lagged friction coefficient (frictional-lag extension) [-]
S_STUCK = state_index('stuck')  # 1.0 while sticking, else 0.0
S_DIR = state_index('slip_dir')  # slip direction sgn(v) of the current sliding phase (+1/-1)
S_PEAK = state_index('peak_passed')  # 1.0 once |v| passed its maximum (deceleration rule)
S_VMAX = state_index('v_max')  # max |v| in the current sliding phase [rad/s]
S_TSTICK = state_index('stick_time')  # duration of the current stick phase [s]
S_SENSOR = state_index('sensor_lag')  # torque-sensor lag filter state [N m] (NaN = not started)

#: Slots of ``s`` that must be finite in every valid state (``StateSlot.finite``); the
#: others (measurement side) may hold NaN ("not started").
S_FINITE: tuple[int, ...] = tuple(i for i, slot in enumerate(STATE_SLOTS) if slot.finite)

# ---------------------------------------------------------------- integrated state
#: ``Y_SLOTS[j]`` is the index in ``s`` of entry ``j`` of the integrated state ``y``
#: (the integrated slots in table order).
Y_SLOTS: tuple[int, ...] = tuple(i for i, slot in enumerate(STATE_SLOTS) if slot.integrated)
NY = len(Y_SLOTS)


def y_index(name: str) -> int:
    """Return the index in ``y`` of the integrated state slot ``name``.

    Parameters
    ----------
    name : str
        Slot name (``StateSlot.name``) of an integrated slot.

    Returns
    -------
    int
        Index ``Y_*`` in the integrated state (and in the right-hand side's result).

    Raises
    ------
    InvalidParameterError
        If the slot does not exist or is not integrated.
    """
    s = state_index(name)
    if s not in Y_SLOTS:
        raise InvalidParameterError(f'kernel state slot {name!r} is not integrated')
    return Y_SLOTS.index(s)


Y_PHI1 = y_index('phi1')  # chamber angle [rad]
Y_W1 = y_index('w1')  # chamber speed [rad/s]
Y_PHI2 = y_index('phi2')  # shaft angle [rad]
Y_W2 = y_index('w2')  # shaft speed [rad/s]
Y_LAG = y_index('lag')  # lagged friction coefficient [-]
#: Index of the friction moment M [N m] in the right-hand side's result (after the NY
#: derivatives).
D_M = NY
ND = NY + 1
#: The zero integrated state and the zero right-hand side (tuples the kernel fills by
#: index; numba compiles them to constants).
Y_ZERO: tuple[float, ...] = (0.0,) * NY
D_ZERO: tuple[float, ...] = (0.0,) * ND

# ---------------------------------------------------------------- output channels
OUT_TORSION = 0  # C1*phi1 [N m]
OUT_ACCEL = 1  # w1' [rad/s^2]
OUT_SPEED = 2  # w2 [rad/s]
OUT_FRICTION = 3  # friction moment M [N m]
OUT_SLIP = 4  # v = w2 - w1 [rad/s]
OUT_STICK = 5  # 1.0 when sticking
OUT_W1 = 6  # chamber speed w1 [rad/s]
N_CH = 7
