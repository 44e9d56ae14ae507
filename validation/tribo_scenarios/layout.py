"""Slots of the compiled simulator's vectors: state, parameters, form codes.

The compiled right-hand side (:mod:`.dynamics`) and integrator (:mod:`.integrator`)
take plain arrays; this module names their entries once. Module-level integers are
compile-time constants for numba.

State ``y`` (``NY`` floats), SI units:

==========  ==========================================================  ========
index       quantity                                                    unit
==========  ==========================================================  ========
``PHI1``    chamber angle phi1 (torsion element deflection)             rad
``W1``      chamber speed w1                                            rad/s
``DEFL``    belt deflection phi2 - phi0 (phi0 includes the ripple)      rad
``W2``      shaft speed w2                                              rad/s
``RHO``     drive angle added by the speed ripple (integral of it)      rad
``Z``       friction memory: lagged coefficient [-] or log state [-]    -
``TF``      torque channel filter output, ``TFD`` its rate              N m, N m/s
``AF``      acceleration channel filter output, ``AFD`` its rate        rad/s^2, rad/s^3
``SF``      speed channel filter output, ``SFD`` its rate               rad/s, rad/s^2
==========  ==========================================================  ========

Mode ``m`` (``NM`` floats): ``STUCK`` (1: discs stick), ``SDIR`` (+-1: direction of
the sliding phase), ``PEAK`` (1: |v| passed its maximum in this phase),
``TSTICK0`` (time the current stick began [s]).
"""

from __future__ import annotations

# --- state -------------------------------------------------------------------------
PHI1, W1, DEFL, W2, RHO, Z, TF, TFD, AF, AFD, SF, SFD = range(12)
NY = 12

# --- mode --------------------------------------------------------------------------
STUCK, SDIR, PEAK, TSTICK0 = range(4)
NM = 4

# --- float parameters P ------------------------------------------------------------
(
    P_I1,  # chamber inertia [kg m^2]
    P_K1,  # chamber damping [N m s/rad]
    P_C1,  # torsion element stiffness [N m/rad]
    P_I2,  # shaft inertia [kg m^2]
    P_K2,  # drive damping [N m s/rad]
    P_C2,  # drive stiffness [N m/rad]
    P_FN,  # normal force [N]
    P_R,  # friction radius [m]
    P_MU0,  # coefficient at v = 0 [-]
    P_MUINF,  # coefficient at large v [-]
    P_K,  # decay constant of Equ. 8 [s/rad]
    P_C1CAL,  # calibration of the torque channel, M_t = C1CAL*phi1 [N m/rad]
    P_DW_A,  # dwell: gain g / log b / power c [-]
    P_DW_B,  # dwell: tau / t0 [s] / exponent n [-]
    P_LAG_T,  # frictional lag: time constant / delay [s]
    P_LAG_B,  # rate and state: b [-]
    P_LAG_DC,  # rate and state: D_c [rad]
    P_LAG_VR,  # rate and state: regularising speed v_r [rad/s]
    P_VIS_C,  # viscous coefficient [N m (s/rad)^n]
    P_VIS_N,  # viscous exponent n [-]
    P_STR_D,  # stretched exponent delta [-]
    P_STR_VS,  # rational / Gaussian speed scale [rad/s]
    P_DR_A0,  # drift of mu0: rate [1/s] / amplitude [-] / -
    P_DR_AINF,  # drift of mu_inf: rate [1/s] / amplitude [-] / ratio [-]
    P_DR_TAU,  # drift time constant [s]
    P_RIP_F,  # ripple fundamental frequency [Hz] (time-locked forms)
    P_BR_M,  # bearing Coulomb moment [N m]
    P_BR_WR,  # bearing regularising speed [rad/s]
    P_BR_C,  # bearing viscous coefficient [N m s/rad]
    P_FNR_A,  # normal-force ripple relative amplitude [-]
    P_FNR_F,  # normal-force ripple frequency [Hz]
    P_FNR_P,  # normal-force ripple phase [rad]
    P_BL_B,  # drive backlash full width [rad]
    P_C1D_D,  # C1 drift: relative change [-] (linear: per second [1/s])
    P_C1D_T0,  # C1 drift start time [s]
    P_C1D_TAU,  # C1 drift time constant [s]
    P_BH_BETA,  # belt hardening beta [-]
    P_BH_DREF,  # belt hardening reference deflection [rad]
    P_CB,  # chamber bearing stiffness [N m/rad]
    P_TF_W,  # torque filter: 1/tau or natural angular frequency [1/s]
    P_TF_Z,  # torque filter damping ratio (2nd order) [-]
    P_AF_W,  # acceleration filter [1/s]
    P_AF_Z,  # acceleration filter damping ratio [-]
    P_SF_W,  # speed filter [1/s]
    P_SF_Z,  # speed filter damping ratio [-]
) = range(45)
NP = 45

# --- integer form codes Q (0 = off) ------------------------------------------------
(
    Q_DWELL,  # 1 exp saturation, 2 logarithmic, 3 power law
    Q_LAG,  # 1 first-order lag, 2 pure time delay, 3 rate and state
    Q_VISC,  # 1 linear, 2 power law
    Q_STRIB,  # 1 stretched exponential, 2 rational, 3 Gaussian
    Q_DRIFT,  # 1 linear, 2 saturating exponential, 3 smooth random function
    Q_RIPPLE,  # 1 time-locked components, 2 locked to the motor angle
    Q_BEARING,  # 1 Coulomb (w/sqrt(w^2 + w_r^2)), 2 Coulomb tanh, 3 tanh + viscous
    Q_FNRIP,  # 1 sinusoidal normal-force ripple
    Q_BELT,  # 1 backlash (dead band), 2 hardening
    Q_C1DRIFT,  # 1 linear, 2 saturating exponential
    Q_TF,  # torque channel filter order 0/1/2
    Q_AF,  # acceleration channel filter order
    Q_SF,  # speed channel filter order
) = range(13)
NQ = 13

#: Form codes by (term, form name): the one mapping from the names of :mod:`.space`.
DWELL_FORMS = {'exp_saturation': 1, 'logarithmic': 2, 'power_law': 3}
LAG_FORMS = {'first_order': 1, 'time_delay': 2, 'rate_state': 3}
VISCOUS_FORMS = {'linear': 1, 'power_law': 2}
STRIBECK_FORMS = {'stretched_exp': 1, 'rational': 2, 'gaussian': 3}
DRIFT_FORMS = {'linear': 1, 'saturating': 2, 'random_smooth': 3}
RIPPLE_FORMS = {'sine': 1, 'harmonics': 1, 'angle_locked': 2}
BEARING_FORMS = {'coulomb': 1, 'coulomb_tanh': 2, 'coulomb_viscous': 3}
BELT_FORMS = {'drive_backlash': 1, 'belt_hardening': 2}
C1DRIFT_FORMS = {'linear': 1, 'saturating': 2}

#: Regularising speed of the library's own bearing form [rad/s].
BEARING_W_REG = 0.01
