"""Parametric bootstrap of a fitted depth profile (the profile's uncertainty).

Replicas A*_i = A_fit(z_i) + s sigma_i eps_i, eps_i ~ N(0, 1) (seeded) are refitted
*including the model choice*, giving F*_b(z); :meth:`.result.DepthProfile.replicas`
computes them once, on first use, through the closure :func:`replica_source` returns.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from tribo_nvct.errors import DepthProfileError

from .fit import _Fit, _Problem
from .shapes import PARAMETRIC

FloatArray = NDArray[np.float64]

#: Default number of bootstrap replicas and seed of the profile uncertainty.
BOOTSTRAP_REPLICAS = 200
BOOTSTRAP_SEED = 20240611
#: Candidates further than this behind the best AICc are not refitted in replicas [-].
REPLICA_AIC_MARGIN = 100.0


def replica_source(
    prob: _Problem,
    fits: Sequence[_Fit],
    best: _Fit,
    noise: FloatArray,
    pieces: Sequence[str],
    n_replicas: int,
    seed: int,
) -> Callable[[], FloatArray]:
    """Return the function that computes the bootstrap replicas F*_b(z_grid) [Bq/m^2].

    Replicas refit only the candidates that could win: an AICc more than
    :data:`REPLICA_AIC_MARGIN` behind the best never wins against the data's noise.

    Parameters
    ----------
    prob : _Problem
        The problem the candidates were fitted on.
    fits : Sequence[_Fit]
        Every candidate fit (their shape parameters start the replica fits).
    best : _Fit
        The chosen fit (its fitted remaining activity is the replicas' mean) [Bq].
    noise : FloatArray
        Standard deviation of the replica noise per layer [Bq].
    pieces : Sequence[str]
        Names of the piecewise candidates (``kind/bins``).
    n_replicas : int
        Number of replicas B.
    seed : int
        Seed of the replica noise.

    Returns
    -------
    Callable[[], FloatArray]
        Computes the replicas, shape (<= B, grid) (replicas no model fits are dropped).
    """
    z = prob.z
    n = z.size
    starts = {f.name: f.theta for f in fits if f.name in PARAMETRIC}
    keep = {f.name for f in fits if f.aic < best.aic + REPLICA_AIC_MARGIN}
    rprob = _Problem(
        z,
        prob.sigma,
        prob.pin_area,
        [m for m in prob.models if m in keep],
        [p for p in pieces if p in keep],
    )
    if not rprob.models and not rprob.pieces:
        rprob = prob

    def replicas() -> FloatArray:
        rng = np.random.default_rng(seed)
        out = np.empty((n_replicas, prob.zg.size))
        m = 0
        for _ in range(n_replicas):
            A_star = best.fitted + noise * rng.standard_normal(n)
            try:
                fb = min(rprob.fit_all(A_star, starts), key=lambda f: f.aic)
            except DepthProfileError:
                continue
            out[m] = np.maximum.accumulate(rprob.grid_F(fb))
            m += 1
        return out[:m]

    return replicas
