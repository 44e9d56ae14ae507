"""Live model monitor: the discrepancy workflow on a rolling window of the rig stream.

:class:`WindowMonitor` keeps the last ``window`` seconds of the rig channels
(torsion moment C1*phi1 [N m], angular acceleration w1' [rad/s^2], shaft
speed w2 [rad/s]) and every ``hop`` seconds evaluates the latest window with
the pieces of the offline workflow (:mod:`.select`):

1. **Baseline**: the paper's model (Equ. 1-8, ``mu0``/``mu_inf`` free) fitted
   by output error over the window's stick-started segments
   (:class:`~.fitting.Problem`, :func:`~.fitting.make_segments`), warm-started
   from the previous window; channel weights from the baseline's residuals as
   in :func:`~.select.run_discrepancy`.
2. **Where**: the torsion residual's energy by motion region (stick, slip
   accelerating, slip decelerating = ``slip_end``, +-3 ms around a breakaway;
   phases of Equ. 3-8 from the baseline simulation) and, for the ranking of
   the candidates, the share of the residual variance that its mean in bins
   of each candidate's localising variable explains (:mod:`.localise`).
3. **Best candidate**: while the window's time budget lasts, a quick
   one-effect refit (``mu0``, ``mu_inf`` and the candidate's parameters) of
   the ``max_candidates`` candidates whose localiser explains most; the one
   with the lowest torsion residual is reported, with its identifiability
   (:func:`identifiability`: Gauss-Newton standard error and correlation with
   mu0/mu_inf, for dwell-time stiction the spread of the stick durations).

No rclpy here: the ``model_monitor`` node is a thin shell around this class.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.model import DriveProfile, RigParams
from tribo_estimation.core.record import RigRecord
from tribo_estimation.errors import EstimationError, InvalidDataError, InvalidParameterError

from . import candidates as cand_lib
from .candidates import Candidate, ParamSpec
from .fitting import CHANNELS, MU0, MU_INF, Problem, Record
from .identify import GaussNewton, Identifiability, gauss_newton, identifiability
from .localise import torque_residual
from .select import baseline_starts
from .stats import (
    SLIP_ACCEL,
    SLIP_DECEL,
    STICK,
    FloatArray,
    noise_floor,
    phase_labels,
    rms,
    stick_durations,
    time_since_breakaway,
)

#: Region labels of :attr:`WindowResult.concentration` (``uniform``: no region stands out).
REGIONS: tuple[str, ...] = ('stick', 'slip', 'slip_end', 'breakaway')

#: Half width of the breakaway region [s].
BREAKAWAY_HALF_WIDTH = 3e-3


@dataclass(frozen=True)
class MonitorConfig:
    """Settings of the live model monitor.

    ``window`` evaluated stretch [s]; ``hop`` time between evaluations [s];
    ``candidates`` candidate effects that may be tried (names of
    :mod:`.candidates`; empty = baseline only); ``max_candidates`` at most this
    many are refitted per window (the best ranked first; no further one once
    a candidate leaves only ``partial_ratio`` noise floors);
    ``time_budget`` wall time per window after which no further candidate is
    started [s] (keep it below ``hop``); ``baseline_nfev`` / ``candidate_nfev``
    simulations per fit; ``ratio_threshold`` candidates are only tried when the
    residual rms exceeds this many noise floors [-]; ``min_gain`` a candidate
    is named only if it lowers the torsion residual rms by this fraction [-];
    ``max_rel_se``, ``max_correlation`` identifiability limits of
    :func:`identifiability` (relative standard error, correlation with
    mu0/mu_inf) [-]; ``thin`` the fits (baseline, ranking, refits,
    covariance) use every ``thin``-th segment of the window (the reported
    residuals all of them); ``partial_ratio`` a named candidate that leaves
    more than this many noise floors is flagged ``partial`` [-].
    """

    window: float = 6.0
    hop: float = 2.0
    candidates: tuple[str, ...] = (
        'viscous_friction',
        'frictional_lag',
        'dwell_time_stiction',
        'friction_drift',
        'torque_offset',
        'torque_sensor_lag',
        'bearing_friction',
    )
    max_candidates: int = 2
    time_budget: float = 1.0
    baseline_nfev: int = 15
    candidate_nfev: int = 30
    ratio_threshold: float = 1.3
    min_gain: float = 0.1
    max_rel_se: float = 0.2
    max_correlation: float = 0.999
    thin: int = 2
    partial_ratio: float = 1.5

    def __post_init__(self) -> None:
        """Refuse non-positive or non-finite times and a hop longer than the window."""
        for name in ('window', 'hop', 'time_budget'):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise InvalidParameterError(f'monitor {name} must be > 0 s, got {v}')
        if self.hop > self.window:
            raise InvalidParameterError(
                f'monitor hop ({self.hop} s) must not exceed the window ({self.window} s)'
            )
        if self.thin < 1:
            raise InvalidParameterError(f'monitor thin must be >= 1, got {self.thin}')
        if self.max_candidates < 0:
            raise InvalidParameterError(
                f'monitor max_candidates must be >= 0, got {self.max_candidates}'
            )
        for name in ('baseline_nfev', 'candidate_nfev'):
            if getattr(self, name) < 3:
                raise InvalidParameterError(
                    f'monitor {name} must be >= 3, got {getattr(self, name)}'
                )
        if not 0.0 <= self.min_gain < 1.0:
            raise InvalidParameterError(f'monitor min_gain must be in [0, 1), got {self.min_gain}')
        if not self.max_rel_se > 0.0:
            raise InvalidParameterError(f'monitor max_rel_se must be > 0, got {self.max_rel_se}')
        if not 0.0 < self.max_correlation <= 1.0:
            raise InvalidParameterError(
                f'monitor max_correlation must be in (0, 1], got {self.max_correlation}'
            )
        known = set(cand_lib.names())
        unknown = [c for c in self.candidates if c not in known]
        if unknown:
            raise InvalidParameterError(
                f'monitor candidates {unknown} are not in the library; known: {sorted(known)}'
            )


@dataclass(frozen=True)
class WindowResult:
    """One evaluated window (see :class:`WindowMonitor`).

    Times in s (the time base of the pushed samples), moments in N m,
    acceleration in rad/s^2, speeds in rad/s; ``params``/``units`` of the
    candidate as in :mod:`.candidates`; ``candidate`` is '' when no candidate
    was tried or none lowered the rms by ``min_gain`` (then ``candidate_rms``
    is NaN); ``quality`` 'ok' or ';'-separated flags (``no_sticks``: no stick
    phase in the window: fitted from sliding states, ``mu0`` NaN; also when the
    window cannot be cut into segments at all, ``over_budget``: the window took longer than the
    hop, ``fit_failed``, ``partial``: the named candidate leaves more than
    ``partial_ratio`` noise floors).
    """

    t_start: float
    t_end: float
    n_samples: int
    mu0: float
    mu_inf: float
    drive_speed: float
    residual_rms: float
    residual_rms_accel: float
    noise_floor: float
    ratio: float
    concentration: str
    concentration_share: float
    candidate: str
    params: dict[str, float]
    units: dict[str, str]
    candidate_rms: float
    identifiable: bool
    identifiable_reason: str
    tried: tuple[str, ...]
    processing_time: float
    quality: str = 'ok'
    ranking: tuple[tuple[str, float], ...] = field(default=())


#: The samples of one window, ready to evaluate (a copy; see :meth:`WindowMonitor.add`).
WindowData = RigRecord


# --------------------------------------------------------------------------- localisation


def concentration(
    residual: FloatArray, stick: npt.NDArray[np.bool_], slip_speed: FloatArray, fs: float
) -> tuple[str, float]:
    """Where the residual energy concentrates: region label and its energy share (-).

    Regions (Equ. 3-8 phases of the simulated motion): ``breakaway`` within
    +-3 ms of the end of a stick phase, else ``stick``, ``slip`` (slip
    accelerating) or ``slip_end`` (slip decelerating). The region whose
    energy share exceeds its time share the most is named if that ratio is
    at least 1.5 and its share at least 0.3; otherwise ``uniform`` (share 1).
    ``residual`` in N m (NaN samples ignored), ``slip_speed`` rad/s, ``fs`` Hz.
    """
    r = np.asarray(residual, dtype=np.float64)
    ok = np.isfinite(r)
    labels = phase_labels(np.nan_to_num(slip_speed), stick)
    tb = time_since_breakaway(stick, fs)
    near = np.isfinite(tb) & (np.abs(tb) <= BREAKAWAY_HALF_WIDTH)
    masks = {
        'stick': (labels == STICK) & ~near,
        'slip': (labels == SLIP_ACCEL) & ~near,
        'slip_end': (labels == SLIP_DECEL) & ~near,
        'breakaway': near,
    }
    total = float(np.sum(r[ok] ** 2))
    n = int(np.count_nonzero(ok))
    if total <= 0.0 or n == 0:
        return 'uniform', 1.0
    best, best_ratio, best_share = 'uniform', 0.0, 1.0
    for name, m in masks.items():
        mm = m & ok
        frac = np.count_nonzero(mm) / n
        if frac <= 0.0:
            continue
        share = float(np.sum(r[mm] ** 2)) / total
        if share / frac > best_ratio:
            best, best_ratio, best_share = name, share / frac, share
    if best_ratio >= 1.5 and best_share >= 0.3:
        return best, best_share
    return 'uniform', 1.0


#: Size of the ranking's probe step, as a fraction of a parameter's typical scale (-).
PROBE_FRACTION = 0.1


def _probe(c: Candidate) -> dict[str, float]:
    """Return a model point of candidate ``c`` a small step from the nested model.

    The point is its default start, with parameters that default to 0 set to ``PROBE_FRACTION``
    of their scale (small, so that the step stays in the linear range).
    """
    out = c.default_start()
    for p in c.params:
        if not p.log and out[p.name] == 0.0:
            out[p.name] = min(PROBE_FRACTION * p.scale, p.upper)
    return out


def linearised_gains(
    problem: Problem,
    base: Mapping[str, float],
    pool: Sequence[Candidate],
    seg_mask: npt.NDArray[np.bool_] | None = None,
) -> dict[str, float]:
    """Predicted relative cost decrease of adding each candidate (-), from one simulation each.

    The weighted residual r of the baseline ``base`` (mu0, mu_inf) is
    projected onto the baseline's two Jacobian columns plus the candidate's
    secant direction (the residual change towards :func:`_probe`); the gain
    is the extra share of ``|r|^2`` that direction explains (a score test on
    the linearised model: cheap, used only to rank which candidates get a
    real refit). ``seg_mask`` selects segments.
    """
    r0 = problem.residual_vector(problem.simulate(base, seg_mask))
    total = float(r0 @ r0)
    cols = []
    for p in (MU0, MU_INF):
        vals = dict(base)
        h = 1e-3 * max(abs(float(base[p.name])), 1e-3)
        vals[p.name] = float(base[p.name]) + h
        cols.append((problem.residual_vector(problem.simulate(vals, seg_mask)) - r0) / h)
    Jb = np.column_stack(cols)
    # r0 = measured - simulated; the model moves the simulation, so fit -dr
    coef, *_ = np.linalg.lstsq(Jb, r0, rcond=None)
    e_base = r0 - Jb @ coef
    base_sq = float(e_base @ e_base)
    out: dict[str, float] = {}
    for c in pool:
        vals = dict(base)
        vals.update(_probe(c))
        d = problem.residual_vector(problem.simulate(vals, seg_mask)) - r0
        J = np.column_stack([Jb, d])
        coef, *_ = np.linalg.lstsq(J, r0, rcond=None)
        e = r0 - J @ coef
        out[c.name] = max(base_sq - float(e @ e), 0.0) / total if total > 0 else 0.0
    return out


# --------------------------------------------------------------------------- monitor


def _specs(c: Candidate | None) -> list[ParamSpec]:
    return [MU0, MU_INF, *(c.params if c is not None else ())]


class WindowMonitor:
    """Rolling-window model monitor (see the module docstring).

    ``rig`` (Tab. 1 values, F_N, R), ``drive`` (nominal speed w0 [rad/s],
    start-up ramp; ``nominal_speed`` 0 = the window's mean shaft speed) and
    ``k`` (Equ. 8, s/rad) are known. Feed samples with :meth:`add` (returns
    the windows due) and evaluate them with :meth:`evaluate`, or both with
    :meth:`push`. The time base of the samples is the drive's (s since the
    drive started: the ramp and the drift effects refer to it).
    """

    def __init__(
        self,
        rig: RigParams,
        drive: DriveProfile,
        *,
        k: float = 2.0,
        config: MonitorConfig | None = None,
    ) -> None:
        self.rig = rig
        self.drive = drive
        self.k = float(k)
        self.config = config or MonitorConfig()
        self._chunks: list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]] = []
        self._n = 0
        self._fs: float | None = None
        self._next_end: float | None = None
        self._last_values: dict[str, float] | None = None

    # ------------------------------------------------------------------ input
    def reset(self) -> None:
        """Forget the buffered samples (after a gap or a restart of the stream)."""
        self._chunks.clear()
        self._n = 0
        self._next_end = None

    def add(
        self,
        time: npt.ArrayLike,
        torsion_moment: npt.ArrayLike,
        angular_acceleration: npt.ArrayLike,
        speed: npt.ArrayLike,
        *,
        sample_rate: float | None = None,
    ) -> list[WindowData]:
        """Append contiguous samples; return the windows that became due.

        ``time`` [s] must continue the buffered samples at the same rate (a
        jump resets the buffer: windows never bridge a gap); ``sample_rate``
        [Hz] if known (else estimated from ``time``). A window is due
        every ``hop`` s once ``window`` s are buffered; if several became due
        at once only the latest is returned (the monitor always evaluates the
        newest data).
        """
        t = np.asarray(time, dtype=np.float64).reshape(-1)
        cols = [
            np.asarray(a, dtype=np.float64).reshape(-1)
            for a in (torsion_moment, angular_acceleration, speed)
        ]
        if any(c.size != t.size for c in cols):
            raise InvalidDataError(
                f'monitor input arrays differ in length: time {t.size}, {[c.size for c in cols]}'
            )
        if t.size == 0:
            return []
        if sample_rate is not None or t.size > 1:
            if sample_rate is not None:
                if not (math.isfinite(sample_rate) and sample_rate > 0.0):
                    raise InvalidDataError(f'monitor sample_rate must be > 0 Hz, got {sample_rate}')
                fs = float(sample_rate)
            else:
                dt = float(np.median(np.diff(t)))
                if not dt > 0:
                    raise InvalidDataError('monitor input time is not increasing')
                fs = 1.0 / dt
            if self._fs is None or abs(fs - self._fs) > 1e-6 * fs:
                if self._fs is not None:
                    self.reset()
                self._fs = fs
        if self._fs is None:
            return []
        if self._chunks:
            expected = self._chunks[-1][0][-1] + 1.0 / self._fs
            if abs(t[0] - expected) > 0.5 / self._fs:
                self.reset()
        self._chunks.append((t, *cols))  # type: ignore[arg-type]
        self._n += t.size
        cfg = self.config
        n_win = round(cfg.window * self._fs)
        if self._next_end is None:
            self._next_end = self._chunks[0][0][0] + (n_win - 1) / self._fs
        out: list[WindowData] = []
        t_last = t[-1]
        if t_last + 0.5 / self._fs >= self._next_end and self._n >= n_win:
            # the latest complete window ending at a hop boundary
            hops = math.floor((t_last - self._next_end) / cfg.hop + 1e-9)
            end = self._next_end + hops * cfg.hop
            self._next_end = end + cfg.hop
            tt = np.concatenate([c[0] for c in self._chunks])
            j1 = int(np.searchsorted(tt, end + 0.5 / self._fs))
            j0 = j1 - n_win
            if j0 >= 0:
                arrs = [np.concatenate([c[i] for c in self._chunks])[j0:j1] for i in range(1, 4)]
                tq, ac, sp = (a.copy() for a in arrs)
                out.append(WindowData(tt[j0:j1].copy(), tq, ac, sp))
        # trim what no future window needs: chunks that end before the next window
        # starts (a window may end inside the newest chunk: trimming by the newest
        # sample would drop the start of the window due now)
        first_needed = self._next_end - (n_win - 0.5) / self._fs
        while self._chunks and self._chunks[0][0][-1] < first_needed:
            self._n -= self._chunks.pop(0)[0].size
        return out

    def push(
        self,
        time: npt.ArrayLike,
        torsion_moment: npt.ArrayLike,
        angular_acceleration: npt.ArrayLike,
        speed: npt.ArrayLike,
    ) -> list[WindowResult]:
        """:meth:`add` and :meth:`evaluate` the due windows (for offline use and tests)."""
        return [
            self.evaluate(w) for w in self.add(time, torsion_moment, angular_acceleration, speed)
        ]

    # ------------------------------------------------------------- evaluation
    def _empty(self, w: WindowData, t0: float, quality: str, drive_speed: float) -> WindowResult:
        return WindowResult(
            t_start=float(w.time[0]),
            t_end=float(w.time[-1]),
            n_samples=int(w.time.size),
            mu0=math.nan,
            mu_inf=math.nan,
            drive_speed=drive_speed,
            residual_rms=math.nan,
            residual_rms_accel=math.nan,
            noise_floor=noise_floor(w.torsion_moment - np.mean(w.torsion_moment)),
            ratio=math.nan,
            concentration='uniform',
            concentration_share=math.nan,
            candidate='',
            params={},
            units={},
            candidate_rms=math.nan,
            identifiable=False,
            identifiable_reason=quality,
            tried=(),
            processing_time=_time.perf_counter() - t0,
            quality=quality,
        )

    def evaluate(self, w: WindowData) -> WindowResult:
        """Baseline fit, localisation and the best single candidate of one window."""
        cfg = self.config
        t0 = _time.perf_counter()
        w0 = self.drive.nominal_speed
        if w0 <= 0.0:
            w0 = float(np.mean(w.speed))
        drive = DriveProfile(w0, self.drive.ramp_time)
        try:
            rec = Record(w.time, w.torsion_moment, w.angular_acceleration, w.speed)
            # the Problem cuts the window into stick-started segments (make_segments)
            pb = Problem(rec, self.rig, drive, k=self.k)
        except EstimationError:
            return self._empty(w, t0, 'no_sticks', w0)
        segs = pb.segments
        # the fits use every `thin`-th segment; the reported residuals all of them
        cmask = (np.arange(segs.n) % cfg.thin == 0) if cfg.thin > 1 and segs.n >= 6 else None
        try:
            start = self._last_values or baseline_starts(pb)[1]
            base = pb.fit([MU0, MU_INF], start, seg_mask=cmask, max_nfev=cfg.baseline_nfev).values
            sim = pb.simulate(base)
            floors = {}
            for ch in CHANNELS:
                m = pb.measured(ch)[sim.covered]
                floors[ch] = max(noise_floor(m), 1e-3 * float(np.std(m)), 1e-12)
            pb.set_residual_weights(sim, floors)
        except EstimationError:
            return self._empty(w, t0, 'fit_failed', w0)
        self._last_values = {'mu0': base['mu0'], 'mu_inf': base['mu_inf']}
        cov = sim.covered
        r = torque_residual(pb, sim)
        base_rms = rms(r[cov])
        sigma = noise_floor(r[cov])
        ratio = base_rms / sigma if sigma > 0 else math.inf
        accel_rms = rms((rec.angular_acceleration - sim.angular_acceleration)[cov])
        stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
        where, share = concentration(r, stick, np.asarray(sim.slip_speed), rec.fs)
        best: tuple[Candidate, dict[str, float], float] | None = None
        tried: list[str] = []
        ranking: tuple[tuple[str, float], ...] = ()
        if ratio >= cfg.ratio_threshold and cfg.candidates and cfg.max_candidates > 0:
            # rank by the linearised gain (one simulation each), refit the best few
            pool = [cand_lib.get(n) for n in cfg.candidates]
            gains = linearised_gains(pb, base, pool, cmask)
            ranked = sorted(pool, key=lambda c: -gains[c.name])
            ranking = tuple((c.name, gains[c.name]) for c in ranked)
            for c in ranked[: cfg.max_candidates]:
                if tried and _time.perf_counter() - t0 > cfg.time_budget:
                    break
                if best is not None and best[2] <= cfg.partial_ratio * sigma:
                    break  # the best so far leaves only noise: nothing more to explain
                st = dict(base)
                st.update(c.default_start())
                try:
                    vals = pb.fit(_specs(c), st, seg_mask=cmask, max_nfev=cfg.candidate_nfev).values
                except EstimationError:
                    continue
                tried.append(c.name)
                c_rms = pb.torque_rms(pb.simulate(vals))
                if best is None or c_rms < best[2]:
                    best = (c, vals, c_rms)
        name, params, units, c_rms = '', {}, {}, math.nan
        ident = Identifiability(False, 'no candidate tried')
        if best is not None:
            c, vals, b_rms = best
            gn = gauss_newton(pb, _specs(c), vals, cmask)
            ident = identifiability(
                c.name,
                c.param_names,
                gn,
                stick_durations(stick[cov], rec.fs),
                max_rel_se=cfg.max_rel_se,
                max_correlation=cfg.max_correlation,
            )
            if b_rms <= (1.0 - cfg.min_gain) * base_rms:
                name, c_rms = c.name, b_rms
                params = {n: float(vals[n]) for n in c.param_names}
                units = c.units()
            else:
                # nothing named; say why the best one could not help if the record says so
                ident = Identifiability(
                    False,
                    f'no tried candidate ({", ".join(tried)}) lowers the residual by '
                    f'{100 * cfg.min_gain:g} %'
                    + ('' if ident.ok else f'; {c.name}: {ident.reason}'),
                )
        elif ratio < cfg.ratio_threshold:
            ident = Identifiability(
                False, f'residual within {cfg.ratio_threshold:g} x the noise floor: nothing to add'
            )
        elapsed = _time.perf_counter() - t0
        flags = []
        if segs.sliding:
            # no stick phase in the window: analysed from measured sliding states
            # (slip-slip, steady sliding); mu0 acts only at breakaways and is not
            # determined
            flags.append('no_sticks')
            base = {**base, 'mu0': math.nan}
        if name and c_rms > cfg.partial_ratio * sigma:
            flags.append('partial')
        if elapsed > cfg.hop:
            flags.append('over_budget')
        return WindowResult(
            t_start=float(w.time[0]),
            t_end=float(w.time[-1]),
            n_samples=int(w.time.size),
            mu0=float(base['mu0']),
            mu_inf=float(base['mu_inf']),
            drive_speed=w0,
            residual_rms=base_rms,
            residual_rms_accel=accel_rms,
            noise_floor=sigma,
            ratio=ratio,
            concentration=where,
            concentration_share=share,
            candidate=name,
            params=params,
            units=units,
            candidate_rms=c_rms,
            identifiable=ident.ok,
            identifiable_reason=ident.reason,
            tried=tuple(tried),
            processing_time=elapsed,
            quality=';'.join(flags) or 'ok',
            ranking=ranking,
        )


__all__ = [
    'REGIONS',
    'GaussNewton',
    'Identifiability',
    'MonitorConfig',
    'WindowData',
    'WindowMonitor',
    'WindowResult',
    'concentration',
    'gauss_newton',
    'identifiability',
    'linearised_gains',
]
