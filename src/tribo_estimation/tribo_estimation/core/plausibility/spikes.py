"""Spikes and bursts: found, repaired by interpolation and counted (no rclpy).

See :mod:`tribo_estimation.core.plausibility` for the criteria.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.plausibility.scales import Scales
from tribo_estimation.core.signal import mad_sigma, noise_level

FloatArray = npt.NDArray[np.float64]

#: Spike threshold in robust standard deviations of the median-filter residual.
SPIKE_SIGMA = 12.0
#: Spike threshold as a fraction of the channel's robust range (a floor for
#: noise-free records).
SPIKE_RANGE = 0.2
#: Running-median width [samples] (removes runs of up to 2 samples).
MEDIAN_WIDTH = 5
#: A sample beyond this many physical scales is never a measurement.
GROSS_FACTOR = 1e3
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
