"""Depth profile: fit against an analytic profile, inversion, uncertainty, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.special import erfc

from tribo_nvct.core.profile import (
    DepthProfile,
    LayerRemovalData,
    fit_depth_profile,
    read_layer_removal_csv,
)
from tribo_nvct.errors import DepthProfileError, ProfileNotDecreasingError

A_PIN = 2.0e-6  # m^2
RHO0 = 1.25e16  # Bq/m^3


def gaussian_tail(z: np.ndarray) -> np.ndarray:
    """Analytic PTLA-like profile: flat, then a Gaussian fall-off around 2 um [Bq/m^3]."""
    return RHO0 * 0.5 * erfc((z - 2.0e-6) / 0.8e-6)


TRUTH = DepthProfile.from_density(gaussian_tail, 6e-6, n=60001)
Z = np.round(np.arange(0.0, 5.0001e-6, 0.1e-6), 12)
AREM = A_PIN * (TRUTH.total - TRUTH.F(Z))


def noisy(seed: int) -> LayerRemovalData:
    rng = np.random.default_rng(seed)
    se = 0.002 * AREM + 5.0
    return LayerRemovalData(Z, AREM + rng.normal(0.0, se), se)


def test_exponential_profile_exact_inversion() -> None:
    # Noise-free exponential profile: F(h) = rho0*L*(1-exp(-h/L)) in closed form.
    L = 1.5e-6
    z = np.round(np.arange(0.0, 6.0001e-6, 0.1e-6), 12)
    arem = A_PIN * RHO0 * L * np.exp(-z / L)
    prof = fit_depth_profile(LayerRemovalData(z, arem, np.full(z.size, 1.0)), A_PIN)
    h = np.array([5e-9, 50e-9, 0.5e-6, 2e-6, 4e-6])
    F_exact = RHO0 * L * -np.expm1(-h / L)
    # Piecewise-linear rho on >= 0.1 um knots vs an exponential with L = 1.5 um:
    # interpolation error well below 0.5 %.
    np.testing.assert_allclose(prof.F(h), F_exact, rtol=5e-3)
    np.testing.assert_allclose(prof.invert(F_exact), h, rtol=5e-3)
    np.testing.assert_allclose(prof.rho(h), RHO0 * np.exp(-h / L), rtol=2e-2)


def test_fit_recovers_analytic_profile_within_its_errors() -> None:
    h = np.array([0.01e-6, 0.1e-6, 1.0e-6, 3.0e-6])
    zs = []
    for seed in range(30):
        prof = fit_depth_profile(noisy(seed), A_PIN)
        zs.append((prof.F(h) - TRUTH.F(h)) / prof.F_se(h))
        # 0.1 um-deep F: noise 100 Bq on 2.5 kBq -> a few % at most (5 sigma bound).
        assert abs(prof.F(1e-7)[0] / TRUTH.F(1e-7)[0] - 1.0) < 0.15
    z = np.array(zs)
    # Standard errors honest: z-scores over 30 seeds have sd near 1 (sampling
    # sd of the sd ~ 0.13; bias from the spline and AIC choice allowed up to 0.5).
    assert np.all(np.abs(z.mean(axis=0)) < 0.6)
    assert np.all((z.std(axis=0) > 0.6) & (z.std(axis=0) < 1.5))


def test_invert_beyond_profile_is_nan_and_negative_is_linear() -> None:
    prof = fit_depth_profile(noisy(1), A_PIN)
    assert math.isnan(prof.invert(prof.total * 1.01)[0])
    assert math.isnan(prof.F(prof.max_depth * 1.01)[0])
    # Below zero (noise): linear in the surface density, sign kept (no clipping bias).
    f = -1e-3 * prof.total
    assert prof.invert(f)[0] == pytest.approx(f / prof.surface_density)


def test_profile_not_decreasing_rejected() -> None:
    a = AREM.copy()
    a[20] += 2000.0  # a 2 kBq jump up at 2 um, noise ~ 50 Bq
    se = 0.002 * AREM + 5.0
    with pytest.raises(ProfileNotDecreasingError, match='rises with depth'):
        fit_depth_profile(LayerRemovalData(Z, a, se), A_PIN)
    with pytest.raises(ProfileNotDecreasingError, match='does not decrease'):
        fit_depth_profile(LayerRemovalData(Z, AREM[::-1].copy(), se), A_PIN)


def test_bad_rows_rejected(tmp_path: Path) -> None:
    with pytest.raises(DepthProfileError, match='first depth'):
        LayerRemovalData(Z + 1e-7, AREM)
    zz = Z.copy()
    zz[5] = zz[4]
    with pytest.raises(DepthProfileError, match='strictly increasing'):
        LayerRemovalData(zz, AREM)
    bad = AREM.copy()
    bad[3] = np.nan
    with pytest.raises(DepthProfileError, match='not finite'):
        LayerRemovalData(Z, bad)
    p = tmp_path / 'p.csv'
    p.write_text('depth,remaining_activity_bq\n0,1\n')
    with pytest.raises(DepthProfileError, match="missing column 'depth_um'"):
        read_layer_removal_csv(p)
    p.write_text('depth_um,remaining_activity_bq\n0,1\n0.1,abc\n')
    with pytest.raises(DepthProfileError, match='bad number'):
        read_layer_removal_csv(p)


def test_shipped_profile_reads(nvct_cfg: object) -> None:
    from tribo_nvct.core.config import NvctConfig

    assert isinstance(nvct_cfg, NvctConfig)
    prof = nvct_cfg.profile
    # The shipped CSV was simulated with 25 kBq/mm^2 over the layer (0.2 % noise).
    assert prof.total == pytest.approx(25e3 / 1e-6, rel=0.01)
    assert np.all(np.diff(prof.cumulative) >= 0.0)
