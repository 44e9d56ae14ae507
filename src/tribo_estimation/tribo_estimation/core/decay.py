"""Free-decay identification of the test chamber (paper Equ. 7).

With the contact opened the chamber oscillates alone:
``I1*phi1'' + K1*phi1' + C1*phi1 = 0`` (7). The rig measures the torsion moment
``M_t = C1*phi1`` [N m] and the acceleration ``a = phi1''`` [rad/s^2], so

    M_t(t) = m0 + exp(-sigma*tau)*(A*cos(wd*tau) + B*sin(wd*tau)),   tau = t - t_0
    a(t)   = a0 + M_t''(t)/C1

(``m0``, ``a0``: sensor offsets). Both records are fitted jointly by weighted
nonlinear least squares (no numerical derivative of noisy data, no noisy
regressors: the derivative is taken of the fitted model). Then
``wn^2 = sigma^2 + wd^2``, ``I1 = C1/wn^2``, ``K1 = 2*sigma*I1``,
``zeta = sigma/wn``, ``f_n = wn/(2 pi)``. Start values come from the FFT peak
(frequency) and the Hilbert envelope (decay rate); the channel weights are the
inverse residual standard deviations of a first pass. Standard errors come from
the Jacobian at the optimum (residuals scaled to unit variance), propagated to
the derived quantities by the delta method.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.signal import hilbert

from tribo_estimation.core.lsq import LsqResult, forward_jacobian, levenberg_marquardt
from tribo_estimation.errors import (
    InvalidDataError,
    NonMonotonicTimeError,
    NoOscillationError,
    TooShortError,
)

#: Fewest full oscillation periods a record must contain.
MIN_CYCLES = 3.0
#: Fewest samples per record.
MIN_SAMPLES = 64
#: Least ratio of the spectral peak to the median spectrum for an oscillation.
MIN_PEAK_RATIO = 30.0


@dataclass(frozen=True)
class DecayResult:
    """Identified chamber parameters with standard errors (``*_se``).

    I1 [kg m^2], K1 [N m s/rad], C1 [N m/rad], f_n_hz undamped natural frequency
    [Hz], zeta damping ratio [-]; torque_offset [N m], accel_offset [rad/s^2];
    rms_torque [N m], rms_accel [rad/s^2] residual RMS; n_samples used.
    """

    I1: float
    K1: float
    C1: float
    f_n_hz: float
    zeta: float
    I1_se: float
    K1_se: float
    C1_se: float
    f_n_hz_se: float
    zeta_se: float
    torque_offset: float
    accel_offset: float
    rms_torque: float
    rms_accel: float
    n_samples: int

    def to_dict(self) -> dict[str, float | int]:
        """Plain mapping (for decay.json)."""
        return asdict(self)


def _validate(
    time: np.ndarray, torque: np.ndarray, accel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arrs = []
    for name, x in (('time', time), ('torsion_moment', torque), ('angular_acceleration', accel)):
        a = np.asarray(x, dtype=float)
        if a.ndim != 1:
            raise InvalidDataError(f'{name} must be one-dimensional, got shape {a.shape}')
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise InvalidDataError(f'{name}: non-finite value {a[bad[0]]} at sample {bad[0]}')
        arrs.append(a)
    t, m, a = arrs
    if not (t.shape == m.shape == a.shape):
        raise InvalidDataError(
            f'time, torsion_moment, angular_acceleration differ in length: '
            f'{t.size}, {m.size}, {a.size}'
        )
    if t.size < MIN_SAMPLES:
        raise TooShortError(f'free-decay record has {t.size} samples, need >= {MIN_SAMPLES}')
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0.0)
    if bad.size:
        raise NonMonotonicTimeError(
            f'time does not increase at sample {bad[0] + 1} ({t[bad[0]]} -> {t[bad[0] + 1]} s)'
        )
    med = float(np.median(dt))
    if np.max(np.abs(dt - med)) > 0.01 * med:
        raise InvalidDataError('free-decay record must be uniformly sampled (dt varies > 1 %)')
    return t, m, a


def _model(q: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    amp_a, amp_b, sigma, wd, m0, inv_c1, a0 = q
    e = np.exp(-sigma * tau)
    c = np.cos(wd * tau)
    s = np.sin(wd * tau)
    mt = m0 + e * (amp_a * c + amp_b * s)
    k = sigma * sigma - wd * wd
    dd = e * (
        (amp_a * k - 2.0 * sigma * wd * amp_b) * c + (amp_b * k + 2.0 * sigma * wd * amp_a) * s
    )
    return mt, a0 + inv_c1 * dd


def identify_free_decay(
    time: np.ndarray,
    torsion_moment: np.ndarray,
    accel: np.ndarray,
    *,
    t_start: float | None = None,
    t_end: float | None = None,
) -> DecayResult:
    """Identify I1, K1, C1 (and f_n, zeta) from a free-decay record (Equ. 7).

    ``time`` [s] (uniform, increasing), ``torsion_moment`` M_t = C1*phi1 [N m],
    ``accel`` chamber angular acceleration [rad/s^2]; the record should start at
    or after the release (``t_start``/``t_end`` [s] cut it). Raises
    :class:`NoOscillationError` when no under-damped oscillation is present,
    :class:`TooShortError` for fewer than three periods or 64 samples.
    """
    t, m, a = _validate(time, torsion_moment, accel)
    keep = np.ones(t.size, dtype=bool)
    if t_start is not None:
        keep &= t >= t_start
    if t_end is not None:
        keep &= t <= t_end
    t, m, a = t[keep], m[keep], a[keep]
    if t.size < MIN_SAMPLES:
        raise TooShortError(f'free-decay window has {t.size} samples, need >= {MIN_SAMPLES}')
    dt = float(np.median(np.diff(t)))
    span = float(t[-1] - t[0])
    tau = t - t[0]
    # ---- start values: frequency from the spectrum peak
    mc = m - np.mean(m)
    if np.ptp(m) == 0.0:
        raise NoOscillationError('torsion moment is constant: no free-decay oscillation')
    nfft = int(2 ** math.ceil(math.log2(t.size * 8)))
    spec = np.abs(np.fft.rfft(mc * np.hanning(t.size), nfft)) ** 2
    freqs = np.fft.rfftfreq(nfft, dt)
    valid = freqs >= 2.0 / span
    if not valid.any():
        raise TooShortError(f'record of {span:.3g} s too short for any oscillation')
    k = int(np.argmax(np.where(valid, spec, 0.0)))
    if spec[k] < MIN_PEAK_RATIO * float(np.median(spec[valid])) or k == 0 or k >= spec.size - 1:
        raise NoOscillationError(
            'no spectral peak in the torsion moment: the record shows no free-decay oscillation'
        )
    # parabolic interpolation of the log peak
    y0, y1, y2 = np.log(spec[k - 1 : k + 2] + 1e-300)
    den = y0 - 2.0 * y1 + y2
    delta = 0.5 * (y0 - y2) / den if den != 0.0 else 0.0
    f0 = float(freqs[k] + delta * (freqs[1] - freqs[0]))
    if f0 * span < MIN_CYCLES:
        raise TooShortError(
            f'record holds {f0 * span:.1f} periods of the {f0:.3g} Hz oscillation; '
            f'need >= {MIN_CYCLES:g}'
        )
    wd0 = 2.0 * math.pi * f0
    # ---- decay rate from the envelope (weighted by the squared amplitude)
    env = np.abs(np.asarray(hilbert(mc)))
    lo, hi = int(0.1 * t.size), int(0.9 * t.size)
    w = env[lo:hi] ** 2
    ln = np.log(np.maximum(env[lo:hi], 1e-300))
    tt = tau[lo:hi]
    tw = np.sum(w * tt) / np.sum(w)
    lw = np.sum(w * ln) / np.sum(w)
    sigma0 = -float(np.sum(w * (tt - tw) * (ln - lw)) / np.sum(w * (tt - tw) ** 2))
    sigma0 = max(sigma0, 0.0)
    # ---- amplitudes (linear LS given wd0, sigma0) and 1/C1 from the acceleration
    e = np.exp(-sigma0 * tau)
    basis = np.column_stack([e * np.cos(wd0 * tau), e * np.sin(wd0 * tau), np.ones_like(tau)])
    coef, *_ = np.linalg.lstsq(basis, m, rcond=None)
    q0 = np.array([coef[0], coef[1], sigma0, wd0, coef[2], 0.0, 0.0])
    _, dd0 = _model(np.array([coef[0], coef[1], sigma0, wd0, 0.0, 1.0, 0.0]), tau)
    ac = a - np.mean(a)
    denom = float(np.dot(dd0, dd0))
    if denom <= 0.0:
        raise NoOscillationError('cannot relate acceleration and torsion moment')
    q0[5] = float(np.dot(dd0, ac)) / denom
    if not q0[5] > 0.0:
        raise InvalidDataError(
            'acceleration is not in phase with -M_t: check the accelerometer sign'
        )
    q0[6] = float(np.mean(a - q0[5] * dd0))
    # ---- joint weighted nonlinear least squares, two passes (weights from residuals)
    sm = float(np.std(mc)) or 1.0
    sa = float(np.std(ac)) or 1.0
    scale = np.array(
        [max(abs(q0[0]), abs(q0[1]), 1e-12)] * 2 + [max(sigma0, 1e-3 * wd0), wd0, sm, q0[5], sa]
    )

    def resid(qs: np.ndarray, wm: float, wa: float) -> np.ndarray:
        mt, ac_ = _model(qs * scale, tau)
        return np.concatenate([(mt - m) / wm, (ac_ - a) / wa])

    q = q0 / scale
    q_lo = np.full(q.size, -np.inf)
    q_hi = np.full(q.size, np.inf)

    def solve(qq: np.ndarray, wm: float, wa: float) -> LsqResult:
        return levenberg_marquardt(
            lambda x: resid(x, wm, wa), qq, q_lo, q_hi, max_iter=200, max_nfev=2000, ftol=1e-12
        )

    for _ in range(2):
        q = solve(q, sm, sa).x
        mt, am = _model(q * scale, tau)
        sm = float(np.std(mt - m)) or sm
        sa = float(np.std(am - a)) or sa
    sol = solve(q, sm, sa)
    qs = sol.x
    qv = qs * scale
    _, _, sigma, wd, m0, inv_c1, a0 = (float(x) for x in qv)
    wd = abs(wd)
    if inv_c1 <= 0.0:
        raise InvalidDataError('fit gave a non-positive stiffness: check signal signs and units')
    jac = (
        sol.jac
        if sol.jac_current
        else forward_jacobian(
            lambda x: resid(x, sm, sa), qs, sol.fun, q_hi, np.maximum(1e-4 * np.abs(qs), 1e-4)
        )
    )
    n_res = jac.shape[0]
    chi2 = float(np.sum(sol.fun**2)) / max(n_res - qs.size, 1)
    try:
        cov_s = np.linalg.inv(jac.T @ jac) * chi2
    except np.linalg.LinAlgError as exc:
        raise NoOscillationError('free-decay fit is singular (no usable oscillation)') from exc
    cov = cov_s * np.outer(scale, scale)
    idx = [2, 3, 5]  # sigma, wd, 1/C1
    c3 = cov[np.ix_(idx, idx)]
    c1 = 1.0 / inv_c1
    wn = math.hypot(sigma, wd)
    zeta = sigma / wn
    if zeta >= 1.0 or sigma < -3.0 * math.sqrt(max(c3[0, 0], 0.0)):
        raise NoOscillationError(
            f'identified damping ratio {zeta:.3g} is not a free decay (need 0 <= zeta < 1)'
        )
    i1 = c1 / wn**2
    k1 = 2.0 * sigma * i1

    def se(grad: np.ndarray) -> float:
        return float(math.sqrt(max(float(grad @ c3 @ grad), 0.0)))

    dwn = np.array([sigma / wn, wd / wn, 0.0])
    dc1 = np.array([0.0, 0.0, -(c1**2)])
    di1 = dc1 / wn**2 - 2.0 * c1 / wn**3 * dwn
    dk1 = 2.0 * sigma * di1 + np.array([2.0 * i1, 0.0, 0.0])
    dzeta = np.array([1.0 / wn, 0.0, 0.0]) - sigma / wn**2 * dwn
    mt, am = _model(qv, tau)
    return DecayResult(
        I1=i1,
        K1=k1,
        C1=c1,
        f_n_hz=wn / (2.0 * math.pi),
        zeta=zeta,
        I1_se=se(di1),
        K1_se=se(dk1),
        C1_se=se(dc1),
        f_n_hz_se=se(dwn) / (2.0 * math.pi),
        zeta_se=se(dzeta),
        torque_offset=m0,
        accel_offset=a0,
        rms_torque=float(np.sqrt(np.mean((mt - m) ** 2))),
        rms_accel=float(np.sqrt(np.mean((am - a) ** 2))),
        n_samples=int(t.size),
    )
