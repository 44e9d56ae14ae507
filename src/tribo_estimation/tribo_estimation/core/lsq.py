"""The one bounded Levenberg-Marquardt solver of the package.

Used by the block fit (:mod:`.blockfit`), the free-decay identification
(:mod:`.decay`) and the discrepancy fit (:mod:`.discrepancy.fitting`).
It minimises ``sum(fun(x)**2)`` within box bounds ``lo <= x <= hi``:

- forward-difference sensitivities (or a given Jacobian function), steps
  projected onto the bounds;
- optional Jacobian reuse ("chord" steps): when the linear model predicted the
  accepted step well, the next step keeps the old sensitivities (one function
  evaluation instead of ``1 + len(x)``);
- hard limits on iterations and function evaluations, and a non-finite guard:
  a step whose residuals are not all finite is rejected like a worse one, a
  non-finite start raises :class:`~tribo_estimation.errors.FitError`. No input
  makes it spin: every loop is bounded by ``max_iter`` x 8 damping trials.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from numba import njit

from ..errors import FitError

FloatArray = npt.NDArray[np.float64]

#: Damping increases tried per iteration before the iteration gives up [-].
_MAX_TRIALS = 8


@dataclass(frozen=True)
class LsqResult:
    """Outcome of :func:`levenberg_marquardt`.

    ``x`` the estimate; ``fun`` the residuals at ``x``; ``cost`` their sum of
    squares; ``jac`` the last Jacobian (d fun / d x; at ``x`` unless
    ``jac_current`` is False); ``nfev`` function evaluations; ``n_iter``
    iterations; ``converged`` True when a stopping test (not a limit) ended it.
    """

    x: FloatArray
    fun: FloatArray
    cost: float
    jac: FloatArray
    nfev: int
    n_iter: int
    converged: bool
    jac_current: bool


@njit(cache=True)
def normal_equations(J: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``J^T J`` and ``J^T r`` of a tall Jacobian (m x p) with compiled loops.

    On a busy shared machine multi-threaded BLAS on tall, thin products spins
    far longer than it computes.

    Parameters
    ----------
    J : numpy.ndarray
        Jacobian, m x p.
    r : numpy.ndarray
        Residuals, m.

    Returns
    -------
    tuple of numpy.ndarray
        ``J^T J`` (p x p) and ``J^T r`` (p).
    """
    m, p = J.shape
    A = np.zeros((p, p))
    g = np.zeros(p)
    for i in range(p):
        acc = 0.0
        for k in range(m):
            acc += J[k, i] * r[k]
        g[i] = acc
        for j in range(i, p):
            acc = 0.0
            for k in range(m):
                acc += J[k, i] * J[k, j]
            A[i, j] = acc
            A[j, i] = acc
    return A, g


def cluster_robust_se(J: FloatArray, r: FloatArray, clusters: npt.NDArray[np.int64]) -> FloatArray:
    """Cluster-robust (sandwich) standard errors of a least-squares estimate.

    Residuals within one cluster are correlated (a shooting segment of the block
    fit, a stick phase of the speed-sensor regression), between clusters nearly
    independent: ``cov = B^-1 (sum_s g_s g_s^T) B^-1 * G/(G - 1)``, ``B = J^T J``,
    ``g_s = J_s^T r_s``. With fewer than 3 clusters the classical
    ``s^2 (J^T J)^-1`` with a lag-1 autocorrelation inflation is used.
    A parameter without any influence (zero Jacobian column, e.g. mu0 in
    steady sliding) gets NaN and is left out for the others.

    Parameters
    ----------
    J : FloatArray
        Jacobian (or design matrix) at the estimate, shape (m, n).
    r : FloatArray
        Residuals at the estimate, shape (m,).
    clusters : numpy.ndarray of int
        Cluster index 0..G-1 of every residual, shape (m,).

    Returns
    -------
    FloatArray
        Standard errors, shape (n,), in the parameters' units.
    """
    n_par = J.shape[1]
    norms = np.sqrt(np.sum(J * J, axis=0))
    live = norms > 1e-9 * max(float(norms.max()) if norms.size else 0.0, 1e-300)
    if not live.all():
        out = np.full(n_par, math.nan)
        if live.any():
            out[live] = cluster_robust_se(J[:, live], r, clusters)
        return out
    B = J.T @ J
    try:
        Binv = np.linalg.inv(B)
    except np.linalg.LinAlgError:
        return np.full(n_par, math.nan)
    G = int(clusters.max()) + 1 if clusters.size else 0
    if G >= 3:
        scores = np.zeros((G, n_par))
        np.add.at(scores, clusters, J * r[:, None])
        meat = scores.T @ scores
        cov = Binv @ meat @ Binv * (G / (G - 1))
    else:
        dof = max(1, r.shape[0] - n_par)
        s2 = float(np.dot(r, r)) / dof
        rr = r - r.mean()
        den = float(np.dot(rr, rr))
        rho = float(np.dot(rr[1:], rr[:-1]) / den) if den > 0.0 else 0.0
        rho = min(max(rho, 0.0), 0.99)
        cov = Binv * s2 * (1.0 + rho) / (1.0 - rho)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def _finite_sq(r: FloatArray) -> float:
    """Sum of squares, +inf when any residual is not finite (the non-finite guard)."""
    if not np.all(np.isfinite(r)):
        return math.inf
    sq = float(np.dot(r, r))
    return sq if math.isfinite(sq) else math.inf


def forward_jacobian(
    fun: Callable[[FloatArray], FloatArray],
    x: FloatArray,
    r0: FloatArray,
    hi: FloatArray,
    steps: FloatArray,
) -> FloatArray:
    """Return the forward-difference Jacobian of ``fun`` at ``x``.

    A step that would leave the upper bound is taken backwards; non-finite
    columns are 0.

    Parameters
    ----------
    fun : callable
        Residual vector of the parameters.
    x : FloatArray
        The parameters.
    r0 : FloatArray
        ``fun(x)``.
    hi : FloatArray
        Upper bounds.
    steps : FloatArray
        Step per parameter.

    Returns
    -------
    FloatArray
        d fun / d x, ``r0.size`` x ``x.size``.
    """
    J = np.empty((r0.shape[0], x.shape[0]))
    for j in range(x.shape[0]):
        h = float(steps[j])
        if x[j] + h > hi[j]:
            h = -h
        xs = x.copy()
        xs[j] += h
        col = (fun(xs) - r0) / h
        J[:, j] = np.where(np.isfinite(col), col, 0.0)
    return J


def levenberg_marquardt(
    fun: Callable[[FloatArray], FloatArray],
    x0: npt.ArrayLike,
    lo: npt.ArrayLike,
    hi: npt.ArrayLike,
    *,
    max_iter: int = 50,
    max_nfev: int = 1000,
    rel_step: float = 1e-4,
    abs_step: npt.ArrayLike | None = None,
    ftol: float = 1e-8,
    xtol: Callable[[FloatArray, FloatArray, FloatArray], FloatArray] | None = None,
    reuse_jacobian: bool = False,
    jac: Callable[[FloatArray, FloatArray], FloatArray] | None = None,
    lam0: float = 1e-3,
) -> LsqResult:
    """Minimise ``sum(fun(x)**2)`` within bounds by Levenberg-Marquardt (module doc).

    Parameters
    ----------
    fun : callable
        Residual vector of the parameters.
    x0, lo, hi : array_like
        Start and bounds (``x0`` is clipped into them).
    max_iter : int
        Iterations at most (each: one Jacobian or chord step).
    max_nfev : int
        Function evaluations at most (Jacobian columns included).
    rel_step, abs_step : float, array_like
        Forward-difference step ``max(rel_step*|x|, abs_step)`` (``abs_step``
        default ``rel_step``).
    ftol : float
        Stop when the relative decrease of the cost falls below it.
    xtol : callable, optional
        ``xtol(x, J, r)`` -> per-parameter step size below which the iteration
        has converged (default ``1e-10*(1 + |x|)``).
    reuse_jacobian : bool
        Keep the Jacobian after a well predicted step.
    jac : callable, optional
        ``jac(x, r)`` analytic Jacobian instead of forward differences.
    lam0 : float
        Start damping [-].

    Returns
    -------
    LsqResult
        The estimate, residuals, cost, Jacobian and counts.

    Raises
    ------
    FitError
        The start values or the residuals at the start are not finite.
    """
    lo_a = np.asarray(lo, dtype=np.float64)
    hi_a = np.asarray(hi, dtype=np.float64)
    x = np.clip(np.asarray(x0, dtype=np.float64).copy(), lo_a, hi_a)
    if not np.all(np.isfinite(x)):
        raise FitError('start values of the least-squares fit are not finite')
    hmin = (
        np.full(x.shape, rel_step)
        if abs_step is None
        else np.broadcast_to(np.asarray(abs_step, dtype=np.float64), x.shape)
    )
    nfev = 0

    def call(xx: FloatArray) -> FloatArray:
        nonlocal nfev
        nfev += 1
        return np.asarray(fun(xx), dtype=np.float64)

    def jacobian(xx: FloatArray, rr: FloatArray) -> FloatArray:
        if jac is not None:
            return np.asarray(jac(xx, rr), dtype=np.float64)
        return forward_jacobian(call, xx, rr, hi_a, np.maximum(rel_step * np.abs(xx), hmin))

    r = call(x)
    cost = _finite_sq(r)
    if not math.isfinite(cost):
        raise FitError('residuals at the start values are not finite')
    J = jacobian(x, r)
    jac_current = True
    lam = lam0
    converged = False
    it = 0
    n_par = x.shape[0]
    while it < max_iter and nfev < max_nfev:
        it += 1
        A, g = normal_equations(np.ascontiguousarray(J), r)
        dA = np.diag(A).copy()
        dA[~(dA > 0.0)] = 1.0
        accepted = False
        good_model = False
        step = np.zeros(n_par)
        for _ in range(_MAX_TRIALS):
            if nfev >= max_nfev:
                break
            try:
                d = np.linalg.solve(A + lam * np.diag(dA), -g)
            except np.linalg.LinAlgError:
                lam *= 10.0
                continue
            if not np.all(np.isfinite(d)):
                lam *= 10.0
                continue
            xn = np.clip(x + d, lo_a, hi_a)
            step = xn - x
            if not np.any(step):
                break
            rn = call(xn)
            cn = _finite_sq(rn)
            if cn <= cost:
                pred = cost - float(np.sum((r + J @ step) ** 2))
                good_model = pred > 0.0 and (cost - cn) >= 0.5 * pred
                rel = (cost - cn) / max(cost, 1e-300)
                x, r, cost = xn, rn, cn
                lam = max(lam / 10.0, 1e-12)
                accepted = True
                if rel < ftol:
                    converged = True
                break
            lam *= 10.0
        tol = xtol(x, J, r) if xtol is not None else 1e-10 * (1.0 + np.abs(x))
        if not accepted or converged or np.all(np.abs(step) <= tol):
            converged = converged or not accepted or bool(np.all(np.abs(step) <= tol))
            jac_current = jac_current and not accepted
            break
        if reuse_jacobian and good_model:
            jac_current = False  # chord step: J stays from an earlier point
            continue
        if nfev + (0 if jac is not None else n_par) > max_nfev:
            jac_current = False
            break
        J = jacobian(x, r)
        jac_current = True
    return LsqResult(x, r, cost, J, nfev, it, converged, jac_current)


def parabola_vertex_log(points: Sequence[tuple[float, float]]) -> float | None:
    """Return the vertex of the parabola through the best point and its neighbours.

    One step of a 1-D search of a positive argument on its logarithm: the points
    ``(value, cost)`` (one per value, the lowest cost kept; non-positive values and
    non-finite costs left out) are sorted, and the parabola through the least-cost
    point and its two neighbours gives its vertex, clipped to the neighbours.

    Parameters
    ----------
    points : sequence of (float, float)
        Argument values (> 0) and their costs.

    Returns
    -------
    float or None
        The vertex's log argument; None if there are fewer than three points, the best
        is an end point or the parabola is not convex.

    Examples
    --------
    >>> import math
    >>> pts = [(v, (math.log(v) - math.log(2.0)) ** 2) for v in (1.0, 1.5, 4.0)]
    >>> round(math.exp(parabola_vertex_log(pts)), 6)
    2.0
    """
    best: dict[float, float] = {}
    for v, c in points:
        if v > 0 and math.isfinite(c):
            x = round(math.log(v), 9)
            best[x] = min(c, best.get(x, math.inf))
    pts = sorted(best.items())
    if len(pts) < 3:
        return None
    k = min(range(len(pts)), key=lambda i: pts[i][1])
    if k == 0 or k == len(pts) - 1:
        return None
    (x0, c0), (x1, c1), (x2, c2) = pts[k - 1 : k + 2]
    d01 = (c1 - c0) / (x1 - x0)
    d12 = (c2 - c1) / (x2 - x1)
    curv = (d12 - d01) / (x2 - x0)
    if not curv > 0.0:
        return None
    return min(max(0.5 * (x0 + x1) - d01 / (2.0 * curv), x0), x2)


__all__ = [
    'LsqResult',
    'forward_jacobian',
    'levenberg_marquardt',
    'normal_equations',
    'parabola_vertex_log',
]
