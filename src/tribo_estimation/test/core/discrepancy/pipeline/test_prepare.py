"""Steps 1-2 of the pipeline: the speed channel's gain from the baseline (pipeline/prepare.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from discrepancy_scenarios import NOISE, constant, record, rpm
from tribo_scenarios.spec import ChannelSpec, InstrumentSpec

from tribo_estimation.core.discrepancy.pipeline.policy import Policy, quiet
from tribo_estimation.core.discrepancy.pipeline.prepare import (
    fit_record_baseline,
    identify_speed_gain,
    prepare,
)


def test_a_second_order_tachometer_gets_its_gain_from_the_baseline() -> None:
    # a tachometer 4 % low behind a second-order lag (1.6 ms, zeta 0.75, as random record
    # 3): in the stick phases the discs swing at one frequency, where the sensor's
    # a2*y'' passes for a gain, and the stick regression is several % off; the baseline
    # refitted at trial gains finds it within 1 % and the speed channel fits to its noise
    t, a, s = NOISE
    inst = InstrumentSpec(
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, t),
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, a),
        ChannelSpec(0.96, 0.02, 2, 0.0016, 0.75, s),
    )
    rec, rig, drv = record(3, constant(rpm(20)), instrument=inst, fs=5000.0, duration=3.0)
    pol = Policy(shaft=False)
    prep = prepare(rec, rig, drv, k=2.0, policy=pol)
    values = fit_record_baseline(prep, pol, quiet)
    entry = prep.instrument['speed_gain']
    assert isinstance(entry, dict)
    regression = float(entry['value'])
    assert abs(regression - 0.96) > 0.02, regression  # the regression alone is off

    def speed_rms(p: object, v: dict[str, float], gain: float) -> float:
        pb = p.problem  # type: ignore[attr-defined]
        sim = pb.simulate(v)
        r = (pb.record.speed - sim.speed)[sim.covered]
        return float(np.sqrt(np.mean(r * r))) * gain  # in the channel's own units

    before = speed_rms(prep, values, regression)
    found, refit = identify_speed_gain(prep, values, pol, quiet)
    used = found.instrument['speed_gain']
    assert isinstance(used, dict)
    gain = float(used['used'])
    assert gain == pytest.approx(0.96, rel=0.01), used
    after = speed_rms(found, refit, gain)
    assert after < 1.1 * s < before, (before, after)
    assert math.isfinite(refit['mu0']) and refit['mu0'] == pytest.approx(0.13, rel=0.01)
