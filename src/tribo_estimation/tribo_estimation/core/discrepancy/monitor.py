"""Live model monitor: the missing-physics pipeline on a rolling window of the rig stream.

:class:`WindowMonitor` keeps the last ``window`` seconds of the rig channels
(torsion moment C1*phi1 [N m], angular acceleration w1' [rad/s^2], shaft
speed w2 [rad/s]) and every ``hop`` seconds evaluates the latest window with the
pipeline of the offline workflow (:func:`.pipeline.find_missing_physics`): the
same steps and decision rules, the live budget (:meth:`.pipeline.Policy.live`:
fewer bootstrap replicas and simulations, a wall-time budget within the hop).
Each window reports the baseline (the paper's model, Equ. 1-8), its residual
against the noise floor, where the residual concentrates (stick, slip,
breakaway, slip end), and the verdict: the named family, the set the window cannot
tell apart, or the best partial explanation.

No rclpy here: the ``model_monitor`` node is a thin shell around this class.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
from tribo_estimation.core.record import RigRecord
from tribo_estimation.errors import EstimationError, InvalidDataError, InvalidParameterError

from . import candidates as cand_lib
from .localise import torque_residual
from .pipeline import Policy, find_missing_physics
from .pipeline.decide import NAMED, NOTHING_MISSING
from .pipeline.null import NullLaw
from .stats import (
    SLIP_ACCEL,
    SLIP_DECEL,
    STICK,
    FloatArray,
    noise_floor,
    phase_labels,
    rms,
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
    ``candidates`` effect families screened (names of :mod:`.candidates`; empty =
    the whole library); ``time_budget`` wall time per window after which no further
    form is screened or refined [s] (keep it below ``hop``); ``alpha`` the
    adequacy decisions' false-alarm rate [-]; ``replicas`` bootstrap replicas of
    the window's null law (5: the prediction bound's Student t factor at alpha = 1 %
    over three statistics is 5.7, against 14 with 3 replicas); ``fresh_replicas``
    replicas each later window measures on its own baseline, pooled with the newest
    replicas of the windows before (the windows overlap: the same process, the same
    noise; the first window after a start or a gap measures all ``replicas``;
    ``fresh_replicas`` = ``replicas``: every window measures its own).
    """

    window: float = 6.0
    hop: float = 2.0
    candidates: tuple[str, ...] = ()
    time_budget: float = 1.5
    alpha: float = 0.01
    replicas: int = 5
    fresh_replicas: int = 2

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
        if not 2 <= self.fresh_replicas <= self.replicas:
            raise InvalidParameterError(
                f'monitor fresh_replicas must be in [2, replicas], got {self.fresh_replicas}'
            )
        if self.replicas < 3:
            # two replicas give a Student t bound with one degree of freedom: so wide
            # that no window would ever be called inadequate
            raise InvalidParameterError(f'monitor replicas must be >= 3, got {self.replicas}')
        if not 0.0 < self.alpha < 0.5:
            raise InvalidParameterError(f'monitor alpha must be in (0, 0.5), got {self.alpha}')
        known = set(cand_lib.families())
        unknown = [c for c in self.candidates if c not in known]
        if unknown:
            raise InvalidParameterError(
                f'monitor candidates {unknown} are not effect families of the library; '
                f'known: {sorted(known)}'
            )

    def policy(self) -> Policy:
        """Return the pipeline's live policy with this monitor's settings."""
        base = Policy.live(self.time_budget)
        return replace(
            base,
            alpha=self.alpha,
            replicas=self.replicas,
            families=self.candidates or None,
            max_effects=1,
        )


@dataclass(frozen=True)
class WindowResult:
    """One evaluated window (see :class:`WindowMonitor`).

    Times in s (the time base of the pushed samples), moments in N m,
    acceleration in rad/s^2, speeds in rad/s; ``candidate`` the named family, or
    the best partial explanation ('' if none; then ``candidate_rms`` is NaN), with
    ``params``/``units`` as in :mod:`.candidates`; ``identifiable`` True when the
    window names it, ``identifiable_reason`` the verdict in one line; ``verdict``
    one of :data:`.pipeline.KINDS`; ``quality`` 'ok' or ';'-separated flags
    (``no_sticks``: no stick phase in the window: fitted from sliding states, ``mu0``
    NaN, ``over_budget``: the window took longer than the hop, ``fit_failed``,
    ``partial``: the candidate explains part of the mismatch, not all,
    ``incomplete``: the time budget ended before every family was screened,
    ``investigation``: the result of :meth:`WindowMonitor.investigate`);
    ``complete`` False when the verdict may change with every family screened (the
    window is then worth an investigation); ``null`` the null law the window was
    judged against (one per record: the window); ``baseline`` its baseline's values
    (SI; the next window's fit starts from them).
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
    verdict: str = field(default='')
    complete: bool = True
    null: tuple[NullLaw, ...] = field(default=(), repr=False, compare=False)
    baseline: dict[str, float] = field(default_factory=dict, repr=False, compare=False)


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
        self._null: tuple[NullLaw, ...] | None = None
        #: the last window's baseline (the next window's fit starts from it)
        self._baseline: dict[str, float] | None = None

    # ------------------------------------------------------------------ input
    def reset(self) -> None:
        """Forget the buffered samples and the null law's replicas (a gap, a restart)."""
        self._chunks.clear()
        self._n = 0
        self._next_end = None
        self._null = None
        self._baseline = None

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

    def warm_up(self, friction: FrictionLaw, *, seed: int = 0) -> float:
        """Evaluate one short simulated window; return its wall time [s].

        The first window of a process otherwise also pays for loading the
        compiled kernels and the pipeline's modules (a few tenths of a second): a
        live monitor calls this before its first window is due. The window is 1.5 s
        of this rig under
        ``friction`` (Equ. 1-3, 6, 8, simulated at 10 kHz with white noise of 1 %
        of each channel's spread); the result is discarded and this monitor's
        buffer and null law are untouched.
        """
        from tribo_estimation.core.simulate import simulate

        t0 = _time.perf_counter()
        w0 = self.drive.nominal_speed if self.drive.nominal_speed > 0.0 else 1.0
        drive = DriveProfile(w0, self.drive.ramp_time)
        sim = simulate(self.rig, friction, drive, self.drive.ramp_time + 2.0)
        keep = sim.time >= sim.time[-1] - 1.5
        rng = np.random.default_rng(seed)
        chans = [
            c[keep] + 0.01 * float(np.std(c[keep])) * rng.standard_normal(int(keep.sum()))
            for c in (sim.torsion_moment, sim.angular_acceleration, sim.speed)
        ]
        scratch = WindowMonitor(
            self.rig, drive, k=self.k, config=replace(self.config, window=1.5, hop=1.5)
        )
        for w in scratch.add(sim.time[keep], *chans, sample_rate=sim.fs):
            scratch.evaluate(w)
        return _time.perf_counter() - t0

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
        """Run the pipeline on one window (live budget) and summarise its verdict.

        The window's null law: ``replicas`` bootstrap replicas of its baseline in the
        first window, then ``fresh_replicas`` of each window's own pooled with the
        newest of the windows before (:class:`MonitorConfig`). The replicas' noise is
        seeded by the window's last sample index, so a skipped window changes no
        other window's replicas. A later window's baseline fit starts from the window
        before's (they overlap; ``find_missing_physics(previous=)``).
        """
        cfg = self.config
        seed = round(float(w.time[-1]) * (self._fs or 1.0))
        if self._null is None:
            pol = replace(cfg.policy(), seed=seed)
            r = self._run(w, pol, None, (), ())
        else:
            pol = replace(cfg.policy(), replicas=cfg.fresh_replicas, seed=seed)
            start = (self._baseline,) if self._baseline else ()
            r = self._run(w, pol, None, self._null, (), start)
        if r.quality != 'fit_failed':
            self._null = r.null
            self._baseline = r.baseline or None
        return r

    def investigate(self, w: WindowData, null: tuple[NullLaw, ...] = ()) -> WindowResult:
        """Run the pipeline on one window with every family screened (no time budget).

        The same steps and decision rules as :meth:`evaluate`; only the wall-time
        budget is lifted, so a window whose evaluation ran out of time before every
        family was screened (``complete`` False) gets its final verdict. A full
        screening takes several hops (about 10 s for a 6 s window at 10 kHz):
        the ``model_monitor`` node runs it beside the windows, one at a time. The
        monitor's state is not changed.

        Parameters
        ----------
        w : WindowData
            The window.
        null : tuple of NullLaw
            The null law its evaluation used (:attr:`WindowResult.null`; empty:
            measured here).

        Returns
        -------
        WindowResult
            The verdict, with the quality flag ``investigation``.
        """
        pol = replace(self.config.policy(), time_budget=math.inf)
        return self._run(w, pol, null or None, (), ('investigation',))

    def _run(
        self,
        w: WindowData,
        policy: Policy,
        null: tuple[NullLaw, ...] | None,
        earlier: tuple[NullLaw, ...],
        flags_in: tuple[str, ...],
        previous: tuple[dict[str, float], ...] = (),
    ) -> WindowResult:
        """Run the pipeline on one window under ``policy`` and summarise the verdict."""
        cfg = self.config
        t0 = _time.perf_counter()
        w0 = self.drive.nominal_speed
        if w0 <= 0.0:
            w0 = float(np.mean(w.speed))
        drive = DriveProfile(w0, self.drive.ramp_time)
        try:
            res = find_missing_physics(
                [w], self.rig, [drive], k=self.k, policy=policy, null=null,
                earlier=earlier, pool=self.config.replicas, previous=previous,
            )  # fmt: skip
        except EstimationError:
            return self._empty(w, t0, 'fit_failed', w0)
        rep = res.records[0]
        tr = res.traces[0]
        pb = tr.problem
        sim = tr.baseline
        cov = sim.covered
        r = torque_residual(pb, sim)
        stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
        where, share = concentration(r, stick, np.asarray(sim.slip_speed), pb.record.fs)
        sigma = rep.noise_floor
        best = res.named[-1] if res.named else (res.partial[0] if res.partial else None)
        tried = tuple(dict.fromkeys(e.family for rnd in res.rounds for e in rnd))
        elapsed = _time.perf_counter() - t0
        wanted = set(cfg.candidates or cand_lib.families())
        complete = res.verdict == NOTHING_MISSING or wanted <= set(tried)
        flags = list(flags_in)
        if pb.segments.sliding:
            flags.append('no_sticks')
        if best is not None and res.verdict != NAMED:
            flags.append('partial')
        if not complete:
            flags.append('incomplete')
        if elapsed > cfg.hop and not flags_in:
            flags.append('over_budget')
        mu0 = float(rep.baseline.get('mu0', math.nan))
        return WindowResult(
            t_start=float(w.time[0]),
            t_end=float(w.time[-1]),
            n_samples=int(w.time.size),
            mu0=math.nan if pb.segments.sliding else mu0,
            mu_inf=float(rep.baseline.get('mu_inf', math.nan)),
            drive_speed=float(pb.drive_estimate.level),
            residual_rms=rep.rms_baseline,
            residual_rms_accel=rms(
                (pb.record.angular_acceleration - sim.angular_acceleration)[cov]
            ),
            noise_floor=sigma,
            ratio=rep.rms_baseline / sigma if sigma > 0 else math.inf,
            concentration=where,
            concentration_share=share,
            candidate=best.family if best is not None else '',
            params=dict(best.params) if best is not None else {},
            units=dict(best.units) if best is not None else {},
            candidate_rms=best.rms[0] if best is not None else math.nan,
            identifiable=res.verdict == NAMED,
            identifiable_reason=res.finding(),
            tried=tried,
            processing_time=elapsed,
            quality=';'.join(flags) or 'ok',
            verdict=res.verdict,
            complete=complete,
            null=tuple(r.null for r in res.records),
            baseline=dict(rep.baseline),
        )


__all__ = [
    'REGIONS',
    'MonitorConfig',
    'WindowData',
    'WindowMonitor',
    'WindowResult',
    'concentration',
]
