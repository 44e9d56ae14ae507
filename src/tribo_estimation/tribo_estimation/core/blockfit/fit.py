"""Block-wise identification of the friction law (paper section 2.5, Fig. 4/5).

The measured record is cut into blocks of ``block_length`` seconds (1 s in the
paper). For each block the friction law of Equ. 8,
``mu(|v|) = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` (with the paper's
deceleration rule), is identified by minimising the squared error between the
simulated and the measured torsion moment ``C1*phi1`` [N m] and chamber
acceleration ``w1'`` [rad/s^2], each weighted by its noise level, with the rig
model of Equ. 1-3 and 6 driven at the constant nominal drive speed ``w0``.

Steps per block:

1. **Observer** (streaming, outside this module's fit): the friction moment
   ``M = I1*w1' + K1*w1 + C1*phi1`` (Equ. 1 solved for M) and the stick phases.
2. **Initial estimate (equation error)**: at breakaway the friction moment
   equals ``F_N*R*mu0`` (Equ. 5), and after the slip-speed peak of each
   sliding phase it equals ``F_N*R*mu_inf`` (deceleration rule); medians of
   the observer moment at these instants give mu0 and mu_inf.
3. **Output-error refinement (multiple shooting)**: the block is split at the
   measured stick phases (:func:`sticks.detect_sticks`). During sticking
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
4. **Identifiability**: mu0 acts only at breakaway. Blocks with fewer than
   :data:`MIN_BREAKAWAYS` stick phases report ``mu0 = NaN`` (in slip-slip the
   deceleration rule keeps ``mu = mu_inf``); so does a relative standard
   error above 50 %.
5. **Standard errors**: cluster-robust (sandwich) over the shooting segments,
   so correlated residuals within a segment do not make them optimistic.

Every value is in SI units: moments N m, speeds rad/s, accelerations rad/s^2,
time s, coefficients dimensionless, k in s/rad.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, fields, replace
from typing import TextIO

import numpy as np
import numpy.typing as npt

from ...errors import EstimationError, FitError, InvalidDataError, InvalidParameterError, UnitError
from .. import kernel as kn
from ..align import AlignEvent, GapEvent, RestartEvent
from ..drive import DriveEstimate, estimate_drive
from ..lsq import levenberg_marquardt
from ..model import DriveProfile, FrictionLaw, RigParams, pack_params
from ..observer import FrictionObserver, friction_moment
from ..shooting import DriveKnots, local_cubic, shoot, sliding_states, stuck_states, window_mean
from ..signal import CHAMBER_HALF, chamber_speed, longest_run, noise_level, runs
from ..sticks import (
    chamber_speed_integral,
    classify_motion,
    detect_sticks,
    estimate_torsion_lag,
    torsion_lag_compensated,
)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


# ============================================================ configuration and results
@dataclass(frozen=True)
class BlockConfig:
    """Settings of the block-wise fit.

    Attributes:
        block_length: block duration [s] (paper: 1 s).
        fit_k: also fit the Stribeck constant k [s/rad] (else k stays fixed).
        nominal_speed: drive speed w0 [rad/s]; ``None`` = mean of the tachometer per block.
        ramp_time: start-up ramp of the drive [s]; blocks starting before
            ``ramp_time`` after the stream start are flagged ``startup``.
        noise_torque: noise of the torsion moment [N m]; ``None`` = estimated per block.
        noise_accel: noise of the acceleration [rad/s^2]; ``None`` = estimated per block.
        max_iter: Levenberg-Marquardt iterations at most [-].
        min_fraction: smallest fraction of valid samples for a fit [-].
        saturation_run: this many equal consecutive samples at the block's
            extreme value mark a clipped sensor [samples].
        min_stick_duration: shortest stick phase counted (1 ms: 10 samples at 10 kHz;
            shorter ones are micro-sticks) [s].
        speed_lag: known first-order lag of the shaft-speed sensor [s] (the fit uses
            the speed channel only for the drive level and, lag-corrected, at
            sliding nodes).
        torsion_lag: first-order lag of the torsion amplifier [s]; ``None`` = estimated
            per block (:func:`sticks.estimate_torsion_lag`), 0 = none. The measured
            torsion moment is compensated before the fit
            (:func:`sticks.torsion_lag_compensated`, exact for a first-order lag).
    """

    block_length: float = 1.0
    fit_k: bool = False
    nominal_speed: float | None = None
    ramp_time: float = 0.0
    noise_torque: float | None = None
    noise_accel: float | None = None
    max_iter: int = 8
    min_fraction: float = 0.5
    saturation_run: int = 5
    min_stick_duration: float = 1e-3
    speed_lag: float = 0.0
    torsion_lag: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.block_length) and 0.01 <= self.block_length <= 600.0):
            raise InvalidParameterError(
                f'block_length must be in [0.01, 600] s, got {self.block_length!r}'
            )
        if self.nominal_speed is not None and not (
            math.isfinite(self.nominal_speed) and self.nominal_speed > 0.0
        ):
            raise InvalidParameterError(
                f'nominal_speed must be > 0 rad/s, got {self.nominal_speed!r}'
            )
        if not (math.isfinite(self.ramp_time) and self.ramp_time >= 0.0):
            raise InvalidParameterError(f'ramp_time must be >= 0 s, got {self.ramp_time!r}')
        for name in ('noise_torque', 'noise_accel'):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0.0):
                raise InvalidParameterError(f'{name} must be > 0, got {v!r}')
        if not 1 <= self.max_iter <= 100:
            raise InvalidParameterError(f'max_iter must be in [1, 100], got {self.max_iter}')
        if not 0.0 < self.min_fraction <= 1.0:
            raise InvalidParameterError(
                f'min_fraction must be in (0, 1], got {self.min_fraction!r}'
            )
        if not (math.isfinite(self.speed_lag) and 0.0 <= self.speed_lag <= 0.1):
            raise InvalidParameterError(f'speed_lag must be in [0, 0.1] s, got {self.speed_lag!r}')
        if self.torsion_lag is not None and not (
            math.isfinite(self.torsion_lag) and 0.0 <= self.torsion_lag <= 0.01
        ):
            raise InvalidParameterError(
                f'torsion_lag must be in [0, 0.01] s, got {self.torsion_lag!r}'
            )
        if self.saturation_run < 2:
            raise InvalidParameterError(
                f'saturation_run must be >= 2 samples, got {self.saturation_run}'
            )
        if not (math.isfinite(self.min_stick_duration) and self.min_stick_duration >= 0.0):
            raise InvalidParameterError(
                f'min_stick_duration must be >= 0 s, got {self.min_stick_duration!r}'
            )


#: Motion types (paper section 2.5).
MOTIONS = ('stick-slip', 'slip-slip', 'steady')

#: Quality flags; a block with any of them is not a good estimate.
FLAGS = ('gap', 'saturated', 'no_sliding', 'startup', 'fit_failed', 'short', 'spikes')


@dataclass(frozen=True)
class BlockResult:
    """Result of one block (one row of ``blocks.csv``, one ``FrictionEstimate``).

    Attributes:
        index: block number since the stream start [-].
        first_index: index of the block's first sample [samples].
        t_start, t_end: block start and end, stream time [s].
        mu0, mu_inf: friction coefficients of Equ. 8 [-] (NaN if not identifiable).
        mu0_se, mu_inf_se: their standard errors [-].
        k, k_se: Stribeck constant used [s/rad] and its standard error (0 if fixed).
        moment_min, moment_max, moment_mean: torsion moment C1*phi1 over the block [N m].
        motion: ``stick-slip``, ``slip-slip`` or ``steady``.
        n_sticks: stick phases in the block [-].
        stick_fraction: fraction of the block's samples sticking [-].
        rms_residual: RMS of the torsion-moment residual of the fit [N m].
        quality: flags from :data:`FLAGS` (empty = ok).
        w0: drive speed the fit used, measured from the shaft speed (mean over the
            block) [rad/s].
        drive_mismatch: relative deviation of ``w0`` from the configured nominal
            speed [-] (NaN: none configured); beyond 5 % the command warns.
        n_samples: valid samples used [-].
        n_iter: Levenberg-Marquardt iterations [-].
        spikes: samples replaced as spikes before the fit (core.plausibility) [-].
    """

    index: int
    first_index: int
    t_start: float
    t_end: float
    mu0: float
    mu_inf: float
    mu0_se: float
    mu_inf_se: float
    k: float
    k_se: float
    moment_min: float
    moment_max: float
    moment_mean: float
    motion: str
    n_sticks: int
    stick_fraction: float
    rms_residual: float
    quality: tuple[str, ...] = ()
    w0: float = math.nan
    n_samples: int = 0
    n_iter: int = 0
    drive_mismatch: float = math.nan
    spikes: int = 0

    @property
    def ok(self) -> bool:
        """True for a good estimate (no quality flag)."""
        return not self.quality

    @property
    def quality_str(self) -> str:
        """``ok`` or the ``;``-separated flags."""
        return ';'.join(self.quality) if self.quality else 'ok'


#: Block-table columns shared with the live estimates (FrictionEstimate) and the
#: report, then ``quality``.
CSV_COLUMNS: tuple[str, ...] = (
    't_start',
    't_end',
    'mu0',
    'mu_inf',
    'mu0_se',
    'mu_inf_se',
    'moment_min',
    'moment_max',
    'moment_mean',
    'motion',
    'n_sticks',
    'stick_fraction',
    'rms_residual',
    'quality',
)

#: Columns of the ``blocks.csv`` file: :data:`CSV_COLUMNS` plus the drive speed the
#: fit used (``w0`` [rad/s], measured) and its relative deviation from the
#: configured nominal speed (``drive_mismatch`` [-]) before ``quality``, and after it
#: the spike count of each block (``spikes``: samples repaired before the fit,
#: :mod:`.plausibility`). Older files without these are read too.
FILE_COLUMNS: tuple[str, ...] = (
    *CSV_COLUMNS[:-1], 'w0', 'drive_mismatch', 'quality', 'spikes'
)
REQUIRED_COLUMNS = CSV_COLUMNS


def _fmt(v: float) -> str:
    return 'nan' if not math.isfinite(v) else repr(float(v))  # round-trip: epoch stamps


class BlockCsvWriter:
    """Write :class:`BlockResult` rows to ``blocks.csv`` as they come (streaming).

    Each row is flushed, so a run that is interrupted keeps every finished block.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = os.fspath(path)
        self._fh: TextIO = open(self.path, 'w', newline='', encoding='utf-8')  # noqa: SIM115
        self._w = csv.writer(self._fh, lineterminator='\n')
        self._w.writerow(FILE_COLUMNS)
        self._fh.flush()
        self.rows = 0

    def write(self, r: BlockResult) -> None:
        """Append one block."""
        self._w.writerow(
            [
                _fmt(r.t_start),
                _fmt(r.t_end),
                _fmt(r.mu0),
                _fmt(r.mu_inf),
                _fmt(r.mu0_se),
                _fmt(r.mu_inf_se),
                _fmt(r.moment_min),
                _fmt(r.moment_max),
                _fmt(r.moment_mean),
                r.motion,
                str(r.n_sticks),
                _fmt(r.stick_fraction),
                _fmt(r.rms_residual),
                _fmt(r.w0),
                _fmt(r.drive_mismatch),
                r.quality_str,
                str(r.spikes),
            ]
        )
        self._fh.flush()
        self.rows += 1

    def close(self) -> None:
        """Close the file."""
        self._fh.close()

    def __enter__(self) -> BlockCsvWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_blocks_csv(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read a ``blocks.csv`` into column arrays (float for numbers, object for text).

    Raises:
        MissingColumnError-like :class:`InvalidDataError` naming the missing column.
    """
    from ...errors import MissingColumnError

    p = os.fspath(path)
    try:
        fh = open(p, newline='', encoding='utf-8')  # noqa: SIM115
    except OSError as exc:
        raise InvalidDataError(f'{p}: cannot read blocks table ({exc.strerror})') from exc
    with fh:
        reader = csv.DictReader(fh)
        cols = reader.fieldnames or []
        for c in REQUIRED_COLUMNS:
            if c not in cols:
                raise MissingColumnError(f'{p}: missing column {c!r} in blocks table')
        rows = list(reader)
    out: dict[str, np.ndarray] = {}
    for c in FILE_COLUMNS:
        vals = [r.get(c) or 'nan' for r in rows]
        if c in ('motion', 'quality'):
            out[c] = np.array(vals, dtype=object)
        else:
            try:
                out[c] = np.array([float(v) for v in vals], dtype=float)
            except ValueError as exc:
                raise InvalidDataError(f'{p}: column {c!r} has a non-numeric value') from exc
    return out


def results_table(results: Iterable[BlockResult]) -> dict[str, np.ndarray]:
    """Column arrays (as :func:`read_blocks_csv` gives) from results in memory."""
    rs = list(results)
    out: dict[str, np.ndarray] = {}
    for c in CSV_COLUMNS:
        if c == 'quality':
            out[c] = np.array([r.quality_str for r in rs], dtype=object)
        elif c == 'motion':
            out[c] = np.array([r.motion for r in rs], dtype=object)
        else:
            out[c] = np.array([float(getattr(r, c)) for r in rs], dtype=float)
    return out


# ============================================================ signal checks
def is_saturated(x: FloatArray, run: int) -> bool:
    """True if ``x`` holds ``run`` or more equal consecutive samples at its max or min
    (a clipped sensor). A constant signal is not called saturated."""
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


# ============================================================ the fit of one block
@dataclass(frozen=True)
class BlockData:
    """Measured and observed signals of one contiguous stretch (one block).

    Attributes:
        t0: time of the first sample [s].
        fs: sample rate [Hz].
        torsion: torsion moment C1*phi1 [N m].
        accel: chamber acceleration w1' [rad/s^2].
        speed: shaft speed w2 (tachometer) [rad/s].
        moment: observer friction moment M [N m] (Equ. 1).
        chamber_speed: observer chamber speed w1 [rad/s].
        stick: True where the discs stick.
    """

    t0: float
    fs: float
    torsion: FloatArray
    accel: FloatArray
    speed: FloatArray
    moment: FloatArray
    chamber_speed: FloatArray
    stick: BoolArray

    def __len__(self) -> int:
        return int(self.torsion.shape[0])


@dataclass(frozen=True)
class FitOutcome:
    """Estimate of one block (before block bookkeeping).

    mu0, mu_inf, k [-, -, s/rad] with standard errors; ``rms_residual`` [N m];
    ``simulated`` torsion moment of the final fit [N m] (NaN outside the
    simulated segments); ``n_iter`` iterations; ``n_eval`` simulations of the
    block; ``converged``; ``w0`` drive speed used [rad/s].
    """

    mu0: float
    mu_inf: float
    k: float
    mu0_se: float
    mu_inf_se: float
    k_se: float
    rms_residual: float
    simulated: FloatArray
    n_iter: int
    n_eval: int
    converged: bool
    w0: float


#: Shooting nodes sit this many samples before the detected end of a stick phase
#: (the stuck motion before it does not depend on the friction law) [samples].
_LEAD = 15

#: Fewest stick phases (breakaways) in a block for mu0 to be reported [-].
MIN_BREAKAWAYS = 3

#: Shortest stick phase used as a shooting node [samples].
_MIN_NODE = 2

#: Spacing of shooting nodes in long sliding stretches [s], and their distance
#: after a breakaway (past the slip-speed peak) [s].
_SLIDE_SPACING = 0.05
_SLIDE_SETTLE = 0.02


def _sliding_nodes(
    vabs: FloatArray,
    stick_starts: npt.NDArray[np.int64],
    stick_ends: npt.NDArray[np.int64],
    fs: float,
) -> npt.NDArray[np.int64]:
    """Extra shooting nodes in long sliding stretches (slip-slip): in every
    ``_SLIDE_SPACING`` s window, at least ``_SLIDE_SETTLE`` s after a breakaway
    and before the next stick phase, the sample of the largest slip speed
    ``vabs`` = |w2 - w1| [rad/s] (its slip-speed peak: the deceleration rule
    holds right after it)."""
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
    """True within +-_JUMP_GUARD samples of a jump of the (simulated) acceleration,
    found as a second difference above ``threshold`` [rad/s^2]; NaN samples count too."""
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


def _robust_se(
    J: FloatArray, r: FloatArray, clusters: npt.NDArray[np.int64], n_par: int
) -> FloatArray:
    """Cluster-robust (sandwich) standard errors of a least-squares estimate.

    Residuals within one shooting segment are correlated (phase and state
    errors), between segments nearly independent, so the segments are the
    clusters: ``cov = B^-1 (sum_s g_s g_s^T) B^-1 * G/(G - 1)``, ``B = J^T J``,
    ``g_s = J_s^T r_s``. With fewer than 3 clusters the classical
    ``s^2 (J^T J)^-1`` with a lag-1 autocorrelation inflation is used.
    A parameter without any influence (zero Jacobian column, e.g. mu0 in
    steady sliding) gets NaN and is left out for the others.
    """
    norms = np.sqrt(np.sum(J * J, axis=0))
    live = norms > 1e-9 * max(float(norms.max()) if norms.size else 0.0, 1e-300)
    if not live.all():
        out = np.full(n_par, math.nan)
        if live.any():
            out[live] = _robust_se(J[:, live], r, clusters, int(live.sum()))
        return out
    B = J.T @ J
    try:
        Binv = np.linalg.inv(B)
    except np.linalg.LinAlgError:
        return np.full(n_par, math.nan)
    G = int(clusters.max()) + 1 if clusters.size else 0
    if G >= 3:
        scores = np.zeros((G, n_par))
        np.add.at(scores, clusters, J * r[:, None])
        meat = scores.T @ scores
        cov = Binv @ meat @ Binv * (G / (G - 1))
    else:
        dof = max(1, r.shape[0] - n_par)
        s2 = float(np.dot(r, r)) / dof
        rr = r - r.mean()
        den = float(np.dot(rr, rr))
        rho = float(np.dot(rr[1:], rr[:-1]) / den) if den > 0.0 else 0.0
        rho = min(max(rho, 0.0), 0.99)
        cov = Binv * s2 * (1.0 + rho) / (1.0 - rho)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


@dataclass(frozen=True)
class _Nodes:
    """Shooting segments of one block: start/end sample, start state, drive piece."""

    start: npt.NDArray[np.int64]
    end: npt.NDArray[np.int64]
    states: FloatArray
    drive: DriveKnots


def _shooting_nodes(
    p: FloatArray, d: BlockData, drive: DriveEstimate, speed_lag: float
) -> tuple[_Nodes, bool]:
    """Segment starts: late in every stick phase (the stuck motion does not depend
    on the friction law until breakaway) and every 50 ms in long sliding
    stretches; states from :mod:`.shooting`. Returns the nodes and whether the
    block has stick phases."""
    n = len(d)
    starts_s, ends_s = runs(d.stick)
    keep = (ends_s - starts_s) >= _MIN_NODE
    starts_s, ends_s = starts_s[keep], ends_s[keep]
    c1 = float(p[kn.P_C1])
    t_of = np.arange(n) / d.fs  # block-local time (see fit_block)
    dk = DriveKnots.from_estimate(drive)
    node_idx: list[npt.NDArray[np.int64]] = []
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
        node_states.append(stuck_states(p, ts, mt, w, acc, np.zeros(ts.size), dk.time, dk.speed))
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
        node_states.append(sliding_states(p, ts, mt, w1, w2, w2d, mom, dk.time, dk.speed))
    idx = np.concatenate(node_idx)
    states = np.vstack(node_states)
    order = np.argsort(idx, kind='stable')
    idx, states = idx[order], states[order]
    idx, first = np.unique(idx, return_index=True)
    states = states[first]
    end = np.r_[idx[1:], n].astype(np.int64)
    ts = t_of[idx]
    return _Nodes(idx, end, states, dk), bool(starts_s.size)


def _noise_weights(cfg: BlockConfig, d: BlockData, fallback_torque: float) -> tuple[float, float]:
    """Noise levels of the torsion moment [N m] and the acceleration [rad/s^2]."""
    sig_m = cfg.noise_torque if cfg.noise_torque is not None else noise_level(d.torsion)
    sig_a = cfg.noise_accel if cfg.noise_accel is not None else noise_level(d.accel)
    sig_m = sig_m if math.isfinite(sig_m) and sig_m > 0.0 else fallback_torque
    sig_a = sig_a if math.isfinite(sig_a) and sig_a > 0.0 else 1.0
    return sig_m, sig_a


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

    Raises:
        FitError: too few samples, no usable start value or non-finite residuals.
    """
    n = len(d)
    if n < 20:
        raise FitError(f'block has only {n} samples; at least 20 are needed')
    fnr = rig.F_N * rig.R
    if fnr <= 0.0:
        raise FitError('F_N*R is zero: no contact, no friction to fit')
    mu0_i, muinf_i = initial_estimate(d, fnr, _MIN_NODE)
    if init is not None:
        mu0_i = init[0] if math.isfinite(init[0]) else mu0_i
        muinf_i = init[1] if math.isfinite(init[1]) else muinf_i
    if not (math.isfinite(muinf_i) and abs(muinf_i) < 10.0):
        raise FitError('no usable start value for mu_inf (observer moment not plausible)')
    if drive is None:
        drive = DriveEstimate(np.array([0.0, n / d.fs]), np.array([w0, w0]), w0, w0, 0.0)
    sig_m, sig_a = _noise_weights(cfg, d, 1e-3 * max(1.0, fnr * muinf_i))
    p0 = pack_params(rig, FrictionLaw(0.1, 0.1, k), DriveProfile(w0))
    nodes, sticky = _shooting_nodes(p0, d, drive, cfg.speed_lag)
    names = ['mu0', 'mu_inf'] + (['k'] if cfg.fit_k and sticky else [])
    if not math.isfinite(mu0_i):
        # slip-slip: mu0 acts only where a sliding phase restarts on the curve of Equ. 8
        mu0_i = float(np.max(np.abs(d.moment))) / fnr
    k_i = k
    if 'k' in names:
        k_eq = initial_k(d, fnr, mu0_i, muinf_i)
        k_i = k_eq if math.isfinite(k_eq) else k
    theta0 = np.array([max(v, 0.0) for v in (mu0_i, muinf_i, k_i)[: len(names)]])
    if not np.all(np.isfinite(theta0)) or theta0[0] > 10.0:
        raise FitError('start values of the block fit are not plausible')
    index = [kn.P_MU0, kn.P_MUINF, kn.P_K][: len(names)]
    dt = 1.0 / d.fs
    n_sub = kn.substeps_for(p0, dt)
    used = np.arange(int(nodes.start[0]), n)
    meas_t, meas_a = d.torsion[used], d.accel[used]
    dk = nodes.drive

    recent: dict[bytes, FloatArray] = {}  # the last simulations, by theta

    def simulate(th: FloatArray) -> FloatArray:
        """Kernel output channels of the block at theta (new arrays, never mutated)."""
        key = np.asarray(th, dtype=np.float64).tobytes()
        if key in recent:
            return recent[key]
        p = p0.copy()
        p[index] = th
        out = np.full((kn.N_CH, n), np.nan)
        shoot(p, nodes.states, nodes.start, nodes.end, dk.time, dk.speed, dt, n_sub, out)
        if len(recent) >= 4:
            recent.pop(next(iter(recent)))
        recent[key] = out
        return out

    # Acceleration samples next to a switching event (found in the simulation at
    # the start values, +-_JUMP_GUARD) jump when the event crosses the sample instant:
    # they are left out; the torsion moment (continuous in theta) keeps every sample.
    sim0 = simulate(theta0)
    w_acc = np.where(_jump_guard(sim0[kn.OUT_ACCEL], 10.0 * sig_a)[used], 0.0, 1.0 / sig_a)

    def residual(th: FloatArray) -> FloatArray:
        out = simulate(th)
        return np.concatenate(
            (
                (out[kn.OUT_TORSION, used] - meas_t) / sig_m,
                (out[kn.OUT_ACCEL, used] - meas_a) * w_acc,
            )
        )

    # clusters for the standard errors: the shooting segments (nearly independent)
    seg_id = np.searchsorted(nodes.start, used, side='right') - 1
    clusters = np.concatenate((seg_id, seg_id)).astype(np.int64)

    def xtol(x: FloatArray, J: FloatArray, r: FloatArray) -> FloatArray:
        # a step far below the statistical uncertainty (or 1e-4 relative) ends the fit
        se = _robust_se(J, r, clusters, x.size)
        return np.maximum(np.where(np.isfinite(se), 0.1 * se, 0.0), 1e-4 * np.abs(x)) + 1e-12

    steps = np.array([0.05, 0.05, 1.0])[: len(names)] * 1e-4
    upper = np.array([10.0, 10.0, 1e3])[: len(names)]
    sol = levenberg_marquardt(
        residual,
        theta0,
        np.zeros(len(names)),
        upper,
        max_iter=cfg.max_iter,
        max_nfev=4 * cfg.max_iter * (1 + len(names)),
        abs_step=steps,
        xtol=xtol,
        reuse_jacobian=True,
        lam0=1e-4,
    )
    se = _robust_se(sol.jac, sol.fun, clusters, len(names))
    final = simulate(sol.x)
    sim_t = final[kn.OUT_TORSION]
    val = dict(zip(names, sol.x, strict=True))
    err = dict(zip(names, se, strict=True))
    return FitOutcome(
        mu0=float(val['mu0']),
        mu_inf=float(val['mu_inf']),
        k=float(val.get('k', k)),
        mu0_se=float(err['mu0']),
        mu_inf_se=float(err['mu_inf']),
        k_se=float(err.get('k', 0.0)),
        rms_residual=float(np.sqrt(np.mean((sim_t[used] - meas_t) ** 2))),
        simulated=sim_t,
        n_iter=sol.n_iter,
        n_eval=sol.nfev + 1,
        converged=sol.converged,
        w0=drive.mean_speed(0.0, n / d.fs),
    )


# ============================================================ per-block evaluation
@dataclass
class PendingBlock:
    """Samples of one block, collected by :class:`BlockEstimator`, ready to evaluate.

    Arrays have the block length; ``valid`` is False where samples are missing (gap).
    ``moment`` is the streaming observer's friction moment [N m] (None: computed
    per block). ``flags`` are those known while collecting (``gap``, ``startup``).
    """

    index: int
    first_index: int
    t_start: float
    fs: float
    torsion: FloatArray
    accel: FloatArray
    speed: FloatArray
    valid: BoolArray
    moment: FloatArray | None = None
    flags: set[str] = field(default_factory=set)

    @property
    def t_end(self) -> float:
        return self.t_start + self.torsion.shape[0] / self.fs


@dataclass(frozen=True)
class BlockDetail:
    """Signals of an evaluated block for plots (Fig. 6): the fitted stretch."""

    result: BlockResult
    data: BlockData
    simulated: FloatArray


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
    t0 = blk.t_start + a / blk.fs
    n = b - a

    def finish(
        out: FitOutcome | None,
        stick: BoolArray,
        motion: str,
        n_sticks: int,
        w0: float,
        data: BlockData | None,
    ) -> BlockDetail:
        order = [f for f in FLAGS if f in flags]
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
            motion=motion,
            n_sticks=n_sticks,
            stick_fraction=float(np.mean(stick)) if stick.size else nan,
            rms_residual=out.rms_residual if out else nan,
            quality=tuple(order),
            w0=w0,
            n_samples=n,
            n_iter=out.n_iter if out else 0,
            drive_mismatch=mismatch,
        )
        empty = np.empty(0)
        dd = data or BlockData(t0, blk.fs, tq, ac, sp, empty, empty, np.zeros(0, bool))
        sim = out.simulated if out else np.full(n, nan)
        return BlockDetail(res, dd, sim)

    mismatch = nan
    if n < max(20, cfg.min_fraction * n_block):
        flags.add('short')
        return finish(None, np.zeros(n, bool), 'steady', 0, nan, None)
    if not (np.all(np.isfinite(tq)) and np.all(np.isfinite(ac)) and np.all(np.isfinite(sp))):
        flags.add('fit_failed')
        return finish(None, np.zeros(n, bool), 'steady', 0, nan, None)
    if is_saturated(tq, cfg.saturation_run) or is_saturated(ac, cfg.saturation_run):
        flags.add('saturated')
    w_mean = float(np.mean(sp))
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
    # block-local time [s since t0]: the drive profile, the stick phases and the fit
    # never work on absolute (epoch) time stamps
    time = np.arange(n) / blk.fs
    tau_t = _torsion_lag(cfg, rig, tq, ac, blk.fs)
    if tau_t > 0.0:  # the torsion amplifier's lag taken out (the mean kept)
        dt = 1.0 / blk.fs
        comp = torsion_lag_compensated(tq, chamber_speed_integral(ac, dt), dt, tau_t, rig.C1)
        tq = comp - (float(np.mean(comp)) - float(np.mean(tq)))
    # the drive speed is measured (the shaft speed over several stick-slip periods);
    # the nominal speed is only a check (drive_mismatch)
    drive = estimate_drive(time, sp, cfg.nominal_speed)
    w0 = drive.mean_speed(float(time[0]), float(time[-1]))
    mismatch = (
        (w0 - cfg.nominal_speed) / cfg.nominal_speed if cfg.nominal_speed is not None else nan
    )
    c1 = rig.C1
    w1 = chamber_speed(tq, blk.fs, c1)
    if tau_t == 0.0 and blk.moment is not None and np.all(np.isfinite(blk.moment[a:b])):
        moment = blk.moment[a:b]
    else:  # one-shot observer (Equ. 1 solved for M) started at the measured speed
        moment, _ = friction_moment(rig, tq, ac, blk.fs, initial_speed=float(w1[0]))
    try:
        phases = detect_sticks(time, tq, ac, sp, rig, min_duration=cfg.min_stick_duration)
    except EstimationError:
        phases = []
    stick = np.zeros(n, dtype=bool)
    for ph in phases:
        i0 = max(0, math.ceil(ph.start * blk.fs - 1e-9))
        i1 = min(n, math.ceil(ph.end * blk.fs - 1e-9))
        stick[i0:i1] = True
    # stick phases that start inside the block (one running at its start is counted
    # in the block before)
    n_sticks = sum(1 for ph in phases if ph.start > 0.5 / blk.fs)
    motion = classify_motion(time, tq, ac, sp, rig, sticks=phases)
    data = BlockData(t0, blk.fs, tq, ac, sp, moment, w1, stick)
    # sliding means a slip speed clearly above the noise of v = w2 - w1 somewhere
    v_thr = max(0.1, min(0.3, 0.5 * abs(w0)))
    sliding = float(np.mean(np.abs(sp - w1) > v_thr))
    if abs(w0) < 1e-3 or float(np.mean(stick)) > 0.99 or sliding < 0.01:
        flags.add('no_sliding')
        stick = np.abs(sp - w1) <= v_thr  # the discs move together (or not at all)
        data = replace(data, stick=stick)
        return finish(None, stick, motion, n_sticks, w0, data)
    try:
        out = fit_block(rig, data, w0, friction.k, cfg, init=init, drive=drive)
    except FitError:
        flags.add('fit_failed')
        return finish(None, stick, motion, n_sticks, w0, data)
    # mu0 is seen only at breakaways: with fewer than MIN_BREAKAWAYS stick phases, or
    # a relative se above 50 %, the data do not determine it and it is not reported
    # (slip-slip without any stick: only where sliding restarts on the curve, so
    # the data must pin it down to 10 % of mu0 - mu_inf)
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
    if (
        not out.converged
        or not all(math.isfinite(v) for v in vals)
        or out.mu_inf_se > 0.5 * max(abs(out.mu_inf), 1e-12)
    ):
        flags.add('fit_failed')
    return finish(out, stick, motion, n_sticks, w0, data)


def _torsion_lag(
    cfg: BlockConfig, rig: RigParams, torsion: FloatArray, accel: FloatArray, fs: float
) -> float:
    """The torsion amplifier's lag [s]: configured, else estimated from the block
    (below 0.1 ms taken as none)."""
    if cfg.torsion_lag is not None:
        return cfg.torsion_lag
    try:
        tau = float(estimate_torsion_lag(torsion, accel, fs, rig.C1))
    except (EstimationError, ValueError, np.linalg.LinAlgError):
        return 0.0
    return tau if math.isfinite(tau) and 1e-4 <= tau <= 0.01 else 0.0


class BlockEstimator:
    """Streaming block-wise estimator: aligned chunks in, one result per block out.

    Blocks are fixed index ranges ``[i*N, (i+1)*N)`` (``N = block_length*fs``)
    of the stream, so results do not depend on how the input was chunked.
    Memory is one block of samples, whatever the session length.

    :meth:`push` collects (cheap, for a subscription callback) and returns
    :class:`PendingBlock` objects; :meth:`evaluate` does the fit (heavy, for a
    worker thread). :meth:`feed` does both.
    """

    def __init__(self, rig: RigParams, friction: FrictionLaw, cfg: BlockConfig) -> None:
        self.rig = rig
        self.friction = friction
        self.cfg = cfg
        self.fs: float | None = None
        self._n = 0
        self._cur: PendingBlock | None = None
        self._epoch_first: int | None = None  # first index of the current epoch
        self._epoch_t0 = math.nan
        self._observer: FrictionObserver | None = None
        self.blocks_done = 0
        #: Observer friction moment of the last chunk pushed [N m] (for /friction/moment).
        self.last_moment: FloatArray = np.zeros(0)

    # ---------------------------------------------------------------- collect
    def _new_block(self, bi: int, t_first: float, idx_first: int) -> PendingBlock:
        assert self.fs is not None
        n = self._n
        start_idx = bi * n
        t_start = t_first - (idx_first - start_idx) / self.fs
        flags: set[str] = set()
        if self._epoch_first is not None and (
            start_idx <= self._epoch_first or t_start < self._epoch_t0 + self.cfg.ramp_time - 1e-9
        ):
            flags.add('startup')
        return PendingBlock(
            index=bi,
            first_index=start_idx,
            t_start=t_start,
            fs=self.fs,
            torsion=np.full(n, np.nan),
            accel=np.full(n, np.nan),
            speed=np.full(n, np.nan),
            valid=np.zeros(n, dtype=bool),
            moment=np.full(n, np.nan),
            flags=flags,
        )

    def push(self, event: AlignEvent) -> list[PendingBlock]:
        """Collect one aligner event; return the blocks completed by it."""
        done: list[PendingBlock] = []
        self.last_moment = np.zeros(0)
        if isinstance(event, RestartEvent):
            if self._cur is not None:
                done.append(self._cur)
            self._cur = None
            self._epoch_first = None
            self._observer = None
            return done
        if isinstance(event, GapEvent):
            if self._cur is not None:
                self._cur.flags.add('gap')
            self._observer = None  # the chamber speed is lost with the samples
            return done
        ch = event
        if self.fs is None:
            self.fs = ch.sample_rate
            self._n = max(1, round(self.cfg.block_length * self.fs))
        if self._epoch_first is None:
            self._epoch_first = ch.first_index
            self._epoch_t0 = ch.t0
        if self._observer is None:
            w_start = float(
                chamber_speed(ch.torsion[: 4 * CHAMBER_HALF], ch.sample_rate, self.rig.C1)[0]
            )
            self._observer = FrictionObserver(self.rig, ch.sample_rate, initial_speed=w_start)
        moment = self._observer.update(ch.torsion, ch.accel)
        self.last_moment = moment
        n = self._n
        pos = 0
        m = len(ch)
        while pos < m:
            idx = ch.first_index + pos
            bi = idx // n
            if self._cur is not None and self._cur.index != bi:
                done.append(self._cur)
                self._cur = None
            if self._cur is None:
                self._cur = self._new_block(bi, ch.t0 + pos / ch.sample_rate, idx)
            off = idx - bi * n
            take = min(n - off, m - pos)
            cur = self._cur
            cur.torsion[off : off + take] = ch.torsion[pos : pos + take]
            cur.accel[off : off + take] = ch.accel[pos : pos + take]
            cur.speed[off : off + take] = ch.speed[pos : pos + take]
            assert cur.moment is not None
            cur.moment[off : off + take] = moment[pos : pos + take]
            cur.valid[off : off + take] = True
            pos += take
            if off + take == n:
                done.append(cur)
                self._cur = None
        return done

    def flush(self) -> list[PendingBlock]:
        """End of input: the partial block (if any)."""
        if self._cur is None:
            return []
        blk = self._cur
        self._cur = None
        return [blk]

    # ---------------------------------------------------------------- evaluate
    def evaluate(self, blk: PendingBlock) -> BlockDetail:
        """Fit one collected block (see :func:`evaluate_block`)."""
        det = evaluate_block(self.rig, self.friction, self.cfg, blk)
        self.blocks_done += 1
        return det

    def feed(self, event: AlignEvent) -> list[BlockDetail]:
        """Collect and evaluate in one go (offline use)."""
        return [self.evaluate(b) for b in self.push(event)]

    def finish(self) -> list[BlockDetail]:
        """Evaluate the partial last block (offline use)."""
        return [self.evaluate(b) for b in self.flush()]


def estimate_blocks(
    rig: RigParams,
    friction: FrictionLaw,
    cfg: BlockConfig,
    events: Iterable[AlignEvent],
) -> Iterator[BlockDetail]:
    """Stream :class:`BlockDetail` for a sequence of aligner events."""
    est = BlockEstimator(rig, friction, cfg)
    for ev in events:
        yield from est.feed(ev)
    yield from est.finish()


def results_as_dicts(results: Iterable[BlockResult]) -> list[dict[str, object]]:
    """Results as plain dicts (all dataclass fields)."""
    return [{f.name: getattr(r, f.name) for f in fields(r)} for r in results]


def with_flags(r: BlockResult, *extra: str) -> BlockResult:
    """A copy of ``r`` with further quality flags."""
    q = [f for f in FLAGS if f in set(r.quality) | set(extra)]
    return replace(r, quality=tuple(q))


@dataclass(frozen=True)
class MomentChunk:
    """Observer friction moment M [N m] for samples ``first_index ...`` (``/friction/moment``).

    ``t0`` time of the first sample [s], ``sample_rate`` [Hz]."""

    first_index: int
    t0: float
    sample_rate: float
    moment: FloatArray


class StreamingPipeline:
    """Aligner + estimator for live input (the estimator node's core, no rclpy).

    :meth:`push` takes one SampleBlock of one channel (cheap: alignment and the
    observer) and returns the observer output chunks, the blocks ready to be
    fitted and the notices (gaps, restarts) for logging. The fit of a block
    (:meth:`evaluate`) is meant for a worker thread. Same input in the same
    order gives the same blocks as the offline ``tribo friction``.
    """

    def __init__(self, rig: RigParams, friction: FrictionLaw, cfg: BlockConfig) -> None:
        from ..align import ChannelAligner

        self.aligner = ChannelAligner()
        self.estimator = BlockEstimator(rig, friction, cfg)

    def push(
        self, channel: str, first_index: int, sample_rate: float, stamp: float, data: FloatArray
    ) -> tuple[list[MomentChunk], list[PendingBlock], list[str]]:
        """Add one block of one channel; see the class docstring."""
        from ..align import AlignedChunk

        moments: list[MomentChunk] = []
        blocks: list[PendingBlock] = []
        notes: list[str] = []
        for ev in self.aligner.push(channel, first_index, sample_rate, stamp, data):
            blocks.extend(self.estimator.push(ev))
            if isinstance(ev, AlignedChunk):
                moments.append(
                    MomentChunk(ev.first_index, ev.t0, ev.sample_rate, self.estimator.last_moment)
                )
            elif isinstance(ev, GapEvent):
                notes.append(
                    f'gap: samples {ev.start_index}..{ev.end_index - 1} ({ev.n_missing}) '
                    f'missing in {", ".join(ev.channels)}; not bridged'
                )
            elif isinstance(ev, RestartEvent):
                notes.append(
                    f'restart: {ev.channel} index went back from {ev.old_index} to '
                    f'{ev.new_index}; new stream epoch'
                )
        return moments, blocks, notes

    def flush(self) -> list[PendingBlock]:
        """End of input: remaining aligned data and the partial block."""
        blocks: list[PendingBlock] = []
        for ev in self.aligner.flush():
            blocks.extend(self.estimator.push(ev))
        blocks.extend(self.estimator.flush())
        return blocks

    def evaluate(self, blk: PendingBlock) -> BlockResult:
        """Fit one block (heavy; worker thread)."""
        return self.estimator.evaluate(blk).result

    def warm_up(self) -> None:
        """Fit a short simulated stretch once, so the compiled code is loaded before
        the first real block ends (keeps the first estimate's latency low)."""
        from ..simulate import simulate

        est = self.estimator
        w0 = est.cfg.nominal_speed or 1.0
        r = simulate(est.rig, est.friction, DriveProfile(w0), 0.3)
        n = r.time.shape[0]
        blk = PendingBlock(
            -1,
            0,
            0.0,
            r.fs,
            r.torsion_moment,
            r.angular_acceleration,
            r.speed,
            np.ones(n, dtype=bool),
        )
        evaluate_block(est.rig, est.friction, replace(est.cfg, min_fraction=0.01), blk)


__all__ = [
    'CSV_COLUMNS',
    'FILE_COLUMNS',
    'FLAGS',
    'MOTIONS',
    'BlockConfig',
    'BlockCsvWriter',
    'BlockData',
    'BlockDetail',
    'BlockEstimator',
    'BlockResult',
    'FitError',
    'FitOutcome',
    'MomentChunk',
    'PendingBlock',
    'StreamingPipeline',
    'estimate_blocks',
    'evaluate_block',
    'fit_block',
    'read_blocks_csv',
    'results_table',
]
