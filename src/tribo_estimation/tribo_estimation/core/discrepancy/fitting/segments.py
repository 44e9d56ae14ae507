"""Cutting a record into simulation segments (multiple shooting).

Each segment starts a few ms into a measured stick phase (the state is known
there from the measurements, Equ. 4, 6), runs to the next segment start, and
belongs to a time block (the unit of the cross validation). A record without
stick-slip gets sliding segments of fixed length instead, starting from the measured
sliding state, in every stretch between stick phases that holds two of them; a record
with stick-slip gets them too in such stretches (sliding after a start-up or a speed
step, before the first stick).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.drive import SMOOTH_TIME, tolerance
from tribo_estimation.core.model import RigParams
from tribo_estimation.core.shooting import DriveKnots, sliding_states, window_mean
from tribo_estimation.core.signal import chamber_speed, rig_half, runs
from tribo_estimation.core.sticks import detect_sticks
from tribo_estimation.errors import EstimationError, TooShortError

from ..stats import FloatArray, IntArray
from .records import Record, Segments

#: Local-fit window of the chamber speed at sliding segment starts [samples] (odd):
#: the chamber speed sets the amplitude of the contact's lightly damped oscillation
#: for the whole segment, and 5 ms at 10 kHz (not 1.5 ms) keep its noise at
#: ~4e-3 rad/s (config/rig.yaml noise).
SLIDE_WIN = 51
#: A stick phase that begins within this time of the record's first sample began
#: before the record (the record cuts it) [s].
CUT_STICK = 2e-3
#: Reason listed in ``Segments.rejected`` for a stick phase the record start cuts.
UNKNOWN_DWELL = (
    'stick began before the record start: its dwell (stick time) is unknown, so the '
    'breakaway that ends it cannot be simulated (not fitted)'
)


def stuck_before_onset(
    record: Record, rig: RigParams, s_start: IntArray, s_stop: IntArray
) -> FloatArray:
    """Return how long before each detected stick phase the discs already moved together.

    While the discs stick the shaft speed (the speed channel through the speed-sensor
    model of :func:`.instrument.identify_speed_sensor`) equals the chamber speed
    ``w1 = (dM_t/dt)/C1`` (Equ. 4). Going back from a phase's first sample to the end
    of the phase before (or the record start), the samples where the two agree within
    ``max(5 robust SD, FALSE_STICK_MIN)`` (the SD over the phases' interiors) are the
    part of the stick the detector left out: the stick detector dates a phase that
    begins just before a drive ramp to the ramp's start (bench 'step' record, seed
    1010: 5.8 ms late), and the dwell clock of dwell-time stiction (``t_stick``,
    Equ. 6 with ``mu_s(t_stick)``) would start late by as much. A correct onset gives
    ~0.1 ms (the slip's last samples).

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (C1, Tab. 1).
    s_start, s_stop : IntArray
        First and stop sample of each detected stick phase (in time order).

    Returns
    -------
    FloatArray
        Time before each phase's first sample in which the discs already stuck [s].
    """
    from tribo_estimation.core.signal import mad_sigma

    from .instrument import FALSE_STICK_MIN, sensor_view, stick_guard

    out = np.zeros(s_start.size)
    if s_start.size == 0:
        return out
    slope, w1, (tau, off) = sensor_view(record, rig, s_start, s_stop)
    slip = record.speed + tau * slope - off - w1
    guard = stick_guard(record, rig)
    inner = [slip[a + guard : b - guard] for a, b in zip(s_start, s_stop, strict=True)]
    inner = [x for x in inner if x.size]
    sd = mad_sigma(np.concatenate(inner)) if inner else 0.0
    limit = max(5.0 * sd, FALSE_STICK_MIN)
    prev_stop = 0
    for k, (a, b) in enumerate(zip(s_start.tolist(), s_stop.tolist(), strict=True)):
        i = a
        while i > prev_stop and abs(float(slip[i - 1])) <= limit:
            i -= 1
        out[k] = (a - i) / record.fs
        prev_stop = max(prev_stop, b)
    return out


def begins_at_drive_start(record: Record, ramp_time: float, level: float) -> bool:
    """Return whether the record begins at rest before or at the drive's start.

    RIG.yaml has a start-up ramp (``ramp_time`` > 0), the record's first sample is at
    t = 0 and the shaft speed there is at rest (mean of the first 10 ms within
    :func:`tribo_estimation.core.drive.tolerance` of 0). A stick phase at such a
    record's start began with the record: its dwell clock starts at the first sample
    (the convention of the reference generator and the kernel's rest state).

    Parameters
    ----------
    record : Record
        The measured record.
    ramp_time : float
        RIG.yaml start-up ramp [s] (0: none).
    level : float
        Drive speed level [rad/s] (scales the at-rest tolerance).

    Returns
    -------
    bool
        True when the record begins at the drive's start from rest.
    """
    n_rest = max(1, round(0.01 * record.fs))  # the first 10 ms of the speed channel
    at_rest = abs(float(np.mean(record.speed[:n_rest]))) < tolerance(level, 0.0)
    return ramp_time > 0.0 and abs(float(record.time[0])) < 1e-6 and at_rest


def waits_at_rest(record: Record, ramp_time: float, level: float) -> bool:
    """Return whether a record that begins at rest waits before the motor starts.

    The speed channel, averaged over 10 ms, stays within
    :func:`tribo_estimation.core.drive.tolerance` of its first 10 ms for longer than
    a start-up ramp of ``ramp_time`` from the first sample would let it, plus the
    drive profile's resolution :data:`~tribo_estimation.core.drive.SMOOTH_TIME` (the
    shaft follows the drive through the belt; a shorter wait is not resolved): of the
    two shapes a controller ramps by, the raised cosine leaves its start slowest, by
    a fraction ``q`` of its change after ``acos(1 - 2q)/pi`` of its time (``q`` the
    tolerance over the level). Such a record's start-up is not RIG.yaml's ramp from
    t = 0; its corners are placed by the drive angles.

    Parameters
    ----------
    record : Record
        The measured record (speed [rad/s]).
    ramp_time : float
        RIG.yaml start-up ramp [s].
    level : float
        Drive speed level [rad/s].

    Returns
    -------
    bool
        True when the motor starts later than a ramp from the first sample would.
    """
    n = max(1, round(0.01 * record.fs))
    if record.speed.size <= n or level == 0.0:
        return False
    tol = tolerance(level, 0.0)
    mean = np.convolve(record.speed, np.ones(n) / n, mode='valid')
    moved = np.flatnonzero(np.abs(mean - mean[0]) > tol)
    if moved.size == 0:
        return True
    q = min(tol / abs(level), 1.0)
    slowest = ramp_time * math.acos(1.0 - 2.0 * q) / math.pi
    return float(moved[0]) / record.fs > slowest + SMOOTH_TIME + n / record.fs


def stick_runs(
    record: Record, rig: RigParams, *, min_duration: float = 2e-3
) -> tuple[IntArray, IntArray, FloatArray]:
    """Find the stick phases of a record with the package's one stick detector.

    The detector is :func:`tribo_estimation.core.sticks.detect_sticks`;
    overlapping phases are merged.

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (Tab. 1).
    min_duration : float
        Shortest stick phase kept [s].

    Returns
    -------
    tuple of (IntArray, IntArray, FloatArray)
        First and stop (exclusive) sample of each phase and its start time [s].
    """
    try:
        phases = detect_sticks(
            record.time,
            record.torsion_moment,
            record.angular_acceleration,
            record.speed,
            rig,
            min_duration=min_duration,
        )
    except EstimationError:
        phases = []
    fs, t0, n = record.fs, float(record.time[0]), record.time.size
    a = np.array([min(n, max(0, math.ceil((p.start - t0) * fs - 1e-9))) for p in phases], np.int64)
    b = np.array([min(n, max(0, math.ceil((p.end - t0) * fs - 1e-9))) for p in phases], np.int64)
    onset = np.array([p.start for p in phases], dtype=np.float64)
    keep = b > a
    a, b, onset = a[keep], b[keep], onset[keep]
    # overlapping phases (if a detector reports any) are merged
    order = np.argsort(a, kind='stable')
    ma: list[int] = []
    mb: list[int] = []
    mo: list[float] = []
    for i in order.tolist():
        if ma and a[i] < mb[-1]:
            mb[-1] = max(mb[-1], int(b[i]))
            mo[-1] = min(mo[-1], float(onset[i]))
        else:
            ma.append(int(a[i]))
            mb.append(int(b[i]))
            mo.append(float(onset[i]))
    return np.array(ma, np.int64), np.array(mb, np.int64), np.array(mo, np.float64)


def make_segments(
    record: Record,
    rig: RigParams,
    *,
    min_length: float = 0.03,
    block_time: float = 0.25,
    start_delay: float = 3e-3,
    runs: tuple[IntArray, IntArray, FloatArray] | None = None,
    dwell_from_start: bool = False,
) -> Segments:
    """Cut the record into segments that start ``start_delay`` s into a stick phase.

    Each segment runs to the next segment start (at least ``min_length`` s
    later); segments are numbered into time blocks of about ``block_time`` s. A
    stick phase longer than two blocks (a rest) gets a start every block from its
    first, each with its dwell since the phase's onset.
    A record with fewer than 3 stick phases (slip-slip, steady sliding) gets
    sliding segments instead (:func:`sliding_segments`).

    A stick phase that the record's start cuts (it begins within
    :data:`CUT_STICK` of the first sample) began at an unknown time: its dwell
    (the stick time the kernel's breakaway test of dwell-time stiction reads,
    ``mu_s(t_stick)``) is unknown, so no segment starts in it and its samples are
    not fitted (listed in ``rejected``) -- unless ``dwell_from_start``: the record
    begins at the drive's start from rest (:func:`begins_at_drive_start`), where
    the stick began with the record. A stick phase whose discs already moved
    together before its detected onset (:func:`stuck_before_onset`) began there: its
    dwell clock starts at that earlier instant.

    Parameters
    ----------
    record : Record
        The measured record.
    rig : RigParams
        Rig parameters (Tab. 1).
    min_length : float
        Shortest segment [s].
    block_time : float
        Length of a time block [s].
    start_delay : float
        Time from a stick phase's start to the segment start [s] (at most half the phase).
    runs : tuple of (IntArray, IntArray, FloatArray), optional
        First, stop sample and start time [s] of each stick phase (default:
        :func:`stick_runs`).
    dwell_from_start : bool
        The record begins at the drive's start from rest: a stick phase at its
        start began there (its dwell is known).

    Returns
    -------
    Segments
        The segments with their blocks and stick phases.
    """
    from .instrument import FALSE_STICK_MIN, FALSE_STICK_SIGMA, false_stick_phases

    s_start, s_stop, onset = runs if runs is not None else stick_runs(record, rig)
    fs = record.fs
    delay = round(start_delay * fs)
    # a segment starts from the stuck state: never in a phase where the shaft
    # and chamber speeds disagree (the discs slip: a false stick phase); its
    # samples stay in the fit, in the segment before
    slip = np.abs(false_stick_phases(record, rig, s_start, s_stop))
    spread = 1.4826 * float(np.median(slip)) if slip.size else 0.0
    limit = max(FALSE_STICK_SIGMA * spread, FALSE_STICK_MIN)
    rejected = [
        (float(record.time[int(a)]), f'no stick: shaft and chamber speeds differ by {v:.3g} rad/s')
        for a, v in zip(s_start, slip, strict=True)
        if v > limit
    ]
    # a stick phase cut by the record start has no known dwell (unless the record
    # begins at the drive's start from rest)
    t_first = float(record.time[0])
    cut = np.asarray(onset, dtype=np.float64) - t_first < CUT_STICK
    if dwell_from_start:
        cut[:] = False
    rejected += [
        (float(record.time[int(a)]), UNKNOWN_DWELL)
        for k, a in enumerate(s_start)
        if cut[k] and slip[k] <= limit
    ]
    # a stick phase whose discs already moved together before its detected onset began
    # earlier: its dwell clock starts where they began to move together
    early = stuck_before_onset(record, rig, s_start, s_stop)
    onset = np.asarray(onset, dtype=np.float64) - early
    length = max(round(block_time * fs), 100)
    cand: list[tuple[int, int]] = []
    for k, (a, b) in enumerate(zip(s_start, s_stop, strict=True)):
        if slip[k] > limit or cut[k]:
            continue
        first = int(a) + min(delay, (int(b) - int(a)) // 2)
        # a stick phase longer than two blocks (a rest, the end of a stop) gets a start
        # every block: the drive profile's angle error at the phase's start would
        # otherwise hold the torsion moment off through the whole rest
        cand.extend((j, k) for j in range(first, int(b) - length + 1, length))
        if not cand or cand[-1][1] != k:
            cand.append((first, k))
    if len(cand) < 3:
        # a stick phase (at rest before a start-up, through a stop) has no sliding
        # state: sliding segments fill the stretches between stick phases
        return sliding_segments(
            record,
            block_time,
            stretches=free_stretches(s_start, s_stop, record.time.size),
            rig=rig,
        )
    min_len = round(min_length * fs)
    chosen = [cand[0]]
    for c in cand[1:]:
        if c[0] - chosen[-1][0] >= min_len:
            chosen.append(c)
    starts = [c[0] for c in chosen]
    stops = [*starts[1:], record.time.size]
    if stops[-1] - starts[-1] < min_len:
        chosen, starts, stops = chosen[:-1], starts[:-1], stops[:-1]
    run_k = np.asarray([c[1] for c in chosen], dtype=np.int64)
    run_a = np.asarray(s_start, dtype=np.int64)[run_k]
    run_b = np.asarray(s_stop, dtype=np.int64)[run_k]
    stuck = np.asarray(starts, dtype=np.int64)
    stick_time = np.maximum(record.time[stuck] - onset[run_k], 0.0)
    # a stretch without stick phases longer than two blocks (sliding after a start-up
    # or a speed step, or before the first stick) is cut into sliding segments: a
    # segment from a stuck start does not run on through it
    slide = _sliding_starts(free_stretches(s_start, s_stop, record.time.size), length, stuck)
    slide = slip_peak_starts(record, slide, rig, length // 4)
    order = np.argsort(np.concatenate((stuck, slide)), kind='stable')
    start_arr = np.concatenate((stuck, slide))[order]
    slides = np.concatenate((np.zeros(stuck.size, bool), np.ones(slide.size, bool)))[order]
    # each segment runs to the next start (the last as before, or to the end when sliding)
    last_stop = record.time.size if slides[-1] else int(stops[-1])
    stop_arr = np.append(start_arr[1:], last_stop).astype(np.int64)
    stick_time = np.concatenate((stick_time, np.zeros(slide.size)))[order]
    run_a = np.concatenate((run_a, slide))[order]
    run_b = np.concatenate((run_b, slide))[order]
    t_rel = (start_arr - start_arr[0]) / fs
    n_blocks = max(2, round((stop_arr[-1] - start_arr[0]) / fs / block_time))
    block = np.minimum((t_rel / block_time).astype(np.int64), n_blocks - 1)
    # renumber so that block ids are 0..B-1 without gaps
    _, block = np.unique(block, return_inverse=True)
    return Segments(
        start_arr,
        stop_arr,
        stick_time.astype(np.float64),
        block.astype(np.int64),
        run_a,
        run_b,
        rejected=tuple(sorted(rejected)),
        unknown_dwell=tuple(
            (int(a), int(b))
            for k, (a, b) in enumerate(zip(s_start, s_stop, strict=True))
            if cut[k] and slip[k] <= limit
        ),
        slides=slides if slide.size else None,
    )


def _sliding_starts(stretches: Sequence[tuple[int, int]], length: int, stuck: IntArray) -> IntArray:
    """Return the sliding segment starts in the long stretches without stick phases.

    A stretch of at least two segment lengths gets a start every ``length`` samples:
    from one length after its first sample when a stuck segment starts before it (that
    segment keeps the breakaway and the first slip), else from :data:`SLIDE_WIN`
    samples in (the local fits at a start need samples on both sides); none within
    half a length of its end.

    Parameters
    ----------
    stretches : sequence of (int, int)
        First and stop sample of each stretch without a stick phase.
    length : int
        Segment length [samples].
    stuck : IntArray
        The stuck segment starts [samples].

    Returns
    -------
    IntArray
        The sliding starts [samples], sorted.
    """
    out: list[IntArray] = []
    for a, b in stretches:
        if b - a < 2 * length:
            continue
        first = a + length if np.any(stuck < a) else a + SLIDE_WIN
        out.append(np.arange(first, b - length // 2, length, dtype=np.int64))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def slip_peak_starts(record: Record, starts: IntArray, rig: RigParams, reach: int) -> IntArray:
    """Move sliding segment starts to the slip-speed peak of the chamber's next swing.

    Each start whose chamber swings back to the disc's speed moves forward, by less
    than one period of the chamber's mode (``omega = sqrt(C1/I1)``) and less than
    ``reach`` samples, to where the slip speed ``|v| = |w2 - w1|`` peaks: the torsion
    moment over that window is fitted by
    ``m + c*t + a*cos(omega*t) + b*sin(omega*t)`` (the chamber's free swing, Equ. 1),
    ``w1 = M_t'/C1`` (Equ. 4) of the fit is extremal there, on the side away from the
    shaft speed w2 (the speed channel's mean over the window). A fit, not the samples'
    extreme, so noise does not choose the start. A start whose fitted swing does not
    reach the shaft speed stays: its sliding phase does not end there.

    A sliding start state has passed its phase's slip-speed peak (the deceleration
    rule of Equ. 8, ``peak_passed`` set by
    :func:`tribo_estimation.core.shooting.sliding_states`). On a chamber that swings
    back to the disc's speed every cycle (brief sticks) that holds only from the
    swing's peak on; before it the kernel would slide at ``mu_inf`` where the record
    follows Equ. 8. At the peak the chamber's acceleration crosses zero, so the window
    estimates of w1 and of the acceleration there carry no curvature bias.

    Parameters
    ----------
    record : Record
        The measured record.
    starts : IntArray
        Nominal starts [samples], each at least ``reach`` samples before the next
        start or the end of its stretch.
    rig : RigParams
        Rig parameters (I1 [kg m^2], C1 [N m/rad]).
    reach : int
        Largest move [samples].

    Returns
    -------
    IntArray
        The moved starts [samples].
    """
    st = np.asarray(starts, dtype=np.int64)
    omega = 2.0 * math.pi * rig.natural_frequency_hz
    span = min(round(2.0 * math.pi / omega * record.fs), reach, record.time.size)
    if st.size == 0 or span < 8:
        return st
    t = np.arange(span) / record.fs
    c, s = np.cos(omega * t), np.sin(omega * t)
    basis = np.column_stack((np.ones(span), t, c, s))
    # slope of the fitted swing per coefficient: d/dt of (m, c*t, a*cos, b*sin)
    slope = np.column_stack((np.zeros(span), np.ones(span), -omega * s, omega * c))
    out = st.copy()
    for k, a in enumerate(st):
        lo = int(a)
        hi = lo + span
        if hi > record.time.size:
            continue
        coef, *_ = np.linalg.lstsq(basis, record.torsion_moment[lo:hi], rcond=None)
        w1 = slope @ coef / rig.C1
        w2 = float(np.mean(record.speed[lo:hi]))
        away = 1.0 if w2 >= float(np.mean(w1)) else -1.0
        slip = away * (w2 - w1)
        # a swing that does not reach the shaft speed never ends the sliding phase:
        # the start state's "past the peak" holds wherever it starts
        if float(np.min(slip)) <= 0.0:
            out[k] = lo + int(np.argmax(slip))
    return out


def free_stretches(s_start: IntArray, s_stop: IntArray, n: int) -> list[tuple[int, int]]:
    """Return the stretches without a stick phase, in time order.

    Parameters
    ----------
    s_start, s_stop : IntArray
        First and stop (exclusive) sample of each stick phase.
    n : int
        Samples in the record.

    Returns
    -------
    list of tuple of int
        ``(first, stop)`` of each stretch (``[(0, n)]`` without stick phases).
    """
    free = np.ones(n, dtype=bool)
    for a, b in zip(s_start.tolist(), s_stop.tolist(), strict=True):
        free[a:b] = False
    first, stop = runs(free)
    return [(int(a), int(b)) for a, b in zip(first, stop, strict=True)]


#: Sample stride of the slip samples of :func:`slip_samples` [-] and their most [-].
SLIP_STRIDE = 4
SLIP_MAX = 12000


def slip_samples(
    n: int, phases: tuple[IntArray, IntArray] | None, min_gap: int, guard: int
) -> IntArray:
    """Return every :data:`SLIP_STRIDE`-th sample of the long stretches without sticks.

    A stretch between stick phases (or before the first, after the last, or the whole
    record without one) of at least ``min_gap`` samples is a sliding stretch, not the
    slip of a stick-slip cycle; its samples, ``guard`` away from its ends, are those
    whose drive angle is taken from the shaft's balance with the observed friction
    moment (Equ. 1, 2) instead of the stuck balance. The stride grows so that at most
    :data:`SLIP_MAX` are returned.

    Parameters
    ----------
    n : int
        Samples in the record [-].
    phases : tuple of IntArray or None
        First and stop (exclusive) sample of each stick phase (None: none).
    min_gap : int
        Shortest sliding stretch [samples].
    guard : int
        Samples left out at each end of a stretch (the smoothing windows) [-].

    Returns
    -------
    IntArray
        Sample indices, sorted.

    Examples
    --------
    >>> import numpy as np
    >>> slip_samples(60, (np.array([10, 20]), np.array([15, 25])), 20, 1).tolist()
    [26, 30, 34, 38, 42, 46, 50, 54, 58]
    """
    none = np.zeros(0, np.int64)
    first, stop = (none, none) if phases is None else phases
    parts = [
        np.arange(a + guard, b - guard, dtype=np.int64)
        for a, b in free_stretches(first, stop, n)
        if b - a >= min_gap
    ]
    idx = np.concatenate(parts) if parts else none
    stride = max(SLIP_STRIDE, -(-idx.size // SLIP_MAX))
    return np.asarray(idx[::stride], dtype=np.int64)


def sliding_segments(
    record: Record,
    block_time: float,
    *,
    first: int = 0,
    last: int | None = None,
    stretches: Sequence[tuple[int, int]] | None = None,
    rig: RigParams | None = None,
) -> Segments:
    """Cut a record without stick-slip (slip-slip, steady sliding) into segments.

    One segment per ``block_time``, each starting from the measured sliding
    state (see :meth:`~.problem.Problem.simulate`), in every stretch between stick
    phases that holds one; with ``rig``, each start at the slip-speed peak of the
    chamber's next swing (:func:`slip_peak_starts`).

    Parameters
    ----------
    record : Record
        The measured record.
    block_time : float
        Segment (and block) length [s], at least 100 samples.
    first : int
        First sample a segment may start at (after a stick phase: the samples
        before are not fitted and are listed in ``Segments.rejected``).
    last : int or None
        Stop sample of the last segment (before a stick phase: the samples from it
        on are not fitted and are listed in ``Segments.rejected``); default: the end.
    stretches : sequence of (int, int) or None
        The stretches without a stick phase (``(first, stop)`` samples, in time order,
        :func:`free_stretches`) instead of ``first`` and ``last``.
    rig : RigParams or None
        Rig parameters (None: the starts stay on the block grid).

    Returns
    -------
    Segments
        Sliding segments, one block each.

    Raises
    ------
    TooShortError
        The record holds fewer than two segments.
    """
    fs = record.fs
    n = record.time.size
    spans = list(stretches) if stretches is not None else [(first, n if last is None else last)]
    spans = [(max(0, a), min(n, b)) for a, b in spans if min(n, b) > max(0, a)]
    length = max(round(block_time * fs), 100)
    edge = SLIDE_WIN  # the local fits at a start need samples on both sides
    starts_l: list[IntArray] = []
    stops_l: list[IntArray] = []
    rejected: list[tuple[float, str]] = []
    covered_to = 0
    for a, b in spans:
        st = np.arange(max(edge, a + edge), b - length // 2, length, dtype=np.int64)
        if st.size == 0:
            continue
        if rig is not None:
            st = slip_peak_starts(record, st, rig, length // 4)
        if a > covered_to:
            rejected.append(
                (
                    float(record.time[covered_to]),
                    f'not fitted: {float(record.time[min(a, n - 1)] - record.time[covered_to]):.3g}'
                    ' s with a stick phase (no sliding state) before a sliding segment',
                )
            )
        starts_l.append(st)
        stops_l.append(np.append(st[1:], b).astype(np.int64))
        covered_to = b
    if covered_to < n and starts_l:
        rejected.append(
            (
                float(record.time[covered_to]),
                f'not fitted: {float(record.time[-1] - record.time[covered_to]):.3g} s with a '
                'stick phase (no sliding state) after the last sliding segment',
            )
        )
    starts = np.concatenate(starts_l) if starts_l else np.zeros(0, dtype=np.int64)
    if starts.size < 2:
        long_a, long_b = max(spans, key=lambda r: r[1] - r[0], default=(0, 0))
        free = (
            f', its longest stretch without a stick {(long_b - long_a) / fs:.3g} s,'
            if (long_a > 0 or long_b < n)
            else ''
        )
        raise TooShortError(
            f'record of {n / fs:.3g} s{free} without three stick phases to fit: the '
            f'discrepancy workflow needs stick-slip cycles or at least {2 * block_time:.3g} s '
            'of sliding'
        )
    stops = np.concatenate(stops_l)
    return Segments(
        starts,
        stops,
        np.zeros(starts.size),
        np.arange(starts.size, dtype=np.int64),
        None,
        None,
        True,
        tuple(rejected),
    )


def sliding_chamber_speed(record: Record, starts: IntArray, rig: RigParams) -> FloatArray:
    """Return the chamber speed at sliding segment starts from the torsion moment.

    ``w1 = (dM_t/dt)/C1`` (Equ. 4) by a local cubic over :data:`SLIDE_WIN` samples,
    at most a quarter period of the rig's fastest mode wide
    (:func:`~tribo_estimation.core.signal.rig_half`). The speed channel measures the
    shaft, not the chamber: while the discs slide it says nothing of w1.

    Parameters
    ----------
    record : Record
        The measured record.
    starts : IntArray
        Start samples of the segments.
    rig : RigParams
        Rig parameters (C1 [N m/rad], the fastest mode).

    Returns
    -------
    FloatArray
        w1 at the starts [rad/s].
    """
    half = rig_half(SLIDE_WIN // 2, record.fs, rig.fastest_mode_hz)
    w1 = chamber_speed(record.torsion_moment, record.fs, rig.C1, 2 * half + 1)
    return np.asarray(w1[np.asarray(starts, dtype=np.int64)], dtype=np.float64)


def sliding_start_states(
    p: FloatArray,
    record: Record,
    starts: IntArray,
    m_true: FloatArray,
    w1: FloatArray,
    w2: FloatArray,
    w2_dot: FloatArray,
    knots: DriveKnots,
) -> FloatArray:
    """Return the kernel states at sliding segment starts from the measured channels.

    ``phi1 = M_t/C1``, the chamber speed ``w1`` (:func:`sliding_chamber_speed`), the
    shaft speed w2 (speed channel, sensor inverted) and its slope, and the
    friction moment from the chamber's balance ``M = I1*w1' - Q1`` (Equ. 1, the
    measured acceleration); the belt deflection then follows from the shaft's
    (Equ. 2, :func:`tribo_estimation.core.shooting.sliding_states`).

    Parameters
    ----------
    p : FloatArray
        Packed kernel parameters.
    record : Record
        The measured record.
    starts : IntArray
        Start samples of the segments.
    m_true : FloatArray
        True torsion moment C1*phi1 at the starts [N m].
    w1 : FloatArray
        Chamber speed at the starts (:func:`sliding_chamber_speed`) [rad/s].
    w2 : FloatArray
        Shaft speed at the starts (speed sensor inverted) [rad/s].
    w2_dot : FloatArray
        Shaft acceleration at the starts [rad/s^2].
    knots : DriveKnots
        The drive profile.

    Returns
    -------
    FloatArray
        Kernel states, one row per segment.
    """
    rig_c1 = float(p[kn.P_C1])
    rec = record
    i0 = starts
    a1 = window_mean(rec.angular_acceleration, i0, SLIDE_WIN // 2)
    moment = np.empty(w1.size)
    for k in range(w1.size):
        q1 = kn.chamber_moment(p, float(m_true[k]) / rig_c1, float(w1[k]))
        moment[k] = float(p[kn.P_I1]) * float(a1[k]) - q1
    t0 = rec.time[i0].astype(np.float64)
    return np.asarray(
        sliding_states(p, t0, m_true, w1, w2, w2_dot, moment, knots.time, knots.speed, knots.shape)
    )
