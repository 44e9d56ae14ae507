"""The drive speed profile w0(t) measured in a record (not assumed).

A real record starts at the drive's start-up, anywhere in a test, or holds
speed steps and ramps (a Stribeck sweep). Over a time much longer than the
stick-slip period the shaft follows the drive (the belt deflection of Equ. 2
stays bounded), so the shaft speed channel w2, averaged over
:data:`SMOOTH_TIME`, is the drive speed w0. The profile is a continuous
function of time through knots, linear between them or, where the drive
angles say so, a raised cosine (an S-shaped speed transition, as a motor
controller's S-ramp; :func:`refine_with_angles`): its knots are placed top-down (split where
the smoothed speed departs most from the chord, the largest departure first,
while it exceeds :func:`tolerance`), and the knot speeds are then a
least-squares fit to the speed averaged in short bins. A stick-slip cycle
longer than :data:`SMOOTH_TIME` (a slow drive) leaves part of its oscillation
in that average; averaged over whole cycles (:func:`cycle_groups`) it leaves
none, since the belt deflection is the same at both ends of a cycle. The same
split of the whole cycles' means gives a second profile, and the one that fits
the means of all groups better (the parts of a cycle at the record's ends
included: a start from rest), by the Bayesian information criterion with two
parameters per knot, is the estimate. A speed-sensor lag (ms) or offset-free gain
error moves this by far less than the tolerance; a sensor offset moves it by
the offset.

The model is driven with one linear piece per shooting segment (kernel
``P_W0``, ``P_W0_RATE``, ``P_T_DRIVE``); the drive *angle* at a segment start
never comes from ``w0*t`` but from the measured state (Equ. 2, see
:mod:`.shooting`). RIG.yaml's ``nominal_speed`` is only a default (a record
without a usable speed channel) and a check: :attr:`DriveEstimate.mismatch`.

Units: time s, speed rad/s, rate rad/s^2.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from numba import njit
from scipy.optimize import least_squares

from .signal import moving_average, noise_level

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
#: Knot times [s] and speeds [rad/s] of a profile the angle fit is pulled toward.
Prior = tuple[FloatArray, FloatArray]

#: Averaging time of the shaft speed for the drive level (several stick-slip periods) [s].
SMOOTH_TIME = 0.1
#: Shape code of a raised-cosine piece (:attr:`DriveEstimate.shape`; 0 is linear):
#: ``w0 = w_a + (w_b - w_a)*(1 - cos(pi*f))/2`` over the piece's fraction ``f``.
COSINE = 1.0


def _cosine_rise(f: FloatArray) -> FloatArray:
    """Return the raised cosine's fraction of the speed change at piece fraction ``f``."""
    out: FloatArray = 0.5 - 0.5 * np.cos(np.pi * f)
    return out


@njit(cache=True)
def _cosine_area(f: float) -> float:
    """Return the integral of :func:`_cosine_rise` from 0 to ``f`` [-] (compiled)."""
    return 0.5 * f - math.sin(math.pi * f) / (2.0 * math.pi)


#: Relative disagreement with the nominal speed that is reported [-].
MISMATCH_LIMIT = 0.05

#: Bin width of the knot least-squares fit [s].
_BIN_TIME = 0.005

#: Most knots of one profile [-].
_MAX_KNOTS = 64


def _mismatch(level: float, nominal: float) -> float:
    """Return ``(level - nominal)/nominal`` [-] (NaN without a nominal speed)."""
    return (level - nominal) / nominal if math.isfinite(nominal) and nominal != 0.0 else math.nan


@dataclass(frozen=True)
class DriveEstimate:
    """Drive speed measured from a record: knots, linear or raised-cosine between them.

    Parameters
    ----------
    knot_time : FloatArray
        Knot instants [s] (first = record start, last = record end).
    knot_speed : FloatArray
        Drive speed at the knots [rad/s].
    nominal : float
        RIG.yaml nominal speed [rad/s] (NaN: none given).
    level : float
        Time-weighted median drive speed of the record [rad/s].
    mismatch : float
        Relative deviation ``(level - nominal)/nominal`` [-] (NaN: no nominal).
    from_record : bool
        False when the speed channel was unusable and the nominal is used.
    shape : FloatArray or None
        Per knot, the shape of the piece it begins: 0 linear, :data:`COSINE` a
        raised cosine [-] (None: all linear).
    """

    knot_time: FloatArray
    knot_speed: FloatArray
    nominal: float
    level: float
    mismatch: float
    from_record: bool = True
    shape: FloatArray | None = None

    @property
    def mismatched(self) -> bool:
        """True when the record disagrees with the nominal speed by more than 5 %."""
        return math.isfinite(self.mismatch) and abs(self.mismatch) > MISMATCH_LIMIT

    @property
    def n_pieces(self) -> int:
        """Number of pieces [-]."""
        return int(self.knot_time.size) - 1

    def shapes(self) -> FloatArray:
        """Per knot, the shape of the piece it begins (0 linear, :data:`COSINE`) [-]."""
        if self.shape is None:
            return np.zeros(self.knot_time.size)
        return self.shape

    def _cosine_pieces(self) -> list[int]:
        if self.shape is None:
            return []
        return [int(j) for j in np.flatnonzero(self.shape[:-1] == COSINE)]

    def speed(self, t: npt.ArrayLike) -> FloatArray:
        """w0(t) [rad/s] (held constant beyond the ends)."""
        tt = np.asarray(t, dtype=np.float64)
        w = np.asarray(np.interp(tt, self.knot_time, self.knot_speed), dtype=np.float64)
        for j in self._cosine_pieces():
            a, b = float(self.knot_time[j]), float(self.knot_time[j + 1])
            inside = (tt > a) & (tt < b)
            f = (tt - a) / (b - a)
            dv = float(self.knot_speed[j + 1] - self.knot_speed[j])
            w = np.where(inside, self.knot_speed[j] + dv * _cosine_rise(f), w)
        return w

    def angle(self, t: npt.ArrayLike) -> FloatArray:
        """Drive angle from the first knot, the integral of :meth:`speed` [rad].

        A raised-cosine piece has its ends' mean speed, as a linear one; the kernel's
        angle-locked ripple (:data:`..kernel.P_RIPA_ANGLE0`) counts from the same knot.
        """
        tt = np.asarray(t, dtype=np.float64)
        tk, vk = self.knot_time, self.knot_speed
        if tk.size < 2:
            return np.asarray(float(vk[0]) * (tt - float(tk[0])), dtype=np.float64)
        at_knot = np.concatenate(([0.0], np.cumsum(0.5 * (vk[1:] + vk[:-1]) * np.diff(tk))))
        j = np.clip(np.searchsorted(tk, tt, side='right') - 1, 0, tk.size - 2)
        s = tt - tk[j]
        h = np.maximum(tk[j + 1] - tk[j], 1e-12)
        dv = vk[j + 1] - vk[j]
        inside = (tt >= tk[0]) & (tt <= tk[-1])
        cos = self.shapes()[j] == COSINE
        rise = np.where(
            cos,
            0.5 * dv * (s - h / np.pi * np.sin(np.pi * s / h)),
            0.5 * dv / h * s * s,
        )
        out = np.where(inside, at_knot[j] + vk[j] * s + rise, 0.0)
        out = np.where(tt < tk[0], vk[0] * (tt - tk[0]), out)
        out = np.where(tt > tk[-1], at_knot[-1] + vk[-1] * (tt - tk[-1]), out)
        return np.asarray(out, dtype=np.float64)

    def rate(self, t: npt.ArrayLike) -> FloatArray:
        """dw0/dt [rad/s^2] of the piece holding t (the later piece at a knot)."""
        tt = np.asarray(t, dtype=np.float64)
        if self.knot_time.size < 2:
            return np.zeros_like(tt)
        slopes = np.diff(self.knot_speed) / np.maximum(np.diff(self.knot_time), 1e-12)
        i = np.clip(np.searchsorted(self.knot_time, tt, side='right') - 1, 0, slopes.size - 1)
        inside = (tt >= self.knot_time[0]) & (tt <= self.knot_time[-1])
        out = np.where(inside, slopes[i], 0.0)
        for j in self._cosine_pieces():
            a, b = float(self.knot_time[j]), float(self.knot_time[j + 1])
            f = (tt - a) / (b - a)
            dv = float(self.knot_speed[j + 1] - self.knot_speed[j])
            peak = 0.5 * math.pi * dv / (b - a)
            out = np.where((tt >= a) & (tt < b), peak * np.sin(np.pi * f), out)
        return out

    def mean_speed(self, t0: float, t1: float) -> float:
        """Mean drive speed over ``[t0, t1]`` [rad/s]."""
        if not t1 > t0:
            return float(self.speed(t0))
        tt = np.linspace(t0, t1, 65)
        return float(np.mean(self.speed(tt)))

    def shifted(self, by: float) -> DriveEstimate:
        """Return the profile with every speed moved by ``by`` [rad/s] (an offset taken out)."""
        level = self.level + by
        return replace(
            self,
            knot_speed=self.knot_speed + by,
            level=level,
            mismatch=_mismatch(level, self.nominal),
        )

    def warning(self) -> str | None:
        """One line for the user when the record disagrees with the nominal speed."""
        if not self.mismatched:
            return None
        return (
            f'drive speed of the record {self.level:.4g} rad/s differs from the RIG.yaml '
            f'nominal_speed {self.nominal:.4g} rad/s by {100.0 * self.mismatch:+.1f} %: '
            'the measured drive speed is used'
        )


def tolerance(level: float, noise: float) -> float:
    """Return the departure of the smoothed speed from a linear piece that starts a knot.

    Parameters
    ----------
    level : float
        Drive level [rad/s].
    noise : float
        Residual scatter of the smoothed speed [rad/s].

    Returns
    -------
    float
        3 % of the level, at least 0.03 rad/s and 5 x ``noise`` [rad/s].
    """
    return max(0.03 * abs(level), 0.03, 5.0 * noise)


def _split(t: FloatArray, y: FloatArray, tol: float) -> list[int]:
    """Top-down piecewise-linear segmentation, largest departure first: knot indices into t."""
    knots = [0, t.size - 1]
    heap: list[tuple[float, int, int, int]] = []

    def push(a: int, b: int) -> None:
        if b - a < 2:
            return
        chord = y[a] + (y[b] - y[a]) * (t[a : b + 1] - t[a]) / (t[b] - t[a])
        dev = np.abs(y[a : b + 1] - chord)
        j = int(np.argmax(dev[1:-1])) + 1
        if dev[j] > tol:
            heapq.heappush(heap, (-float(dev[j]), a, a + j, b))

    push(0, t.size - 1)
    while heap and len(knots) < _MAX_KNOTS:
        _, a, m, b = heapq.heappop(heap)
        knots.append(m)
        push(a, m)
        push(m, b)
    return sorted(set(knots))


#: Hysteresis of the cycle detector of :func:`cycle_groups`: white-noise standard
#: deviations, and the fraction of the local rms oscillation, that the speed must
#: pass on either side of its running mean [-].
_CYCLE_NOISE = 2.0
_CYCLE_FRACTION = 0.25
#: Longest cycle of :func:`cycle_groups`, in units of its ``span`` [-].
_CYCLE_LONGEST = 3.0


def cycle_groups(
    time: FloatArray, speed: FloatArray, span: float = SMOOTH_TIME
) -> tuple[IntArray, npt.NDArray[np.bool_]]:
    """Return the edges of groups of whole oscillation cycles of the shaft speed.

    A cycle begins where the speed rises through its running mean (over
    3 x ``span``) past a hysteresis band (:data:`_CYCLE_NOISE` white-noise
    deviations, at least :data:`_CYCLE_FRACTION` of the local rms oscillation);
    consecutive cycles are grouped until each group lasts at least ``span``. A
    stretch without a cycle for :data:`_CYCLE_LONGEST` x ``span`` (no oscillation,
    or a ramp the running mean lags) is cut into groups of ``span``.

    Parameters
    ----------
    time : FloatArray
        Sample times [s], uniform.
    speed : FloatArray
        Shaft speed w2 [rad/s], finite.
    span : float
        Shortest group [s].

    Returns
    -------
    edges : IntArray
        Sample indices: group ``g`` is ``edges[g]:edges[g + 1]``.
    whole : numpy.ndarray of bool
        Per group: it holds whole cycles (False for the part of a cycle cut by the
        record's start or end).

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0.0, 2.0, 1e-3)
    >>> w = 1.0 + 2.0 * np.sin(2.0 * np.pi * 7.3 * t) ** 9
    >>> e, whole = cycle_groups(t, w)
    >>> means = np.add.reduceat(w, e[:-1]) / np.diff(e)
    >>> bool(np.all(np.abs(means[whole] - 1.0) < 0.01)), int(whole.size - whole.sum())
    (True, 2)
    """
    t = np.asarray(time, dtype=np.float64)
    w = np.asarray(speed, dtype=np.float64)
    n = t.size
    dt = float((t[-1] - t[0]) / (n - 1))
    width = max(1, round(3.0 * span / dt))
    r = w - moving_average(w, width)
    sigma = noise_level(w)
    band = np.maximum(
        _CYCLE_NOISE * (sigma if math.isfinite(sigma) else 0.0),
        _CYCLE_FRACTION * np.sqrt(moving_average(r * r, width)),
    )
    side = np.where(r > band, 1, np.where(r < -band, -1, 0))
    last = np.maximum.accumulate(np.where(side != 0, np.arange(n), 0))
    held = side[last]
    ups = np.flatnonzero((held[1:] == 1) & (held[:-1] == -1)) + 1
    step = max(1, round(span / dt))
    longest = _CYCLE_LONGEST * span
    bounds = [0]
    cycle = [False]  # the bound is a cycle's start
    for b in [*ups.tolist(), n]:
        while t[min(b, n - 1)] - t[bounds[-1]] > longest:
            bounds.append(bounds[-1] + step)
            cycle.append(False)
        if b < n and t[b] - t[bounds[-1]] >= span:
            bounds.append(b)
            cycle.append(True)
    if len(bounds) > 1 and t[-1] - t[bounds[-1]] < span:
        bounds.pop()
        cycle.pop()
    bounds.append(n)
    cycle.append(False)
    whole = np.ones(len(bounds) - 1, dtype=bool)
    whole[0] = not cycle[1]
    whole[-1] = whole[-1] and not cycle[-2]
    return np.asarray(bounds, dtype=np.int64), whole


def _group_misfit(
    t: FloatArray, lo: IntArray, hi: IntArray, means: FloatArray, d: DriveEstimate
) -> float:
    """Return the BIC of a profile against the means of groups ``lo:hi`` [-].

    Two parameters per knot (its time and speed).
    """
    p = d.speed(t)
    c = np.concatenate(([0.0], np.cumsum(p)))
    pm = (c[hi] - c[lo]) / (hi - lo)
    g = means.size
    sse = float(np.sum((pm - means) ** 2))
    return g * math.log(max(sse / g, 1e-300)) + 2.0 * d.knot_time.size * math.log(g)


def _fit_knots(tk: FloatArray, tb: FloatArray, yb: FloatArray) -> FloatArray:
    """Return the least-squares knot speeds through the bin means (hat-function basis).

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    tb, yb : FloatArray
        Bin times [s] and mean speeds [rad/s].

    Returns
    -------
    FloatArray
        Knot speeds of the continuous piecewise-linear function [rad/s].
    """
    k = tk.size
    basis = np.zeros((tb.size, k))
    i = np.clip(np.searchsorted(tk, tb, side='right') - 1, 0, k - 2)
    w = (tb - tk[i]) / np.maximum(tk[i + 1] - tk[i], 1e-12)
    w = np.clip(w, 0.0, 1.0)
    rows = np.arange(tb.size)
    basis[rows, i] = 1.0 - w
    basis[rows, i + 1] += w
    sol, *_ = np.linalg.lstsq(basis, yb, rcond=None)
    return np.asarray(sol, dtype=np.float64)


def estimate_drive(
    time: FloatArray, speed: FloatArray, nominal: float | None = None
) -> DriveEstimate:
    """Drive speed profile of a record from its shaft speed channel (module doc).

    Args:
        time: sample times [s], uniform.
        speed: shaft speed w2 [rad/s].
        nominal: RIG.yaml nominal drive speed [rad/s] (default and check only).
    """
    t = np.asarray(time, dtype=np.float64)
    w = np.asarray(speed, dtype=np.float64)
    nom = float(nominal) if nominal is not None and math.isfinite(nominal) else math.nan
    ok = np.isfinite(w)
    if t.size < 2 or int(ok.sum()) < max(10, t.size // 2):
        c = nom if math.isfinite(nom) else 0.0
        t0, t1 = (float(t[0]), float(t[-1])) if t.size else (0.0, 0.0)
        return DriveEstimate(np.array([t0, max(t1, t0)]), np.array([c, c]), nom, c, 0.0, False)
    if not ok.all():
        w = np.interp(t, t[ok], w[ok])
    dt = float((t[-1] - t[0]) / (t.size - 1))
    span = min(SMOOTH_TIME, 0.5 * float(t[-1] - t[0]))
    width = max(1, round(span / dt))
    smoothed = _profile(t, w, moving_average(w, width), nom, max(1, round(_BIN_TIME / dt)))
    edges, whole = cycle_groups(t, w, span)
    if int(whole.sum()) < 3:
        return smoothed
    lo, hi = edges[:-1], edges[1:]
    means = np.add.reduceat(w, lo) / (hi - lo)
    tc = (0.5 * (t[lo] + t[hi - 1]))[whole]
    cycles = _profile(tc, means[whole], means[whole], nom, 1, (float(t[0]), float(t[-1])))
    # judged on every group: the parts of a cycle at the record's ends hold what the
    # cycle means leave out (a start from rest)
    if _group_misfit(t, lo, hi, means, cycles) < _group_misfit(t, lo, hi, means, smoothed):
        return cycles
    return smoothed


def _profile(
    t: FloatArray,
    w: FloatArray,
    ws: FloatArray,
    nom: float,
    nb: int,
    ends: tuple[float, float] | None = None,
) -> DriveEstimate:
    """Return the profile split on ``ws`` and fitted to ``w``, both in bins of ``nb`` samples.

    ``t`` may be irregular (cycle means, ``nb`` = 1); ``ends`` are the record's first
    and last instants [s] (default: those of ``t``).
    """
    m = (t.size // nb) * nb
    if m < 2 * nb:
        tb, yb, ysb = t, w, ws
    else:
        tb = t[:m].reshape(-1, nb).mean(axis=1)
        yb = w[:m].reshape(-1, nb).mean(axis=1)
        ysb = ws[:m].reshape(-1, nb).mean(axis=1)
    t0, t1 = ends if ends is not None else (float(t[0]), float(t[-1]))
    level_guess = float(np.median(ysb))
    scatter = float(np.median(np.abs(np.diff(ysb)))) * 1.4826 if ysb.size > 2 else 0.0
    tol = tolerance(level_guess, scatter)
    idx = _split(tb, ysb, tol)
    tk = tb[idx].copy()
    tk[0], tk[-1] = t0, t1
    if tk.size >= 2 and tk[-1] > tk[0]:
        vk = _fit_knots(tk, tb, yb)
    else:
        tk = np.array([t0, t1])
        vk = np.full(2, level_guess)
    # time-weighted median of the profile
    grid = np.linspace(tk[0], tk[-1], 512)
    level = float(np.median(np.interp(grid, tk, vk)))
    mismatch = _mismatch(level, nom)
    return DriveEstimate(tk, vk, nom, level, mismatch, True)


__all__ = [
    'COSINE',
    'MIN_PIECE',
    'MISMATCH_LIMIT',
    'SMOOTH_TIME',
    'TRANSITION_MAX',
    'DriveEstimate',
    'cycle_groups',
    'estimate_drive',
    'tolerance',
    'transitions',
    'untimed_transitions',
    'with_durations',
]


#: Weight of the knot-speed smoothness penalty of :func:`refine_with_angles` [s].
_KNOT_SMOOTH = 1e-4

#: Corner-time search of :func:`refine_with_angles`: coarse grid points, sweeps [-].
_CORNER_GRID = 41
_CORNER_SWEEPS = 3

#: Shortest linear piece of a refined profile [s].
MIN_PIECE = 2e-3

#: Outlying drive angles of :func:`refine_with_angles`: robust standard deviations
#: [-], smallest flagged residual [rad] and most re-fits [-].
_OUTLIER_SIGMA = 8.0
_OUTLIER_FLOOR = 1e-4
_OUTLIER_ROUNDS = 3


def _angle_basis(tk: FloatArray, tt: FloatArray, sk: FloatArray | None = None) -> FloatArray:
    """Return the integral from ``tk[0]`` to ``tt`` of each knot's basis function.

    Exact for a continuous w0 through the knots, linear between them (hat functions)
    or a raised cosine where ``sk`` says so: inside such a piece of length ``h`` the
    angle gained is ``h*(f - A(f))`` times its first knot's speed plus ``h*A(f)``
    times its second's (``A`` = :func:`_cosine_area`, ``f`` the piece's fraction);
    over the whole piece both are ``h/2``, as for a linear one. The dense form of
    :func:`_knot_columns` (which the knot fit uses).

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    tt : FloatArray
        Times [s].
    sk : FloatArray, optional
        Shape of the piece each knot begins (:attr:`DriveEstimate.shape`; default linear).

    Returns
    -------
    FloatArray
        Shape ``(tt.size, tk.size)`` [s].
    """
    tk = np.ascontiguousarray(tk, dtype=np.float64)
    order = np.argsort(tt, kind='stable')
    ts = np.ascontiguousarray(np.asarray(tt, dtype=np.float64)[order])
    shapes = np.zeros(tk.size) if sk is None else np.ascontiguousarray(sk, dtype=np.float64)
    piece, u, v = _knot_columns(tk, shapes, ts)
    full = _knot_constants(tk)
    out = np.zeros((tt.size, tk.size))
    for i, (p, a, b) in enumerate(zip(piece.tolist(), u.tolist(), v.tolist(), strict=True)):
        if p < 0:  # before the first knot: no angle gained
            continue
        row = out[order[i]]
        row[:p] = full[:p]
        row[p] = a
        if p < tk.size - 1:
            row[p + 1] = b
    return out


@njit(cache=True)
def _knot_constants(tk: FloatArray) -> FloatArray:
    """Return each knot's basis integral over its whole support [s] (half its pieces)."""
    k = tk.shape[0]
    out = np.zeros(k)
    for j in range(k):
        if j > 0:
            out[j] += 0.5 * (tk[j] - tk[j - 1])
        if j < k - 1:
            out[j] += 0.5 * (tk[j + 1] - tk[j])
    return out


@njit(cache=True)
def _knot_columns(
    tk: FloatArray, sk: FloatArray, ts: FloatArray
) -> tuple[IntArray, FloatArray, FloatArray]:
    """Return the sparse rows of :func:`_angle_basis` at sorted times ``ts`` [s].

    A time inside piece ``p`` (``tk[p] <= t < tk[p+1]``; -1 before the first knot,
    ``k - 1`` from the last on, where w0 is held) has the whole-support integrals
    (:func:`_knot_constants`) in the columns before ``p``, ``u`` in column ``p``,
    ``v`` in column ``p + 1`` and zeros after.

    Returns
    -------
    tuple of (IntArray, FloatArray, FloatArray)
        The piece of each time [-], ``u`` and ``v`` [s].
    """
    k = tk.shape[0]
    n = ts.shape[0]
    piece = np.empty(n, dtype=np.int64)
    u = np.zeros(n)
    v = np.zeros(n)
    j = 0
    for i in range(n):
        x = ts[i]
        while j < k and tk[j] <= x:
            j += 1
        p = j - 1
        piece[i] = p
        if p < 0:
            continue
        left = 0.5 * (tk[p] - tk[p - 1]) if p > 0 else 0.0
        s = x - tk[p]
        if p == k - 1:
            u[i] = left + s
            continue
        h = tk[p + 1] - tk[p]
        a = left + s - s * s / (2.0 * h)
        b = s * s / (2.0 * h)
        if sk[p] == COSINE:
            f = s / h
            d = h * (_cosine_area(f) - 0.5 * f * f)
            a -= d
            b += d
        u[i] = a
        v[i] = b
    return piece, u, v


@njit(cache=True)
def _knot_normal(
    tk: FloatArray,
    sk: FloatArray,
    ts: FloatArray,
    ph: FloatArray,
    prior_t: FloatArray,
    prior_v: FloatArray,
    pulled: bool,
    start_known: bool,
) -> tuple[FloatArray, FloatArray, IntArray, FloatArray, FloatArray]:
    """Return the normal equations of the knot fit in ``x = (c, v)`` (compiled).

    The angle rows' Gram matrix and right-hand side from per-piece sums of the sparse
    rows (:func:`_knot_columns`), in O(n + k^2), plus the second-difference penalty
    and the pull toward the prior (:func:`_pull_weights`; none on a known first speed).

    Returns
    -------
    tuple
        Gram matrix, right-hand side, and the rows' pieces, ``u`` and ``v``.
    """
    k = tk.shape[0]
    piece, u, v = _knot_columns(tk, sk, ts)
    # per piece p (index p + 1): count, sums of u, v, uu, uv, vv, y, yu, yv
    acc = np.zeros((k + 1, 9))
    for i in range(ts.shape[0]):
        q = piece[i] + 1
        a, b, y = u[i], v[i], ph[i]
        acc[q, 0] += 1.0
        acc[q, 1] += a
        acc[q, 2] += b
        acc[q, 3] += a * a
        acc[q, 4] += a * b
        acc[q, 5] += b * b
        acc[q, 6] += y
        acc[q, 7] += y * a
        acc[q, 8] += y * b
    # tails over the pieces after column c (index c + 1; c = -1 the constant)
    tail_n = np.zeros(k + 2)
    tail_y = np.zeros(k + 2)
    for q in range(k, -1, -1):
        tail_n[q] = tail_n[q + 1] + acc[q, 0]
        tail_y[q] = tail_y[q + 1] + acc[q, 6]
    # column c's whole-support value: 1 for the constant, else _knot_constants
    full = np.ones(k + 1)
    full[1:] = _knot_constants(tk)
    gram = np.zeros((k + 1, k + 1))
    rhs = np.zeros(k + 1)
    gram[0, 0] = tail_n[0]
    rhs[0] = tail_y[0]
    for cb in range(1, k + 1):
        # column cb (knot cb - 1): u in piece cb - 1 (index cb), v in piece cb - 2
        qu, qv = cb, cb - 1
        for ca in range(cb):
            g = full[ca] * full[cb] * tail_n[cb + 1] + full[ca] * acc[qu, 1]
            if ca < cb - 1:
                g += full[ca] * acc[qv, 2]
            else:  # column ca is u where column cb is v
                g += acc[qv, 4]
            gram[ca, cb] = g
            gram[cb, ca] = g
        gram[cb, cb] = full[cb] * full[cb] * tail_n[cb + 1] + acc[qu, 3] + acc[qv, 5]
        rhs[cb] = full[cb] * tail_y[cb + 1] + acc[qu, 7] + acc[qv, 8]
    if k >= 3:
        s2 = _KNOT_SMOOTH * _KNOT_SMOOTH
        for r in range(k - 2):
            for a in range(3):
                for b in range(3):  # the row (1, -2, 1)'s outer product
                    da = 1.0 if a != 1 else -2.0
                    db = 1.0 if b != 1 else -2.0
                    gram[1 + r + a, 1 + r + b] += s2 * da * db
    if pulled:
        weight = _pull_weights(tk, ts)
        if start_known:
            weight[0] = 0.0
        for j in range(k):
            w2 = weight[j] * weight[j]
            gram[1 + j, 1 + j] += w2
            rhs[1 + j] += w2 * np.interp(tk[j], prior_t, prior_v)
    return gram, rhs, piece, u, v


@njit(cache=True)
def _cholesky_solve(gram: FloatArray, rhs: FloatArray) -> tuple[FloatArray, bool]:
    """Solve ``gram @ x = rhs`` by Cholesky (compiled); False if not positive definite."""
    m = gram.shape[0]
    low = np.zeros((m, m))
    for i in range(m):
        for j in range(i + 1):
            s = gram[i, j]
            for q in range(j):
                s -= low[i, q] * low[j, q]
            if i == j:
                if not s > 0.0:
                    return np.zeros(m), False
                low[i, i] = math.sqrt(s)
            else:
                low[i, j] = s / low[j, j]
    z = np.zeros(m)
    for i in range(m):
        s = rhs[i]
        for q in range(i):
            s -= low[i, q] * z[q]
        z[i] = s / low[i, i]
    x = np.zeros(m)
    for i in range(m - 1, -1, -1):
        s = z[i]
        for q in range(i + 1, m):
            s -= low[q, i] * x[q]
        x[i] = s / low[i, i]
    return x, True


@njit(cache=True)
def _knot_residuals(
    tk: FloatArray, x: FloatArray, ph: FloatArray, piece: IntArray, u: FloatArray, v: FloatArray
) -> FloatArray:
    """Return ``c + integral of w0 - angle`` at the sorted rows (compiled) [rad]."""
    k = tk.shape[0]
    full = _knot_constants(tk)
    level = np.empty(k + 1)  # c + the whole supports before piece p (index p + 1)
    level[0] = x[0]
    for p in range(k):
        level[p + 1] = level[p] + full[p] * x[1 + p]
    out = np.empty(ph.shape[0])
    for i in range(ph.shape[0]):
        p = piece[i]
        r = level[p + 1] - ph[i] if p < 0 else level[p] + u[i] * x[1 + p] - ph[i]
        if 0 <= p < k - 1:
            r += v[i] * x[2 + p]
        out[i] = r
    return out


def _knot_fit(
    tk: FloatArray,
    tt: FloatArray,
    ph: FloatArray,
    start: float | None,
    prior: Prior | None,
    tt_sorted: bool,
    sk: FloatArray | None,
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Return ``(c, v)`` of the knot fit, its residuals and the rows' order.

    :func:`_solve_speeds`' solution; the residuals [rad] are those of the angles
    sorted by time, ``order`` the sort (an identity when ``tt_sorted``).
    """
    k = tk.size
    tk = np.ascontiguousarray(tk, dtype=np.float64)
    if tt_sorted:
        order = np.arange(tt.size)
        ts, ys = np.ascontiguousarray(tt), np.ascontiguousarray(ph)
    else:
        order = np.argsort(tt, kind='stable')
        ts, ys = np.ascontiguousarray(tt[order]), np.ascontiguousarray(ph[order])
    shapes = np.zeros(k) if sk is None else np.ascontiguousarray(sk, dtype=np.float64)
    empty = np.zeros(1)
    prior_t, prior_v = (empty, empty) if prior is None else prior
    gram, rhs, piece, u, v = _knot_normal(
        tk, shapes, ts, ys, np.ascontiguousarray(prior_t, dtype=np.float64),
        np.ascontiguousarray(prior_v, dtype=np.float64), prior is not None, start is not None,
    )  # fmt: skip
    x = np.zeros(k + 1)
    if start is None:
        x[:] = _solve_normal(gram, rhs)
    else:  # known: its column moves to the right-hand side
        cols = np.delete(np.arange(k + 1), 1)
        x[1] = start
        x[cols] = _solve_normal(gram[np.ix_(cols, cols)], rhs[cols] - start * gram[cols, 1])
    return x, _knot_residuals(tk, x, ys, piece, u, v), order


def _solve_speeds(
    tk: FloatArray,
    tt: FloatArray,
    ph: FloatArray,
    start: float | None = None,
    prior: Prior | None = None,
    tt_sorted: bool = False,
    sk: FloatArray | None = None,
) -> tuple[FloatArray, float]:
    """Solve the knot speeds of the least-squares fit ``c + integral of w0`` to angles.

    A weak second-difference penalty acts on the knot speeds, and as weak a pull
    toward the ``prior`` profile (the smoothed speed channel): where angles pin a
    knot they decide, and a knot with no angle near it (sliding without sticks
    before, after or between them) keeps the channel's speed instead of the
    penalty's straight-line extrapolation. The normal equations are assembled
    from the sparse rows of the basis (:func:`_knot_normal`).

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    tt : FloatArray
        Times of the angles [s].
    ph : FloatArray
        Drive angles [rad].
    start : float, optional
        The first knot's speed [rad/s] when known (a drive starting from rest).
    prior : tuple of FloatArray, optional
        Knot times [s] and speeds [rad/s] of the profile the knots are pulled toward.
    tt_sorted : bool
        ``tt`` is sorted already.
    sk : FloatArray, optional
        Shape of the piece each knot begins (default linear).

    Returns
    -------
    tuple of (FloatArray, float)
        Knot speeds [rad/s] and the data's sum of squared residuals [rad^2].
    """
    x, r, _ = _knot_fit(tk, tt, ph, start, prior, tt_sorted, sk)
    return np.asarray(x[1:], dtype=np.float64), float(r @ r)


@njit(cache=True)
def _pull_weights(tk: FloatArray, ts: FloatArray) -> FloatArray:
    """Return the weight of each knot's pull toward the prior profile [s] (compiled).

    The angles fix a knot's speed over the part of its hat function's support they
    span (the fit's constant takes the angle before the first of them). The rest of
    the support (sliding, or stick phases too short to sample, before, between or
    after the stick phases that give angles) has only the prior: the pull weighs
    half the width of the support the angles leave uncovered, the angle error [rad]
    one rad/s of speed error makes over it, so a knot keeps the speed channel's
    value unless the angles around its gap say otherwise; a knot whose support the
    angles span gets a weak pull (:data:`_KNOT_SMOOTH`).

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    ts : FloatArray
        Times of the angles [s], sorted.

    Returns
    -------
    FloatArray
        One weight per knot [s].
    """
    k = tk.shape[0]
    n = ts.shape[0]
    out = np.empty(k)
    for j in range(k):
        lo = tk[j - 1] if j > 0 else tk[0]
        hi = tk[j + 1] if j < k - 1 else tk[k - 1]
        covered = 0.0
        if n > 0:
            i0 = np.searchsorted(ts, lo, side='left')
            i1 = np.searchsorted(ts, hi, side='right')
            if i1 > i0:
                covered = ts[i1 - 1] - ts[i0]
        out[j] = max(0.5 * (hi - lo - covered), _KNOT_SMOOTH)
    return out


def _solve_normal(gram: FloatArray, rhs: FloatArray) -> FloatArray:
    """Solve the normal equations ``gram @ x = rhs`` of the knot fit.

    The knot fit's design is tall and thin (thousands of angles, tens of knots) and
    well conditioned (the penalty and pull rows keep every knot speed pinned), so its
    Gram matrix is positive definite and solved directly (:func:`_cholesky_solve`);
    one that is not (a knot with neither angles nor pull) gets the least-norm solution.
    """
    x, ok = _cholesky_solve(np.ascontiguousarray(gram), np.ascontiguousarray(rhs))
    if not ok:
        return np.asarray(np.linalg.lstsq(gram, rhs, rcond=None)[0], dtype=np.float64)
    return np.asarray(x, dtype=np.float64)


def _outliers(
    tk: FloatArray,
    tt: FloatArray,
    ph: FloatArray,
    start: float | None,
    prior: Prior | None,
    sk: FloatArray | None = None,
) -> npt.NDArray[np.bool_]:
    """Flag angle samples far off the least-squares profile with knots ``tk``.

    A phase the stick detector takes for a stick while the discs still slip
    (e.g. the slow end of a slip just before a real stick) gives drive angles
    that are off by the slip; a few of them pull a corner of a speed step by
    many ms. Flagged: residuals beyond :data:`_OUTLIER_SIGMA` robust standard
    deviations (1.4826 x the median absolute residual) and beyond
    :data:`_OUTLIER_FLOOR`.

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    tt : FloatArray
        Sample times [s].
    ph : FloatArray
        Drive angles [rad].
    start : float or None
        Known first knot speed [rad/s].
    prior : tuple of FloatArray or None
        Knot times [s] and speeds [rad/s] the knot speeds are weakly pulled toward.
    sk : FloatArray, optional
        Shape of the piece each knot begins (default linear).

    Returns
    -------
    numpy.ndarray of bool
        True for an outlier.
    """
    _, fit, order = _knot_fit(tk, tt, ph, start, prior, False, sk)
    r = np.empty(tt.size)
    r[order] = fit
    r = r - np.median(r)
    sigma = 1.4826 * float(np.median(np.abs(r)))
    return np.asarray(np.abs(r) > max(_OUTLIER_SIGMA * sigma, _OUTLIER_FLOOR), dtype=np.bool_)


def _corners(inner: FloatArray) -> FloatArray:
    """Return the initial corners of the transitions.

    Interior knots closer than 2 x :data:`SMOOTH_TIME` form one transition (a
    step or a ramp blurred by the smoothing), represented by its first and last
    knot moved inwards by a quarter of the smoothing width; a lone knot is one
    corner.

    Parameters
    ----------
    inner : FloatArray
        Interior knot times of :func:`estimate_drive` [s].

    Returns
    -------
    FloatArray
        Corner times [s], sorted.
    """
    if inner.size == 0:
        return inner
    groups: list[list[float]] = [[float(inner[0])]]
    for x in inner[1:].tolist():
        if x - groups[-1][-1] < 2.0 * SMOOTH_TIME:
            groups[-1].append(x)
        else:
            groups.append([x])
    out: list[float] = []
    for g in groups:
        if len(g) == 1:
            out.append(g[0])
        else:
            out.extend((g[0] + 0.25 * SMOOTH_TIME, g[-1] - 0.25 * SMOOTH_TIME))
    return np.asarray(sorted(out), dtype=np.float64)


#: Most corners whose pieces' shapes :func:`_choose_shapes` chooses [-] (its greedy
#: moves cost about the cube of the count); more (several transitions, or the smoothed
#: speed following slow stick-slip cycles) are placed and stay linear.
_MAX_PLACED = 12
#: Most drive angles the corner placement fits [-] (the knot speeds of the final
#: profile are solved on all of them).
_PLACE_SAMPLES = 3000


def _place(
    tk: FloatArray,
    free: npt.NDArray[np.bool_],
    tt: FloatArray,
    ph: FloatArray,
    start: float | None = None,
    coarse_grid: bool = True,
    prior: Prior | None = None,
    sk: FloatArray | None = None,
) -> FloatArray:
    """Move the free knot times to the least-squares angle fit.

    The angles fix the *mean* time of a transition's two corners far better than
    their spread (a narrow valley of the cost), so the moves are: one corner,
    both corners shifted, both spread apart; each a coarse grid within
    +-:data:`SMOOTH_TIME`, then grids of 1 ms and 0.1 ms around the best,
    repeated :data:`_CORNER_SWEEPS` times.

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    free : numpy.ndarray of bool
        The knots that move.
    tt : FloatArray
        Times of the angles [s].
    ph : FloatArray
        Drive angles [rad].
    start : float, optional
        Known first knot speed [rad/s].
    coarse_grid : bool
        Search the coarse grid (False for corners placed before).
    prior : tuple of FloatArray, optional
        Knot times [s] and speeds [rad/s] the knot speeds are weakly pulled toward.
    sk : FloatArray, optional
        Shape of the piece each knot begins (default linear; kept as the knots move).

    Returns
    -------
    FloatArray
        The knot times [s].
    """
    tk = tk.copy()
    if tt.size > _PLACE_SAMPLES:
        # the corners' placement sees at most this many angles (evenly thinned): every
        # trial is a least-squares solve over them
        pick = np.linspace(0, tt.size - 1, _PLACE_SAMPLES).astype(np.int64)
        tt, ph = tt[pick], ph[pick]
    order = np.argsort(tt, kind='stable')  # sorted once for every trial's knot weights
    tt, ph = tt[order], ph[order]
    _, best = _solve_speeds(tk, tt, ph, start, prior, tt_sorted=True, sk=sk)
    idx = np.flatnonzero(free).tolist()
    moves: list[tuple[list[int], FloatArray]] = [([j], np.ones(1)) for j in idx]
    for j in idx:
        if j + 1 in idx:
            moves.append(([j, j + 1], np.array([1.0, 1.0])))
            moves.append(([j, j + 1], np.array([-1.0, 1.0])))
    coarse = np.linspace(-SMOOTH_TIME, SMOOTH_TIME, _CORNER_GRID)
    fine = np.linspace(-1.0, 1.0, 11) * float(coarse[1] - coarse[0])
    # the fine grid's spacing (1 ms) leaves a corner up to 0.5 ms off; at a speed
    # step of 38 rad/s^2 that is a drive speed error of 0.02 rad/s, which shows in
    # the stick-slip cycles of the transition: a last grid of 0.1 ms
    finest = np.linspace(-1.0, 1.0, 21) * float(fine[1] - fine[0])
    for _ in range(_CORNER_SWEEPS):
        before = tk
        for ks, dirs in moves:
            for grid in (coarse, fine, finest) if coarse_grid else (fine, finest):
                base = tk.copy()
                for d in grid.tolist():
                    if d == 0.0:  # the current knots: their cost is ``best``
                        continue
                    trial = base.copy()
                    trial[ks] += d * dirs
                    if not np.all(np.diff(trial) > MIN_PIECE):
                        continue
                    _, sse = _solve_speeds(trial, tt, ph, start, prior, tt_sorted=True, sk=sk)
                    if sse < best:
                        best, tk = sse, trial
        if tk is before:  # a sweep without a move: the next would repeat it exactly
            break
    return _polish_corners(tk, free, tt, ph, start, prior, sk)


#: Most rounds of :func:`_polish_corners` [-]: each lets a time move half the gap to
#: its neighbours.
_POLISH_ROUNDS = 6
#: Most evaluations of one round of :func:`_polish_corners` [-].
_POLISH_NFEV = 50
#: A polished time within this fraction of its bounds' span of a bound is at it [-].
_POLISH_BOUND = 0.01


def _polish_corners(
    tk: FloatArray,
    free: npt.NDArray[np.bool_],
    tt: FloatArray,
    ph: FloatArray,
    start: float | None,
    prior: Prior | None,
    sk: FloatArray | None,
    rounds: int = _POLISH_ROUNDS,
    nfev: int = _POLISH_NFEV,
) -> FloatArray:
    """Move the free knot times jointly to the nearest least-squares angle fit.

    The grids of :func:`_place` move one corner or one pair at a time; corners of
    neighbouring transitions share the fit's constant and the speeds between them, so
    the grid search can stop where no single move helps though a joint one would.
    From there a trust-region least squares over the free times (the knot speeds
    solved at every evaluation, a variable projection) reaches the joint minimum.
    Each time stays within half the gap to its neighbours (less :data:`MIN_PIECE`),
    so the knots keep their order; a time that ends at such a bound is polished again
    from there (at most :data:`_POLISH_ROUNDS` rounds), so a corner the grids left
    farther off than the gaps allow (an S-ramp from rest, whose blurred knots start a
    tenth of a second early) still reaches the minimum.

    Parameters
    ----------
    tk : FloatArray
        Knot times [s] (from the grid search).
    free : numpy.ndarray of bool
        The knots that move.
    tt, ph : FloatArray
        Sorted times [s] of the drive angles and the angles [rad].
    start : float or None
        Known first knot speed [rad/s].
    prior : tuple of FloatArray or None
        Knot times [s] and speeds [rad/s] the knot speeds are weakly pulled toward.
    sk : FloatArray or None
        Shape of the piece each knot begins (default linear).

    Returns
    -------
    FloatArray
        The knot times [s] (``tk`` where the polish does not lower the sum of squares).
    """
    idx = np.flatnonzero(free)
    if idx.size == 0 or tt.size <= tk.size + 2:
        return tk
    for _ in range(rounds):
        gap = np.diff(tk)
        lo = tk[idx] - 0.5 * (gap[idx - 1] - MIN_PIECE)
        hi = tk[idx] + 0.5 * (gap[np.minimum(idx, gap.size - 1)] - MIN_PIECE)
        if not np.all(hi > lo):
            return tk
        x0 = np.clip(tk[idx], lo, hi)

        def residuals(x: FloatArray, tk: FloatArray = tk) -> FloatArray:
            trial = tk.copy()
            trial[idx] = x
            return _knot_fit(trial, tt, ph, start, prior, True, sk)[1]

        r0 = residuals(x0)
        sol = least_squares(
            residuals, x0, bounds=(lo, hi), x_scale=1e-3, diff_step=1e-7, max_nfev=nfev
        )
        if not float(sol.fun @ sol.fun) < float(r0 @ r0):
            return tk
        tk = tk.copy()
        tk[idx] = sol.x
        room = np.minimum(sol.x - lo, hi - sol.x)
        if not np.any(room < _POLISH_BOUND * (hi - lo)):
            break
    return tk


#: Most placed corners one raised-cosine piece replaces [-] (:func:`_choose_shapes`).
_SPANNED_CORNERS = 3
#: Rounds and evaluations per round of the brief polish a merge into one raised cosine is
#: judged by (:func:`_choose_shapes`; the chosen merge is then polished fully) [-].
_MERGE_POLISH = (2, 12)
#: Spreads of a piece's placed corners about its mid-time tried with its other shape:
#: a grid of factors [-], then two finer grids (steps of a fifth) around the best.
_SPREADS = np.linspace(0.6, 1.6, 11)


def _spread_search(
    tk: FloatArray,
    removable: npt.NDArray[np.bool_],
    j: int,
    tt: FloatArray,
    ph: FloatArray,
    start: float | None,
    prior: Prior | None,
    sk: FloatArray,
) -> tuple[FloatArray, float]:
    """Spread piece ``j``'s removable corners about its mid-time to the least squares.

    A corner that may not move stays; spreads that leave a piece shorter than
    :data:`MIN_PIECE` are skipped.

    Returns
    -------
    tuple of (FloatArray, float)
        The knot times [s] and the angles' sum of squares [rad^2].
    """
    a, b = float(tk[j]), float(tk[j + 1])
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    best_tk, best = tk, math.inf
    grid, step = _SPREADS, float(_SPREADS[1] - _SPREADS[0])
    for _ in range(3):
        centre = 1.0
        for f in grid.tolist():
            trial = tk.copy()
            if removable[j]:
                trial[j] = mid - f * half
            if removable[j + 1]:
                trial[j + 1] = mid + f * half
            if not np.all(np.diff(trial) > MIN_PIECE):
                continue
            _, sse = _solve_speeds(trial, tt, ph, start, prior, tt_sorted=True, sk=sk)
            if sse < best:
                best_tk, best, centre = trial, sse, f
        step /= 5.0
        grid = np.asarray(centre + step * np.arange(-5, 6), dtype=np.float64)
    return best_tk, best


def _polish_piece(
    tk: FloatArray,
    removable: npt.NDArray[np.bool_],
    j: int,
    tt: FloatArray,
    ph: FloatArray,
    start: float | None,
    prior: Prior | None,
    sk: FloatArray,
    rounds: int = _POLISH_ROUNDS,
    nfev: int = _POLISH_NFEV,
) -> FloatArray:
    """Polish the removable ends of piece ``j`` (:func:`_polish_corners`), the rest kept."""
    ends = np.zeros(tk.size, dtype=bool)
    ends[j : j + 2] = removable[j : j + 2]
    return _polish_corners(tk, ends, tt, ph, start, prior, sk, rounds, nfev)


def _shaped_by_angles(ts: FloatArray, a: float, b: float) -> bool:
    """Return True if the sorted angle times ``ts`` [s] inside ``(a, b)`` can shape it.

    At least :data:`_TIMED_ANGLES` of them, spanning at least half of it (the rule
    that times a transition, :func:`untimed_transitions`).
    """
    inside = ts[np.searchsorted(ts, a, side='right') : np.searchsorted(ts, b, side='left')]
    return inside.size >= _TIMED_ANGLES and float(inside[-1] - inside[0]) >= 0.5 * (b - a)


def _choose_shapes(
    tk: FloatArray,
    removable: npt.NDArray[np.bool_],
    tt: FloatArray,
    ph: FloatArray,
    start: float | None,
    prior: Prior | None,
    sk: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """Choose each piece's shape, linear or raised cosine, by the angles' least squares.

    A motor controller's speed transition is a linear ramp or an S-ramp; linear
    pieces follow an S-ramp only with extra corners, whose speeds still miss it by a
    few percent of its change, and the belt (Equ. 2, ``C2`` of thousands of N m/rad)
    turns the drive angle that misses into tens of N m. Greedy moves, the one that
    lowers the angles' sum of squares most first, until none does: a piece changes
    its shape (as many parameters), or up to :data:`_SPANNED_CORNERS`
    consecutive removable knots go and the pieces they joined become one raised
    cosine (fewer parameters), whose removable ends are spread about its mid-time
    and then polished (:func:`_polish_corners`). A piece's shape is decided only by
    angles inside it (:func:`_shaped_by_angles`); the angles around a short step fix
    its mid-time, not its shape.

    Parameters
    ----------
    tk : FloatArray
        Knot times [s].
    removable : numpy.ndarray of bool
        Interior knots that may go (placed corners, not known ones).
    tt, ph : FloatArray
        Sorted times [s] of the drive angles and the angles [rad].
    start : float or None
        Known first knot speed [rad/s].
    prior : tuple of FloatArray or None
        Knot times [s] and speeds [rad/s] the knot speeds are weakly pulled toward.
    sk : FloatArray, optional
        The pieces' shapes to start from (default: all linear).

    Returns
    -------
    tuple of (FloatArray, FloatArray, numpy.ndarray of bool)
        The knot times [s], their pieces' shapes and which of them may still move.
    """
    if tt.size > _PLACE_SAMPLES:  # evenly thinned, as for the corners' placement
        pick = np.linspace(0, tt.size - 1, _PLACE_SAMPLES).astype(np.int64)
        tt, ph = tt[pick], ph[pick]
    sk = np.zeros(tk.size) if sk is None else sk.copy()
    _, best = _solve_speeds(tk, tt, ph, start, prior, tt_sorted=True, sk=sk)
    while True:
        move: tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]] | None = None
        chosen = -1  # the first knot of a chosen merge's raised cosine
        for j in range(tk.size - 1):
            if not _shaped_by_angles(tt, float(tk[j]), float(tk[j + 1])):
                continue
            trial = sk.copy()
            trial[j] = 0.0 if sk[j] == COSINE else COSINE
            # a shape's corners sit elsewhere (an S-ramp's are wider apart than the
            # linear ramp's through the same angles, about 1.4x): its placed corners
            # spread about their mid-time
            if removable[j] or removable[j + 1]:
                tk2, sse = _spread_search(tk, removable, j, tt, ph, start, prior, trial)
            else:
                tk2 = tk
                _, sse = _solve_speeds(tk, tt, ph, start, prior, tt_sorted=True, sk=trial)
            if sse < best:
                best, move = sse, (tk2, trial, removable)
        for i in range(tk.size - 2):
            for j in range(i + 2, min(i + 2 + _SPANNED_CORNERS, tk.size)):
                if not removable[i + 1 : j].all():
                    break
                if not _shaped_by_angles(tt, float(tk[i]), float(tk[j])):
                    continue
                keep = np.ones(tk.size, dtype=bool)
                keep[i + 1 : j] = False
                tk2, sk2, rm2 = tk[keep], sk[keep], removable[keep]
                sk2[i] = COSINE
                if rm2[i] or rm2[i + 1]:
                    # the cosine's ends sit wider apart than the corners it replaces
                    # (an S-ramp of a second from rest): spread about its mid-time, then
                    # polished jointly, briefly
                    tk2, _ = _spread_search(tk2, rm2, i, tt, ph, start, prior, sk2)
                    tk2 = _polish_piece(tk2, rm2, i, tt, ph, start, prior, sk2, *_MERGE_POLISH)
                _, sse = _solve_speeds(tk2, tt, ph, start, prior, tt_sorted=True, sk=sk2)
                if sse < best:
                    best, move = sse, (tk2, sk2, rm2)
                    chosen = i
        if move is None:
            return tk, sk, removable
        tk, sk, removable = move
        if chosen >= 0:  # the chosen merge's ends polished to the end
            tk = _polish_piece(tk, removable, chosen, tt, ph, start, prior, sk)
            _, best = _solve_speeds(tk, tt, ph, start, prior, tt_sorted=True, sk=sk)


def refine_with_angles(
    drive: DriveEstimate,
    t: FloatArray,
    phi0: FloatArray,
    hint_knots: FloatArray | None = None,
    *,
    place: bool = True,
    start_speed: float | None = None,
    keep_corners: bool = False,
    prior: DriveEstimate | None = None,
) -> DriveEstimate:
    """Re-fit the drive profile to measured drive *angles* (least squares).

    The drive angle at a stick follows from the shaft angle (integral of w2) and
    the belt deflection of Equ. 2, which is known while the discs stick; the angle
    pins the mean drive speed between sticks to the noise of that deflection
    (~1e-3 rad/s), far better than the smoothed shaft speed. Outlying angles (a
    phase taken for a stick while the discs still slip) are dropped
    (:func:`_outliers`) and the fit repeated. The knots are weakly pulled toward
    the ``prior`` profile's speeds, which a knot without angles near it keeps.

    Parameters
    ----------
    drive : DriveEstimate
        The profile to refine.
    t : FloatArray
        Times of the angles [s].
    phi0 : FloatArray
        Drive angles [rad].
    hint_knots : FloatArray, optional
        Corners known in advance [s] (RIG.yaml's start-up ramp end); a detected
        knot within :data:`SMOOTH_TIME` of one moves onto it and stays there. With a
        ``start_speed`` (the record begins at the drive's start) each is a knot,
        detected or not.
    place : bool
        Search the corner times: the smoothing of :func:`estimate_drive` blurs
        each corner (a 50 ms speed step spreads over 150 ms), so its interior
        knots only say *where* the speed changes; each transition becomes two
        corners (one for a lone knot) whose times are searched within
        +-:data:`SMOOTH_TIME` for the best angle fit, the knot speeds solved by
        linear least squares at every trial. False: keep the knot times of
        ``drive`` and re-fit the speeds only.
    start_speed : float, optional
        Drive speed at the record's start when known [rad/s] (0 for a record that
        begins at the drive's start from rest): the angles alone leave it
        ~4e-4 rad/s off, which a torque-offset drift then absorbs.
    keep_corners : bool
        The interior knots of ``drive`` are corners placed before (not blurred
        knots of :func:`estimate_drive`): searched again locally from where they
        are (fine grids only), for angles recomputed with that profile, each piece
        keeping its shape. Otherwise the placed corners' pieces get their shapes,
        linear or raised cosine (:func:`_choose_shapes`), and are placed again.
    prior : DriveEstimate, optional
        The profile of the speed channel (:func:`estimate_drive`) the knot speeds are
        weakly pulled toward (default: ``drive``).

    Returns
    -------
    DriveEstimate
        The refined profile (``drive`` itself when the angles are too few).
    """
    t_lo, t_hi = float(drive.knot_time[0]), float(drive.knot_time[-1])
    base = drive if prior is None else prior
    pull: Prior = (base.knot_time, base.knot_speed)
    tt = np.asarray(t, dtype=np.float64)
    ph = np.asarray(phi0, dtype=np.float64)
    ok = np.isfinite(tt) & np.isfinite(ph)
    tt, ph = tt[ok], ph[ok]
    free = np.zeros(drive.knot_time.size, dtype=bool)
    tk0 = drive.knot_time
    if place:
        inner = drive.knot_time[1:-1]
        hints = np.asarray(hint_knots if hint_knots is not None else [], dtype=np.float64)
        hints = hints[(hints > t_lo + 0.01) & (hints < t_hi - 0.01)]
        if hints.size and inner.size:
            dist = np.abs(inner[:, None] - hints[None, :])
            hinted = (dist <= SMOOTH_TIME).any(axis=1)
            moved = np.unique(hints[np.argmin(dist, axis=1)][hinted])
            inner = inner[~hinted]
        else:
            moved = np.zeros(0)
        if start_speed is not None:
            # the record begins at the drive's start: the ramp's end is a corner whether
            # or not the speed channel's profile put a knot near it
            moved = np.unique(np.concatenate((moved, hints)))
        corners = inner.copy() if keep_corners else _corners(inner)
        corners = corners[(corners > t_lo + MIN_PIECE) & (corners < t_hi - MIN_PIECE)]
        # a corner without angles near it has nothing to place it by: its transition
        # keeps the smoothed speed's knots
        near = np.asarray(
            [np.count_nonzero(np.abs(tt - c) < 2.0 * SMOOTH_TIME) >= 3 for c in corners.tolist()],
            dtype=bool,
        )
        if not near.all():
            far = corners[~near]
            kept = inner[(np.abs(inner[:, None] - far[None, :]) <= SMOOTH_TIME).any(axis=1)]
            kept = kept[(kept > t_lo + MIN_PIECE) & (kept < t_hi - MIN_PIECE)]
            corners = np.concatenate((corners[near], kept))
            near = np.concatenate((np.ones(int(near.sum()), bool), np.zeros(kept.size, bool)))
        tk = np.concatenate(([t_lo, t_hi], moved, corners))
        n_fixed = 2 + moved.size
        free = np.concatenate((np.zeros(n_fixed, bool), near))
        order = np.argsort(tk, kind='stable')
        tk, free = tk[order], free[order]
        keep = np.concatenate(([True], np.diff(tk) > MIN_PIECE))
        tk, free = tk[keep], free[keep]
        if tt.size < tk.size + 2 or tk.size < 2:
            return drive
        sk = _shapes_of(drive, tk) if keep_corners else np.zeros(tk.size)
        tk0 = tk
        coarse = not keep_corners
        if free.any():
            tk = _place(tk0, free, tt, ph, start_speed, coarse, pull, sk)
        if int(free.sum()) <= _MAX_PLACED:
            order = np.argsort(tt, kind='stable')
            shaped = _choose_shapes(tk, free, tt[order], ph[order], start_speed, pull, sk)
            if not np.array_equal(shaped[0], tk) or not np.array_equal(shaped[1], sk):
                # the placed corners again, locally, with the shapes
                tk, sk, free = shaped
                tk0, coarse = tk, False
                if free.any() and int(free.sum()) <= _MAX_PLACED:
                    tk = _place(tk0, free, tt, ph, start_speed, False, pull, sk)
    else:
        tk = drive.knot_time.copy()
        sk = drive.shapes().copy()
        if tt.size < tk.size + 2 or tk.size < 2:
            return drive
    # outlying angles (a false stick phase) are dropped and the fit repeated; the
    # flags are re-evaluated against each new fit, so samples only pulled off by
    # a wrongly placed corner come back
    kept = np.ones(tt.size, dtype=bool)
    for _ in range(_OUTLIER_ROUNDS):
        out = _outliers(tk, tt, ph, start_speed, pull, sk)
        if not out.any() or np.array_equal(~out, kept) or int((~out).sum()) < tk.size + 2:
            break
        kept = ~out
        if place and free.any():
            tk = _place(tk0, free, tt[kept], ph[kept], start_speed, coarse, pull, sk)
    tt, ph = tt[kept], ph[kept]
    vk, _ = _solve_speeds(tk, tt, ph, start_speed, pull, sk=sk)
    if not np.all(np.isfinite(vk)):
        return drive
    out_shape = sk if sk.any() else None
    est = DriveEstimate(tk.copy(), vk, drive.nominal, 0.0, math.nan, drive.from_record, out_shape)
    level = float(np.median(est.speed(np.linspace(tk[0], tk[-1], 512))))
    return replace(est, level=level, mismatch=_mismatch(level, drive.nominal))


def _shapes_of(drive: DriveEstimate, tk: FloatArray) -> FloatArray:
    """Return the shapes of ``drive``'s pieces on the knots ``tk`` (by knot time)."""
    src = drive.shapes()
    out = np.zeros(tk.size)
    if not src.any():
        return out
    i = np.clip(np.searchsorted(drive.knot_time, tk), 0, src.size - 1)
    same = np.abs(drive.knot_time[i] - tk) <= 1e-9
    out[same] = src[i[same]]
    out[-1] = 0.0
    return out


#: Widest drive transition [s]: :func:`refine_with_angles` makes each speed step or
#: ramp two corners within 2 x :data:`SMOOTH_TIME` of each other.
TRANSITION_MAX = 2.0 * SMOOTH_TIME
#: Fewest drive angles between a transition's corners that time it [-].
_TIMED_ANGLES = 3


def transitions(drive: DriveEstimate) -> list[int]:
    """Return the transitions of a placed profile: adjacent interior knots close together.

    A transition is a pair of adjacent interior knots at most :data:`TRANSITION_MAX`
    apart (a speed step, the end of a start-up or a stop); pairs do not overlap.

    Parameters
    ----------
    drive : DriveEstimate
        The placed profile.

    Returns
    -------
    list of int
        The index of each transition's first knot.

    Examples
    --------
    >>> import numpy as np
    >>> d = DriveEstimate(np.array([0.0, 1.0, 1.03, 1.5, 3.0]),
    ...                   np.array([2.0, 2.0, 1.0, 1.0, 1.0]), float('nan'), 1.5, float('nan'))
    >>> transitions(d)
    [1]
    """
    tk = drive.knot_time
    out: list[int] = []
    j = 1
    while j + 2 < tk.size:
        if float(tk[j + 1] - tk[j]) <= TRANSITION_MAX:
            out.append(j)
            j += 2
            continue
        j += 1
    return out


def untimed_transitions(drive: DriveEstimate, angle_times: FloatArray) -> list[int]:
    """Return the transitions whose duration the drive angles leave open.

    A transition is a pair of adjacent interior knots at most :data:`TRANSITION_MAX`
    apart. The angles on either side fix its mid-time (the angle gained over it,
    ``integral of w0``, is that of a step at the mid-time whatever its duration) but
    not its duration; angles spread between the corners would. Fewer than
    :data:`_TIMED_ANGLES` there, or angles spanning less than half the time between
    the corners (the end of a stick phase that a corner placed too early takes in),
    leave the duration open: the torsion moment it drives through the belt (Equ. 2)
    decides it (``Problem.set_transition_durations`` of the discrepancy fit).

    Parameters
    ----------
    drive : DriveEstimate
        The placed profile.
    angle_times : FloatArray
        Times of the drive angles it was fitted to [s].

    Returns
    -------
    list of int
        The index of each such transition's first knot.
    """
    tk = drive.knot_time
    ts = np.sort(np.asarray(angle_times, dtype=np.float64))
    return [
        j for j in transitions(drive) if not _shaped_by_angles(ts, float(tk[j]), float(tk[j + 1]))
    ]


def with_durations(drive: DriveEstimate, durations: tuple[tuple[float, ...], ...]) -> DriveEstimate:
    """Return the profile with transitions of the given durations at their mid-times.

    Each ``(mid-time, duration)`` or ``(mid-time, duration, shape)`` applies to the
    pair of adjacent interior knots at most :data:`TRANSITION_MAX` apart whose
    mid-time is nearest and within :data:`SMOOTH_TIME` of it; the pair keeps its own
    mid-time (the drive angles') and takes the duration, within its neighbouring
    knots less the shortest piece, and the shape if one is given (0 linear,
    :data:`COSINE`). The knot speeds are kept.

    Parameters
    ----------
    drive : DriveEstimate
        The placed profile.
    durations : tuple of tuple of float
        Mid-time [s], duration [s] and optionally shape [-] per transition.

    Returns
    -------
    DriveEstimate
        The profile (``drive`` itself without a matching pair).

    Examples
    --------
    >>> import numpy as np
    >>> d = DriveEstimate(np.array([0.0, 1.0, 1.002, 3.0]), np.array([1.0, 1.0, 2.0, 2.0]),
    ...                   float('nan'), 1.5, float('nan'))
    >>> with_durations(d, ((1.001, 0.02),)).knot_time.round(4).tolist()
    [0.0, 0.991, 1.011, 3.0]
    """
    tk = drive.knot_time.copy()
    sk = drive.shapes().copy()
    if tk.size < 4:  # no interior pair of knots
        return drive
    changed = False
    for mid, duration, *shape in durations:
        j_all = np.arange(1, tk.size - 2)
        gap = tk[j_all + 1] - tk[j_all]
        mids = 0.5 * (tk[j_all] + tk[j_all + 1])
        ok = (gap <= TRANSITION_MAX) & (np.abs(mids - mid) <= SMOOTH_TIME)
        if not ok.any():
            continue
        j = int(j_all[ok][np.argmin(np.abs(mids[ok] - mid))])
        m = 0.5 * float(tk[j] + tk[j + 1])
        room = min(m - float(tk[j - 1]), float(tk[j + 2]) - m) - MIN_PIECE
        half = min(0.5 * float(duration), room)
        if half < 0.5 * MIN_PIECE:
            continue
        tk[j], tk[j + 1] = m - half, m + half
        if shape:
            sk[j] = shape[0]
        changed = True
    if not changed:
        return drive
    if drive.shape is None and not sk.any():
        return replace(drive, knot_time=tk)
    return replace(drive, knot_time=tk, shape=sk)
