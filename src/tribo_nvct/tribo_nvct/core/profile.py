"""Depth profile of the activation: rho_I(z) and its cumulative integral (paper 3.2).

Reference pins of the same alloy are irradiated with the specimens; thin layers
(about 0.1 um) are removed one after the other and the activity remaining in
the pin is measured after every step. With the pin's activated face area
``A_pin`` [m^2] the concentration profile is (physics notes, section 2)

    rho_I(z) = -(1/A_pin) dA_rem/dz                       [Bq/m^3]
    F(h)     = integral_0^h rho_I dz = (A_rem(0) - A_rem(h))/A_pin   [Bq/m^2]

and the activity released by a wear height h of a tagged area A_I is
``A_oil = A_I * F(h)`` (the general form of the paper's Equ. 8), inverted for h.

Estimate (no differentiation, no smoothing toward the interior)
---------------------------------------------------------------
The measured remaining activity is itself an integral of rho_I, so it is fitted
directly, by weighted least squares with weights 1/sigma_i^2, with models whose
density is non-negative (hence A_rem monotone non-increasing):

* ``erfc`` (flat, then an erfc fall-off; PTLA-like):
  rho_I = rho0 erfc((z - z0)/w)/2,
  A_rem(z) = A_pin rho0 (w/2) ierfc((z - z0)/w),  ierfc(x) = exp(-x^2)/sqrt(pi) - x erfc(x)
* ``exponential``: rho_I = rho0 exp(-z/L),  A_rem(z) = A_pin rho0 L exp(-z/L)
* ``ramp`` (linear): rho_I = rho0 (1 - z/D)_+,  A_rem(z) = A_pin rho0 (D - z)_+^2 / (2 D)
* each of the three also ``+c``: plus a constant remaining activity c (bulk
  activation below the layer, or an offset of the pin measurements);
* ``piecewise``: rho_I constant on bins of one layer step down to 0.5 um and of
  1, 2 or 4 steps below (the surface is never averaged with the interior), rho_j >= 0,
  or (``linear``) continuous piecewise-linear on the same knots with rho(knot) >= 0,
  A_rem(z_i) = A_pin sum_j rho_j |[z_i, Z] n bin_j| + c  (c: activity below the
  last measured depth Z), fitted by non-negative least squares (NNLS).

The amplitude (and c) enter linearly and are solved in closed form for every
trial of the shape parameters (variable projection). The model is chosen by
AIC = chi^2 + 2 k (k fitted parameters; for ``piecewise`` the active
coefficients), with the small-sample correction (AICc):
AICc = AIC + 2k(k+1)/(n-k-1), n layers, so the flexible piecewise model is
chosen only where no smooth shape fits. The surface density is the model's
own rho_I(0): nothing pulls it toward the interior. Without a
``remaining_activity_se_bq`` column the noise model
sigma_i^2 = s_0 + s_2 A_i^2 is estimated from the fourth differences of the
data (independent of any model) and rescaled by the chosen fit's chi^2/dof.
(The parametric shapes have no offset term: remaining activity measured to
the end of the activated layer, or an exponential tail below it, is assumed.)

Uncertainty
-----------
``cumulative_se``: delta method, sigma_F(z)^2 = g(z)^T C g(z) with g = dF/dp
and C = s^2 (J^T W J)^-1 the covariance of the chosen model's parameters
(s^2 = max(1, chi^2/dof)); used for the per-dwell systematic SE.

:meth:`DepthProfile.replicas`: parametric bootstrap over the layer-removal
noise (``B`` replicas, seeded): A*_i = A_fit(z_i) + s sigma_i eps_i, eps_i ~ N(0, 1);
every replica is refitted *including the model choice*, giving F*_b(z).
Computed once per profile on first use and cached (the streaming evaluator
calls it once per configuration, not per dwell). The evaluation inverts the
measured activities with every F*_b and takes the spread of the results
(paper 3.5 figures) as their profile standard error.
"""

from __future__ import annotations

import csv
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import OptimizeWarning, least_squares, nnls
from scipy.special import erfc

from tribo_nvct.errors import DepthProfileError, ProfileNotDecreasingError

FloatArray = NDArray[np.float64]

#: Fine evaluation grid of the fitted profile [points].
GRID_POINTS = 4001
#: Model names accepted by :func:`fit_depth_profile` (``auto``: chosen by AIC).
PROFILE_MODELS = ('auto', 'erfc', 'exponential', 'ramp', 'piecewise')
#: Default number of bootstrap replicas and seed of the profile uncertainty.
BOOTSTRAP_REPLICAS = 200
BOOTSTRAP_SEED = 20240611
#: Candidates further than this behind the best AICc are not refitted in replicas [-].
REPLICA_AIC_MARGIN = 100.0
#: Non-parametric densities: constant per bin, or continuous piecewise-linear.
PIECEWISE_KINDS = ('piecewise', 'linear')
#: Depth above which the piecewise model's bins may span several layers [m].
SURFACE_FINE_M = 0.5e-6
#: Bin widths of the piecewise model below SURFACE_FINE_M [layer steps].
PIECEWISE_BINS = (1, 2, 4)


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


@dataclass(frozen=True, eq=False)
class DepthProfile:
    """Fitted activation depth profile on a fine grid (SI units).

    z_grid: depth [m] from 0 to ``max_depth``.
    cumulative: F(z) = integral_0^z rho_I [Bq/m^2] (non-decreasing).
    cumulative_se: standard error of F [Bq/m^2] (delta method of the chosen model).
    density: rho_I(z) [Bq/m^3] (>= 0), density_se its standard error.
    residual_rms_bq: RMS residual of the layer-removal fit [Bq] (NaN for analytic profiles).
    model: chosen model (``erfc``, ``exponential``, ``ramp``, ``piecewise/<k>``, ``analytic``).
    aic: (model, AIC) of every candidate fitted; chi2_red: chi^2/dof of the chosen fit.
    """

    z_grid: FloatArray
    cumulative: FloatArray
    cumulative_se: FloatArray
    density: FloatArray
    density_se: FloatArray
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
        return cls(z, F, zero, rho, zero.copy())


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


# --- parametric shapes (depth in um inside; R = integral_z^inf shape) ---------------------


def _ierfc(x: FloatArray) -> FloatArray:
    """ierfc(x) = integral_x^inf erfc(s) ds = exp(-x^2)/sqrt(pi) - x erfc(x), stable for x > 0."""
    from scipy.special import erfcx

    xp = np.clip(x, 0.0, None)
    pos = np.exp(-xp * xp) * (1.0 / math.sqrt(math.pi) - xp * erfcx(xp))
    xn = np.clip(x, None, 0.0)
    neg = np.exp(-xn * xn) / math.sqrt(math.pi) - xn * erfc(xn)
    return np.asarray(np.where(x > 0.0, pos, neg))


def _R(name: str, zu: FloatArray, th: FloatArray) -> FloatArray:
    """Remaining activity per unit amplitude of a parametric shape [um]."""
    name = name.removesuffix('+c')
    if name == 'erfc':
        z0, w = th
        return 0.5 * w * _ierfc((zu - z0) / w)
    if name == 'exponential':
        (L,) = th
        return np.asarray(L * np.exp(-zu / L))
    (D,) = th
    d = np.clip(D - zu, 0.0, None)
    return np.asarray(d * d / (2.0 * D))


def _S(name: str, zu: FloatArray, th: FloatArray) -> FloatArray:
    """Density shape (value 1 at the top of the flat part) [-]."""
    name = name.removesuffix('+c')
    if name == 'erfc':
        z0, w = th
        return np.asarray(0.5 * erfc((zu - z0) / w))
    if name == 'exponential':
        (L,) = th
        return np.asarray(np.exp(-zu / L))
    (D,) = th
    return np.asarray(np.clip(1.0 - zu / D, 0.0, None))


def _bounds(name: str, Z: float, step: float) -> tuple[list[float], list[float]]:
    name = name.removesuffix('+c')
    if name == 'erfc':
        return [-2.0 * Z, max(0.05 * step, 1e-4)], [4.0 * Z, 4.0 * Z]
    if name == 'exponential':
        return [0.05 * step], [100.0 * Z]
    return [step], [100.0 * Z]


def _starts(name: str, Z: float) -> list[FloatArray]:
    name = name.removesuffix('+c')
    if name == 'erfc':
        return [np.array([a * Z, b * Z]) for a in (0.1, 0.3, 0.5, 0.8) for b in (0.05, 0.15, 0.4)]
    if name == 'exponential':
        return [np.array([a * Z]) for a in (0.1, 0.3, 1.0, 3.0)]
    return [np.array([a * Z]) for a in (0.5, 1.0, 1.5, 3.0)]


#: Parametric candidates; ``+c``: with a constant remaining activity c (bulk
#: activation below the layer, or a background offset of the pin measurements).
PARAMETRIC = ('erfc', 'exponential', 'ramp', 'erfc+c', 'exponential+c', 'ramp+c')


@dataclass(frozen=True, eq=False)
class _Fit:
    """One candidate fit: name, parameters, fitted remaining activity [Bq], chi^2, k."""

    name: str
    theta: FloatArray  # shape parameters [um] (parametric) or bin edges [m] (piecewise)
    coef: FloatArray  # amplitude [Bq/um] (parametric) or [rho_j..., c+, c-] (piecewise)
    fitted: FloatArray
    chi2: float
    k: int

    @property
    def aic(self) -> float:
        """AICc = chi^2 + 2k + 2k(k+1)/(n-k-1) (inf when n <= k+1)."""
        n, k = self.fitted.size, self.k
        if n - k - 1 <= 0:
            return math.inf
        return self.chi2 + 2.0 * k + 2.0 * k * (k + 1) / (n - k - 1)


def _basis(kind: str, z: FloatArray, edges: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(G, H): integral_0^z of the density basis [m] and its values [-] at depths z [m].

    ``piecewise``: indicator of each bin; ``linear``: hat functions on the edges
    (continuous piecewise-linear density).
    """
    if kind == 'piecewise':
        lo, hi = edges[:-1], edges[1:]
        G = np.clip(z[:, None], lo[None, :], hi[None, :]) - lo[None, :]
        j = np.clip(np.searchsorted(edges, z, side='right') - 1, 0, edges.size - 2)
        H = np.zeros((z.size, edges.size - 1))
        H[np.arange(z.size), j] = 1.0
        return G, H
    K = edges.size
    G = np.zeros((z.size, K))
    for k in range(K):
        c = edges[k]
        lo_k = edges[k - 1] if k > 0 else c
        hi_k = edges[k + 1] if k < K - 1 else c
        if c > lo_k:
            left = np.clip(z, lo_k, c) - lo_k
            G[:, k] += left * left / (2.0 * (c - lo_k))
        if hi_k > c:
            right = np.clip(z, c, hi_k) - c
            G[:, k] += right - right * right / (2.0 * (hi_k - c))
    eye = np.eye(K)
    H = np.column_stack([np.interp(z, edges, eye[k]) for k in range(K)])
    return G, H


class _Problem:
    """Layer-removal data prepared for repeated fits (weights, piecewise design matrices)."""

    def __init__(
        self,
        z: FloatArray,
        sigma: FloatArray,
        pin_area: float,
        models: Sequence[str],
        pieces: Sequence[str],
    ) -> None:
        self.z = z
        self.zu = z * 1e6
        self.Z = float(z[-1])
        self.Zu = self.Z * 1e6
        self.step_u = float(np.median(np.diff(self.zu)))
        self.sigma = sigma
        self.pin_area = pin_area
        self.models = [m for m in models if m in PARAMETRIC]
        self.zg = np.linspace(0.0, self.Z, GRID_POINTS)
        self.pieces: list[tuple[str, FloatArray, FloatArray, FloatArray]] = []
        n = z.size
        i0 = int(np.searchsorted(z, SURFACE_FINE_M))
        for name in pieces:
            kind, k = name.split('/')[0], int(name.split('/')[1])
            # One bin per layer near the surface (no averaging of the surface density
            # with the interior), k layers per bin below SURFACE_FINE_M.
            edges = np.concatenate([z[:i0], z[i0::k]])
            if edges[-1] < self.Z:
                edges = np.append(edges, self.Z)
            G, _ = _basis(kind, np.append(z, self.Z), edges)
            nb = G.shape[1]
            if nb < 2 or nb + 1 > n:
                continue
            M = pin_area * (G[-1][None, :] - G[:-1])
            X = np.hstack([M, np.ones((n, 1)), -np.ones((n, 1))]) / sigma[:, None]
            scale = np.linalg.norm(X, axis=0)
            scale[scale == 0.0] = 1.0
            self.pieces.append((name, edges, X, scale))

    # parametric --------------------------------------------------------------------------
    def _proj(self, name: str, th: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Residuals and linear coefficients [a] or [a, c] for shape parameters th."""
        col = _R(name, self.zu, th) / self.sigma
        if name.endswith('+c'):
            X = np.column_stack([col, 1.0 / self.sigma])
            sol = np.linalg.lstsq(X, y, rcond=None)[0]
            coef: FloatArray = np.asarray(sol, dtype=np.float64)
            return y - X @ coef, coef
        cc = float(col @ col)
        a = float(col @ y) / cc if cc > 0.0 else 0.0
        return y - a * col, np.array([a])

    def fit_parametric(self, name: str, A: FloatArray, start: FloatArray | None) -> _Fit | None:
        y = A / self.sigma
        lo, hi = _bounds(name, self.Zu, self.step_u)
        starts = [start] if start is not None else _starts(name, self.Zu)
        best = min(starts, key=lambda th: float(np.sum(self._proj(name, th, y)[0] ** 2)))
        x0 = np.clip(best, np.array(lo) * (1 + 1e-9) + 1e-12, np.array(hi) * (1 - 1e-9))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter('ignore', OptimizeWarning)
                res = least_squares(
                    lambda th: self._proj(name, th, y)[0],
                    x0,
                    bounds=(lo, hi),
                    x_scale='jac',
                    xtol=1e-10,
                    ftol=1e-10,
                    max_nfev=200,
                )
        except ValueError:
            return None
        r, coef = self._proj(name, res.x, y)
        if not coef[0] > 0.0:
            return None
        fitted = coef[0] * _R(name, self.zu, res.x) + (coef[1] if coef.size > 1 else 0.0)
        return _Fit(name, res.x, coef, fitted, float(r @ r), res.x.size + coef.size)

    # piecewise ---------------------------------------------------------------------------
    def fit_piecewise(self, i: int, A: FloatArray) -> _Fit:
        name, edges, X, scale = self.pieces[i]
        y = A / self.sigma
        cs, _ = nnls(X / scale, y, maxiter=50 * X.shape[1])
        coef = cs / scale
        fitted = (X @ coef) * self.sigma
        r = y - X @ coef
        k = int(np.count_nonzero(coef[:-2] > 0.0)) + int(np.any(coef[-2:] > 0.0))
        return _Fit(name, edges, coef, fitted, float(r @ r), k)

    def fit_all(self, A: FloatArray, starts: dict[str, FloatArray] | None = None) -> list[_Fit]:
        fits: list[_Fit] = []
        for m in self.models:
            f = self.fit_parametric(m, A, None if starts is None else starts.get(m))
            if f is not None:
                fits.append(f)
        for i in range(len(self.pieces)):
            fits.append(self.fit_piecewise(i, A))
        if not fits:
            raise DepthProfileError('no depth-profile model could be fitted')
        return fits

    # grids -------------------------------------------------------------------------------
    def grid_F(self, f: _Fit, zg: FloatArray | None = None) -> FloatArray:
        """F(z) on the grid [Bq/m^2]."""
        zg = self.zg if zg is None else zg
        if f.name in PARAMETRIC:
            zero = np.zeros(1)
            R0 = float(_R(f.name, zero, f.theta)[0])
            return np.asarray(f.coef[0] * (R0 - _R(f.name, zg * 1e6, f.theta)) / self.pin_area)
        G, _ = _basis(f.name.split('/')[0], zg, f.theta)
        return np.asarray(G @ f.coef[:-2])

    def grid_rho(self, f: _Fit) -> FloatArray:
        """rho_I(z) on the grid [Bq/m^3]."""
        if f.name in PARAMETRIC:
            return np.asarray(f.coef[0] * 1e6 * _S(f.name, self.zg * 1e6, f.theta) / self.pin_area)
        _, H = _basis(f.name.split('/')[0], self.zg, f.theta)
        return np.asarray(H @ f.coef[:-2])

    def grid_se(self, f: _Fit, s2: float) -> tuple[FloatArray, FloatArray]:
        """Delta-method standard errors of F and rho on the grid."""
        if f.name in PARAMETRIC:
            p = np.concatenate([f.theta, f.coef])
            nt = f.theta.size

            def model(pp: FloatArray) -> FloatArray:
                off = pp[nt + 1] if pp.size > nt + 1 else 0.0
                return np.asarray((pp[nt] * _R(f.name, self.zu, pp[:nt]) + off) / self.sigma)

            def gridF(pp: FloatArray) -> FloatArray:
                g = _Fit(f.name, pp[:nt], pp[nt:], f.fitted, f.chi2, f.k)
                return np.concatenate([self.grid_F(g), self.grid_rho(g)])

            J = np.empty((self.z.size, p.size))
            Gd = np.empty((2 * self.zg.size, p.size))
            for j in range(p.size):
                # Shape parameters [um]; the linear ones (a, c) are exact with any step.
                hstep = 1e-6 * max(abs(p[j]), 1e-3 * self.Zu if j < nt else 1.0)
                pp, pm = p.copy(), p.copy()
                pp[j] += hstep
                pm[j] -= hstep
                J[:, j] = (model(pp) - model(pm)) / (2 * hstep)
                Gd[:, j] = (gridF(pp) - gridF(pm)) / (2 * hstep)
            col = np.linalg.norm(J, axis=0)
            col[col == 0.0] = 1.0
            Js = J / col
            cov = s2 * np.linalg.pinv(Js.T @ Js) / np.outer(col, col)
            var = np.einsum('ij,jk,ik->i', Gd, cov, Gd)
            sd = np.sqrt(np.clip(var, 0.0, None))
            return sd[: self.zg.size], sd[self.zg.size :]
        i = [p[0] for p in self.pieces].index(f.name)
        _, edges, X, _ = self.pieces[i]
        active = np.flatnonzero(f.coef > 0.0)
        Xa = X[:, active]
        col = np.linalg.norm(Xa, axis=0)
        col[col == 0.0] = 1.0
        cov_a = s2 * np.linalg.pinv((Xa / col).T @ (Xa / col)) / np.outer(col, col)
        G0, H0 = _basis(f.name.split('/')[0], self.zg, edges)
        G = np.hstack([G0, np.zeros((self.zg.size, 2))])
        H = np.hstack([H0, np.zeros((self.zg.size, 2))])
        Ga, Ha = G[:, active], H[:, active]
        F_var = np.einsum('ij,jk,ik->i', Ga, cov_a, Ga)
        r_var = np.einsum('ij,jk,ik->i', Ha, cov_a, Ha)
        return np.sqrt(np.clip(F_var, 0.0, None)), np.sqrt(np.clip(r_var, 0.0, None))


def _estimate_noise(A: FloatArray) -> FloatArray:
    """sigma_i [Bq] from fourth differences: Var(d4) = 70 sigma^2, sigma^2 = s0 + s2 A^2."""
    if A.size < 8:
        return np.full(A.size, max(float(np.std(np.diff(A))), 1e-12))
    d4 = np.diff(A, 4)
    v = d4 * d4 / 70.0
    Ac = A[2:-2]
    M = np.column_stack([np.ones_like(Ac), Ac * Ac])
    cs = np.linalg.norm(M, axis=0)
    cs[cs == 0.0] = 1.0
    ab, _ = nnls(M / cs, v)
    ab = ab / cs
    var = ab[0] + ab[1] * A * A
    floor = max(float(np.mean(v)) * 1e-3, 1e-24 * float(np.max(np.abs(A))) ** 2, 1e-300)
    return np.asarray(np.sqrt(np.maximum(var, floor)))


def fit_depth_profile(
    data: LayerRemovalData,
    pin_area_m2: float,
    knot_spacing_m: float | None = None,
    model: str = 'auto',
    bootstrap_replicas: int = BOOTSTRAP_REPLICAS,
    seed: int = BOOTSTRAP_SEED,
) -> DepthProfile:
    """Fit rho_I(z) >= 0 to layer-removal data of a pin of area ``pin_area_m2`` [m^2].

    model: ``auto`` (AIC among all), or one of ``erfc``, ``exponential``, ``ramp``,
    ``piecewise``. knot_spacing_m: fixes the piecewise model's bin width [m] (rounded
    to whole layer steps; implies ``piecewise``). bootstrap_replicas, seed: parametric
    bootstrap of :meth:`DepthProfile.replicas` (0: none).
    Raises :class:`ProfileNotDecreasingError` when the remaining activity rises
    with depth beyond its noise, or does not fall at all.
    """
    if not (math.isfinite(pin_area_m2) and pin_area_m2 > 0.0):
        raise DepthProfileError(f'pin area must be > 0 m^2, got {pin_area_m2!r}')
    if model not in PROFILE_MODELS:
        raise DepthProfileError(f'profile model must be one of {PROFILE_MODELS}, got {model!r}')
    if bootstrap_replicas < 0:
        raise DepthProfileError(f'bootstrap replicas must be >= 0, got {bootstrap_replicas!r}')
    z = data.depth_m
    n = z.size
    step = float(np.median(np.diff(z)))
    bins: Sequence[int] = PIECEWISE_BINS
    kinds = PIECEWISE_KINDS
    models: Sequence[str] = PARAMETRIC
    if knot_spacing_m is not None:
        if not (math.isfinite(knot_spacing_m) and knot_spacing_m > 0.0):
            raise DepthProfileError(f'knot spacing must be > 0, got {knot_spacing_m!r}')
        bins = (max(1, round(knot_spacing_m / step)),)
        models = ()
    elif model == 'piecewise':
        models = ()
    elif model != 'auto':
        models, bins = (model, model + '+c'), ()
    estimated = data.remaining_se_bq is None
    A = data.remaining_bq
    sigma = _estimate_noise(A) if estimated else np.asarray(data.remaining_se_bq)
    pieces = [f'{kind}/{b}' for kind in kinds for b in bins]
    prob = _Problem(z, sigma, pin_area_m2, models, pieces)
    if not prob.models and not prob.pieces:
        raise DepthProfileError(f'{data.source}: bin width too coarse or too fine for {n} layers')
    fits = prob.fit_all(A)
    best = min(fits, key=lambda f: f.aic)
    dof = n - best.k
    chi2_red = best.chi2 / dof if dof > 0 else math.nan
    if estimated:
        s2 = chi2_red if dof >= 3 and chi2_red > 0.0 else 1.0
    else:
        s2 = max(1.0, chi2_red) if dof >= 5 else 1.0
    noise = sigma * math.sqrt(s2)
    # Given SEs are the measurement's own: an outlier must not widen its own test.
    _check_decreasing(data, noise if estimated else sigma)
    F = prob.grid_F(best)
    if F[-1] <= 0.0:
        raise ProfileNotDecreasingError(f'{data.source}: remaining activity does not decrease')
    rho = prob.grid_rho(best)
    F_se, rho_se = prob.grid_se(best, s2)
    starts = {f.name: f.theta for f in fits if f.name in PARAMETRIC}
    # Replicas refit only the candidates that could win: an AIC more than
    # REPLICA_AIC_MARGIN behind the best never wins against the data's noise.
    keep = {f.name for f in fits if f.aic < best.aic + REPLICA_AIC_MARGIN}
    rprob = _Problem(
        z,
        sigma,
        pin_area_m2,
        [m for m in prob.models if m in keep],
        [p for p in pieces if p in keep],
    )
    if not rprob.models and not rprob.pieces:
        rprob = prob

    def replicas() -> FloatArray:
        rng = np.random.default_rng(seed)
        out = np.empty((bootstrap_replicas, prob.zg.size))
        m = 0
        for _ in range(bootstrap_replicas):
            A_star = best.fitted + noise * rng.standard_normal(n)
            try:
                fb = min(rprob.fit_all(A_star, starts), key=lambda f: f.aic)
            except DepthProfileError:
                continue
            out[m] = np.maximum.accumulate(rprob.grid_F(fb))
            m += 1
        return out[:m]

    rms = float(math.sqrt(np.mean((A - best.fitted) ** 2)))
    return DepthProfile(
        prob.zg,
        np.maximum.accumulate(F),
        F_se,
        rho,
        rho_se,
        residual_rms_bq=rms,
        model=best.name,
        aic=tuple((f.name, f.aic) for f in fits),
        chi2_red=chi2_red,
        replica_source=replicas if bootstrap_replicas > 0 else None,
    )


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
