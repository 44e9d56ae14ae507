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
   measured stick phases. During sticking ``w1 = w2`` and the full state is
   known from the measurements: ``phi1 = M_t/C1``, ``w`` from the slope of
   ``M_t`` (or the observer), and the shaft twist ``phi2 - phi0`` from the
   stuck equations of motion (Equ. 1, 2 with Equ. 4). Every segment is
   simulated from the state at its stick phase to the next stick phase, so a
   1 s fit cannot drift out of phase. A Levenberg-Marquardt iteration with
   forward-difference sensitivities (a handful of kernel calls) minimises the
   weighted residuals. Blocks without sticking are simulated in one piece from
   the observer state; there the deceleration rule keeps ``mu = mu_inf`` and
   mu0 is not identifiable (reported as NaN).
4. **Standard errors** from the Jacobian and the residual variance, inflated
   by ``(1 + rho)/(1 - rho)`` for the lag-1 autocorrelation ``rho`` of the
   residuals (effective number of independent samples).

Every value is in SI units: moments N m, speeds rad/s, accelerations rad/s^2,
time s, coefficients dimensionless, k in s/rad.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, fields, replace
from typing import TextIO

import numpy as np
import numpy.typing as npt
from numba import njit

from ..errors import EstimationError, InvalidDataError, InvalidParameterError, UnitError
from . import kernel as kn
from .model import DriveProfile, FrictionLaw, RigParams, pack_params

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class FitError(EstimationError):
    """The block fit could not produce an estimate (too little or unusable data)."""


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
        min_stick_samples: shortest stick phase used as a shooting node [samples].
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
    min_stick_samples: int = 2

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
        if self.saturation_run < 2:
            raise InvalidParameterError(
                f'saturation_run must be >= 2 samples, got {self.saturation_run}'
            )
        if self.min_stick_samples < 1:
            raise InvalidParameterError(
                f'min_stick_samples must be >= 1, got {self.min_stick_samples}'
            )


#: Motion types (paper section 2.5).
MOTIONS = ('stick-slip', 'slip-slip', 'steady')

#: Quality flags; a block with any of them is not a good estimate.
FLAGS = ('gap', 'saturated', 'no_sliding', 'startup', 'fit_failed', 'short')


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
        w0: drive speed the fit used [rad/s].
        n_samples: valid samples used [-].
        n_iter: Levenberg-Marquardt iterations [-].
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

    @property
    def ok(self) -> bool:
        """True for a good estimate (no quality flag)."""
        return not self.quality

    @property
    def quality_str(self) -> str:
        """``ok`` or the ``;``-separated flags."""
        return ';'.join(self.quality) if self.quality else 'ok'


#: Columns of ``blocks.csv`` (issue 4), then ``quality``.
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


def _fmt(v: float) -> str:
    return 'nan' if not math.isfinite(v) else f'{v:.9g}'


class BlockCsvWriter:
    """Write :class:`BlockResult` rows to ``blocks.csv`` as they come (streaming).

    Each row is flushed, so a run that is interrupted keeps every finished block.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = os.fspath(path)
        self._fh: TextIO = open(self.path, 'w', newline='', encoding='utf-8')  # noqa: SIM115
        self._w = csv.writer(self._fh, lineterminator='\n')
        self._w.writerow(CSV_COLUMNS)
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
                r.quality_str,
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
    from ..errors import MissingColumnError

    p = os.fspath(path)
    try:
        fh = open(p, newline='', encoding='utf-8')  # noqa: SIM115
    except OSError as exc:
        raise InvalidDataError(f'{p}: cannot read blocks table ({exc.strerror})') from exc
    with fh:
        reader = csv.DictReader(fh)
        cols = reader.fieldnames or []
        for c in CSV_COLUMNS:
            if c not in cols:
                raise MissingColumnError(f'{p}: missing column {c!r} in blocks table')
        rows = list(reader)
    out: dict[str, np.ndarray] = {}
    for c in CSV_COLUMNS:
        vals = [r[c] for r in rows]
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
def noise_level(x: FloatArray) -> float:
    """Robust white-noise standard deviation of a sampled signal [unit of x].

    From the median absolute second difference (a smooth signal's second
    difference is far below the noise at 10 kHz): ``sigma = 1.4826*MAD/sqrt(6)``.
    """
    if x.shape[0] < 8:
        return math.nan
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return 1.4826 * mad / math.sqrt(6.0)


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
        m = (x == ext).astype(np.int8)
        if int(m.sum()) < run:
            continue
        d = np.diff(np.r_[0, m, 0])
        starts = np.flatnonzero(d == 1)
        ends = np.flatnonzero(d == -1)
        if np.max(ends - starts) >= run:
            return True
    return False


def stick_phases(stick: BoolArray) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Start and end (exclusive) indices of the runs of True in ``stick``."""
    s = np.asarray(stick, dtype=np.int8)
    d = np.diff(np.r_[0, s, 0])
    return np.flatnonzero(d == 1).astype(np.int64), np.flatnonzero(d == -1).astype(np.int64)


# ============================================================ compiled multiple shooting
@njit(cache=True)
def _shoot(
    p: np.ndarray,
    states: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    dt: float,
    n_sub: int,
    sim_torsion: np.ndarray,
    sim_accel: np.ndarray,
    scratch: np.ndarray,
) -> int:
    """Simulate every segment ``[starts[i], ends[i])`` from ``states[i]`` with the
    kernel (:func:`kernel.integrate`) and write torsion moment [N m] and
    acceleration [rad/s^2] into the block-length arrays. Returns the events."""
    n_ev = 0
    s = np.empty(states.shape[1])
    for i in range(starts.shape[0]):
        n = ends[i] - starts[i]
        if n <= 0:
            continue
        for j in range(states.shape[1]):
            s[j] = states[i, j]
        n_ev += kn.integrate(p, s, n, dt, n_sub, scratch)
        for j in range(n):
            sim_torsion[starts[i] + j] = scratch[kn.OUT_TORSION, j]
            sim_accel[starts[i] + j] = scratch[kn.OUT_ACCEL, j]
    return n_ev


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
    simulated segments); ``n_iter`` iterations; ``converged``.
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
    converged: bool
    w0: float


def _local_poly(y: FloatArray, j: int, lo: int, hi: int) -> tuple[float, float]:
    """Value at sample j and slope per sample of a local cubic through y[lo:hi]."""
    n = hi - lo
    if n < 6:
        return float(y[j]), math.nan
    x = np.arange(lo, hi, dtype=float) - j
    A = np.vstack((np.ones(n), x, x * x, x * x * x)).T
    coef, *_ = np.linalg.lstsq(A, y[lo:hi], rcond=None)
    return float(coef[0]), float(coef[1])


#: Half width of the local polynomial that gives phi1 and w1 = phi1' [samples].
_HALF = 7


def _stuck_state(
    p: np.ndarray, d: BlockData, j: int, lo: int, hi: int, w0: float
) -> np.ndarray:
    """Full kernel state at sample j of a stick phase [lo, hi) from the measurements.

    Sticking (Equ. 4): w1 = w2 = w. phi1 = M_t/C1 and w = phi1' = (dM_t/dt)/C1
    from a local cubic through the stick samples around j (the observer's
    w1 when the phase is too short). The shaft twist follows from Equ. 1 and 2 with w1' = w2' = a:
    ``Q2 = (I1 + I2)*a - Q1``, ``Q1 = -K1*w - C1*phi1``,
    ``phi2 - phi0 = -(Q2 + K2*(w - w0))/C2`` (phi0 = 0 at the segment start).
    """
    c1 = p[kn.P_C1]
    mt, slope = _local_poly(d.torsion, j, max(lo, j - _HALF), min(hi, j + _HALF + 1))
    if math.isfinite(slope):
        w = slope * d.fs / c1
    else:
        w = float(d.chamber_speed[j])
    phi1 = mt / c1
    a_lo, a_hi = max(lo, j - 2), min(hi, j + 3)
    a = float(np.mean(d.accel[a_lo:a_hi]))
    q1 = -p[kn.P_K1] * w - c1 * phi1
    q2 = (p[kn.P_I1] + p[kn.P_I2]) * a - q1
    phi2 = -(q2 + p[kn.P_K2] * (w - w0)) / p[kn.P_C2]
    s = np.zeros(kn.NS)
    s[kn.S_PHI1] = phi1
    s[kn.S_W1] = w
    s[kn.S_PHI2] = phi2
    s[kn.S_W2] = w
    s[kn.S_STUCK] = 1.0
    s[kn.S_DIR] = 1.0
    s[kn.S_SENSOR] = math.nan
    return s


def _sliding_state(p: np.ndarray, d: BlockData, j: int, w0: float) -> np.ndarray:
    """Kernel state at sample j while sliding (no stick phase to anchor on).

    phi1 = M_t/C1, w1 from the observer, w2 from the tachometer; shaft twist
    quasi-static from Equ. 2 with w2' = 0: ``C2*(phi2 - phi0) = -M - K2*(w2 - w0)``.
    The phase is taken as past its slip-speed peak (mu = mu_inf, deceleration rule).
    """
    lo, hi = max(0, j - 5), min(len(d), j + 6)
    mt = float(np.mean(d.torsion[lo:hi]))
    m = float(np.mean(d.moment[lo:hi]))
    w1 = float(d.chamber_speed[j])
    w2 = float(np.mean(d.speed[lo:hi]))
    s = np.zeros(kn.NS)
    s[kn.S_PHI1] = mt / p[kn.P_C1]
    s[kn.S_W1] = w1
    s[kn.S_W2] = w2
    s[kn.S_PHI2] = -(m + p[kn.P_K2] * (w2 - w0)) / p[kn.P_C2]
    s[kn.S_STUCK] = 0.0
    v = w2 - w1
    s[kn.S_DIR] = 1.0 if v >= 0.0 else -1.0
    s[kn.S_PEAK] = 1.0
    s[kn.S_VMAX] = abs(v)
    s[kn.S_SENSOR] = math.nan
    return s


def initial_estimate(d: BlockData, fnr: float, min_stick: int = 2) -> tuple[float, float]:
    """Equation-error estimate of (mu0, mu_inf) from the observer moment M [N m].

    mu0: median over stick phases of max |M| around the breakaway (last stuck
    sample and the first sliding ones), divided by F_N*R (Equ. 5). mu_inf: median
    |M|/(F_N*R) over the second half of each sliding phase, where the
    deceleration rule gives mu = mu_inf. Without sticking mu0 is NaN and mu_inf
    the median |M|/(F_N*R) of the block.
    """
    m = np.abs(d.moment)
    starts, ends = stick_phases(d.stick)
    keep = (ends - starts) >= min_stick
    starts, ends = starts[keep], ends[keep]
    n = len(d)
    if starts.size == 0:
        return math.nan, float(np.median(m)) / fnr
    peaks = [float(np.max(m[max(0, e - 1) : min(n, e + 3)])) for e in ends if e < n]
    mu0 = float(np.median(peaks)) / fnr if peaks else float(np.max(m)) / fnr
    tails: list[FloatArray] = []
    for e, s_next in zip(ends, np.r_[starts[1:], n], strict=True):
        if s_next - e >= 4:
            mid = e + (s_next - e) // 2
            tails.append(m[mid:s_next])
    mu_inf = float(np.median(np.concatenate(tails))) / fnr if tails else float(np.min(m)) / fnr
    return mu0, mu_inf


def _autocorr1(r: FloatArray) -> float:
    if r.shape[0] < 3:
        return 0.0
    r = r - r.mean()
    den = float(np.dot(r, r))
    if den <= 0.0:
        return 0.0
    return float(np.dot(r[1:], r[:-1]) / den)


def fit_block(
    rig: RigParams,
    d: BlockData,
    w0: float,
    k: float,
    cfg: BlockConfig,
    init: tuple[float, float] | None = None,
) -> FitOutcome:
    """Fit mu0, mu_inf (and k if ``cfg.fit_k``) of Equ. 8 to one block (see module doc).

    Args:
        rig: rig parameters (Tab. 1, F_N [N], R [m]).
        d: measured and observed block signals.
        w0: constant nominal drive speed [rad/s].
        k: Stribeck constant [s/rad] (start value when fitted).
        cfg: fit settings.
        init: start values (mu0, mu_inf); default the equation-error estimate.

    Raises:
        FitError: too few samples or no usable start value.
    """
    n = len(d)
    if n < 20:
        raise FitError(f'block has only {n} samples; at least 20 are needed')
    fnr = rig.F_N * rig.R
    if fnr <= 0.0:
        raise FitError('F_N*R is zero: no contact, no friction to fit')
    mu0_i, muinf_i = initial_estimate(d, fnr, cfg.min_stick_samples)
    if init is not None:
        if math.isfinite(init[0]):
            mu0_i = init[0]
        if math.isfinite(init[1]):
            muinf_i = init[1]
    if not math.isfinite(muinf_i):
        raise FitError('no start value for mu_inf (observer moment not finite)')
    # noise levels for the weights
    sig_m = cfg.noise_torque if cfg.noise_torque is not None else noise_level(d.torsion)
    sig_a = cfg.noise_accel if cfg.noise_accel is not None else noise_level(d.accel)
    sig_m = sig_m if math.isfinite(sig_m) and sig_m > 0.0 else 1e-3 * max(1.0, fnr * muinf_i)
    sig_a = sig_a if math.isfinite(sig_a) and sig_a > 0.0 else 1.0

    p = pack_params(rig, FrictionLaw(max(mu0_i, 0.0) if math.isfinite(mu0_i) else muinf_i,
                                     max(muinf_i, 0.0), k), DriveProfile(w0))
    dt = 1.0 / d.fs
    n_sub = kn.substeps_for(p, dt)

    # shooting nodes
    starts_s, ends_s = stick_phases(d.stick)
    keep = (ends_s - starts_s) >= cfg.min_stick_samples
    starts_s, ends_s = starts_s[keep], ends_s[keep]
    sticky = starts_s.size > 0
    if sticky:
        anchors = starts_s + np.minimum(_HALF, (ends_s - starts_s - 1) // 2)
        states = np.vstack(
            [_stuck_state(p, d, int(j), int(lo), int(hi), w0)
             for j, lo, hi in zip(anchors, starts_s, ends_s, strict=True)]
        )
        seg_start = anchors.astype(np.int64)
        seg_end = np.r_[anchors[1:], n].astype(np.int64)
        names = ['mu0', 'mu_inf'] + (['k'] if cfg.fit_k else [])
    else:
        states = _sliding_state(p, d, 0, w0)[None, :]
        seg_start = np.zeros(1, dtype=np.int64)
        seg_end = np.array([n], dtype=np.int64)
        names = ['mu_inf']
    used = np.zeros(n, dtype=bool)
    for a, b in zip(seg_start, seg_end, strict=True):
        used[a:b] = True
    n_used = int(used.sum())
    sim_t = np.full(n, np.nan)
    sim_a = np.full(n, np.nan)
    scratch = np.empty((kn.N_CH, int(np.max(seg_end - seg_start)) + 1))
    meas_t = d.torsion[used]
    meas_a = d.accel[used]

    idx = {'mu0': kn.P_MU0, 'mu_inf': kn.P_MUINF, 'k': kn.P_K}

    def set_theta(th: FloatArray) -> None:
        for name, v in zip(names, th, strict=True):
            p[idx[name]] = v
        if not sticky:
            p[kn.P_MU0] = p[kn.P_MUINF]  # irrelevant after the peak; kept consistent

    def residual(th: FloatArray) -> FloatArray:
        set_theta(th)
        _shoot(p, states, seg_start, seg_end, dt, n_sub, sim_t, sim_a, scratch)
        return np.concatenate(((sim_t[used] - meas_t) / sig_m, (sim_a[used] - meas_a) / sig_a))

    start = {'mu0': mu0_i, 'mu_inf': muinf_i, 'k': k}
    theta = np.array([max(start[nm], 0.0) for nm in names], dtype=float)
    lower = np.zeros(len(names))
    r = residual(theta)
    cost = float(np.dot(r, r))
    lam = 1e-3
    converged = False
    it = 0
    J = np.zeros((r.shape[0], len(names)))
    for it in range(1, cfg.max_iter + 1):  # noqa: B007
        # forward-difference sensitivities (event-accurate kernel: smooth in theta)
        for j, nm in enumerate(names):
            h = 1e-4 * max(abs(theta[j]), 0.05 if nm != 'k' else 1.0)
            th = theta.copy()
            th[j] += h
            J[:, j] = (residual(th) - r) / h
        g = J.T @ r
        A = J.T @ J
        improved = False
        for _ in range(6):
            step = np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), -g)
            th_new = np.maximum(theta + step, lower)
            r_new = residual(th_new)
            c_new = float(np.dot(r_new, r_new))
            if c_new < cost:
                improved = True
                rel = (cost - c_new) / max(cost, 1e-300)
                theta, r, cost = th_new, r_new, c_new
                lam = max(lam / 10.0, 1e-9)
                small = np.all(np.abs(step) <= 1e-7 + 1e-6 * np.abs(theta))
                if small or rel < 1e-10:
                    converged = True
                break
            lam *= 10.0
        if not improved:
            converged = True  # no descent direction left at this resolution
            break
        if converged:
            break
    # final residual at theta (simulated arrays hold the last evaluation: recompute)
    r = residual(theta)
    # standard errors: residual variance, corrected for lag-1 autocorrelation
    m_used = r.shape[0]
    dof = max(1, m_used - len(names))
    s2 = float(np.dot(r, r)) / dof
    rho = max(_autocorr1(r[:n_used]), _autocorr1(r[n_used:]), 0.0)
    rho = min(rho, 0.99)
    infl = (1.0 + rho) / (1.0 - rho)
    for j, nm in enumerate(names):  # Jacobian at the final theta
        h = 1e-4 * max(abs(theta[j]), 0.05 if nm != 'k' else 1.0)
        th = theta.copy()
        th[j] += h
        J[:, j] = (residual(th) - r) / h
    r = residual(theta)  # leave sim arrays at the estimate
    try:
        cov = np.linalg.inv(J.T @ J) * s2 * infl
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(names), math.nan)
    val = dict(zip(names, theta, strict=True))
    err = dict(zip(names, se, strict=True))
    rms = float(np.sqrt(np.mean((sim_t[used] - meas_t) ** 2)))
    return FitOutcome(
        mu0=float(val.get('mu0', math.nan)),
        mu_inf=float(val['mu_inf']),
        k=float(val.get('k', k)),
        mu0_se=float(err.get('mu0', math.nan)),
        mu_inf_se=float(err['mu_inf']),
        k_se=float(err.get('k', 0.0)),
        rms_residual=rms,
        simulated=sim_t.copy(),
        n_iter=it,
        converged=converged,
        w0=w0,
    )
