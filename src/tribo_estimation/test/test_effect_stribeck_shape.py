"""The ``stribeck_shape`` candidate (one module: core/discrepancy/effects/stribeck_shape.py).

Truth: a 1 s record of the config/rig.yaml rig (paper Tab. 1, 30 rpm, seeded
noise 0.05 N m / 2 rad/s^2 / 0.005 rad/s) simulated by the kernel with the
Stribeck shape exponent delta = 0.6 hidden (``stribeck_shape = delta - 1 =
-0.4``). The workflow, trying the whole library, must name ``stribeck_shape``
first and recover delta within 20 %.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.discrepancy import SelectionSettings, candidates, run_discrepancy
from tribo_estimation.core.discrepancy.fitting import Record
from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    pack_params,
)
from tribo_estimation.core.simulate import NoiseSpec, simulate

RIG_YAML = Path(__file__).resolve().parents[3] / 'config' / 'rig.yaml'
DELTA = 0.6
START = 0.25  # s after the drive start (inside the 0.5 s ramp, as test_discrepancy_workflow)


def test_registered_from_its_module() -> None:
    c = candidates.get('stribeck_shape')
    assert c.param_names == ('stribeck_shape',)
    assert c.localiser == 'slip_speed'
    assert c.demo_effects is not None and c.demo_effects['stribeck_shape'] == -0.4


def test_kernel_law_with_shape_exponent() -> None:
    # analytic: mu = (mu0 - mu_inf)*exp(-(k v)^delta) + mu_inf, exact to 1e-12
    fr = FrictionLaw(0.13, 0.1, 2.0)
    v = np.array([0.0, 0.1, 0.5, 1.0, 3.0])
    p = pack_params(RigParams.tab1(), fr, DriveProfile(0.0), Extensions(stribeck_shape=DELTA - 1))
    got = kn.friction_coefficient_array(p, 0.0, v, False)
    want = (fr.mu0 - fr.mu_inf) * np.exp(-((fr.k * v) ** DELTA)) + fr.mu_inf
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # shape 0 is Equ. 8
    p0 = pack_params(RigParams.tab1(), fr, DriveProfile(0.0))
    np.testing.assert_allclose(
        kn.friction_coefficient_array(p0, 0.0, v, False), fr.mu(v), rtol=0, atol=1e-15
    )


@pytest.mark.slow
def test_workflow_names_stribeck_shape_and_recovers_delta() -> None:
    cfg = load_rig_config(RIG_YAML)
    r = simulate(
        cfg.rig,
        cfg.friction,
        cfg.drive,
        START + 1.0,
        extensions=Extensions(stribeck_shape=DELTA - 1.0),
        noise=NoiseSpec(torque=0.05, accel=2.0, speed=0.005),
        seed=300,
    )
    m = r.time >= START
    rec = Record(r.time[m], r.torsion_moment[m], r.angular_acceleration[m], r.speed[m])
    res = run_discrepancy(
        rec, cfg.rig, cfg.drive, k=cfg.friction.k, settings=SelectionSettings(max_effects=1)
    )
    assert res.added, res.rounds
    first = res.added[0]
    assert first.effect == 'stribeck_shape'
    delta = 1.0 + first.params['stribeck_shape']
    assert delta == pytest.approx(DELTA, rel=0.2)
    # the torsion-moment residual rms drops at least by half
    assert first.rms_after <= 0.5 * first.rms_before
    assert math.isfinite(res.final.rms) and res.final.rms < 0.1
