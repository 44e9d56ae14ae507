"""Released activity to wear height and volume (paper Equ. 8-9, physics notes section 2).

    A_oil = A_I * F(h),  F(h) = integral_0^h rho_I dz   ->  h = F^-1(A_oil / A_I)
    V_I = h * A_I,       V_W = V_I * k_A = h * A_contact

(not the flat-profile shortcut V_I = A/rho_I). Standard errors:
statistical (counting) sigma_h = sigma_A / (A_I rho_I(h)); systematic (common
to a whole test) from the depth profile, sigma_F(h)/rho_I(h), and from k_DET.
A reading above A_I*F(max depth) is *beyond the activated depth*: the height
is NaN and the point is flagged, never extrapolated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from tribo_nvct.core.config import NvctConfig
from tribo_nvct.core.counting import (
    ActivityEstimate,
    Dwell,
    currie_critical_level_counts,
    currie_detection_limit_counts,
    decay_factor,
)

#: Flags a wear point can carry (WearState.quality uses the same words).
FLAG_NOT_MIXED = 'not_mixed'
FLAG_BEYOND = 'beyond_profile'
FLAG_BELOW = 'below_detection_limit'
#: The dwell counted far fewer counts than the configured background alone gives
#: (more than :data:`BELOW_BACKGROUND_SIGMA` standard deviations): impossible for a
#: Poisson count, so the background or the counts are wrong; the point is not used.
FLAG_BELOW_BACKGROUND = 'below_background'
#: Standard deviations (Poisson counts and the background's own SE) that make a
#: dwell's deficit against the background a contradiction [-].
BELOW_BACKGROUND_SIGMA = 5.0
FLAG_GAP = 'gap'


@dataclass(frozen=True)
class WearPoint:
    """Wear after one dwell (SI).

    t_start, t_end [s] test time; counts; live_time [s];
    activity, activity_se: released activity at the profile reference date [Bq];
    height, height_se: mean wear height h [m] (statistical SE);
    tagged_volume, tagged_volume_se: V_I = h*A_I [m^3];
    volume, volume_se, volume_sys_se: V_W = V_I*k_A [m^3];
    flags: subset of not_mixed, beyond_profile, below_detection_limit, below_background, gap.
    """

    t_start: float
    t_end: float
    counts: int
    live_time: float
    activity: float
    activity_se: float
    height: float
    height_se: float
    tagged_volume: float
    tagged_volume_se: float
    volume: float
    volume_se: float
    volume_sys_se: float
    flags: tuple[str, ...] = field(default_factory=tuple)

    @property
    def t_mid(self) -> float:
        """Dwell centre [s]."""
        return 0.5 * (self.t_start + self.t_end)

    @property
    def quality(self) -> str:
        """'ok' or ';'-joined flags."""
        return ';'.join(self.flags) if self.flags else 'ok'

    @property
    def usable(self) -> bool:
        """True if the point may enter fits (mixed oil, inside the profile)."""
        return not {FLAG_NOT_MIXED, FLAG_BEYOND, FLAG_BELOW_BACKGROUND} & set(self.flags)


def activity_to_wear(
    cfg: NvctConfig, activity: float, activity_se: float
) -> tuple[float, float, float]:
    """(h, sigma_h statistical, sigma_h systematic) [m] for released activity [Bq]."""
    prof = cfg.profile
    F = activity / cfg.tagged_area
    h = float(prof.invert(F)[0])
    if not math.isfinite(h):
        return math.nan, math.nan, math.nan
    rho = float(prof.rho(h)[0])
    if not rho > 0.0:
        return h, math.inf, math.inf
    h_se = activity_se / (cfg.tagged_area * rho)
    sys_F = float(prof.F_se(max(h, 0.0))[0])
    sys_k = abs(F) * cfg.k_det_rel_se
    h_sys = math.hypot(sys_F, sys_k) / rho
    return h, h_se, h_sys


def make_point(
    cfg: NvctConfig,
    dwell: Dwell,
    act: ActivityEstimate,
    released: float,
    released_se: float,
    gap: bool,
) -> WearPoint:
    """Build the :class:`WearPoint` of a dwell from its (deposition-corrected) activity [Bq]."""
    flags: list[str] = []
    if cfg.circuit is not None and dwell.t_end < cfg.circuit.mixing_time:
        flags.append(FLAG_NOT_MIXED)
    h, h_se, h_sys = activity_to_wear(cfg, released, released_se)
    if not math.isfinite(h):
        flags.append(FLAG_BEYOND)
    bg_counts = cfg.background.rate * dwell.live_time
    net_counts = act.net_rate * dwell.live_time
    if net_counts < currie_critical_level_counts(bg_counts):
        flags.append(FLAG_BELOW)
    bg_se_counts = cfg.background.se * dwell.live_time
    if net_counts < -BELOW_BACKGROUND_SIGMA * math.sqrt(max(bg_counts, 1.0) + bg_se_counts**2):
        flags.append(FLAG_BELOW_BACKGROUND)
    if gap:
        flags.append(FLAG_GAP)
    A_I = cfg.tagged_area
    A_c = cfg.contact_area
    return WearPoint(
        t_start=dwell.t_start,
        t_end=dwell.t_end,
        counts=dwell.counts,
        live_time=dwell.live_time,
        activity=released,
        activity_se=released_se,
        height=h,
        height_se=h_se,
        tagged_volume=h * A_I,
        tagged_volume_se=h_se * A_I,
        volume=h * A_c,
        volume_se=h_se * A_c,
        volume_sys_se=h_sys * A_c,
        flags=tuple(flags),
    )


def detection_limit_height(
    cfg: NvctConfig, counting_time: float, extra_rate: float = 0.0, t_test: float = 0.0
) -> float:
    """Currie detection limit as mean wear height [m] for a counting time [s].

    L_D = 2.71 + 4.65 sqrt(B) counts with B the background counts (plus
    ``extra_rate`` [1/s], e.g. the oil's current activity, for the limit on a
    wear *increment*), converted with k_DET, decay at test time ``t_test`` [s]
    and the surface concentration rho_I(0).
    """
    B = (cfg.background.rate + extra_rate) * counting_time
    LD_rate = currie_detection_limit_counts(B) / counting_time
    dec = decay_factor(t_test, t_test + counting_time, cfg.decay_constant, cfg.reference_offset_s)
    activity = cfg.k_det * LD_rate * dec
    rho0 = float(np.asarray(cfg.profile.rho(0.0))[0])
    return activity / (cfg.tagged_area * rho0)
