"""The fitted depth profile: F(z), rho_I(z), their standard errors and inversion."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from tribo_nvct.errors import DepthProfileError

FloatArray = NDArray[np.float64]

#: Fine evaluation grid of the fitted profile [points].
GRID_POINTS = 4001


@dataclass(frozen=True, eq=False)
class DepthProfile:
    """Fitted activation depth profile on a fine grid (SI units).

    z_grid: depth [m] from 0 to ``max_depth``.
    cumulative: F(z) = integral_0^z rho_I [Bq/m^2] (non-decreasing).
    cumulative_se: standard error of F [Bq/m^2] (delta method of the chosen model).
    density: rho_I(z) [Bq/m^3] (>= 0).
    residual_rms_bq: RMS residual of the layer-removal fit [Bq] (NaN for analytic profiles).
    model: chosen model (``erfc``, ``exponential``, ``ramp``, ``piecewise/<k>``, ``analytic``).
    aic: (model, AIC) of every candidate fitted; chi2_red: chi^2/dof of the chosen fit.
    """

    z_grid: FloatArray
    cumulative: FloatArray
    cumulative_se: FloatArray
    density: FloatArray
    residual_rms_bq: float = math.nan
    model: str = 'analytic'
    aic: tuple[tuple[str, float], ...] = ()
    chi2_red: float = math.nan
    replica_source: Callable[[], FloatArray] | None = field(default=None, repr=False)
    _cache: dict[str, FloatArray] = field(default_factory=dict, repr=False)

    @property
    def max_depth(self) -> float:
        """Deepest depth covered by the profile (activated depth measured) [m]."""
        return float(self.z_grid[-1])

    @property
    def total(self) -> float:
        """F(max_depth): areal activity of the measured layer [Bq/m^2]."""
        return float(self.cumulative[-1])

    @property
    def surface_density(self) -> float:
        """Slope of F at the surface used for h < 0 (noise below zero) [Bq/m^3]."""
        rho0 = float(self.density[0])
        if rho0 > 0.0:
            return rho0
        k = max(1, self.z_grid.size // 100)
        return float(self.cumulative[k] / self.z_grid[k]) if self.cumulative[k] > 0 else math.nan

    def F(self, h: float | FloatArray) -> FloatArray:
        """F(h) [Bq/m^2]; NaN beyond the profile; linear (surface density) for h < 0."""
        hh = np.atleast_1d(np.asarray(h, dtype=float))
        out = np.interp(hh, self.z_grid, self.cumulative)
        out = np.where(hh < 0.0, hh * self.surface_density, out)
        return np.where(hh > self.max_depth, np.nan, out)

    def F_se(self, h: float | FloatArray) -> FloatArray:
        """Return the standard error of F(h) [Bq/m^2] (systematic for a whole test)."""
        hh = np.atleast_1d(np.asarray(h, dtype=float))
        out = np.interp(np.clip(hh, 0.0, None), self.z_grid, self.cumulative_se)
        return np.where(hh > self.max_depth, np.nan, out)

    def rho(self, h: float | FloatArray) -> FloatArray:
        """rho_I(h) [Bq/m^3]; NaN beyond the profile."""
        hh = np.atleast_1d(np.asarray(h, dtype=float))
        out = np.interp(np.clip(hh, 0.0, None), self.z_grid, self.density)
        out = np.where(hh < 0.0, self.surface_density, out)
        return np.where(hh > self.max_depth, np.nan, out)

    def invert(self, F_value: float | FloatArray) -> FloatArray:
        """Wear height h [m] with F(h) = F_value [Bq/m^2].

        Values above F(max_depth) give NaN (wear beyond the activated depth:
        never extrapolated). Negative values (counting noise around zero) map
        linearly with the surface density.
        """
        return _invert(self.z_grid, self.cumulative, F_value, self.surface_density)

    def replicas(self) -> FloatArray:
        """Bootstrap replicas F*_b(z_grid) [Bq/m^2], shape (B, grid); (0, grid) if none.

        Computed on the first call and cached (see the module docstring).
        """
        if 'F' not in self._cache:
            if self.replica_source is None:
                self._cache['F'] = np.zeros((0, self.z_grid.size))
            else:
                self._cache['F'] = self.replica_source()
        return self._cache['F']

    def invert_replicas(self, F_value: FloatArray) -> FloatArray:
        """h_b = F*_b^-1(F_value) [m] for every bootstrap replica, shape (B, n) (NaN beyond).

        F_value [Bq/m^2]: shape (n,) (same values for every replica) or (B, n).
        """
        reps = self.replicas()
        B = reps.shape[0]
        f = np.asarray(F_value, dtype=float)
        f = np.broadcast_to(f, (B, f.shape[-1])) if f.ndim else np.full((B, 1), float(f))
        out = np.empty(f.shape)
        k = max(1, self.z_grid.size // 100)
        for b in range(B):
            Fb = reps[b]
            slope = Fb[k] / self.z_grid[k] if Fb[k] > 0 else self.surface_density
            out[b] = _invert(self.z_grid, Fb, f[b], float(slope))
        return out

    @classmethod
    def from_density(
        cls, density: Callable[[FloatArray], FloatArray], max_depth_m: float, n: int = GRID_POINTS
    ) -> DepthProfile:
        """Profile from an analytic rho_I(z) [Bq/m^3] on [0, max_depth_m] (no uncertainty)."""
        z = np.linspace(0.0, max_depth_m, n)
        rho = np.asarray(density(z), dtype=float)
        if np.any(rho < 0.0) or not np.all(np.isfinite(rho)):
            raise DepthProfileError('analytic density must be finite and >= 0')
        F = np.concatenate([[0.0], np.cumsum(0.5 * (rho[1:] + rho[:-1]) * np.diff(z))])
        zero = np.zeros_like(z)
        return cls(z, F, zero, rho)


def _invert(
    z: FloatArray, cum: FloatArray, F_value: float | FloatArray, slope0: float
) -> FloatArray:
    """First z with cum(z) = F_value [m]; NaN above cum[-1]; F/slope0 below 0."""
    f = np.atleast_1d(np.asarray(F_value, dtype=float))
    out = np.full(f.shape, np.nan)
    neg = f < 0.0
    out[neg] = f[neg] / slope0
    ok = (f >= 0.0) & (f <= cum[-1])
    if np.any(ok):
        idx = np.searchsorted(cum, f[ok], side='left')
        idx = np.clip(idx, 1, cum.size - 1)
        f0 = cum[idx - 1]
        f1 = cum[idx]
        span = f1 - f0
        frac = np.where(span > 0.0, (f[ok] - f0) / np.where(span > 0, span, 1.0), 0.0)
        out[ok] = z[idx - 1] + frac * (z[idx] - z[idx - 1])
    return out
