"""The pipeline's reach when nothing is missing (pipeline/run.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tribo_estimation.core.discrepancy.pipeline.run import detection_limit


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
