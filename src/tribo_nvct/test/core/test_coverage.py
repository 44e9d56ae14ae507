"""Combined SE covers the truth: a small seeded coverage check with the independent generator.

The full benchmark (150 tests, 200 replicas) is bench/bench_nvct_coverage.py; here
18 tests with 40 profile replicas keep it to a few seconds.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tribo_nvct.core.config import config_from_dict
from tribo_nvct.core.counting import Dwell
from tribo_nvct.core.streaming import WearEvaluator

from ..truthgen import SHAPES, Truth, random_case

UM3 = 1e-18


def test_truth_within_two_combined_se(tmp_path: Path) -> None:
    hits_v, hits_w, rel_v = [], [], []
    for i in range(18):
        rng = np.random.default_rng([2024, i])
        case = random_case(rng, i, SHAPES[i % 3], (0.002, 0.003, 0.005)[(i // 3) % 3])
        truth = Truth(case)
        csv = tmp_path / f'p{i}.csv'
        truth.write_layer_removal(csv, rng)
        raw = truth.nvct_yaml(csv)
        raw['profile_bootstrap_replicas'] = 40
        cfg = config_from_dict(raw, tmp_path, f'case{i}')
        ev = WearEvaluator(cfg)
        for d in truth.dwells(rng):
            ev.add(Dwell(*d))
        e = ev.evaluation(fit_model=False)
        tg = truth.targets()
        v_true = tg['total_volume_um3'] * UM3
        w_true = tg['progressive_rate_um3_per_min'] * UM3 / 60.0
        assert e.total_volume_combined_se >= e.total_volume_se > 0.0
        assert e.total_volume_profile_se > 0.0 and e.profile_replicas >= 30
        hits_v.append(abs(e.total_volume - v_true) < 2.0 * e.total_volume_combined_se)
        hits_w.append(abs(e.progressive_rate - w_true) < 2.0 * e.progressive_rate_combined_se)
        rel_v.append(e.total_volume / v_true - 1.0)
    # Nominal 95 %; with 18 tests >= 80 % fails by chance with probability ~1 %.
    assert np.mean(hits_v) >= 0.8, hits_v
    assert np.mean(hits_w) >= 0.8, hits_w
    # No gross bias of the total volume (old estimate: +1-2 % on the tests).
    assert abs(float(np.mean(rel_v))) < 0.005


def test_bootstrap_once_per_configuration(tmp_path: Path) -> None:
    rng = np.random.default_rng([2024, 99])
    truth = Truth(random_case(rng, 99, 'flat_erfc', 0.003))
    csv = tmp_path / 'p.csv'
    truth.write_layer_removal(csv, rng)
    raw = truth.nvct_yaml(csv)
    raw['profile_bootstrap_replicas'] = 20
    cfg = config_from_dict(raw, tmp_path, 'case')
    ev = WearEvaluator(cfg)
    for d in truth.dwells(rng):
        ev.add(Dwell(*d))
    reps = cfg.profile.replicas()
    e1 = ev.evaluation(fit_model=False)
    e2 = ev.evaluation(fit_model=False)
    assert cfg.profile.replicas() is reps
    assert e1.total_volume_profile_se == e2.total_volume_profile_se > 0.0
    # Without the profile spread the combined SE is the counting SE.
    e3 = ev.evaluation(fit_model=False, profile_se=False)
    assert e3.total_volume_combined_se == e3.total_volume_se


def test_k_det_calibration_enters_the_profile_se(tmp_path: Path) -> None:
    # No profile bootstrap, 1 % k_DET calibration SE: h is nearly proportional to the
    # released activity in the flat top of the profile, so V_180 carries ~1 % (200 draws:
    # sampling sd of an sd ~ 5 %, tolerance 15 %).
    rng = np.random.default_rng([2024, 7])
    truth = Truth(random_case(rng, 7, 'flat_erfc', 0.003))
    csv = tmp_path / 'p.csv'
    truth.write_layer_removal(csv, rng)
    raw = truth.nvct_yaml(csv)
    raw['profile_bootstrap_replicas'] = 0
    raw['k_det_rel_se'] = 0.01
    cfg = config_from_dict(raw, tmp_path, 'case')
    ev = WearEvaluator(cfg)
    for d in truth.dwells(rng):
        ev.add(Dwell(*d))
    e = ev.evaluation(fit_model=False)
    assert e.profile_replicas == 200
    assert e.total_volume_profile_se / e.total_volume == pytest.approx(0.01, rel=0.15)
    assert e.progressive_rate_profile_se / e.progressive_rate == pytest.approx(0.01, rel=0.15)
