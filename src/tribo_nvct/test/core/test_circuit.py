"""Oil-circuit transport: mass balance, mixing, lag, early oscillation."""

from __future__ import annotations

import numpy as np
import pytest

from tribo_nvct.core.circuit import OilCircuit, rebuild_released
from tribo_nvct.errors import NvctConfigError


def test_mixed_reading_equals_released_and_oscillates_before() -> None:
    c = OilCircuit(81.0)
    t = np.arange(0.0, 3600.0, 1.0)
    R = c.response(t)
    late = t > c.mixing_time
    # Once mixed the reading is the whole released activity (within the tolerance).
    assert np.max(np.abs(R[late] - 1.0)) < c.mixing_tolerance
    # Before mixing the first slug overshoots strongly (the paper's early oscillation).
    assert R[t < c.circulation_time].max() > 3.0
    # Mass balance: over each later circulation the mean reading is 1.
    k = (t > 1200.0) & (t <= 1200.0 + 81.0)
    assert R[k].mean() == pytest.approx(1.0, abs=0.01)


def test_ramp_release_lags_by_the_model_lag() -> None:
    c = OilCircuit(81.0)
    t = np.arange(0.0, 4000.0, 1.0)
    released = 2.0 * t  # Bq, constant release rate 2 Bq/s
    seen = c.detector_activity(t, released)
    late = t > 2000.0
    # A_det(t) = r (t - lag) once mixed; 1 Bq tolerance ~ 0.5 s of release.
    np.testing.assert_allclose(seen[late], 2.0 * (t[late] - c.lag), atol=1.0)


def test_deposition_rebuild_inverts_first_order_loss() -> None:
    k = 1e-4
    dt = np.full(200, 60.0)
    t = np.cumsum(dt)
    rel = 5.0 * t
    # Mixed reading with first-order loss: dA_det/dt = r - k A_det.
    det = 5.0 / k * (1.0 - np.exp(-k * t))
    rebuilt = rebuild_released(det, dt, k)
    # Rectangle rule of the integral: error ~ k*r*dt^2/2 per step, < 0.5 % here.
    np.testing.assert_allclose(rebuilt, rel, rtol=5e-3)


def test_bad_circuit_parameters() -> None:
    with pytest.raises(NvctConfigError, match='circulation_time_s'):
        OilCircuit(0.0)
    with pytest.raises(NvctConfigError, match='transit_fraction'):
        OilCircuit(60.0, transit_fraction=1.5)
