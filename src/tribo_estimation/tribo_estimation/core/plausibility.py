"""Plausibility of rig records before any fit: units, time base, spikes (no rclpy).

Each input channel is compared with what the rig's physics allows (symbols of
the paper, units SI; see ``docs/physics.md``):

* torsion moment ``C1 phi1`` [N m]: of the order of the friction moment
  ``F_N R mu`` (Equ. 8 with mu0/mu_inf of RIG.yaml); a 1000-fold larger median
  says N mm;
* shaft speed ``w2`` [rad/s]: near ``nominal_speed`` of the drive; 30/pi = 9.55
  times larger says rpm; a > 5 % difference of the median over the second half
  of the checked samples (past the start-up ramp) is a warning (a RIG.yaml describing
  another run), a speed channel at rest under a driven RIG.yaml an error;
* chamber acceleration ``w1'`` [rad/s^2]: bounded by torque over inertia
  ``|C1 phi1 - M_R| / I1`` (Equ. 1); far larger says deg/s^2 or mrad/s^2;
* time base: 0.1-100 kHz sampling, fast enough for the stick-slip frequency
  ``sqrt(C1/I1)/(2 pi)``; 1000 times slower says the time column is in ms.

A likely unit error raises :class:`~tribo_estimation.errors.UnitError`, a time
base that cannot be analysed :class:`~tribo_estimation.errors.TimeBaseError`;
both name the channel, the measured value and what was expected (CLI exit 2).

Isolated spikes (a sample or two far off a 5-sample running median, compared
with the MAD noise level of that residual), samples beyond any physical
bound and bursts (runs of up to :data:`BURST_MAX` samples that enter and leave
with a step no physical signal makes: a saturating channel, an ADC glitch;
:func:`find_bursts`) are replaced by linear interpolation of their good
neighbours and counted; the block fit leaves the replaced samples out of its
residuals, so they never bias a fit and never disturb neighbouring blocks.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.align import AlignedChunk, AlignEvent
from tribo_estimation.core.model import FrictionLaw, RigParams
from tribo_estimation.core.signal import noise_level
from tribo_estimation.errors import TimeBaseError, UnitError

FloatArray = npt.NDArray[np.float64]

#: Sample rates a rig record may have [Hz] (DAQ range of the rig).
FS_MIN = 100.0
FS_MAX = 100_000.0
#: Largest ratio between a channel's robust amplitude and its physical scale
#: before the channel is taken as written in other units.
UNIT_RATIO = 30.0
#: Acceleration may exceed its physical bound (|C1 phi1| + F_N R mu)/I1 by this
#: factor (noise) before it is taken as written in other units (deg/s^2: x57.3).
ACCEL_RATIO = 4.0
#: Relative difference of the speed channel's median from nominal_speed that
#: is reported (warning) [-].
SPEED_WARN = 0.05
#: Spike threshold in robust standard deviations of the median-filter residual.
SPIKE_SIGMA = 12.0
#: Spike threshold as a fraction of the channel's robust range (a floor for
#: noise-free records).
SPIKE_RANGE = 0.2
#: Running-median width [samples] (removes runs of up to 2 samples).
MEDIAN_WIDTH = 5
#: A sample beyond this many physical scales is never a measurement.
GROSS_FACTOR = 1e3
#: No channel of the rig measures a magnitude beyond this (SI units) [-].
ABSURD = 1e30
#: Longest burst (a run of corrupted samples: a saturating channel, an ADC glitch)
#: that is repaired [samples]; a longer excursion is left to the block checks. A
#: burst needs two steps no physical signal makes, so a long limit finds nothing
#: in clean records; it keeps a 100-400-sample burst from the fits (at the start of
#: a record one drove the discrepancy fit's simulations 200x slower).
BURST_MAX = 512
#: A step of a channel between two samples larger than this many physical scales
#: is not physical (torsion moment and speeds are continuous states; the
#: acceleration jumps by at most about one scale at a re-stick, Equ. 1) [-].
BURST_SCALES = 3.0
#: Samples held back at a chunk edge (and kept as context) so that a burst that
#: crosses the edge is judged whole [samples].
EDGE_HOLD = BURST_MAX + MEDIAN_WIDTH + 2


def mad_sigma(x: FloatArray) -> float:
    """Robust standard deviation ``1.4826 * median(|x - median(x)|)`` [unit of x]."""
    if x.size == 0:
        return math.nan
    med = float(np.median(x))
    return 1.4826 * float(np.median(np.abs(x - med)))


def running_median(x: FloatArray, width: int = MEDIAN_WIDTH) -> FloatArray:
    """Centred running median of odd ``width`` (edges use the nearest full window)."""
    n = x.shape[0]
    h = width // 2
    if n < width:
        return np.full(n, float(np.median(x)) if n else 0.0)
    win = np.lib.stride_tricks.sliding_window_view(x, width)
    mid = np.median(win, axis=1)
    return np.concatenate([np.full(h, mid[0]), mid, np.full(h, mid[-1])])


def find_spikes(x: FloatArray, scale: float) -> npt.NDArray[np.bool_]:
    """Mask of isolated spikes and gross outliers in ``x``.

    ``scale`` is the channel's physical scale (same unit as ``x``): a sample
    more than ``GROSS_FACTOR * scale`` from zero (``scale > 0``; without a scale,
    ``GROSS_FACTOR`` times the channel's 1-99 % range from its median) is always
    an outlier; otherwise
    (not within two samples of either end, where a step cannot be told from a
    spike) a spike needs a residual above ``SPIKE_SIGMA`` robust
    standard deviations and above ``SPIKE_RANGE`` times the channel's
    1-99 % range.
    """
    n = x.shape[0]
    bad = ~np.isfinite(x)
    if n < MEDIAN_WIDTH:
        return bad
    xs = np.where(bad, 0.0, x)
    with np.errstate(over='ignore', invalid='ignore'):
        res = np.abs(xs - running_median(xs))
        h = MEDIAN_WIDTH // 2
        res[:h] = 0.0  # one-sided window: a step looks like a spike; only gross ones count
        res[-h:] = 0.0
        good = res[np.isfinite(res)]
        sigma = mad_sigma(good) if good.size else 0.0
        lo, hi = np.percentile(xs, [1.0, 99.0])
        span = float(hi - lo) if math.isfinite(float(hi - lo)) else math.inf
        thr = max(SPIKE_SIGMA * sigma, SPIKE_RANGE * span, 1e-12 * max(scale, 0.0))
        if scale > 0:
            gross = np.abs(xs) > GROSS_FACTOR * scale
        else:  # no physical scale: GROSS_FACTOR times the channel's own 1-99 % range off
            # its median (a constant channel: any other value; also at the two end
            # samples, where the running median cannot judge)
            gross = np.abs(xs - float(np.median(xs))) > GROSS_FACTOR * span
        out: npt.NDArray[np.bool_] = bad | gross | ~np.isfinite(res) | (res > thr)
    return out


def find_bursts(x: FloatArray, scale: float, max_len: int = BURST_MAX) -> npt.NDArray[np.bool_]:
    """Mask of bursts: runs of up to ``max_len`` samples displaced from the signal.

    A burst enters and leaves with a step between two samples that no physical
    signal of the rig makes: larger than ``BURST_SCALES * scale`` (a slip phase's
    torque drop is fast but smooth, bounded by F_N R mu and C1, Equ. 1-3) and
    larger than ``SPIKE_SIGMA`` robust noise levels of the first difference. A
    run from such a step to the first later step (at most ``max_len`` samples on)
    after which the signal is back within that threshold of its level before
    the run is a burst; a run that starts or ends at an end of ``x`` and is
    displaced by more than the threshold from the rest is one too. A lasting
    step (an offset change) is not a burst and is left alone.

    Parameters
    ----------
    x : numpy.ndarray
        Finite samples of one channel (spikes and non-finite values repaired
        first, :func:`find_spikes`) [unit of the channel].
    scale : float
        Physical scale of the channel [unit of the channel]; ``<= 0``: no
        physical bound known, no bursts are looked for.
    max_len : int
        Longest burst [samples].

    Returns
    -------
    numpy.ndarray
        True at the samples of a burst (bool, shape of ``x``).
    """
    n = x.shape[0]
    out = np.zeros(n, dtype=bool)
    if not (scale > 0.0 and math.isfinite(scale)) or n < 3:
        return out
    with np.errstate(over='ignore', invalid='ignore'):
        step = np.abs(np.diff(x))
    thr = BURST_SCALES * scale
    if not np.any(step > thr):  # the usual case: nothing to do
        return out
    sig = noise_level(x, 2)
    if math.isfinite(sig):
        thr = max(thr, SPIKE_SIGMA * math.sqrt(2.0) * sig)
    jumps = np.flatnonzero(step > thr)  # a step between sample j and j + 1
    if jumps.size == 0:  # all steps within the noise
        return out
    i = 0
    while i < jumps.size:
        s = int(jumps[i]) + 1  # first displaced sample
        base = float(x[s - 1])
        stop = -1
        k = i
        while k < jumps.size and int(jumps[k]) + 1 - s <= max_len:
            if abs(float(x[int(jumps[k]) + 1]) - base) <= thr:
                stop = k
                break
            k += 1
        if stop >= 0:
            out[s : int(jumps[stop]) + 1] = True
            i = stop + 1
        elif n - s <= max_len and np.all(np.abs(x[s:] - base) > thr):
            out[s:] = True  # displaced up to the end of x
            break
        else:
            i += 1
    j0 = int(jumps[0]) + 1  # the first step follows sample j0 - 1
    if j0 <= max_len and not out[j0] and np.all(np.abs(x[:j0] - float(x[j0])) > thr):
        out[:j0] = True  # displaced from the start of x on
    return out


def repair(x: FloatArray, mask: npt.NDArray[np.bool_]) -> FloatArray:
    """Replace the masked samples of ``x``.

    By linear interpolation of the unmasked ones (constant beyond the ends); all
    masked: zeros.
    """
    if not mask.any():
        return x
    good = np.flatnonzero(~mask)
    if good.size == 0:
        return np.zeros_like(x)
    idx = np.arange(x.shape[0])
    y = x.copy()
    y[mask] = np.interp(idx[mask], good, x[good])
    return y


@dataclass(frozen=True)
class Scales:
    """Physical scales of the rig's channels (SI).

    Attributes
    ----------
    torque
        friction moment ``F_N R mu`` with the larger mu of RIG.yaml [N m].
    accel
        ``torque / I1`` [rad/s^2].
    speed
        ``|nominal_speed|`` [rad/s] (0: drive at rest).
    f_stick_slip
        natural frequency of the chamber ``sqrt(C1/I1)/(2 pi)`` [Hz].
    from_record
        True when the scales are the record's own medians (no rig config,
        :meth:`from_data`): not physical bounds, so a burst must also stand out
        of the record's own amplitude (:func:`despike_chunk`).
    """

    torque: float
    accel: float
    speed: float
    f_stick_slip: float
    from_record: bool = False

    @classmethod
    def of(cls, rig: RigParams, friction: FrictionLaw, nominal_speed: float) -> Scales:
        """Take the scales from the rig config.

        Parameters
        ----------
        rig : RigParams
            Rig parameters (F_N [N], R [m], I1 [kg m^2], C1 [N m/rad]).
        friction : FrictionLaw
            Friction law of the config (the larger of mu0, mu_inf counts).
        nominal_speed : float
            Drive speed of the config [rad/s].

        Returns
        -------
        Scales
            The physical scales of the channels.
        """
        mu = max(friction.mu0, friction.mu_inf, 0.01)
        torque = rig.F_N * rig.R * mu
        return cls(
            torque=torque,
            accel=torque / rig.I1,
            speed=abs(nominal_speed),
            f_stick_slip=math.sqrt(rig.C1 / rig.I1) / (2.0 * math.pi),
        )

    @classmethod
    def from_data(
        cls, torque: FloatArray, accel: FloatArray, speed: FloatArray, source: str = 'record'
    ) -> Scales:
        """Take the scales from the record itself.

        Median of each |channel| (robust to bursts of up to half the record), for a
        record without a rig config (free decay); ``f_stick_slip`` is NaN.

        Parameters
        ----------
        torque, accel, speed : numpy.ndarray
            Torsion moment [N m], chamber acceleration [rad/s^2], shaft speed [rad/s].
        source : str
            Name of the record for messages.

        Returns
        -------
        Scales
            The record's own scales (``from_record`` True).

        Raises
        ------
        UnitError
            A channel's median is beyond :data:`ABSURD` (no rig measures that:
            most of the channel is garbage).
        """

        def amp(x: FloatArray, name: str) -> float:
            a = np.abs(x[np.isfinite(x)])
            with np.errstate(over='ignore', invalid='ignore'):  # median of two 1e308
                med = float(np.median(a)) if a.size else 0.0
            if med > ABSURD:
                raise UnitError(
                    f'{source}: {name} is not a measurement: median |value| {med:.3g} '
                    f'(most samples beyond {ABSURD:g})'
                )
            return med

        return cls(
            amp(torque, 'torsion_moment'),
            amp(accel, 'angular_acceleration'),
            amp(speed, 'speed'),
            math.nan,
            True,
        )


def _amp(x: FloatArray) -> float:
    """Robust amplitude: the 95th percentile of |x|."""
    return float(np.percentile(np.abs(x), 95.0)) if x.size else 0.0


def check_time_base(fs: float, source: str, f_stick_slip: float | None = None) -> None:
    """Refuse a sample rate [Hz] that the rig cannot have.

    Outside 0.1-100 kHz (naming the likely time unit) or too slow for the
    stick-slip frequency ``f_stick_slip`` [Hz].
    """
    if not math.isfinite(fs) or fs <= 0.0:
        raise TimeBaseError(f'{source}: time column gives no sample rate ({fs} Hz)')
    if fs < FS_MIN:
        hint = ''
        if FS_MIN <= fs * 1e3 <= FS_MAX:
            hint = f'; the time column looks like ms (that would be {fs * 1e3:g} Hz): convert to s'
        raise TimeBaseError(
            f'{source}: sample rate {fs:.4g} Hz is below the rig DAQ range '
            f'{FS_MIN:g}-{FS_MAX:g} Hz{hint}'
        )
    if fs > FS_MAX:
        hint = ''
        for unit, f in (('us', 1e-6), ('ns', 1e-9)):
            if FS_MIN <= fs * f <= FS_MAX:
                hint = f'; the time column looks like {unit}: convert to s'
                break
        raise TimeBaseError(
            f'{source}: sample rate {fs:.4g} Hz is above the rig DAQ range '
            f'{FS_MIN:g}-{FS_MAX:g} Hz{hint}'
        )
    if f_stick_slip is not None and fs < 4.0 * f_stick_slip:
        raise TimeBaseError(
            f'{source}: sample rate {fs:.4g} Hz is too slow for the stick-slip frequency '
            f'sqrt(C1/I1)/2pi = {f_stick_slip:.4g} Hz (need >= 4x)'
        )


def _clean(x: FloatArray, scale: float) -> FloatArray:
    """Finite, non-spike samples of ``x`` (for robust statistics)."""
    m = find_spikes(x, scale) if scale > 0 else ~np.isfinite(x)
    return x[~m]


def check_channels(
    torque: FloatArray,
    accel: FloatArray,
    speed: FloatArray,
    scales: Scales,
    source: str,
    whole_record: bool = True,
) -> list[str]:
    """Compare each channel with the rig's physical scales.

    Returns warnings (one line each); raises :class:`UnitError` for a likely unit
    mistake or, when the channels are the ``whole_record``, a speed channel at rest
    under a driven RIG.yaml (for the start of a stream that is a warning: the drive
    may start later).
    """
    warnings: list[str] = []
    tq = _clean(torque, scales.torque)
    if scales.torque > 0 and tq.size:
        med = float(np.median(np.abs(tq)))
        amp = _amp(tq)
        if amp > UNIT_RATIO * scales.torque:
            ratio = amp / scales.torque
            hint = ' looks like N mm' if 300.0 <= ratio <= 3000.0 else ' is far too large'
            raise UnitError(
                f'{source}: torsion_moment{hint}: median {med:.3g}, expected about '
                f'{scales.torque:.3g} N m (F_N R mu of the rig config)'
            )
    if scales.torque > 0 and scales.accel > 0:
        # |w1'| <= (|C1 phi1| + F_N R mu) / I1 (Equ. 1); I1 = torque / accel scale
        per_nm = scales.accel / scales.torque  # 1 / I1 [1/(kg m^2)]
        expected = (max(_amp(tq) if tq.size else 0.0, 0.0) + scales.torque) * per_nm
        amp_a = _amp(_clean(accel, GROSS_FACTOR * expected))
        if amp_a > ACCEL_RATIO * expected:
            raise UnitError(
                f'{source}: angular_acceleration exceeds what the torque can cause: 95th '
                f'percentile {amp_a:.3g}, at most about {expected:.3g} rad/s^2 '
                '((|C1 phi1| + F_N R mu) / I1); deg/s^2 instead of rad/s^2 (x57.3)?'
            )
    # the second half: past the drive's start-up ramp
    sp = _clean(speed[speed.shape[0] // 2 :], max(scales.speed, 1.0))
    if scales.speed > 0 and sp.size:
        med = float(np.median(np.abs(sp)))
        ratio = med / scales.speed
        if abs(ratio - 30.0 / math.pi) < 0.15 * 30.0 / math.pi:
            raise UnitError(
                f'{source}: speed looks like rpm: median {med:.4g}, expected about '
                f'{scales.speed:.4g} rad/s (nominal_speed); convert: rad/s = rpm*pi/30'
            )
        if ratio < SPEED_WARN:
            msg = (
                f'{source}: speed channel is at rest (median {med:.3g} rad/s) but the rig '
                f'config drives at {scales.speed:.4g} rad/s: a free-decay record? '
                '(use `tribo decay`)'
            )
            if whole_record:
                raise UnitError(msg)
            warnings.append(msg.replace('is at rest', 'is at rest at the start'))
        # a drive speed other than nominal_speed is not checked here: the fits measure
        # the drive profile and warn about it once (core.drive, drive_mismatch)
    return warnings


@dataclass
class SpikeLog:
    """Spike positions seen so far (sample indices since the stream start)."""

    indices: list[npt.NDArray[np.int64]] = field(default_factory=list)
    done: int = 0

    def add(self, first_index: int, mask: npt.NDArray[np.bool_]) -> None:
        """Log the replaced samples of a chunk starting at sample ``first_index``."""
        if mask.any():
            self.indices.append(first_index + np.flatnonzero(mask).astype(np.int64))

    def mask(self, first: int, end: int) -> npt.NDArray[np.bool_]:
        """Mark the replaced samples of ``first <= index < end``.

        Parameters
        ----------
        first, end : int
            Sample range since the stream start [samples].

        Returns
        -------
        numpy.ndarray
            True at the replaced samples (bool, length ``end - first``).
        """
        out = np.zeros(max(0, end - first), dtype=bool)
        for a in self.indices:
            k = a[(a >= first) & (a < end)]
            out[k - first] = True
        return out

    def count(self, first: int, end: int) -> int:
        """Spikes with ``first <= index < end``."""
        return int(sum(int(np.count_nonzero((a >= first) & (a < end))) for a in self.indices))

    def forget_before(self, index: int) -> None:
        """Drop spikes before ``index`` (blocks already reported): bounded memory."""
        self.done += sum(int(np.count_nonzero(a < index)) for a in self.indices)
        self.indices = [k for a in self.indices if (k := a[a >= index]).size]

    @property
    def total(self) -> int:
        """All spikes seen (forgotten ones included)."""
        return self.done + int(sum(a.size for a in self.indices))


def despike(
    x: FloatArray, scale: float, burst_scale: float | None = None
) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Repair the spikes and then the bursts of one channel.

    Parameters
    ----------
    x : numpy.ndarray
        Samples of the channel [unit of the channel].
    scale : float
        Physical scale of the channel [unit of the channel] (``<= 0``: none
        known; spikes only).
    burst_scale : float or None
        Scale of the burst steps (:func:`find_bursts`) when not ``scale``.

    Returns
    -------
    tuple of numpy.ndarray
        The repaired samples (linear interpolation of the good neighbours,
        :func:`repair`) and the mask of the replaced samples (non-finite and
        gross samples, bursts, then spikes).
    """
    with np.errstate(invalid='ignore'):
        gross = ~np.isfinite(x) | (np.abs(x) > GROSS_FACTOR * scale if scale > 0 else False)
    # bursts before spikes: a burst's samples would shift the running median of the
    # good samples next to it and make them look like spikes
    y = repair(x, gross)
    bursts = find_bursts(y, scale if burst_scale is None else burst_scale)
    pre = gross | bursts
    mask = pre | find_spikes(repair(x, pre), scale)
    return repair(x, mask), mask


def _own_amplitude(x: FloatArray, scale: float) -> float:
    """Return the record's own amplitude [unit of x].

    The larger of ``scale`` and the 99th percentile of ``|x - median(x)|`` over
    the finite samples within ``GROSS_FACTOR * scale`` (0 when ``scale <= 0``).
    """
    if not scale > 0.0:
        return 0.0
    ok = np.isfinite(x) & (np.abs(x) <= GROSS_FACTOR * scale)
    if not ok.any():
        return scale
    xs = x[ok]
    return max(scale, float(np.percentile(np.abs(xs - np.median(xs)), 99.0)))


def despike_chunk(
    torsion: FloatArray, accel: FloatArray, speed: FloatArray, scales: Scales
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """Repair spikes and bursts of the three channels (:func:`despike`).

    Parameters
    ----------
    torsion, accel, speed : numpy.ndarray
        Torsion moment [N m], chamber acceleration [rad/s^2], shaft speed [rad/s].
    scales : Scales
        Physical scales of the channels.

    Returns
    -------
    tuple of numpy.ndarray
        The three repaired channels and the union of their masks of replaced
        samples.
    """
    st, sa = scales.torque, scales.accel  # 0 (no F_N): no gross bound, spikes only
    sv = max(scales.speed, 1.0)
    if scales.from_record:
        # the record's medians are no bound: a free decay starts far above its median,
        # so a burst must also step by more than the record's own amplitude
        t, mt = despike(torsion, st, _own_amplitude(torsion, st))
        a, ma = despike(accel, sa, _own_amplitude(accel, sa))
        v, mv = despike(speed, sv, _own_amplitude(speed, sv))
        return t, a, v, mt | ma | mv
    t, mt = despike(torsion, st)
    a, ma = despike(accel, sa)
    v, mv = despike(speed, sv)
    return t, a, v, mt | ma | mv


def repair_summary(mask: npt.NDArray[np.bool_]) -> dict[str, int | str]:
    """Summarise the replaced samples of a record for a report.

    Parameters
    ----------
    mask : numpy.ndarray
        True at the replaced samples (:func:`despike_chunk`).

    Returns
    -------
    dict
        ``spikes``: replaced samples [-], ``bursts``: runs of 3 or more of them
        [-], ``quality``: ``ok``, or ``spikes``/``bursts`` (``;``-separated) as
        in ``blocks.csv``.
    """
    from tribo_estimation.core.signal import runs

    st, en = runs(mask)
    n_bursts = int(np.count_nonzero(en - st >= 3))
    flags = [f for f, on in (('spikes', bool(np.any(en - st < 3))), ('bursts', n_bursts > 0)) if on]
    return {
        'spikes': int(np.count_nonzero(mask)),
        'bursts': n_bursts,
        'quality': ';'.join(flags) or 'ok',
    }


class _Despiker:
    """Repair spikes and bursts across chunk boundaries.

    The last :data:`EDGE_HOLD`
    samples of a chunk wait for the next contiguous chunk, so a step of the signal
    or a burst at a chunk edge is judged with samples on both sides.
    """

    def __init__(self, scales: Scales, log: SpikeLog) -> None:
        self.scales = scales
        self.log = log
        self.hold: AlignedChunk | None = None  # raw tail not yet emitted
        self.ctx: tuple[int, FloatArray, FloatArray, FloatArray] | None = None  # emitted tail

    def _run(self, ch: AlignedChunk, keep: int) -> list[AlignEvent]:
        c = 0
        arrs = [np.asarray(x, dtype=np.float64) for x in (ch.torsion, ch.accel, ch.speed)]
        if self.ctx is not None and self.ctx[0] == ch.first_index:
            c = self.ctx[1].shape[0]
            arrs = [np.concatenate([a, b]) for a, b in zip(self.ctx[1:], arrs, strict=True)]
        t, a, v, mask = despike_chunk(arrs[0], arrs[1], arrs[2], self.scales)
        n = ch.torsion.shape[0]
        m = max(0, n - keep)
        self.hold = (
            replace(
                ch,
                first_index=ch.first_index + m,
                t0=ch.t0 + m / ch.sample_rate,
                torsion=arrs[0][c + m :],
                accel=arrs[1][c + m :],
                speed=arrs[2][c + m :],
            )
            if m < n
            else None
        )
        if m == 0:
            return []
        self.log.add(ch.first_index, mask[c : c + m])
        out = replace(ch, torsion=t[c : c + m], accel=a[c : c + m], speed=v[c : c + m])
        k = max(0, m - EDGE_HOLD)
        self.ctx = (ch.first_index + m, t[c + k : c + m], a[c + k : c + m], v[c + k : c + m])
        return [out]

    def push(self, ch: AlignedChunk) -> list[AlignEvent]:
        out: list[AlignEvent] = []
        held = self.hold
        if held is not None:
            if held.end_index == ch.first_index and held.sample_rate == ch.sample_rate:
                ch = replace(
                    held,
                    torsion=np.concatenate([held.torsion, ch.torsion]),
                    accel=np.concatenate([held.accel, ch.accel]),
                    speed=np.concatenate([held.speed, ch.speed]),
                )
            else:
                out.extend(self.flush())
        self.hold = None
        out.extend(self._run(ch, EDGE_HOLD))
        return out

    def flush(self) -> list[AlignEvent]:
        held, self.hold = self.hold, None
        if held is None:
            return []
        out = self._run(held, 0)
        self.ctx = None
        return out


def checked_chunks(
    events: Iterable[AlignEvent],
    scales: Scales,
    source: str,
    log: SpikeLog,
    warn: list[str],
    check_samples: int = 20_000,
) -> Iterator[AlignEvent]:
    """Pass aligner events through the checks and the repair.

    The first ``check_samples`` samples are checked
    (time base and channels; warnings appended to ``warn``) before anything is
    yielded, spikes of every :class:`~tribo_estimation.core.align.AlignedChunk`
    are repaired (:func:`find_spikes`, judged across chunk boundaries) and logged
    in ``log``.
    """
    held: list[AlignEvent] = []
    n_held = 0
    checked = False
    desp = _Despiker(scales, log)

    def check() -> None:
        chunks = [e for e in held if isinstance(e, AlignedChunk)]
        if not chunks:
            return
        check_time_base(chunks[0].sample_rate, source, scales.f_stick_slip)
        warn.extend(
            check_channels(
                np.concatenate([c.torsion for c in chunks]),
                np.concatenate([c.accel for c in chunks]),
                np.concatenate([c.speed for c in chunks]),
                scales,
                source,
                whole_record=False,
            )
        )

    def stream() -> Iterator[AlignEvent]:
        for ev in events:
            if isinstance(ev, AlignedChunk):
                yield from desp.push(ev)
            else:
                yield from desp.flush()
                yield ev
        yield from desp.flush()

    for ev in stream():
        if isinstance(ev, AlignedChunk):
            n_held += len(ev)
        if checked:
            yield ev
            continue
        held.append(ev)
        if n_held >= check_samples:
            check()
            checked = True
            yield from held
            held.clear()
    if not checked:
        check()
        yield from held
