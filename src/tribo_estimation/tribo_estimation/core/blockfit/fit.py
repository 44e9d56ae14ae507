"""The output-error fit of one block's friction law (paper section 2.5, Fig. 4/5).

For each block the friction law of Equ. 8,
``mu(|v|) = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` (with the paper's
deceleration rule), is identified by minimising the squared error between the
simulated and the measured torsion moment ``C1*phi1`` [N m] and chamber
acceleration ``w1'`` [rad/s^2], each weighted by its noise level, with the rig
model of Equ. 1-3 and 6 driven at the measured drive speed.

1. **Initial estimate (equation error)**: at breakaway the friction moment
   equals ``F_N*R*mu0`` (Equ. 5), and after the slip-speed peak of each
   sliding phase it equals ``F_N*R*mu_inf`` (deceleration rule); medians of
   the observer moment at these instants give mu0 and mu_inf
   (:func:`initial_estimate`, :func:`initial_k`).
2. **Output-error refinement (multiple shooting)**: the block is split at the
   measured stick phases (:func:`..sticks.detect_sticks`). During sticking
   ``w1 = w2`` and the full state is known from the measurements:
   ``phi1 = M_t/C1``, ``w = phi1'`` from a local cubic through ``M_t``, and the
   shaft twist ``phi2 - phi0`` from the stuck equations of motion (Equ. 1, 2
   with Equ. 4). Each segment is simulated with the compiled kernel from the
   state late in its stick phase (the stuck motion does not depend on the
   friction law before breakaway) to the next stick phase, so a 1 s fit
   cannot drift out of phase. Long sliding stretches (slip-slip) get further
   nodes every 50 ms, their state from the torsion moment, the tachometer and
   Equ. 2. A Levenberg-Marquardt iteration with forward-difference
   sensitivities (typically five kernel passes over the block) minimises the
   weighted residuals. Acceleration samples next to a switching event (where
   the acceleration jumps) are left out of the comparison: their value changes
   discontinuously when the event crosses a sample instant.
3. **Standard errors**: cluster-robust (sandwich) over the shooting segments,
   so correlated residuals within a segment do not make them optimistic.

Which estimates a block reports (identifiability of mu0, quality flags) is
decided by :mod:`.evaluate`. Every value is in SI units: moments N m, speeds
rad/s, accelerations rad/s^2, time s, coefficients dimensionless, k in s/rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ...errors import FitError
from .. import kernel as kn
from ..drive import DriveEstimate
from ..lsq import LsqResult, cluster_robust_se, levenberg_marquardt
from ..model import DriveProfile, FrictionLaw, RigParams, pack_params
from ..shooting import DriveKnots, local_cubic, shoot, sliding_states, stuck_states, window_mean
from ..signal import CHAMBER_HALF, noise_level, runs
from .results import BlockConfig, BlockData, BoolArray, FitOutcome, FloatArray

IntArray = npt.NDArray[np.int64]

#: Shooting nodes sit this many samples before the detected end of a stick phase
#: (the stuck motion before it does not depend on the friction law) [samples].
_LEAD = 15

#: Shortest stick phase used as a shooting node [samples].
_MIN_NODE = 2

#: Spacing of shooting nodes in long sliding stretches [s], and their distance
#: after a breakaway (past the slip-speed peak) [s].
_SLIDE_SPACING = 0.05
_SLIDE_SETTLE = 0.02


def _sliding_nodes(
    vabs: FloatArray,
    stick_starts: IntArray,
    stick_ends: IntArray,
    fs: float,
) -> IntArray:
    """Place extra shooting nodes in long sliding stretches (slip-slip).

    In every
    ``_SLIDE_SPACING`` s window, at least ``_SLIDE_SETTLE`` s after a breakaway
    and before the next stick phase, the sample of the largest slip speed
    ``vabs`` = |w2 - w1| [rad/s] (its slip-speed peak: the deceleration rule
    holds right after it).
    """
    n = vabs.shape[0]
    spacing = max(1, round(_SLIDE_SPACING * fs))
    settle = max(1, round(_SLIDE_SETTLE * fs))
    nodes: list[int] = []
    slide_starts = np.r_[0, stick_ends]
    slide_ends = np.r_[stick_starts, n]
    for a, b in zip(slide_starts, slide_ends, strict=True):
        first = int(a) + (settle if a > 0 else CHAMBER_HALF)
        last = int(b) - CHAMBER_HALF - 1
        for w in range(first, last - spacing // 2, spacing):
            hi = min(w + spacing, last)
            nodes.append(w + int(np.argmax(vabs[w:hi])))
    return np.array(sorted(set(nodes)), dtype=np.int64)


def initial_estimate(d: BlockData, fnr: float, min_stick: int = 2) -> tuple[float, float]:
    """Equation-error estimate of (mu0, mu_inf) from the observer moment M [N m].

    mu0: median over stick phases of max |M| around the breakaway (the end of
    the stick phase and the first sliding samples), divided by F_N*R (Equ. 5). mu_inf: median
    |M|/(F_N*R) over the second half of each sliding phase, where the
    deceleration rule gives mu = mu_inf. Without sticking mu0 is NaN and mu_inf
    the median |M|/(F_N*R) of the block.
    """
    m = np.abs(d.moment)
    starts, ends = runs(d.stick)
    keep = (ends - starts) >= min_stick
    starts, ends = starts[keep], ends[keep]
    n = len(d)
    if starts.size == 0:
        return math.nan, float(np.median(m)) / fnr
    # |M_stick| grows until breakaway (Equ. 5), then mu(|v|) falls: the maximum of
    # |M| over the end of the stick phase and the first sliding samples
    peaks = [
        float(np.max(m[max(s0, e - 40) : min(n, e + 3)]))
        for s0, e in zip(starts, ends, strict=True)
        if e < n
    ]
    mu0 = float(np.median(peaks)) / fnr if peaks else float(np.max(m)) / fnr
    tails: list[FloatArray] = []
    for e, s_next in zip(ends, np.r_[starts[1:], n], strict=True):
        if s_next - e >= 4:
            mid = e + (s_next - e) // 2
            tails.append(m[mid:s_next])
    mu_inf = float(np.median(np.concatenate(tails))) / fnr if tails else float(np.min(m)) / fnr
    return mu0, mu_inf


def initial_k(d: BlockData, fnr: float, mu0: float, mu_inf: float) -> float:
    """Equation-error estimate of the Stribeck constant k [s/rad] (Equ. 8).

    In the acceleration part of a sliding phase ``y = (|M|/(F_N*R) - mu_inf) /
    (mu0 - mu_inf) = exp(-k*|v|)`` with the slip speed ``v = w2 - w1``; samples
    with ``0.1 < y < 0.9`` (after the peak y = 0) give ``k`` by least squares of
    ``log y = -k*|v|`` through the origin. NaN when there are too few samples.
    """
    dmu = mu0 - mu_inf
    if not (math.isfinite(dmu) and dmu > 0.0) or d.moment.size != d.torsion.size:
        return math.nan
    y = (np.abs(d.moment) / fnr - mu_inf) / dmu
    v = np.abs(d.speed - d.chamber_speed)
    sel = (~d.stick) & (y > 0.1) & (y < 0.9) & (v > 0.05)
    if int(sel.sum()) < 10:
        return math.nan
    vv = v[sel]
    k = -float(np.dot(vv, np.log(y[sel]))) / float(np.dot(vv, vv))
    return k if math.isfinite(k) and k > 0.0 else math.nan


#: Acceleration samples this close to a switching event are not compared [samples].
_JUMP_GUARD = 3


def _jump_guard(a: FloatArray, threshold: float) -> BoolArray:
    """Mark the samples near a jump of the (simulated) acceleration.

    True within +-_JUMP_GUARD samples of a second difference above ``threshold``
    [rad/s^2]; NaN samples count too.
    """
    n = a.shape[0]
    bad = ~np.isfinite(a)
    d2 = np.zeros(n)
    ok = np.isfinite(a)
    aa = np.where(ok, a, 0.0)
    d2[1:-1] = np.abs(aa[2:] - 2.0 * aa[1:-1] + aa[:-2])
    jump = (d2 > threshold) & ok
    if jump.any():
        k = np.ones(2 * _JUMP_GUARD + 1)
        jump = np.convolve(jump.astype(float), k, mode='same') > 0.0
    return jump | bad


#: Samples on either side of a replaced one (spike, burst) that the fit leaves out
#: too: the chamber speed and the observer moment spread a repair over a few
#: samples [samples].
_REPAIR_GUARD = 3


def _dilate(mask: BoolArray, width: int) -> BoolArray:
    """Widen the True runs of ``mask`` by ``width`` samples on either side.

    Parameters
    ----------
    mask : numpy.ndarray
        Samples to widen (bool).
    width : int
        Samples added on either side of each True sample.

    Returns
    -------
    numpy.ndarray
        The widened mask (bool, shape of ``mask``).
    """
    k = np.ones(2 * width + 1)
    return np.asarray(np.convolve(mask.astype(np.float64), k, mode='same') > 0.0)


@dataclass(frozen=True)
class _Nodes:
    """Shooting segments of one block: start/end sample, start state, drive piece."""

    start: IntArray
    end: IntArray
    states: FloatArray
    drive: DriveKnots


def _shooting_nodes(
    p: FloatArray, d: BlockData, drive: DriveEstimate, speed_lag: float
) -> tuple[_Nodes, bool]:
    """Place the shooting nodes of a block.

    Segment starts: late in every stick phase (the stuck motion does not depend
    on the friction law until breakaway) and every 50 ms in long sliding
    stretches; states from :mod:`.shooting`. Returns the nodes and whether the
    block has stick phases.
    """
    n = len(d)
    starts_s, ends_s = runs(d.stick)
    keep = (ends_s - starts_s) >= _MIN_NODE
    starts_s, ends_s = starts_s[keep], ends_s[keep]
    c1 = float(p[kn.P_C1])
    t_of = np.arange(n) / d.fs  # block-local time (see fit_block)
    dk = DriveKnots.from_estimate(drive)
    node_idx: list[IntArray] = []
    node_states: list[FloatArray] = []
    if starts_s.size:
        anchors = np.maximum(
            starts_s + np.minimum(CHAMBER_HALF, (ends_s - starts_s - 1) // 2), ends_s - _LEAD
        )
        mt, slope = local_cubic(d.torsion, anchors, starts_s, ends_s)
        w = np.where(np.isfinite(slope), slope * d.fs / c1, d.chamber_speed[anchors])
        acc = window_mean(d.accel, anchors, 2, starts_s, ends_s)
        ts = t_of[anchors]
        node_idx.append(anchors)
        node_states.append(
            stuck_states(p, ts, mt, w, acc, np.zeros(ts.size), dk.time, dk.speed, dk.shape)
        )
    slide = _sliding_nodes(np.abs(d.speed - d.chamber_speed), starts_s, ends_s, d.fs)
    if slide.size == 0 and starts_s.size == 0:
        slide = np.zeros(1, dtype=np.int64)  # short block: start at its first sample
    if slide.size:
        mt, dmt = local_cubic(d.torsion, slide)
        y, dy = local_cubic(d.speed, slide)
        mom, _ = local_cubic(d.moment, slide)
        w1 = np.where(np.isfinite(dmt), dmt * d.fs / c1, d.chamber_speed[slide])
        w2d = np.where(np.isfinite(dy), dy * d.fs, 0.0)
        w2 = y + speed_lag * w2d  # first-order sensor lag inverted: w2 = y + tau*y'
        ts = t_of[slide]
        node_idx.append(slide)
        node_states.append(sliding_states(p, ts, mt, w1, w2, w2d, mom, dk.time, dk.speed, dk.shape))
    idx = np.concatenate(node_idx)
    states = np.vstack(node_states)
    order = np.argsort(idx, kind='stable')
    idx, states = idx[order], states[order]
    idx, first = np.unique(idx, return_index=True)
    states = states[first]
    end = np.r_[idx[1:], n].astype(np.int64)
    return _Nodes(idx, end, states, dk), bool(starts_s.size)


def _noise_weights(cfg: BlockConfig, d: BlockData, fallback_torque: float) -> tuple[float, float]:
    """Noise levels of the torsion moment [N m] and the acceleration [rad/s^2]."""
    sig_m = cfg.noise_torque if cfg.noise_torque is not None else noise_level(d.torsion)
    sig_a = cfg.noise_accel if cfg.noise_accel is not None else noise_level(d.accel)
    sig_m = sig_m if math.isfinite(sig_m) and sig_m > 0.0 else fallback_torque
    sig_a = sig_a if math.isfinite(sig_a) and sig_a > 0.0 else 1.0
    return sig_m, sig_a


#: Parameters the fit can estimate, in this order: name, index in the kernel's
#: parameter vector, forward-difference step, upper bound (mu0, mu_inf [-], k [s/rad]).
_FIT_PARAMS: tuple[tuple[str, int, float, float], ...] = (
    ('mu0', kn.P_MU0, 0.05 * 1e-4, 10.0),
    ('mu_inf', kn.P_MUINF, 0.05 * 1e-4, 10.0),
    ('k', kn.P_K, 1.0 * 1e-4, 1e3),
)


def _start_values(
    d: BlockData, fnr: float, init: tuple[float, float] | None
) -> tuple[float, float]:
    """Choose the start values (mu0, mu_inf).

    The equation-error estimate, with the finite
    entries of ``init`` in its place; mu0 NaN when the block has no stick phase.

    Raises
    ------
    FitError
        mu_inf is not finite or not below 10 (observer moment implausible).
    """
    mu0_i, muinf_i = initial_estimate(d, fnr, _MIN_NODE)
    if init is not None:
        mu0_i = init[0] if math.isfinite(init[0]) else mu0_i
        muinf_i = init[1] if math.isfinite(init[1]) else muinf_i
    if not (math.isfinite(muinf_i) and abs(muinf_i) < 10.0):
        raise FitError('no usable start value for mu_inf (observer moment not plausible)')
    return mu0_i, muinf_i


def _theta0(
    d: BlockData, fnr: float, start: tuple[float, float], k: float, n_par: int
) -> FloatArray:
    """Start vector of the first ``n_par`` of (mu0, mu_inf, k) [-, -, s/rad].

    Without a stick phase mu0 starts at the largest observer moment over F_N*R
    (slip-slip: mu0 acts only where a sliding phase restarts on the curve of
    Equ. 8); a fitted k starts at :func:`initial_k` (else at ``k``).

    Raises
    ------
    FitError
        a start value is not finite or mu0 is above 10.
    """
    mu0_i, muinf_i = start
    if not math.isfinite(mu0_i):
        mu0_i = float(np.max(np.abs(d.moment))) / fnr
    k_i = k
    if n_par == 3:
        k_eq = initial_k(d, fnr, mu0_i, muinf_i)
        k_i = k_eq if math.isfinite(k_eq) else k
    theta0 = np.array([max(v, 0.0) for v in (mu0_i, muinf_i, k_i)[:n_par]])
    if not np.all(np.isfinite(theta0)) or theta0[0] > 10.0:
        raise FitError('start values of the block fit are not plausible')
    return theta0


@dataclass(frozen=True)
class _Problem:
    """The weighted output-error problem of one block (multiple shooting).

    ``p0``: kernel parameter vector with the fixed parameters (never mutated);
    ``index``: its entries the fit estimates; ``used``: the compared samples
    (from the first shooting node on); ``sig_m`` torsion-moment noise [N m];
    ``clusters``: shooting segment of each residual (torsion, then
    acceleration), for the standard errors.
    """

    p0: FloatArray
    index: list[int]
    nodes: _Nodes
    dt: float
    n_sub: int
    n: int
    used: IntArray
    meas_torsion: FloatArray
    meas_accel: FloatArray
    sig_m: float
    clusters: IntArray
    keep: FloatArray
    _recent: dict[bytes, FloatArray] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def build(
        cls, p0: FloatArray, n_par: int, nodes: _Nodes, d: BlockData, sig_m: float
    ) -> _Problem:
        """Build the problem of block ``d`` for the first ``n_par`` of (mu0, mu_inf, k)."""
        n = len(d)
        dt = 1.0 / d.fs
        used = np.arange(int(nodes.start[0]), n)
        # clusters for the standard errors: the shooting segments (nearly independent)
        seg_id = np.searchsorted(nodes.start, used, side='right') - 1
        clusters = np.concatenate((seg_id, seg_id)).astype(np.int64)
        keep = np.ones(n)
        if d.repaired is not None and d.repaired.any():
            keep[_dilate(d.repaired, _REPAIR_GUARD)] = 0.0
        return cls(
            p0=p0,
            index=[ix for _, ix, _, _ in _FIT_PARAMS[:n_par]],
            nodes=nodes,
            dt=dt,
            n_sub=kn.substeps_for(p0, dt),
            n=n,
            used=used,
            meas_torsion=d.torsion[used],
            meas_accel=d.accel[used],
            sig_m=sig_m,
            clusters=clusters,
            keep=keep[used],
        )

    def simulate(self, theta: FloatArray) -> FloatArray:
        """Simulate the block at ``theta``.

        Returns the kernel output channels (new arrays, never mutated; the last
        four simulations are kept).
        """
        key = np.asarray(theta, dtype=np.float64).tobytes()
        if key in self._recent:
            return self._recent[key]
        p = self.p0.copy()
        p[self.index] = theta
        out = np.full((kn.N_CH, self.n), np.nan)
        dk = self.nodes.drive
        nd = self.nodes
        shoot(p, nd.states, nd.start, nd.end, dk.time, dk.speed, dk.shape, self.dt, self.n_sub, out)
        if len(self._recent) >= 4:
            self._recent.pop(next(iter(self._recent)))
        self._recent[key] = out
        return out

    def accel_weights(self, theta0: FloatArray, sig_a: float) -> FloatArray:
        """Weigh the compared acceleration samples [s^2/rad].

        ``1/sig_a`` (0 at replaced samples), 0
        next to a switching event of the simulation at ``theta0`` (+-_JUMP_GUARD
        samples; the acceleration jumps when the event crosses the sample instant).
        The torsion moment (continuous in theta) keeps every sample.
        """
        sim0 = self.simulate(theta0)
        guard = _jump_guard(sim0[kn.OUT_ACCEL], 10.0 * sig_a)[self.used]
        return np.where(guard, 0.0, self.keep / sig_a)

    def residual(self, theta: FloatArray, w_acc: FloatArray) -> FloatArray:
        """Weighted residuals (torsion moment, then acceleration) at ``theta`` [-]."""
        out = self.simulate(theta)
        return np.concatenate(
            (
                (out[kn.OUT_TORSION, self.used] - self.meas_torsion) * (self.keep / self.sig_m),
                (out[kn.OUT_ACCEL, self.used] - self.meas_accel) * w_acc,
            )
        )

    def xtol(self, x: FloatArray, J: FloatArray, r: FloatArray) -> FloatArray:
        """Step tolerance: far below the statistical uncertainty (or 1e-4 relative)."""
        se = cluster_robust_se(J, r, self.clusters)
        return np.maximum(np.where(np.isfinite(se), 0.1 * se, 0.0), 1e-4 * np.abs(x)) + 1e-12


def _solve(prob: _Problem, theta0: FloatArray, w_acc: FloatArray, max_iter: int) -> LsqResult:
    """Levenberg-Marquardt on the weighted residuals, bounded to [0, upper]."""
    n_par = theta0.size
    spec = _FIT_PARAMS[:n_par]
    return levenberg_marquardt(
        lambda th: prob.residual(th, w_acc),
        theta0,
        np.zeros(n_par),
        np.array([hi for _, _, _, hi in spec]),
        max_iter=max_iter,
        max_nfev=4 * max_iter * (1 + n_par),
        abs_step=np.array([step for _, _, step, _ in spec]),
        xtol=prob.xtol,
        reuse_jacobian=True,
        lam0=1e-4,
    )


def fit_block(
    rig: RigParams,
    d: BlockData,
    w0: float,
    k: float,
    cfg: BlockConfig,
    init: tuple[float, float] | None = None,
    drive: DriveEstimate | None = None,
) -> FitOutcome:
    """Fit mu0, mu_inf (and k if ``cfg.fit_k``) of Equ. 8 to one block (see module doc).

    Args:
        rig: rig parameters (Tab. 1, F_N [N], R [m]).
        d: measured and observed block signals.
        w0: drive speed [rad/s] when ``drive`` is not given (constant).
        k: Stribeck constant [s/rad] (start value when fitted).
        cfg: fit settings.
        init: start values (mu0, mu_inf); default the equation-error estimate.
        drive: measured drive profile (:func:`drive.estimate_drive`) on block-local
            time: seconds since the block's first sample, ``d.t0``. The fit never
            integrates on absolute time: epoch stamps (about 1.8e9 s) would leave
            ``t + dt`` with a rounding error of 2e-7 s, 0.2 % of a 10 kHz step.

    Raises
    ------
    FitError
        too few samples, no usable start value or non-finite residuals.
    """
    n = len(d)
    if n < 20:
        raise FitError(f'block has only {n} samples; at least 20 are needed')
    fnr = rig.F_N * rig.R
    if fnr <= 0.0:
        raise FitError('F_N*R is zero: no contact, no friction to fit')
    start = _start_values(d, fnr, init)
    if drive is None:
        drive = DriveEstimate(np.array([0.0, n / d.fs]), np.array([w0, w0]), w0, w0, 0.0)
    sig_m, sig_a = _noise_weights(cfg, d, 1e-3 * max(1.0, fnr * start[1]))
    p0 = pack_params(rig, FrictionLaw(0.1, 0.1, k), DriveProfile(w0))
    nodes, sticky = _shooting_nodes(p0, d, drive, cfg.speed_lag)
    n_par = 3 if cfg.fit_k and sticky else 2
    theta0 = _theta0(d, fnr, start, k, n_par)
    prob = _Problem.build(p0, n_par, nodes, d, sig_m)
    sol = _solve(prob, theta0, prob.accel_weights(theta0, sig_a), cfg.max_iter)
    se = cluster_robust_se(sol.jac, sol.fun, prob.clusters)
    sim_t = prob.simulate(sol.x)[kn.OUT_TORSION]
    return FitOutcome(
        mu0=float(sol.x[0]),
        mu_inf=float(sol.x[1]),
        k=float(sol.x[2]) if n_par == 3 else k,
        mu0_se=float(se[0]),
        mu_inf_se=float(se[1]),
        k_se=float(se[2]) if n_par == 3 else 0.0,
        rms_residual=float(
            np.sqrt(np.mean(((sim_t[prob.used] - prob.meas_torsion)[prob.keep > 0.0]) ** 2))
        ),
        simulated=sim_t,
        n_iter=sol.n_iter,
        n_eval=sol.nfev + 1,
        converged=sol.converged,
        w0=drive.mean_speed(0.0, n / d.fs),
    )
