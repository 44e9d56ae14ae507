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

A package with one job per module (``from tribo_nvct.core.profile import X`` gives
every public name): :mod:`.data` (layer-removal data, checks, noise model),
:mod:`.shapes` (model shapes), :mod:`.fit` (the fits and their AICc),
:mod:`.select` (:func:`fit_depth_profile`: model choice), :mod:`.bootstrap`
(replicas) and :mod:`.result` (:class:`DepthProfile`).
"""

from __future__ import annotations

from .bootstrap import BOOTSTRAP_REPLICAS, BOOTSTRAP_SEED, REPLICA_AIC_MARGIN
from .data import LayerRemovalData, read_layer_removal_csv
from .fit import PIECEWISE_BINS, PIECEWISE_KINDS, SURFACE_FINE_M
from .result import GRID_POINTS, DepthProfile
from .select import PROFILE_MODELS, fit_depth_profile
from .shapes import PARAMETRIC

__all__ = [
    'BOOTSTRAP_REPLICAS',
    'BOOTSTRAP_SEED',
    'GRID_POINTS',
    'PARAMETRIC',
    'PIECEWISE_BINS',
    'PIECEWISE_KINDS',
    'PROFILE_MODELS',
    'REPLICA_AIC_MARGIN',
    'SURFACE_FINE_M',
    'DepthProfile',
    'LayerRemovalData',
    'fit_depth_profile',
    'read_layer_removal_csv',
]
