"""Inertia-corrected friction observer, M = I1*w1' + K1*w1 + C1*phi1 (paper Equ. 1).

Inputs per sample: measured torsion moment ``M_t = C1*phi1`` [N m] and chamber
acceleration ``a = w1'`` [rad/s^2]. The chamber speed ``w1`` [rad/s] is not
measured; it comes from a complementary filter that needs no derivative of
noisy data and cannot drift:

    w1 = [ a + wc*s*phi1 ] / (s + wc),       phi1 = M_t/C1

i.e. the integral of the acceleration high-passed at ``wc`` plus the derivative of
the torsion angle low-passed at ``wc`` (for the chamber ``w1 = phi1'``; the two
paths sum to one, so the estimate is exact when the signals are). Implemented
without any derivative as ``w1 = x + wc*phi1`` with ``x' = -wc*x + a - wc^2*phi1``,
discretised by the trapezoidal (Tustin) rule. Corner frequency ``corner_hz``
(default 10 Hz): an accelerometer bias ``b`` gives a speed error ``b/wc``; the
torque noise reaches ``w1`` with gain ``wc/C1``; a jump of the acceleration
between two samples (stick/slip switch) leaves a trapezoid error of up to
``jump*dt/2`` that decays with ``wc`` (about 0.1 rad/s for 10 kHz stick-slip).
All are negligible for the friction moment because ``K1`` is small.

Streaming: :class:`FrictionObserver` carries the filter state, so feeding blocks
gives exactly the result of one call on the concatenated signals.
"""

from __future__ import annotations

import math

import numpy as np

from tribo_estimation.core.model import RigParams
from tribo_estimation.core.signal import iir1
from tribo_estimation.errors import InvalidDataError, InvalidParameterError


class FrictionObserver:
    """Streaming inertia-corrected friction moment observer (Equ. 1).

    ``rig`` supplies I1 [kg m^2], K1 [N m s/rad], C1 [N m/rad]; ``fs`` sample rate
    [Hz]; ``corner_hz`` complementary-filter corner [Hz]; ``initial_speed`` chamber
    speed at the first sample [rad/s] (0 = rig at rest or sticking at low speed).
    """

    def __init__(
        self,
        rig: RigParams,
        fs: float = 10_000.0,
        corner_hz: float = 10.0,
        initial_speed: float = 0.0,
    ) -> None:
        if not (math.isfinite(fs) and fs > 0.0):
            raise InvalidParameterError(f'fs must be > 0 Hz, got {fs!r}')
        if not (math.isfinite(corner_hz) and 0.0 < corner_hz < 0.25 * fs):
            raise InvalidParameterError(
                f'corner_hz must be in (0, fs/4) = (0, {0.25 * fs}) Hz, got {corner_hz!r}'
            )
        self.rig = rig
        self.fs = float(fs)
        self.corner_hz = float(corner_hz)
        self.initial_speed = float(initial_speed)
        wc = 2.0 * math.pi * corner_hz
        dt = 1.0 / fs
        den = 1.0 + 0.5 * wc * dt
        self._wc = wc
        self._b = 0.5 * dt / den  # both numerator coefficients
        self._a1 = -(1.0 - 0.5 * wc * dt) / den
        self._zi: float | None = None
        self.last_speed = np.zeros(0)

    def reset(self, initial_speed: float | None = None) -> None:
        """Forget the filter state (next sample starts anew)."""
        if initial_speed is not None:
            self.initial_speed = float(initial_speed)
        self._zi = None

    def chamber_speed(self, torsion: np.ndarray, accel: np.ndarray) -> np.ndarray:
        """Advance the filter and return the chamber speed estimate w1 [rad/s]."""
        mt = np.asarray(torsion, dtype=float)
        ac = np.asarray(accel, dtype=float)
        if mt.shape != ac.shape or mt.ndim != 1:
            raise InvalidDataError(
                f'torsion and accel must be 1-D of equal length, got {mt.shape}, {ac.shape}'
            )
        if mt.size == 0:
            return np.zeros(0)
        if not (np.all(np.isfinite(mt)) and np.all(np.isfinite(ac))):
            raise InvalidDataError('torsion or accel contains NaN/inf')
        phi = mt / self.rig.C1
        u = ac - self._wc**2 * phi
        if self._zi is None:
            # first sample: x = w1(0) - wc*phi1(0) with the given initial speed
            x0 = self.initial_speed - self._wc * phi[0]
            zi = self._trap_zi(x0, u[0])
            if u.size > 1:
                rest, zf = iir1(self._b, self._b, self._a1, u[1:], zi)
                x = np.concatenate([[x0], rest])
            else:
                x, zf = np.array([x0]), zi
        else:
            x, zf = iir1(self._b, self._b, self._a1, u, self._zi)
        self._zi = zf
        return x + self._wc * phi

    def _trap_zi(self, x_prev: float, u_prev: float) -> float:
        # direct form II transposed state so that the next output is
        # y = -a1*x_prev + b0*u + b1*u_prev
        return float(-self._a1 * x_prev + self._b * u_prev)

    def update(self, torsion: np.ndarray, accel: np.ndarray) -> np.ndarray:
        """Friction moment M = I1*a + K1*w1 + M_t [N m] for the next block of samples."""
        w1 = self.chamber_speed(torsion, accel)
        self.last_speed = w1
        rig = self.rig
        ac = np.asarray(accel, dtype=float)
        moment: np.ndarray = rig.I1 * ac + rig.K1 * w1 + np.asarray(torsion, dtype=float)
        return moment


def friction_moment(
    rig: RigParams,
    torsion: np.ndarray,
    accel: np.ndarray,
    fs: float = 10_000.0,
    corner_hz: float = 10.0,
    initial_speed: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """One-shot observer: returns (friction moment M [N m], chamber speed w1 [rad/s])."""
    obs = FrictionObserver(rig, fs, corner_hz, initial_speed)
    m = obs.update(torsion, accel)
    return m, obs.last_speed
