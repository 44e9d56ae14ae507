"""Evaluation of one collected block: checks, stick detection, fit, bookkeeping.

:func:`evaluate_block` turns a :class:`.results.PendingBlock` into a
:class:`.results.BlockDetail`. It never raises for bad data in the block:
problems become quality flags (:data:`.results.FLAGS`); only wrong units raise
:class:`UnitError` (a configuration error that would spoil every block).

Identifiability (paper section 2.5): mu0 acts only at breakaway. Blocks with
fewer than :data:`MIN_BREAKAWAYS` stick phases report ``mu0 = NaN`` (in
slip-slip the deceleration rule keeps ``mu = mu_inf``); so does a relative
standard error above 50 %.

Every value is in SI units: moments N m, speeds rad/s, accelerations rad/s^2,
time s, coefficients dimensionless, k in s/rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ...errors import EstimationError, FitError, UnitError
from ..drive import DriveEstimate, estimate_drive
from ..model import FrictionLaw, RigParams
from ..observer import friction_moment
from ..signal import chamber_speed, longest_run, runs
from ..sticks import (
    StickPhase,
    chamber_speed_integral,
    classify_motion,
    detect_sticks,
    estimate_torsion_lag,
    torsion_lag_compensated,
)
from .fit import fit_block
from .results import (
    BURST_MIN,
    FLAGS,
    MAX_REPAIRED,
    BlockConfig,
    BlockData,
    BlockDetail,
    BlockResult,
    BoolArray,
    FitOutcome,
    FloatArray,
    PendingBlock,
)

#: Fewest stick phases (breakaways) in a block for mu0 to be reported [-].
MIN_BREAKAWAYS = 3


# ============================================================ signal checks
def is_saturated(x: FloatArray, run: int) -> bool:
    """Tell whether ``x`` looks clipped.

    True if ``x`` holds ``run`` or more equal consecutive samples at its max or min
    (a clipped sensor). A constant signal is not called saturated.
    """
    n = x.shape[0]
    if n < run:
        return False
    hi = float(np.max(x))
    lo = float(np.min(x))
    if hi == lo:
        return False
    for ext in (hi, lo):
        m = x == ext
        if int(m.sum()) < run:
            continue
        a, b = longest_run(m)
        if b - a >= run:
            return True
    return False


def repair_counts(repaired: BoolArray) -> tuple[int, int]:
    """Count the replaced samples and the bursts among them.

    Parameters
    ----------
    repaired : numpy.ndarray
        True at the samples replaced before the fit (bool).

    Returns
    -------
    tuple of int
        Replaced samples and bursts (runs of at least :data:`.results.BURST_MIN`
        samples).
    """
    st, en = runs(repaired)
    return int(np.count_nonzero(repaired)), int(np.count_nonzero(en - st >= BURST_MIN))


def repair_flags(repaired: BoolArray) -> set[str]:
    """Name the quality flags of a block's replaced samples.

    Parameters
    ----------
    repaired : numpy.ndarray
        True at the samples replaced before the fit (bool).

    Returns
    -------
    set of str
        ``spikes`` for runs shorter than :data:`.results.BURST_MIN`, ``bursts``
        for longer ones, ``repaired`` when more than :data:`.results.MAX_REPAIRED`
        of the samples were replaced (the block is not fitted).
    """
    st, en = runs(repaired)
    flags: set[str] = set()
    if np.any(en - st < BURST_MIN):
        flags.add('spikes')
    if np.any(en - st >= BURST_MIN):
        flags.add('bursts')
    if repaired.size and float(np.mean(repaired)) > MAX_REPAIRED:
        flags.add('repaired')
    return flags


def drive_over_cycles(
    drive: DriveEstimate, time: FloatArray, speed: FloatArray, phases: list[StickPhase]
) -> DriveEstimate:
    """Level the drive profile with the shaft speed's mean over whole stick-slip cycles.

    The shaft speed w2 oscillates with the stick-slip cycle, so its mean over a
    block that holds a fraction of a cycle more or less is off the drive speed
    (at 10 rpm by up to 0.5 %, which biases mu0 and mu_inf far beyond their
    standard errors). Over whole cycles, from one stick start to a later one,
    the shaft turns as far as the drive (the twist of Equ. 2 repeats), so the mean
    of w2 from the first to the last stick start is the drive's mean there; the
    profile is shifted to match it.

    Parameters
    ----------
    drive : DriveEstimate
        Drive profile measured from the shaft speed (block-local time [s]).
    time : numpy.ndarray
        Block-local sample times [s].
    speed : numpy.ndarray
        Shaft speed w2 [rad/s].
    phases : list of StickPhase
        Stick phases of the block (block-local times [s]).

    Returns
    -------
    DriveEstimate
        The shifted profile; ``drive`` itself with fewer than three stick starts
        in the block or cycles covering less than half of it.
    """
    n = time.shape[0]
    if n < 2:
        return drive
    fs = (n - 1) / float(time[-1] - time[0]) if time[-1] > time[0] else math.nan
    if not math.isfinite(fs):
        return drive
    starts = [round(ph.start * fs) for ph in phases if ph.start * fs > 0.5]
    if len(starts) < 3:
        return drive
    i0, i1 = starts[0], min(starts[-1], n)
    if i1 - i0 < n // 2:
        return drive
    shift = float(np.mean(speed[i0:i1])) - float(np.mean(drive.speed(time[i0:i1])))
    if not math.isfinite(shift):
        return drive
    return replace(drive, knot_speed=drive.knot_speed + shift)


#: A speed channel whose level differs from the stick lines' drive speed by more than
#: this fraction (and 4 standard errors) is off (offset or gain error): the drive
#: profile is levelled with the stick lines instead [-].
SPEED_CHANNEL_TOL = 0.01


def drive_from_stick_lines(
    drive: DriveEstimate, phases: list[StickPhase]
) -> tuple[DriveEstimate, float]:
    """Check the drive profile's level against the stick lines; correct a clear offset.

    The profile comes from the speed channel; each stick line gives the drive speed
    at its middle without it (:attr:`..sticks.StickPhase.drive_speed`, Equ. 1 + 2 while
    sticking). Their difference at the sticks, ``d = mean(w0_channel(t_k) - w0_line_k)``
    (weighted by the sticks' durations), is the channel's offset (or gain error)
    there. Above :data:`SPEED_CHANNEL_TOL` of the drive speed and 4 standard errors the
    profile is shifted by ``-d`` (a wrong tachometer level biases mu0 by about as much
    as the speed is off: 2.5 % for 1 rad/s at 30 rpm).

    Parameters
    ----------
    drive : DriveEstimate
        Drive profile from the speed channel (block-local time [s]).
    phases : list of StickPhase
        Stick phases of the block, with their line speeds.

    Returns
    -------
    tuple of (DriveEstimate, float)
        The profile (shifted if the channel is off) and ``d`` [rad/s] (NaN with
        fewer than 3 stick lines).
    """
    lines = [ph for ph in phases if math.isfinite(ph.drive_speed)]
    if len(lines) < 3:
        return drive, math.nan
    t_k = np.asarray([0.5 * (ph.start + ph.end) for ph in lines])
    w_k = np.asarray([ph.drive_speed for ph in lines])
    n_k = np.asarray([ph.duration for ph in lines])
    diff = drive.speed(t_k) - w_k
    d = float(np.sum(n_k * diff) / np.sum(n_k))
    se = float(np.sqrt(np.sum(n_k * (diff - d) ** 2) / np.sum(n_k) / (t_k.size - 1)))
    level = float(np.sum(n_k * w_k) / np.sum(n_k))
    if abs(d) > max(SPEED_CHANNEL_TOL * abs(level), 4.0 * se):
        return replace(drive, knot_speed=drive.knot_speed - d), d
    return drive, d


def _check_speed_units(cfg: BlockConfig, speed: FloatArray) -> None:
    """Raise :class:`UnitError` when the shaft speed [rad/s] looks like rpm."""
    w_mean = float(np.mean(speed))
    if cfg.nominal_speed is not None:
        ratio = w_mean / cfg.nominal_speed
        if 9.0 < ratio < 10.2:
            raise UnitError(
                f'speed mean {w_mean:.4g} is {ratio:.3g} x the nominal speed '
                f'{cfg.nominal_speed:.4g} rad/s: the speed looks like rpm, expected rad/s'
            )
    elif abs(w_mean) > 20.0:
        raise UnitError(
            f'speed mean {w_mean:.4g} is beyond the rig (about 10 rad/s at 100 rpm): '
            'the speed looks like rpm, expected rad/s'
        )


def _torsion_lag(
    cfg: BlockConfig, rig: RigParams, torsion: FloatArray, accel: FloatArray, fs: float
) -> float:
    """Return the torsion amplifier's lag [s].

    Configured, else estimated from the block (below 0.1 ms taken as none).
    """
    if cfg.torsion_lag is not None:
        return cfg.torsion_lag
    try:
        tau = float(estimate_torsion_lag(torsion, accel, fs, rig.C1, rig.fastest_mode_hz))
    except (EstimationError, ValueError, np.linalg.LinAlgError):
        return 0.0
    return tau if math.isfinite(tau) and 1e-4 <= tau <= 0.01 else 0.0


def _compensated_torsion(
    cfg: BlockConfig, rig: RigParams, torsion: FloatArray, accel: FloatArray, fs: float
) -> tuple[FloatArray, float]:
    """Take the amplifier's first-order lag out of the torsion moment.

    Returns the torsion moment [N m] with the lag taken out (the mean kept) and
    the lag [s] (0: none, ``torsion`` returned as it is).
    """
    tau_t = _torsion_lag(cfg, rig, torsion, accel, fs)
    if tau_t <= 0.0:
        return torsion, tau_t
    dt = 1.0 / fs
    comp = torsion_lag_compensated(torsion, chamber_speed_integral(accel, dt), dt, tau_t, rig.C1)
    return comp - (float(np.mean(comp)) - float(np.mean(torsion))), tau_t


def _stick_mask(phases: list[StickPhase], n: int, fs: float) -> BoolArray:
    """Mark the samples of the stick phases (block-local times [s])."""
    stick = np.zeros(n, dtype=bool)
    for ph in phases:
        i0 = max(0, math.ceil(ph.start * fs - 1e-9))
        i1 = min(n, math.ceil(ph.end * fs - 1e-9))
        stick[i0:i1] = True
    return stick


def _judged(out: FitOutcome, phases: list[StickPhase]) -> tuple[FitOutcome, bool]:
    """Judge a fit outcome.

    Returns the outcome with mu0 withheld where the data do not determine it, and
    whether the fit failed (not converged, non-finite or mu_inf's relative se
    above 50 %).

    mu0 is seen only at breakaways: with fewer than :data:`MIN_BREAKAWAYS` stick
    phases, or a relative se above 50 %, it is not reported (slip-slip without any
    stick: only where sliding restarts on the curve of Equ. 8, so the data must pin
    it down to 10 % of mu0 - mu_inf).
    """
    mu0_known = len(phases) >= MIN_BREAKAWAYS or (
        not phases
        and math.isfinite(out.mu0_se)
        and out.mu0_se < 0.1 * max(abs(out.mu0 - out.mu_inf), 1e-12)
    )
    if not (
        mu0_known and math.isfinite(out.mu0_se) and out.mu0_se < 0.5 * max(abs(out.mu0), 1e-12)
    ):
        out = replace(out, mu0=math.nan, mu0_se=math.nan)
    vals = [out.mu_inf, out.mu_inf_se] + ([out.mu0] if mu0_known else [])
    failed = (
        not out.converged
        or not all(math.isfinite(v) for v in vals)
        or out.mu_inf_se > 0.5 * max(abs(out.mu_inf), 1e-12)
    )
    return out, failed


@dataclass(frozen=True)
class _Outcome:
    """What the evaluation found, before it becomes a :class:`BlockResult`.

    ``data`` is None when the block never got as far as the stick detection (the
    measured signals are then used as they are); ``w0`` [rad/s] and
    ``mismatch`` [-] are NaN before the drive speed is measured.
    """

    flags: frozenset[str]
    fit: FitOutcome | None
    stick: BoolArray
    motion: str
    n_sticks: int
    w0: float
    mismatch: float
    data: BlockData | None
    speed_offset: float = math.nan


def _detail(
    blk: PendingBlock, friction: FrictionLaw, cfg: BlockConfig, a: int, b: int, o: _Outcome
) -> BlockDetail:
    """Build the :class:`BlockDetail` of block ``blk`` (valid samples ``[a, b)``).

    The torsion-moment statistics are those of the signal the fit saw (lag
    compensated when it was).
    """
    nan = math.nan
    out = o.fit
    if o.data is not None:
        data = o.data
    else:
        empty = np.empty(0)
        t0 = blk.t_start + a / blk.fs
        tq_raw, ac_raw, sp_raw = blk.torsion[a:b], blk.accel[a:b], blk.speed[a:b]
        data = BlockData(t0, blk.fs, tq_raw, ac_raw, sp_raw, empty, empty, np.zeros(0, bool))
    tq = data.torsion
    n = tq.shape[0]
    n_rep, n_bursts = repair_counts(blk.repaired) if blk.repaired is not None else (0, 0)
    res = BlockResult(
        index=blk.index,
        first_index=blk.first_index,
        t_start=blk.t_start,
        t_end=blk.t_end,
        mu0=out.mu0 if out else nan,
        mu_inf=out.mu_inf if out else nan,
        mu0_se=out.mu0_se if out else nan,
        mu_inf_se=out.mu_inf_se if out else nan,
        k=out.k if out else friction.k,
        k_se=out.k_se if out else (nan if cfg.fit_k else 0.0),
        moment_min=float(np.min(tq)) if n else nan,
        moment_max=float(np.max(tq)) if n else nan,
        moment_mean=float(np.mean(tq)) if n else nan,
        motion=o.motion,
        n_sticks=o.n_sticks,
        stick_fraction=float(np.mean(o.stick)) if o.stick.size else nan,
        rms_residual=out.rms_residual if out else nan,
        quality=tuple(f for f in FLAGS if f in o.flags),
        w0=o.w0,
        n_samples=n,
        n_iter=out.n_iter if out else 0,
        drive_mismatch=o.mismatch,
        speed_offset=o.speed_offset,
        spikes=n_rep,
        bursts=n_bursts,
    )
    sim = out.simulated if out else np.full(n, nan)
    return BlockDetail(res, data, sim)


def evaluate_block(
    rig: RigParams,
    friction: FrictionLaw,
    cfg: BlockConfig,
    blk: PendingBlock,
    init: tuple[float, float] | None = None,
) -> BlockDetail:
    """Evaluate one collected block: checks, stick detection, fit, bookkeeping.

    ``friction`` gives k (fixed or start value) and the fallback start values
    of mu0/mu_inf. Never raises for bad data in the block: problems become
    quality flags; only wrong units raise :class:`UnitError` (a configuration
    error that would spoil every block).
    """
    flags = set(blk.flags)
    a, b = longest_run(blk.valid)
    n_block = blk.torsion.shape[0]
    nan = math.nan
    if b - a < n_block:
        flags.add('gap')
    tq = blk.torsion[a:b]
    ac = blk.accel[a:b]
    sp = blk.speed[a:b]
    n = b - a

    def done(
        fit: FitOutcome | None,
        stick: BoolArray,
        motion: str,
        n_sticks: int,
        w0: float = nan,
        mismatch: float = nan,
        data: BlockData | None = None,
        speed_offset: float = nan,
    ) -> BlockDetail:
        o = _Outcome(
            frozenset(flags), fit, stick, motion, n_sticks, w0, mismatch, data, speed_offset
        )
        return _detail(blk, friction, cfg, a, b, o)

    if n < max(20, cfg.min_fraction * n_block):
        flags.add('short')
        return done(None, np.zeros(n, bool), 'steady', 0)
    rep = blk.repaired[a:b] if blk.repaired is not None else np.zeros(n, dtype=bool)
    if rep.any():
        flags.update(repair_flags(rep))
        if float(np.mean(rep)) > MAX_REPAIRED:  # mostly interpolated: nothing to fit
            return done(None, np.zeros(n, bool), 'steady', 0)
    if not (np.all(np.isfinite(tq)) and np.all(np.isfinite(ac)) and np.all(np.isfinite(sp))):
        flags.add('fit_failed')
        return done(None, np.zeros(n, bool), 'steady', 0)
    if is_saturated(tq, cfg.saturation_run) or is_saturated(ac, cfg.saturation_run):
        flags.add('saturated')
    _check_speed_units(cfg, sp)
    # block-local time [s since t0]: the drive profile, the stick phases and the fit
    # never work on absolute (epoch) time stamps
    time = np.arange(n) / blk.fs
    tq, tau_t = _compensated_torsion(cfg, rig, tq, ac, blk.fs)
    # the drive speed is measured (the shaft speed over several stick-slip periods);
    # the nominal speed is only a check (drive_mismatch)
    drive = estimate_drive(time, sp, cfg.nominal_speed)
    w0 = drive.mean_speed(float(time[0]), float(time[-1]))
    mismatch = (
        (w0 - cfg.nominal_speed) / cfg.nominal_speed if cfg.nominal_speed is not None else nan
    )
    w1 = chamber_speed(tq, blk.fs, rig.C1)
    if tau_t == 0.0 and blk.moment is not None and np.all(np.isfinite(blk.moment[a:b])):
        moment = blk.moment[a:b]
    else:  # one-shot observer (Equ. 1 solved for M) started at the measured speed
        moment, _ = friction_moment(rig, tq, ac, blk.fs, initial_speed=float(w1[0]))
    try:
        # tq has the amplifier lag taken out already (or the block has none): the
        # detector must not estimate and compensate it a second time
        phases = detect_sticks(
            time, tq, ac, sp, rig, min_duration=cfg.min_stick_duration, torsion_lag=0.0
        )
    except EstimationError:
        phases = []
    stick = _stick_mask(phases, n, blk.fs)
    drive = drive_over_cycles(drive, time, sp, phases)
    # speed channel - stick-line drive speed [rad/s]
    drive, speed_off = drive_from_stick_lines(drive, phases)
    w0 = drive.mean_speed(float(time[0]), float(time[-1]))
    mismatch = (
        (w0 - cfg.nominal_speed) / cfg.nominal_speed if cfg.nominal_speed is not None else nan
    )
    # stick phases that start inside the block (one running at its start is counted
    # in the block before)
    n_sticks = sum(1 for ph in phases if ph.start > 0.5 / blk.fs)
    motion = classify_motion(time, tq, ac, sp, rig, sticks=phases)
    data = BlockData(
        blk.t_start + a / blk.fs, blk.fs, tq, ac, sp, moment, w1, stick, rep if rep.any() else None
    )
    # sliding means a slip speed clearly above the noise of v = w2 - w1 somewhere
    v_thr = max(0.1, min(0.3, 0.5 * abs(w0)))
    sliding = float(np.mean(np.abs(sp - w1) > v_thr))
    if abs(w0) < 1e-3 or float(np.mean(stick)) > 0.99 or sliding < 0.01:
        flags.add('no_sliding')
        stick = np.abs(sp - w1) <= v_thr  # the discs move together (or not at all)
        return done(
            None, stick, motion, n_sticks, w0, mismatch, replace(data, stick=stick), speed_off
        )
    try:
        out = fit_block(rig, data, w0, friction.k, cfg, init=init, drive=drive)
    except FitError:
        flags.add('fit_failed')
        return done(None, stick, motion, n_sticks, w0, mismatch, data, speed_off)
    out, failed = _judged(out, phases)
    if failed:
        flags.add('fit_failed')
    return done(out, stick, motion, n_sticks, w0, mismatch, data, speed_off)
