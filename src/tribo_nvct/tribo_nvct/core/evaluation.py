"""Running-in vs progressive wear and wear coefficients (paper 3.5, Equ. 10).

Window method (paper): the progressive wear rate w is the slope of V_W(t)
between 120 and 180 min -- here a weighted least-squares regression over all
usable dwells in the window (not two points). With the regression line
V = a + w t:

    total volume at 180 min   V_180 = a + w * 180 min
    progressive volume        V_p   = w * 180 min
    running-in volume         V_r   = V_180 - V_p = a

(standard errors from the regression covariance, inflated by sqrt(chi2/dof)
when the scatter exceeds the counting statistics).

Wear coefficient (Equ. 10): k_w = V / (L * d_s), d_s = stroke*frequency*duration
(paper; ASTM G133: 2*stroke per cycle), reported in um^3/(N m).

Model fit: V(t) = V_r (1 - exp(-t/tau)) + w t (an exponentially decaying
running-in rate plus a constant progressive rate) by weighted non-linear least
squares, with standard errors from the covariance; compared with the window method.

The time axis of the fits is the dwell centre minus the oil circuit's lag.

Profile (systematic) uncertainty: the depth profile F(h) and k_DET are common
to every dwell of a test, so their errors do not average out. For every
bootstrap replica F*_b of the profile (see ``tribo_nvct.core.profile``) and a
draw k*_b = k_DET (1 + r_k eps_b) of the detector coefficient (r_k =
``k_det_rel_se``), the window points are re-inverted,

    h_i,b = F*_b^-1((k*_b/k_DET) A_i / A_I),   V_i,b = h_i,b A_contact,

and refitted with the same weights (the window regression is linear in V);
the standard deviation over b of V_180, w, V_p, V_r (and k_w) is their profile
standard error sigma_prof. Reported beside the counting SE sigma_count and
combined in quadrature: sigma_comb = sqrt(sigma_count^2 + sigma_prof^2).
The mean wear height and tagged volume at the window end are h_180 = V_180/A_contact
and V_I = h_180 A_I (Equ. 9) with the same relative errors.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import OptimizeWarning, curve_fit

from tribo_nvct.core.config import SLIDING_CONVENTIONS, NvctConfig
from tribo_nvct.core.profile import BOOTSTRAP_SEED
from tribo_nvct.core.wear import WearPoint, detection_limit_height
from tribo_nvct.errors import EvaluationError

FloatArray = NDArray[np.float64]
UM3 = 1e-18


@dataclass(frozen=True)
class LineFit:
    """Weighted regression V = a + b t: a [m^3], b [m^3/s], covariance, n points, chi2/dof."""

    a: float
    b: float
    cov: tuple[tuple[float, float], tuple[float, float]]
    n: int
    chi2_red: float

    def value(self, t: float) -> float:
        """V(t) [m^3]."""
        return self.a + self.b * t

    def value_se(self, t: float) -> float:
        """Return the standard error of V(t) [m^3] at time ``t`` [s]."""
        (caa, cab), (_, cbb) = self.cov
        return math.sqrt(max(caa + 2.0 * t * cab + t * t * cbb, 0.0))

    @property
    def b_se(self) -> float:
        """Standard error of the slope [m^3/s]."""
        return math.sqrt(self.cov[1][1])

    @property
    def a_se(self) -> float:
        """Standard error of the intercept [m^3]."""
        return math.sqrt(self.cov[0][0])


def weighted_line(t: FloatArray, v: FloatArray, se: FloatArray) -> LineFit:
    """Weighted least-squares line through (t [s], v [m^3]) with standard errors se [m^3].

    The time origin is shifted to the data mean internally for conditioning.
    """
    if t.size < 3:
        raise EvaluationError('need at least 3 points for a line fit')
    w = 1.0 / se**2
    t0 = float(np.average(t, weights=w))
    x = t - t0
    Sw = w.sum()
    Sxx = float((w * x * x).sum())
    if Sxx <= 0.0:
        raise EvaluationError('time values do not vary')
    b = float((w * x * v).sum() / Sxx)
    a0 = float((w * v).sum() / Sw)
    resid = v - a0 - b * x
    dof = t.size - 2
    chi2_red = float((w * resid * resid).sum() / dof)
    scale = max(1.0, chi2_red)
    var_a0 = scale / Sw
    var_b = scale / Sxx
    # Back to the original origin: a = a0 - b t0.
    a = a0 - b * t0
    caa = var_a0 + t0 * t0 * var_b
    cab = -t0 * var_b
    return LineFit(a, b, ((caa, cab), (cab, var_b)), int(t.size), chi2_red)


@dataclass(frozen=True)
class ExpFit:
    """V(t) = V_r (1 - exp(-t/tau)) + w t: V_r [m^3], tau [s], w [m^3/s] with standard errors.

    ok False (values NaN) when the fit did not converge; message says why.
    """

    V_r: float
    V_r_se: float
    tau: float
    tau_se: float
    w: float
    w_se: float
    chi2_red: float
    ok: bool
    message: str = ''

    def value(self, t: FloatArray | float) -> FloatArray:
        """Model volume [m^3] at t [s]."""
        tt = np.asarray(t, dtype=float)
        return np.asarray(self.V_r * -np.expm1(-tt / self.tau) + self.w * tt)


def _exp_model(t: FloatArray, V_r: float, tau: float, w: float) -> FloatArray:
    return np.asarray(V_r * -np.expm1(-t / tau) + w * t)


def fit_exponential(
    t: FloatArray, v: FloatArray, se: FloatArray, guess_rate: float | None = None
) -> ExpFit:
    """Weighted fit of V(t) = V_r (1 - exp(-t/tau)) + w t (t [s], v, se [m^3])."""
    nan = math.nan
    if t.size < 5:
        return ExpFit(nan, nan, nan, nan, nan, nan, nan, False, 'fewer than 5 usable points')
    t_end = float(t.max())
    late = t > 0.5 * t_end
    if guess_rate is None or not math.isfinite(guess_rate):
        guess_rate = weighted_line(t[late], v[late], se[late]).b if late.sum() >= 3 else 0.0
    V_end = float(np.median(v[t > 0.9 * t_end])) if np.any(t > 0.9 * t_end) else float(v[-1])
    Vr0 = max(V_end - guess_rate * t_end, 1e-3 * max(abs(V_end), 1e-30))
    scale_v = max(float(np.max(np.abs(v))), 1e-30)
    best: tuple[float, FloatArray, FloatArray] | None = None
    # A few starting values of tau (the fit is non-convex in tau).
    for frac in (0.02, 0.1, 0.3):
        p0 = [Vr0 / scale_v, frac * t_end, guess_rate * t_end / scale_v]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter('ignore', OptimizeWarning)
                popt, pcov = curve_fit(
                    lambda tt, a, tau, b: _exp_model(tt, a, tau, b / t_end),
                    t,
                    v / scale_v,
                    p0=p0,
                    sigma=se / scale_v,
                    absolute_sigma=True,
                    bounds=([0.0, 1e-3 * t_end, -np.inf], [np.inf, 10.0 * t_end, np.inf]),
                    max_nfev=2000,
                )
        except (RuntimeError, ValueError):
            continue
        r = (v / scale_v - _exp_model(t, popt[0], popt[1], popt[2] / t_end)) / (se / scale_v)
        chi2 = float(r @ r)
        if best is None or chi2 < best[0]:
            best = (chi2, popt, pcov)
    if best is None or not np.all(np.isfinite(best[2])):
        return ExpFit(nan, nan, nan, nan, nan, nan, nan, False, 'fit did not converge')
    chi2, popt, pcov = best
    dof = max(t.size - 3, 1)
    chi2_red = chi2 / dof
    cov = pcov * max(1.0, chi2_red)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return ExpFit(
        V_r=float(popt[0] * scale_v),
        V_r_se=float(sd[0] * scale_v),
        tau=float(popt[1]),
        tau_se=float(sd[1]),
        w=float(popt[2] * scale_v / t_end),
        w_se=float(sd[2] * scale_v / t_end),
        chi2_red=chi2_red,
        ok=True,
    )


@dataclass(frozen=True)
class Evaluation:
    """Paper 3.5 evaluation (SI; NaN where the data do not reach the window).

    total_volume: V_W at the window end (180 min) [m^3]; progressive_rate [m^3/s];
    progressive_volume, running_in_volume [m^3]; k_w_* [m^3/(N m)]; sliding_distance [m]
    at the window end; window_s: (start, end) [s]; exp_fit: model fit; flags.
    """

    total_volume: float
    total_volume_se: float
    progressive_rate: float
    progressive_rate_se: float
    progressive_volume: float
    progressive_volume_se: float
    running_in_volume: float
    running_in_volume_se: float
    k_w_progressive: float
    k_w_progressive_se: float
    k_w_running_in: float
    k_w_running_in_se: float
    sliding_distance: float
    sliding_convention: str
    window_s: tuple[float, float]
    n_window: int
    window_chi2_red: float
    exp_fit: ExpFit
    lag_s: float
    flags: tuple[str, ...]
    total_volume_profile_se: float = 0.0
    progressive_rate_profile_se: float = 0.0
    progressive_volume_profile_se: float = 0.0
    running_in_volume_profile_se: float = 0.0
    k_w_progressive_profile_se: float = 0.0
    k_w_running_in_profile_se: float = 0.0
    profile_replicas: int = 0
    profile_model: str = ''

    @property
    def total_volume_combined_se(self) -> float:
        """Counting and profile SE of V_180 in quadrature [m^3]."""
        return math.hypot(self.total_volume_se, self.total_volume_profile_se)

    @property
    def progressive_rate_combined_se(self) -> float:
        """Combined SE of the progressive rate [m^3/s]."""
        return math.hypot(self.progressive_rate_se, self.progressive_rate_profile_se)

    @property
    def progressive_volume_combined_se(self) -> float:
        """Combined SE of the progressive volume [m^3]."""
        return math.hypot(self.progressive_volume_se, self.progressive_volume_profile_se)

    @property
    def running_in_volume_combined_se(self) -> float:
        """Combined SE of the running-in volume [m^3]."""
        return math.hypot(self.running_in_volume_se, self.running_in_volume_profile_se)

    @property
    def k_w_progressive_combined_se(self) -> float:
        """Combined SE of k_w (progressive) [m^3/(N m)]."""
        return math.hypot(self.k_w_progressive_se, self.k_w_progressive_profile_se)

    @property
    def k_w_running_in_combined_se(self) -> float:
        """Combined SE of k_w (running-in) [m^3/(N m)]."""
        return math.hypot(self.k_w_running_in_se, self.k_w_running_in_profile_se)

    def summary(self, cfg: NvctConfig, dwell_s: float | None = None) -> dict[str, object]:
        """JSON-ready summary in the CLI's units (um^3, um^3/min, um^3/(N m), nm)."""
        t2 = self.window_s[1]
        ef = self.exp_fit
        A_c = cfg.contact_area
        out: dict[str, object] = {
            'total_volume_um3': self.total_volume / UM3,
            'total_volume_se_um3': self.total_volume_se / UM3,
            'total_volume_profile_se_um3': self.total_volume_profile_se / UM3,
            'total_volume_combined_se_um3': self.total_volume_combined_se / UM3,
            'total_height_nm': self.total_volume / A_c * 1e9,
            'total_height_se_nm': self.total_volume_se / A_c * 1e9,
            'total_height_combined_se_nm': self.total_volume_combined_se / A_c * 1e9,
            'total_tagged_volume_um3': self.total_volume / cfg.k_A / UM3,
            'total_tagged_volume_se_um3': self.total_volume_se / cfg.k_A / UM3,
            'total_tagged_volume_combined_se_um3': self.total_volume_combined_se / cfg.k_A / UM3,
            'progressive_rate_um3_per_min': self.progressive_rate * 60.0 / UM3,
            'progressive_rate_se_um3_per_min': self.progressive_rate_se * 60.0 / UM3,
            'progressive_rate_profile_se_um3_per_min': self.progressive_rate_profile_se
            * 60.0
            / UM3,
            'progressive_rate_combined_se_um3_per_min': self.progressive_rate_combined_se
            * 60.0
            / UM3,
            'progressive_volume_um3': self.progressive_volume / UM3,
            'progressive_volume_se_um3': self.progressive_volume_se / UM3,
            'progressive_volume_profile_se_um3': self.progressive_volume_profile_se / UM3,
            'progressive_volume_combined_se_um3': self.progressive_volume_combined_se / UM3,
            'running_in_volume_um3': self.running_in_volume / UM3,
            'running_in_volume_se_um3': self.running_in_volume_se / UM3,
            'running_in_volume_profile_se_um3': self.running_in_volume_profile_se / UM3,
            'running_in_volume_combined_se_um3': self.running_in_volume_combined_se / UM3,
            'k_w_progressive': self.k_w_progressive / UM3,
            'k_w_progressive_se': self.k_w_progressive_se / UM3,
            'k_w_progressive_profile_se': self.k_w_progressive_profile_se / UM3,
            'k_w_progressive_combined_se': self.k_w_progressive_combined_se / UM3,
            'k_w_running_in': self.k_w_running_in / UM3,
            'k_w_running_in_se': self.k_w_running_in_se / UM3,
            'k_w_running_in_profile_se': self.k_w_running_in_profile_se / UM3,
            'k_w_running_in_combined_se': self.k_w_running_in_combined_se / UM3,
            'k_w_unit': 'um^3/(N m)',
            'sliding_distance_m': self.sliding_distance,
            'sliding_distance_convention': self.sliding_convention,
            'sliding_distance_definition': SLIDING_CONVENTIONS[self.sliding_convention],
            'window_min': [self.window_s[0] / 60.0, t2 / 60.0],
            'window_points': self.n_window,
            'window_chi2_red': self.window_chi2_red,
            'oil_circuit_lag_s': self.lag_s,
            'exponential_fit': {
                'model': 'V(t) = V_r*(1-exp(-t/tau)) + w*t',
                'ok': ef.ok,
                'message': ef.message,
                'V_r_um3': ef.V_r / UM3,
                'V_r_se_um3': ef.V_r_se / UM3,
                'tau_min': ef.tau / 60.0,
                'tau_se_min': ef.tau_se / 60.0,
                'w_um3_per_min': ef.w * 60.0 / UM3,
                'w_se_um3_per_min': ef.w_se * 60.0 / UM3,
                'chi2_red': ef.chi2_red,
                'volume_at_window_end_um3': float(ef.value(t2)) / UM3 if ef.ok else math.nan,
                'running_in_at_window_end_um3': (
                    ef.V_r * -math.expm1(-t2 / ef.tau) / UM3 if ef.ok else math.nan
                ),
            },
            'standard_errors': (
                '*_se*: statistical (counting); *_profile_se*: depth profile (bootstrap over '
                'the layer-removal noise) and k_DET; *_combined_se*: both in quadrature; '
                'exponential_fit: counting only'
            ),
            'depth_profile': {
                'model': self.profile_model,
                'bootstrap_replicas': self.profile_replicas,
                'aic': dict(cfg.profile.aic),
                'chi2_red': cfg.profile.chi2_red,
                'residual_rms_bq': cfg.profile.residual_rms_bq,
            },
            'flags': list(self.flags),
        }
        if dwell_s:
            out['detection_limit_nm_per_dwell'] = detection_limit_height(cfg, dwell_s) * 1e9
            out['dwell_s'] = dwell_s
        out['detection_limit_nm_per_hour'] = detection_limit_height(cfg, 3600.0) * 1e9
        return out


def evaluate(
    points: Sequence[WearPoint], cfg: NvctConfig, fit_model: bool = True, profile_se: bool = True
) -> Evaluation:
    """Evaluate running-in and progressive wear from the wear points of a test.

    fit_model: also fit the exponential running-in model (skipped when False).
    profile_se: propagate the depth profile's bootstrap and k_DET's uncertainty
    (the profile's bootstrap runs once per configuration, on first use).
    """
    lag = cfg.circuit.lag if cfg.circuit is not None else 0.0
    use = [p for p in points if p.usable and math.isfinite(p.volume_se) and p.volume_se > 0]
    t = np.array([p.t_mid - lag for p in use])
    v = np.array([p.volume for p in use])
    se = np.array([p.volume_se for p in use])
    t1, t2 = cfg.window_s
    flags: list[str] = []
    nan = math.nan
    line: LineFit | None = None
    if t.size:
        dt = float(np.median(np.diff(t))) if t.size > 1 else 60.0
        in_win = (t >= t1) & (t <= t2)
        covered = t.max() >= t2 - 1.5 * dt and t.min() <= t1 + 1.5 * dt
        if not covered:
            flags.append('window_not_covered')
        elif in_win.sum() < 3:
            flags.append('too_few_points_in_window')
        else:
            line = weighted_line(t[in_win], v[in_win], se[in_win])
    else:
        flags.append('no_usable_points')
    n_beyond = sum(1 for p in points if 'beyond_profile' in p.flags)
    if n_beyond:
        flags.append(f'beyond_profile_points={n_beyond}')
    n_below_bg = sum(1 for p in points if 'below_background' in p.flags)
    if n_below_bg:
        flags.append(f'below_background_points={n_below_bg}')
    d_s = cfg.sliding_distance(t2)
    denom = cfg.load * d_s
    if line is not None:
        V180, V180_se = line.value(t2), line.value_se(t2)
        rate, rate_se = line.b, line.b_se
        Vp, Vp_se = rate * t2, rate_se * t2
        Vr, Vr_se = line.a, line.a_se
        n_win, chi2 = line.n, line.chi2_red
    else:
        V180 = V180_se = rate = rate_se = Vp = Vp_se = Vr = Vr_se = nan
        n_win, chi2 = 0, nan
    prof_se = (0.0, 0.0, 0.0, 0.0)
    n_rep = 0
    if line is not None and profile_se:
        in_win = (t >= t1) & (t <= t2)
        act = np.array([p.activity for p in use])[in_win]
        prof_se, n_rep = _profile_spread(cfg, t[in_win], act, se[in_win], t2)
    guess = rate if line is not None else None
    ef = (
        fit_exponential(t, v, se, guess)
        if t.size and fit_model
        else ExpFit(nan, nan, nan, nan, nan, nan, nan, False, 'not fitted')
    )
    return Evaluation(
        total_volume=V180,
        total_volume_se=V180_se,
        progressive_rate=rate,
        progressive_rate_se=rate_se,
        progressive_volume=Vp,
        progressive_volume_se=Vp_se,
        running_in_volume=Vr,
        running_in_volume_se=Vr_se,
        k_w_progressive=Vp / denom,
        k_w_progressive_se=Vp_se / denom,
        k_w_running_in=Vr / denom,
        k_w_running_in_se=Vr_se / denom,
        sliding_distance=d_s,
        sliding_convention=cfg.sliding_convention,
        window_s=(t1, t2),
        n_window=n_win,
        window_chi2_red=chi2,
        exp_fit=ef,
        lag_s=lag,
        flags=tuple(flags),
        total_volume_profile_se=prof_se[0],
        progressive_rate_profile_se=prof_se[1],
        progressive_volume_profile_se=prof_se[2],
        running_in_volume_profile_se=prof_se[3],
        k_w_progressive_profile_se=prof_se[2] / denom,
        k_w_running_in_profile_se=prof_se[3] / denom,
        profile_replicas=n_rep,
        profile_model=cfg.profile.model,
    )


def _profile_spread(
    cfg: NvctConfig, t: FloatArray, activity: FloatArray, se: FloatArray, t2: float
) -> tuple[tuple[float, float, float, float], int]:
    """Profile + k_DET standard errors of (V_180, w, V_p, V_r) [m^3, m^3/s, m^3, m^3].

    t [s], activity [Bq] and se [m^3] of the window points; see the module docstring.
    Returns the SEs and the number of replicas used.
    """
    prof = cfg.profile
    F = activity / cfg.tagged_area
    reps = prof.replicas()
    rel = cfg.k_det_rel_se
    n_rep = reps.shape[0] if reps.shape[0] >= 2 else 200
    kfac: FloatArray = 1.0 + rel * np.random.default_rng(BOOTSTRAP_SEED + 1).standard_normal(n_rep)
    if reps.shape[0] >= 2:
        H = prof.invert_replicas(kfac[:, None] * F[None, :])
    elif rel > 0.0:
        H = np.vstack([prof.invert(k * F) for k in kfac])
    else:
        return (0.0, 0.0, 0.0, 0.0), 0
    V = H * cfg.contact_area
    V = V[np.all(np.isfinite(V), axis=1)]
    if V.shape[0] < 2:
        return (math.nan, math.nan, math.nan, math.nan), int(V.shape[0])
    w = 1.0 / se**2
    t0 = float(np.average(t, weights=w))
    x = t - t0
    b = (V * (w * x)).sum(axis=1) / float((w * x * x).sum())
    a0 = (V * w).sum(axis=1) / float(w.sum())
    v180 = a0 + b * (t2 - t0)
    vr = a0 - b * t0
    sd = [float(np.std(q, ddof=1)) for q in (v180, b, b * t2, vr)]
    return (sd[0], sd[1], sd[2], sd[3]), int(V.shape[0])


def recent_rate(points: Sequence[WearPoint], window_s: float) -> tuple[float, float]:
    """Estimate the wear rate dV/dt [m^3/s] and its SE from the last ``window_s`` [s]."""
    if not points:
        return math.nan, math.nan
    t_last = points[-1].t_mid
    use = [
        p
        for p in points
        if p.usable
        and p.t_mid >= t_last - window_s
        and math.isfinite(p.volume_se)
        and p.volume_se > 0
    ]
    if len(use) < 3:
        return math.nan, math.nan
    line = weighted_line(
        np.array([p.t_mid for p in use]),
        np.array([p.volume for p in use]),
        np.array([p.volume_se for p in use]),
    )
    return line.b, line.b_se
