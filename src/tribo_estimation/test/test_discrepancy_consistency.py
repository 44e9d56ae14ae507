"""A named effect must improve the record all through: controls never name an effect.

The record comes from the independent record generator (core/reference_records.py,
rig noise) with a measuring-spring stiffness C1 that grows by 2 % during the record,
an effect outside the candidate library: the stick-slip period drifts, and a drive
speed ripple locked to the stick-slip frequency buys a lower residual over most of
the record by making its start clearly worse. It must not be named; the mismatch is
reported as unexplained, with where in time it concentrates.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.discrepancy.fitting import Record
from tribo_estimation.core.discrepancy.report import to_dict
from tribo_estimation.core.discrepancy.select import SelectionSettings, run_discrepancy
from tribo_estimation.core.discrepancy.select.scoring import worst_block_loss
from tribo_estimation.core.model import DriveProfile
from tribo_estimation.core.reference import SpeedProfile, Unmodelled
from tribo_estimation.core.reference_records import RecordSpec, make_record, rig_channels, rpm

CFG = load_rig_config(Path(__file__).resolve().parents[3] / 'config' / 'rig.yaml')


def test_worst_block_loss() -> None:
    assert worst_block_loss([1.0, 2.0, 4.0], [0.5, 2.2, 1.0]) == pytest.approx(0.1, abs=1e-12)
    assert worst_block_loss([1.0, 2.0], [0.5, 1.0]) == pytest.approx(-0.5, abs=1e-12)
    # uncovered blocks (NaN) and mismatched block counts are ignored
    assert worst_block_loss([1.0, math.nan], [0.9, 5.0]) == pytest.approx(-0.1, abs=1e-12)
    assert worst_block_loss([1.0], [1.0, 2.0]) == -math.inf


def test_stiffness_drift_names_no_effect() -> None:
    tc, ac, sc = rig_channels(1.0)
    w = rpm(60)
    duration, start = 3.0, 0.5  # the matrix case (bench/bench_discrepancy_matrix.py)
    spec = RecordSpec(CFG.rig, CFG.friction, SpeedProfile.startup(w, 0.2),
                      unmodelled=Unmodelled(stiffness_drift=0.02 / (start + duration)),
                      torsion=tc, accel=ac, speed=sc, seed=1044, duration=duration,
                      start_offset=start)  # fmt: skip
    r = make_record(spec)
    rec = Record(r.time - r.time[0], r.torsion_moment, r.angular_acceleration, r.speed)
    res = run_discrepancy(rec, CFG.rig, DriveProfile(w, 0.0), k=CFG.friction.k,
                          settings=SelectionSettings(candidates=('drive_speed_ripple',),
                                                     max_effects=1,
                                                     propose_terms=False))  # fmt: skip
    ripple = res.rounds[0][0]
    # the ripple lowers the residual of the record as a whole ...
    assert ripple.gain > 0.1
    # ... by making a time block clearly worse (> 10 %): not named
    assert ripple.block_loss > 0.1
    assert res.added == ()
    assert res.inconsistent == ('drive_speed_ripple',)
    kinds = {u.kind for u in res.unexplained}
    assert 'time' in kinds, kinds
    d = to_dict(res)
    assert d['inconsistent'] == ['drive_speed_ripple'] and d['added'] == []
