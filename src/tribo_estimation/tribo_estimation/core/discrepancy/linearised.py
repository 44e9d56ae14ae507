"""Linearised uncertainty of an output-error fit at its solution.

:func:`gauss_newton` gives the standard errors and correlations of the fitted values
from the Jacobian of the weighted residual vector (a :class:`ResidualModel`, e.g.
:class:`ProblemResiduals` of a :class:`.fitting.Problem`), with a block-robust
model-error term (:func:`_block_robust_sd`: leverage-corrected block scores, the
block jackknife of the linearised fit). The verdicts that use these numbers are in
:mod:`.identify`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
import numpy.typing as npt

from .candidates import ParamSpec
from .fitting import CHANNELS, Problem
from .stats import FloatArray


class ResidualModel(Protocol):
    """What :func:`gauss_newton` needs: the weighted residual vector of a value mapping."""

    @property
    def fs(self) -> float:
        """Sample rate [Hz]."""
        ...

    def residuals(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """Return the weighted residual vector (-) of ``values`` on the selected segments."""
        ...

    def residual_blocks(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.int64]:
        """Return the time block of every element of :meth:`residuals` (-1: none)."""
        ...


def sample_blocks(problem: Problem) -> npt.NDArray[np.int64]:
    """Return the time block of every sample of a record (-1: in no segment).

    Parameters
    ----------
    problem : Problem
        The record's fit problem (its segments carry the blocks).

    Returns
    -------
    numpy.ndarray of int64
        One block index per sample.
    """
    seg = problem.segments
    out = np.full(problem.record.time.size, -1, dtype=np.int64)
    for a, b, blk in zip(seg.start, seg.stop, seg.block, strict=True):
        out[int(a) : int(b)] = int(blk)
    return out


def problem_residual_blocks(
    problem: Problem, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
) -> npt.NDArray[np.int64]:
    """Return the time block of every element of the weighted residual vector.

    The layout of :meth:`.fitting.Problem.residual_vector`: the weighted channels one
    after the other, each over the samples the simulation covers.

    Parameters
    ----------
    problem : Problem
        The record's fit problem (weights set).
    values : Mapping[str, float]
        Model values (SI) of the simulation.
    seg_mask : numpy.ndarray of bool or None
        Segments simulated (None: all).

    Returns
    -------
    numpy.ndarray of int64
        One block index per residual element.
    """
    cov = problem.simulate(values, seg_mask).covered
    blocks = sample_blocks(problem)[cov]
    n_ch = sum(1 for c in CHANNELS if problem.weights.get(c, 0.0) > 0)
    return np.tile(blocks, n_ch)


class ProblemResiduals:
    """:class:`ResidualModel` of one record's :class:`.fitting.Problem`."""

    def __init__(self, problem: Problem) -> None:
        """Wrap ``problem``."""
        self.problem = problem

    @property
    def fs(self) -> float:
        """Sample rate of the record [Hz]."""
        return self.problem.record.fs

    def residuals(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """Return the weighted residual vector (-) (:meth:`.fitting.Problem.residual_vector`).

        Parameters
        ----------
        values : Mapping[str, float]
            Model values (SI).
        seg_mask : numpy.ndarray of bool or None
            Segments simulated (None: all).

        Returns
        -------
        FloatArray
            The weighted residuals.
        """
        return self.problem.residual_vector(self.problem.simulate(values, seg_mask))

    def residual_blocks(
        self, values: Mapping[str, float], seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.int64]:
        """Return the time block of every residual element (:func:`problem_residual_blocks`).

        Parameters
        ----------
        values : Mapping[str, float]
            Model values (SI).
        seg_mask : numpy.ndarray of bool or None
            Segments simulated (None: all).

        Returns
        -------
        numpy.ndarray of int64
            One block index per residual element.
        """
        return problem_residual_blocks(self.problem, values, seg_mask)


@dataclass(frozen=True)
class GaussNewton:
    """Linearised uncertainty of an output-error fit at its solution.

    ``names`` the fitted parameters; ``values`` and their standard errors
    ``se`` in the parameters' SI units; ``corr`` their correlation matrix (-),
    rows/columns in the order of ``names``; ``dead`` the parameters the
    simulated channels do not depend on at all (zero Jacobian column);
    ``model_error`` the parameters whose standard error is set by the scatter
    between time blocks (model error) rather than by the noise; ``profiled`` those
    whose standard error comes from the curvature of their cost profile
    (:meth:`with_profile_se`).
    """

    names: tuple[str, ...]
    values: tuple[float, ...]
    se: tuple[float, ...]
    corr: FloatArray
    dead: tuple[str, ...]
    model_error: tuple[str, ...] = ()
    profiled: tuple[str, ...] = ()

    def with_profile_se(self, profile_se: Mapping[str, float]) -> GaussNewton:
        """Return a copy whose standard errors are at least the profile's.

        Parameters
        ----------
        profile_se : Mapping[str, float]
            Standard error [SI] of a parameter from the curvature of its cost profile
            (:meth:`.select.scoring.Selector.fit_best`), by name.

        Returns
        -------
        GaussNewton
            The copy; ``profiled`` names the parameters whose profile error is larger.
        """
        se = list(self.se)
        raised = []
        for i, n in enumerate(self.names):
            p = profile_se.get(n)
            if p is not None and math.isfinite(p) and p > se[i]:
                se[i] = float(p)
                raised.append(n)
        return replace(self, se=tuple(se), profiled=(*self.profiled, *raised))


def gauss_newton(
    problem: ResidualModel | Problem,
    specs: Sequence[ParamSpec],
    values: Mapping[str, float],
    seg_mask: npt.NDArray[np.bool_] | None = None,
    *,
    corr_time: float = 1e-3,
    robust: bool = True,
) -> GaussNewton:
    """Gauss-Newton covariance of an output-error fit (:meth:`.fitting.Problem.fit`).

    The Jacobian J of the weighted residual vector (``problem.residuals``) by
    forward differences in the optimiser's coordinates (value/scale, or log for
    time constants); covariance ``s^2*(J^T J)^-1*c`` with s^2 the residual
    variance per sample and ``c = corr_time*fs`` (>= 1): residuals of a model
    mismatch are correlated over about ``corr_time`` [s], so only one sample in
    c counts (as the selection's BIC does). A singular J^T J gives
    correlations of +-1 (NaN entries become 1). ``seg_mask`` selects segments.

    ``robust``: the model-error term. A model mismatch leaves residuals correlated
    over far longer than ``corr_time`` (a whole stick-slip cycle, a drift), which the
    noise count above does not see: the block-robust (sandwich) covariance
    ``A^-1 (sum_b g_b g_b^T) A^-1 * (G-1)/G``, ``A = J^T J``, of the leverage-corrected
    block scores ``g_b = (I - A_b A^-1)^-1 J_b^T r_b`` (``A_b = J_b J_b^T``) of the G
    time blocks (``problem.residual_blocks``), estimates the scatter of the parameters
    from how the residual's projection varies between the blocks, whatever its
    correlation within a block. The leverage correction is the block jackknife of the
    linearised fit (each block's score as if the fit had not seen it): with about a
    dozen blocks the plain sandwich ``G/(G-1)`` understates the scatter, most for a
    parameter a few blocks dominate (a drift: the record's ends; over 20 seeds of a
    torque-offset drift 0.4x of config/rig.yaml the plain term left the errors at 1.5
    stated SE rms, the corrected one at 1.3). Each standard error is the larger of
    the two (``model_error`` names the parameters where the block term is larger);
    the correlations are those of the noise term (the structure of J).

    Parameters
    ----------
    problem : ResidualModel or Problem
        The residual model (a :class:`.fitting.Problem` is wrapped).
    specs : Sequence[ParamSpec]
        The fitted parameters.
    values : Mapping[str, float]
        The fit's solution (SI), with every value the simulation needs.
    seg_mask : numpy.ndarray of bool or None
        Segments used (None: all).
    corr_time : float
        Residual correlation time of the noise term [s].
    robust : bool
        Include the block-robust model-error term.

    Returns
    -------
    GaussNewton
        Values, standard errors (SI), correlations, dead and model-error parameters.
    """
    if isinstance(problem, Problem):
        problem = ProblemResiduals(problem)
    base = dict(values)

    def coord(p: ParamSpec, v: float) -> float:
        return math.log(max(v, p.lower)) if p.log else v / p.scale

    def value(p: ParamSpec, x: float) -> float:
        return math.exp(x) if p.log else x * p.scale

    r0 = problem.residuals(base, seg_mask)
    cols = []
    for p in specs:
        x = coord(p, float(base[p.name]))
        h = 1e-3 * max(1.0, abs(x))
        vals = dict(base)
        hi = coord(p, p.upper)
        xs = x + h if x + h <= hi else x - h
        vals[p.name] = value(p, xs)
        cols.append((problem.residuals(vals, seg_mask) - r0) / (xs - x))
    J = np.vstack(cols)
    m, k = r0.size, len(specs)
    s2 = float(r0 @ r0) / max(m - k, 1)
    inflation = max(1.0, corr_time * problem.fs)
    a_inv = np.asarray(np.linalg.pinv(J @ J.T), dtype=np.float64)
    cov = a_inv * s2 * inflation
    d = np.sqrt(np.abs(np.diag(cov)))
    d_model = np.zeros_like(d)
    if robust:
        d_model = _block_robust_sd(J, r0, a_inv, problem.residual_blocks(base, seg_mask))
    with np.errstate(invalid='ignore', divide='ignore'):
        corr = cov / np.outer(d, d)
    corr = np.where(np.isfinite(corr), corr, 1.0)
    dead_mask = ~np.any(J != 0.0, axis=1)
    corr[dead_mask, :] = 1.0
    corr[:, dead_mask] = 1.0
    se = []
    for p, dx in zip(specs, np.maximum(d, d_model), strict=True):
        v = float(base[p.name])
        se.append(abs(v) * float(dx) if p.log else float(dx) * p.scale)
    return GaussNewton(
        names=tuple(p.name for p in specs),
        values=tuple(float(base[p.name]) for p in specs),
        se=tuple(se),
        corr=np.asarray(corr, dtype=np.float64),
        dead=tuple(p.name for p, dd in zip(specs, dead_mask, strict=True) if dd),
        model_error=tuple(
            p.name for p, a, b in zip(specs, d, d_model, strict=True) if b > a and not b <= 0
        ),
    )


def _block_robust_sd(
    jac: FloatArray,
    r0: FloatArray,
    a_inv: FloatArray,
    blocks: npt.NDArray[np.int64],
) -> FloatArray:
    """Return the block-robust (sandwich) standard deviations in the fit coordinates.

    Parameters
    ----------
    jac : FloatArray
        Jacobian, one row per parameter, one column per residual element.
    r0 : FloatArray
        Weighted residual vector at the solution (-).
    a_inv : FloatArray
        Pseudo-inverse of ``jac @ jac.T``.
    blocks : numpy.ndarray of int64
        Time block of every residual element (-1: none).

    Returns
    -------
    FloatArray
        One standard deviation per parameter (zeros with fewer than 3 blocks).
    """
    k = jac.shape[0]
    out = np.zeros(k)
    if blocks.size != r0.size:
        return out
    ids = np.unique(blocks[blocks >= 0])
    g_n = ids.size
    if g_n < 3:
        return out
    meat = np.zeros((k, k))
    eye = np.eye(k)
    for b in ids:
        m = blocks == b
        g = jac[:, m] @ r0[m]
        # the block's own leverage: its residual is the fit's, which it pulled
        # towards itself; (I - A_b A^-1)^-1 g_b is its score had it been left out
        a_b = jac[:, m] @ jac[:, m].T
        try:
            g = np.linalg.solve(eye - a_b @ a_inv, g)
        except np.linalg.LinAlgError:
            pass  # a block that alone determines a parameter: its plain score
        meat += np.outer(g, g)
    cov = a_inv @ meat @ a_inv * ((g_n - 1.0) / g_n)
    return np.asarray(np.sqrt(np.abs(np.diag(cov))), dtype=np.float64)
