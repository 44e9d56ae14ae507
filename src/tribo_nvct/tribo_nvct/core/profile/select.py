"""Model choice of the depth profile: every candidate fitted, the smallest AICc wins.

:func:`fit_depth_profile` fits the parametric shapes (with and without an offset)
and the piecewise densities, chooses by AICc, rescales the noise model by the
chosen fit's chi^2/dof, checks that the activity falls with depth, and attaches
the parametric bootstrap (:mod:`.bootstrap`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from tribo_nvct.errors import DepthProfileError, ProfileNotDecreasingError

from .bootstrap import BOOTSTRAP_REPLICAS, BOOTSTRAP_SEED, replica_source
from .data import LayerRemovalData, _check_decreasing, _estimate_noise
from .fit import PIECEWISE_BINS, PIECEWISE_KINDS, _Problem
from .result import DepthProfile
from .shapes import PARAMETRIC

#: Model names accepted by :func:`fit_depth_profile` (``auto``: chosen by AIC).
PROFILE_MODELS = ('auto', 'erfc', 'exponential', 'ramp', 'piecewise')


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
    F_se, _ = prob.grid_se(best, s2)
    rms = float(math.sqrt(np.mean((A - best.fitted) ** 2)))
    return DepthProfile(
        prob.zg,
        np.maximum.accumulate(F),
        F_se,
        rho,
        residual_rms_bq=rms,
        model=best.name,
        aic=tuple((f.name, f.aic) for f in fits),
        chi2_red=chi2_red,
        replica_source=(
            replica_source(prob, fits, best, noise, pieces, bootstrap_replicas, seed)
            if bootstrap_replicas > 0
            else None
        ),
    )
