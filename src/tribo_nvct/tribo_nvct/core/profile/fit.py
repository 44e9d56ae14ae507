"""Weighted least-squares fits of the depth-profile models (variable projection, NNLS).

One :class:`_Fit` per candidate model with its AICc (:attr:`_Fit.aic`); :class:`_Problem`
holds the layer-removal data prepared for repeated fits (also of bootstrap replicas)
and evaluates a fit on the fine grid, with delta-method standard errors.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import OptimizeWarning, least_squares, nnls

from tribo_nvct.errors import DepthProfileError

from .result import GRID_POINTS
from .shapes import _R, _S, PARAMETRIC, _basis, _bounds, _starts

FloatArray = NDArray[np.float64]

#: Depth above which the piecewise model's bins may span several layers [m].
SURFACE_FINE_M = 0.5e-6
#: Non-parametric densities: constant per bin, or continuous piecewise-linear.
PIECEWISE_KINDS = ('piecewise', 'linear')
#: Bin widths of the piecewise model below SURFACE_FINE_M [layer steps].
PIECEWISE_BINS = (1, 2, 4)


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
