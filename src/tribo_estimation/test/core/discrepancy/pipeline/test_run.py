"""The pipeline's reach when nothing is missing (pipeline/run.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.pipeline.decide import NOTHING_MISSING, UNEXPLAINED
from tribo_estimation.core.discrepancy.pipeline.null import NullLaw
from tribo_estimation.core.discrepancy.pipeline.run import detection_limit, null_verdict


def test_an_effect_of_the_detection_limit_reaches_the_bound() -> None:
    # a residual of 1.2 x the noise (0.05 N m) and a bound of 1.3 x: an independent
    # sinusoid of the limit's rms added to it brings the statistic to the bound (to the
    # sampling error of 200000 samples, 1e-3)
    noise, stat, bound = 0.05, 1.2, 1.3
    limit = detection_limit(stat, bound, noise)
    assert limit == pytest.approx(noise * math.sqrt(bound**2 - stat**2), rel=1e-12)
    rng = np.random.default_rng(1)
    n = 200_000
    base = rng.normal(0.0, stat * noise, n)
    effect = limit * math.sqrt(2.0) * np.sin(2.0 * np.pi * 37.0 * np.arange(n) / 10_000.0)
    assert float(np.sqrt(np.mean((base + effect) ** 2))) / noise == pytest.approx(bound, abs=1e-2)


def test_a_statistic_at_or_beyond_its_bound_needs_no_effect() -> None:
    assert detection_limit(1.4, 1.3, 0.05) == 0.0
    assert math.isnan(detection_limit(1.2, math.nan, 0.05))


def _law(*torque: float) -> NullLaw:
    return NullLaw({'torsion_moment': torque, 'speed': (1.0, 1.01, 1.02)}, 0.01)


def test_a_residual_beyond_the_noise_that_only_failed_replicas_reach_is_unexplained() -> None:
    # replicas refitted to 1.02-1.04 x their noise but one at 4 x (centre 1.36, under
    # sqrt(2): self-consistent); its bound is far above sqrt(2)
    law = _law(1.02, 1.03, 1.04, 1.03, 4.0)
    assert law.self_consistent() and law.bound('torsion_moment') > 5.0
    # a record at 3 x lies within that bound: the fit's own failures, not the noise,
    # cover it, so no statistic decides (nothing missing before)
    got = null_verdict([3.0], [law], [0.05], fails=False)
    assert got is not None and got.kind == UNEXPLAINED, got
    assert 'own error' in got.reason
    # a record within the noise (1.1 x) is explained by its model whatever the bound
    got = null_verdict([1.1], [law], [0.05], fails=False)
    assert got is not None and got.kind == NOTHING_MISSING, got
    # a law of replicas all within their noise: a record within its bound is explained
    tight = _law(1.02, 1.03, 1.04, 1.03, 1.05)
    assert tight.bound('torsion_moment') < math.sqrt(2.0)
    got = null_verdict([1.06], [tight], [0.05], fails=False)
    assert got is not None and got.kind == NOTHING_MISSING, got
    # a failing baseline with usable laws is screened
    assert null_verdict([4.0], [tight], [0.05], fails=True) is None


def test_a_law_not_self_consistent_is_unexplained_even_when_the_baseline_fails() -> None:
    lost = _law(3.0, 2.5, 4.0)
    assert not lost.self_consistent()
    for fails in (False, True):
        got = null_verdict([20.0], [lost], [0.05], fails=fails)
        assert got is not None and got.kind == UNEXPLAINED and 'does not recover' in got.reason
