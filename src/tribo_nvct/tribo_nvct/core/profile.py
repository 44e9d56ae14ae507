"""Depth profile of the activation: rho_I(z) and its cumulative integral (paper 3.2).

Reference pins of the same alloy are irradiated with the specimens; thin layers
(about 0.1 um) are removed one after the other and the activity remaining in
the pin is measured after every step. With the pin's activated face area
``A_pin`` [m^2] the concentration profile is (physics notes, section 2)

    rho_I(z) = -(1/A_pin) dA_rem/dz                       [Bq/m^3]
    F(h)     = integral_0^h rho_I dz = (A_rem(0) - A_rem(h))/A_pin   [Bq/m^2]

and the activity released by a wear height h of a tagged area A_I is
``A_oil = A_I * F(h)`` (the general form of the paper's Equ. 8).

Smoothing: rho_I is a non-negative combination of piecewise-linear hat
functions (a shape-constrained linear spline), fitted to the remaining
activity by non-negative least squares. The constraint rho_I >= 0 is exactly
"remaining activity never rises with depth"; where it is not active the fit is
an ordinary (unbiased) weighted least-squares spline fit. The knot spacing is
chosen by AIC among multiples of the layer step. Standard errors follow from
the covariance of the active coefficients (constraint-free where they are
free; bound coefficients carry no variance, which is the usual active-set
approximation).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls

from tribo_nvct.errors import DepthProfileError, ProfileNotDecreasingError

FloatArray = NDArray[np.float64]

#: Fine evaluation grid of the fitted profile [points].
GRID_POINTS = 4001


@dataclass(frozen=True, eq=False)
class LayerRemovalData:
    """Raw layer-removal measurements of a reference pin.

    depth_m: removed depth z_i [m], strictly increasing, first 0.
    remaining_bq: activity left in the pin after removal to z_i [Bq].
    remaining_se_bq: its standard error [Bq], or None (then estimated from the fit).
    source: file name for messages.
    """

    depth_m: FloatArray
    remaining_bq: FloatArray
    remaining_se_bq: FloatArray | None = None
    source: str = '<data>'

    def __post_init__(self) -> None:
        z, a = self.depth_m, self.remaining_bq
        src = self.source
        if z.ndim != 1 or a.shape != z.shape or z.size < 4:
            raise DepthProfileError(f'{src}: need >= 4 rows of depth and remaining activity')
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(a))):
            raise DepthProfileError(f'{src}: depth or remaining activity is not finite (NaN/inf)')
        if abs(z[0]) > 1e-12:
            raise DepthProfileError(
                f'{src}: first depth must be 0 (the unworn surface), got {z[0] * 1e6:g} um'
            )
        dz = np.diff(z)
        if np.any(dz <= 0.0):
            i = int(np.argmax(dz <= 0.0)) + 1
            raise DepthProfileError(
                f'{src}: depth not strictly increasing at row {i + 1} ({z[i] * 1e6:g} um)'
            )
        # Background-subtracted activities deep in the pin may scatter slightly below
        # zero: that is good data, not an error. The surface value must be positive.
        if a[0] <= 0.0:
            raise DepthProfileError(f'{src}: remaining activity at the surface must be > 0')
        if self.remaining_se_bq is not None:
            se = self.remaining_se_bq
            if se.shape != z.shape or not np.all(np.isfinite(se)) or np.any(se <= 0.0):
                raise DepthProfileError(f'{src}: remaining_activity_se_bq must be finite and > 0')


def read_layer_removal_csv(path: str | Path) -> LayerRemovalData:
    """Read ``depth_um,remaining_activity_bq[,remaining_activity_se_bq]`` (um, Bq, Bq).

    Lines starting with ``#`` are comments. Units are converted to SI (m).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding='utf-8')
    except OSError as exc:
        raise DepthProfileError(f'cannot read depth profile {p}: {exc.strerror}') from None
    rows = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith('#')]
    if not rows:
        raise DepthProfileError(f'{p}: empty depth profile')
    reader = csv.DictReader(rows)
    fields = [f.strip() for f in (reader.fieldnames or [])]
    reader.fieldnames = fields
    for col in ('depth_um', 'remaining_activity_bq'):
        if col not in fields:
            raise DepthProfileError(f'{p}: missing column {col!r} (have {fields})')
    has_se = 'remaining_activity_se_bq' in fields
    z: list[float] = []
    a: list[float] = []
    se: list[float] = []
    for n, row in enumerate(reader, start=2):
        try:
            z.append(float(row['depth_um']) * 1e-6)
            a.append(float(row['remaining_activity_bq']))
            if has_se:
                se.append(float(row['remaining_activity_se_bq']))
        except (TypeError, ValueError):
            raise DepthProfileError(f'{p}: bad number in data row {n - 1}: {row}') from None
    return LayerRemovalData(
        np.asarray(z),
        np.asarray(a),
        np.asarray(se) if has_se else None,
        source=str(p),
    )


def _hat_antiderivative(z: FloatArray, knots: FloatArray) -> FloatArray:
    """Phi[i, k] = integral_0^{z_i} phi_k(s) ds for the hat functions on ``knots`` [m]."""
    K = knots.size
    out = np.zeros((z.size, K))
    for k in range(K):
        c = knots[k]
        lo = knots[k - 1] if k > 0 else c
        hi = knots[k + 1] if k < K - 1 else c
        if c > lo:
            left = np.clip(z, lo, c) - lo
            out[:, k] += left * left / (2.0 * (c - lo))
        if hi > c:
            right = np.clip(z, c, hi) - c
            out[:, k] += right - right * right / (2.0 * (hi - c))
    return out


def _hat_values(z: FloatArray, knots: FloatArray) -> FloatArray:
    """phi[i, k] = phi_k(z_i), hat functions (value 1 at knot k) [-]."""
    K = knots.size
    out = np.zeros((z.size, K))
    eye = np.eye(K)
    for k in range(K):
        out[:, k] = np.interp(z, knots, eye[k])
    return out


@dataclass(frozen=True, eq=False)
class DepthProfile:
    """Fitted activation depth profile on a fine grid (SI units).

    z_grid: depth [m] from 0 to ``max_depth``.
    cumulative: F(z) = integral_0^z rho_I [Bq/m^2] (non-decreasing).
    cumulative_se: standard error of F [Bq/m^2].
    density: rho_I(z) [Bq/m^3] (>= 0), density_se its standard error.
    residual_rms_bq: RMS residual of the layer-removal fit [Bq] (NaN for analytic profiles).
    knot_spacing_m: spline knot spacing chosen [m] (NaN for analytic profiles).
    """

    z_grid: FloatArray
    cumulative: FloatArray
    cumulative_se: FloatArray
    density: FloatArray
    density_se: FloatArray
    residual_rms_bq: float = math.nan
    knot_spacing_m: float = math.nan

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
        """Standard error of F(h) [Bq/m^2] (systematic for a whole test)."""
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
        f = np.atleast_1d(np.asarray(F_value, dtype=float))
        out = np.full(f.shape, np.nan)
        neg = f < 0.0
        out[neg] = f[neg] / self.surface_density
        ok = (f >= 0.0) & (f <= self.cumulative[-1])
        if np.any(ok):
            # First crossing: searchsorted on the non-decreasing cumulative.
            idx = np.searchsorted(self.cumulative, f[ok], side='left')
            idx = np.clip(idx, 1, self.cumulative.size - 1)
            f0 = self.cumulative[idx - 1]
            f1 = self.cumulative[idx]
            z0 = self.z_grid[idx - 1]
            z1 = self.z_grid[idx]
            span = f1 - f0
            frac = np.where(span > 0.0, (f[ok] - f0) / np.where(span > 0, span, 1.0), 0.0)
            out[ok] = z0 + frac * (z1 - z0)
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
        return cls(z, F, zero, rho, zero.copy())


def _fit_spline(
    data: LayerRemovalData, pin_area_m2: float, knots: FloatArray
) -> tuple[FloatArray, FloatArray, float, int]:
    """NNLS fit; returns (coef over [hats..., deep], weighted residuals, RSS_w, n_active)."""
    z = data.depth_m
    Z = float(z[-1])
    Phi = _hat_antiderivative(z, knots)
    PhiZ = _hat_antiderivative(np.array([Z]), knots)[0]
    X = np.hstack([pin_area_m2 * (PhiZ[None, :] - Phi), np.ones((z.size, 1))])
    sig = data.remaining_se_bq if data.remaining_se_bq is not None else np.ones_like(z)
    # Scale the columns for conditioning; NNLS is invariant to positive column scaling.
    Xw = X / sig[:, None]
    scale = np.linalg.norm(Xw, axis=0)
    scale[scale == 0.0] = 1.0
    coef_s, _ = nnls(Xw / scale, data.remaining_bq / sig, maxiter=50 * X.shape[1])
    coef = coef_s / scale
    resid = (data.remaining_bq - X @ coef) / sig
    return coef, resid, float(resid @ resid), int(np.count_nonzero(coef > 0.0))


def fit_depth_profile(
    data: LayerRemovalData,
    pin_area_m2: float,
    knot_spacing_m: float | None = None,
    candidates: Sequence[float] = (1.0, 2.0, 3.0, 4.0, 6.0),
) -> DepthProfile:
    """Fit rho_I(z) >= 0 to layer-removal data of a pin of area ``pin_area_m2`` [m^2].

    ``knot_spacing_m`` fixes the spline knot spacing [m]; by default it is chosen
    by AIC among ``candidates`` x the median layer step.
    Raises :class:`ProfileNotDecreasingError` when the remaining activity rises
    with depth beyond its noise, or does not fall at all.
    """
    if not (math.isfinite(pin_area_m2) and pin_area_m2 > 0.0):
        raise DepthProfileError(f'pin area must be > 0 m^2, got {pin_area_m2!r}')
    z = data.depth_m
    Z = float(z[-1])
    step = float(np.median(np.diff(z)))
    n = z.size
    estimated_noise = data.remaining_se_bq is None
    if estimated_noise:
        data = _with_noise_model(data, pin_area_m2, step)
    spacings = [knot_spacing_m] if knot_spacing_m is not None else [c * step for c in candidates]
    best: tuple[float, FloatArray, FloatArray, float, FloatArray] | None = None
    for sp in spacings:
        if not (math.isfinite(sp) and sp > 0.0):
            raise DepthProfileError(f'knot spacing must be > 0, got {sp!r}')
        nk = max(2, round(Z / sp) + 1)
        if nk + 1 > n:
            continue
        knots = np.linspace(0.0, Z, nk)
        coef, resid, rss, p = _fit_spline(data, pin_area_m2, knots)
        if estimated_noise:
            aic = n * math.log(max(rss, 1e-300) / n) + 2.0 * p
        else:
            aic = rss + 2.0 * p
        if best is None or aic < best[0]:
            best = (aic, knots, coef, rss, resid)
    if best is None:
        raise DepthProfileError(
            f'{data.source}: knot spacing too fine for {n} layers (need fewer knots than layers)'
        )
    _, knots, coef, rss, resid = best
    K = knots.size
    assert data.remaining_se_bq is not None
    sig = data.remaining_se_bq
    active = np.flatnonzero(coef > 0.0)
    p = active.size
    # With an estimated noise model only the shape is known: scale it by the residuals.
    s2 = rss / max(n - p, 1) if estimated_noise else 1.0
    noise = sig * math.sqrt(s2)
    # Covariance of the active coefficients (weighted LSQ restricted to the active set).
    Phi = _hat_antiderivative(z, knots)
    PhiZ = _hat_antiderivative(np.array([Z]), knots)[0]
    X = np.hstack([pin_area_m2 * (PhiZ[None, :] - Phi), np.ones((n, 1))])
    Xa = X[:, active] / sig[:, None]
    col = np.linalg.norm(Xa, axis=0)
    col[col == 0.0] = 1.0
    Xs = Xa / col  # unit columns: the normal matrix is well scaled for pinv
    cov_a = s2 * np.linalg.pinv(Xs.T @ Xs) / np.outer(col, col)

    zg = np.linspace(0.0, Z, GRID_POINTS)
    G = np.hstack([_hat_antiderivative(zg, knots), np.zeros((zg.size, 1))])
    H = np.hstack([_hat_values(zg, knots), np.zeros((zg.size, 1))])
    F = G @ coef
    rho = H @ coef
    Ga = G[:, active]
    Ha = H[:, active]
    F_var = np.einsum('ij,jk,ik->i', Ga, cov_a, Ga)
    rho_var = np.einsum('ij,jk,ik->i', Ha, cov_a, Ha)
    raw_resid = data.remaining_bq - X @ coef
    _check_decreasing(data, noise)
    if F[-1] <= 0.0:
        raise ProfileNotDecreasingError(f'{data.source}: remaining activity does not decrease')
    del K
    rms = float(math.sqrt(np.mean(raw_resid**2)))
    return DepthProfile(
        zg,
        np.maximum.accumulate(F),
        np.sqrt(np.clip(F_var, 0.0, None)),
        rho,
        np.sqrt(np.clip(rho_var, 0.0, None)),
        residual_rms_bq=rms,
        knot_spacing_m=float(knots[1] - knots[0]),
    )


def _with_noise_model(data: LayerRemovalData, pin_area_m2: float, step: float) -> LayerRemovalData:
    """Attach an estimated noise model sigma_i^2 = s0 + s1*A_i + s2*A_i^2 (all >= 0).

    Used when the CSV has no ``remaining_activity_se_bq`` column: a first unweighted
    fit gives residuals, whose squares are regressed (non-negatively) on the activity
    (constant, counting-like and proportional terms).
    Only the shape matters; the overall scale is re-estimated from the final fit.
    """
    z = data.depth_m
    Z = float(z[-1])
    nk = max(2, min(z.size - 2, round(Z / (2.0 * step)) + 1))
    knots = np.linspace(0.0, Z, nk)
    unit = LayerRemovalData(z, data.remaining_bq, np.ones_like(z), source=data.source)
    _, resid, _, _ = _fit_spline(unit, pin_area_m2, knots)
    a = np.clip(data.remaining_bq, 0.0, None)
    M = np.column_stack([np.ones_like(a), a, a * a])
    cscale = np.linalg.norm(M, axis=0)
    cscale[cscale == 0.0] = 1.0
    ab, _ = nnls(M / cscale, resid**2)
    ab = ab / cscale
    var = M @ ab
    floor = max(float(np.mean(resid**2)) * 1e-3, 1e-300)
    sig = np.sqrt(np.maximum(var, floor))
    return LayerRemovalData(z, data.remaining_bq, sig, source=data.source)


def _check_decreasing(data: LayerRemovalData, noise: FloatArray) -> None:
    """Raise if the raw remaining activity rises by more than 5 sigma or never falls."""
    a = data.remaining_bq
    src = data.source
    drop = a[0] - a[-1]
    total_noise = math.hypot(float(noise[0]), float(noise[-1]))
    if drop <= 5.0 * total_noise:
        raise ProfileNotDecreasingError(
            f'{src}: remaining activity does not decrease with depth '
            f'({a[0]:g} Bq at surface, {a[-1]:g} Bq at {data.depth_m[-1] * 1e6:g} um)'
        )
    d = np.diff(a)
    pair_noise = np.hypot(noise[1:], noise[:-1])
    bad = np.flatnonzero(d > 5.0 * pair_noise)
    if bad.size:
        i = int(bad[0]) + 1
        raise ProfileNotDecreasingError(
            f'{src}: remaining activity rises with depth at {data.depth_m[i] * 1e6:g} um '
            f'(+{d[i - 1]:g} Bq, noise {pair_noise[i - 1]:.3g} Bq): not a layer-removal profile'
        )
