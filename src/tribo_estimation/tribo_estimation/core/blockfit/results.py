"""Settings and result types of the block-wise friction fit (paper section 2.5).

:class:`BlockConfig` (settings), :class:`BlockData` (the signals of one block),
:class:`FitOutcome` (the estimate of one block's fit), :class:`PendingBlock`
(samples collected by the streaming estimator), :class:`BlockResult` (one row of
``blocks.csv``) and :class:`BlockDetail` (a result with its signals, for plots).
Every value is in SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from ...errors import InvalidParameterError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class BlockConfig:
    """Settings of the block-wise fit.

    Attributes
    ----------
    block_length
        block duration [s] (paper: 1 s).
    fit_k
        also fit the Stribeck constant k [s/rad] (else k stays fixed).
    nominal_speed
        drive speed w0 [rad/s]; ``None`` = mean of the tachometer per block.
    ramp_time
        start-up ramp of the drive [s]; blocks starting before
        ``ramp_time`` after the stream start are flagged ``startup``.
    noise_torque
        noise of the torsion moment [N m]; ``None`` = estimated per block.
    noise_accel
        noise of the acceleration [rad/s^2]; ``None`` = estimated per block.
    max_iter
        Levenberg-Marquardt iterations at most [-].
    min_fraction
        smallest fraction of valid samples for a fit [-].
    saturation_run
        this many equal consecutive samples at the block's
        extreme value mark a clipped sensor [samples].
    min_stick_duration
        shortest stick phase counted (1 ms: 10 samples at 10 kHz;
        shorter ones are micro-sticks) [s].
    speed_lag
        known first-order lag of the shaft-speed sensor [s] (the fit uses
        the speed channel only for the drive level and, lag-corrected, at
        sliding nodes).
    torsion_lag
        first-order lag of the torsion amplifier [s]; ``None`` = estimated
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
        """Refuse settings out of range (:class:`InvalidParameterError`)."""
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
FLAGS = (
    'gap',
    'saturated',
    'no_sliding',
    'startup',
    'fit_failed',
    'short',
    'spikes',
    'bursts',
    'repaired',
)

#: Largest fraction of a block's samples that may be replaced (spikes, bursts:
#: :mod:`..plausibility`) for the block to be fitted; above it the block is
#: flagged ``repaired`` and not fitted [-].
MAX_REPAIRED = 0.2

#: A run of at least this many replaced samples is a burst, shorter ones are
#: spikes [samples].
BURST_MIN = 3


@dataclass(frozen=True)
class BlockResult:
    """Result of one block (one row of ``blocks.csv``, one ``FrictionEstimate``).

    Attributes
    ----------
    index
        block number since the stream start [-].
    first_index
        index of the block's first sample [samples].
    t_start, t_end
        block start and end, stream time [s].
    mu0, mu_inf
        friction coefficients of Equ. 8 [-] (NaN if not identifiable).
    mu0_se, mu_inf_se
        their standard errors [-].
    k, k_se
        Stribeck constant used [s/rad] and its standard error (0 if fixed).
    moment_min, moment_max, moment_mean
        torsion moment C1*phi1 over the block [N m].
    motion
        ``stick-slip``, ``slip-slip`` or ``steady``.
    n_sticks
        stick phases in the block [-].
    stick_fraction
        fraction of the block's samples sticking [-].
    rms_residual
        RMS of the torsion-moment residual of the fit [N m].
    quality
        flags from :data:`FLAGS` (empty = ok).
    w0
        drive speed the fit used, measured from the shaft speed (mean over the
        block's whole stick-slip cycles) [rad/s].
    drive_mismatch
        relative deviation of ``w0`` from the configured nominal
        speed [-] (NaN: none configured); beyond 5 % the command warns.
    speed_offset
        speed channel minus the drive speed of the stick lines at the sticks [rad/s]
        (a tachometer offset or gain error; above 1 % the drive level is taken from
        the stick lines; NaN with fewer than 3 sticks).
    n_samples
        valid samples used [-].
    n_iter
        Levenberg-Marquardt iterations [-].
    spikes
        samples replaced before the fit (spikes and bursts, core.plausibility;
        left out of the fit's residuals) [-].
    bursts
        runs of at least :data:`BURST_MIN` replaced samples in the block [-].
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
    speed_offset: float = math.nan
    spikes: int = 0
    bursts: int = 0

    @property
    def ok(self) -> bool:
        """True for a good estimate (no quality flag)."""
        return not self.quality

    @property
    def quality_str(self) -> str:
        """``ok`` or the ``;``-separated flags."""
        return ';'.join(self.quality) if self.quality else 'ok'


@dataclass(frozen=True)
class BlockData:
    """Measured and observed signals of one contiguous stretch (one block).

    Attributes
    ----------
    t0
        time of the first sample [s].
    fs
        sample rate [Hz].
    torsion
        torsion moment C1*phi1 [N m].
    accel
        chamber acceleration w1' [rad/s^2].
    speed
        shaft speed w2 (tachometer) [rad/s].
    moment
        observer friction moment M [N m] (Equ. 1).
    chamber_speed
        observer chamber speed w1 [rad/s].
    stick
        True where the discs stick.
    repaired
        True at samples replaced before the fit (spikes, bursts), which
        the fit leaves out of its residuals; None: none.
    """

    t0: float
    fs: float
    torsion: FloatArray
    accel: FloatArray
    speed: FloatArray
    moment: FloatArray
    chamber_speed: FloatArray
    stick: BoolArray
    repaired: BoolArray | None = None

    def __len__(self) -> int:
        """Return the number of samples."""
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


@dataclass
class PendingBlock:
    """Samples of one block, collected by :class:`BlockEstimator`, ready to evaluate.

    Arrays have the block length; ``valid`` is False where samples are missing (gap).
    ``moment`` is the streaming observer's friction moment [N m] (None: computed
    per block). ``flags`` are those known while collecting (``gap``, ``startup``).
    ``repaired`` is True at samples replaced before (spikes, bursts; None: none).
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
    repaired: BoolArray | None = None

    @property
    def t_end(self) -> float:
        """End of the block, stream time [s]."""
        return float(self.t_start + self.torsion.shape[0] / self.fs)


@dataclass(frozen=True)
class BlockDetail:
    """Signals of an evaluated block for plots (Fig. 6): the fitted stretch."""

    result: BlockResult
    data: BlockData
    simulated: FloatArray


def with_flags(r: BlockResult, *extra: str) -> BlockResult:
    """Copy ``r`` with further quality flags."""
    q = [f for f in FLAGS if f in set(r.quality) | set(extra)]
    return replace(r, quality=tuple(q))
