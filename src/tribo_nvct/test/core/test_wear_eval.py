"""Known-truth simulated tests: counts -> wear -> running-in/progressive evaluation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from tribo_nvct.core.config import NvctConfig, load_config
from tribo_nvct.core.counting import Dwell
from tribo_nvct.core.evaluation import fit_exponential
from tribo_nvct.core.profile import DepthProfile
from tribo_nvct.core.simulate import ForwardSimulator, SimSettings, TrueWear
from tribo_nvct.core.streaming import WearEvaluator
from tribo_nvct.core.wear import activity_to_wear
from tribo_nvct.errors import NvctConfigError

from ..conftest import CONFIG_DIR

N_SEEDS = 50


def run(sim: ForwardSimulator, seed: int) -> WearEvaluator:
    ev = WearEvaluator(sim.cfg)
    for d in sim.run(seed):
        ev.add(d)
    return ev


def test_known_truth_over_seeds(simulator: ForwardSimulator) -> None:
    truth = simulator.paper_truth()
    rows = []
    for seed in range(N_SEEDS):
        e = run(simulator, seed).evaluation()
        rows.append(
            [
                e.total_volume,
                e.total_volume_se,
                e.progressive_rate,
                e.progressive_rate_se,
                e.running_in_volume,
                e.running_in_volume_se,
                e.exp_fit.w,
                e.exp_fit.w_se,
                e.exp_fit.V_r,
                e.exp_fit.V_r_se,
            ]
        )
    r = np.array(rows)
    checks = (
        ('total', 0, truth['total_volume'], 0.03),  # issue: within 3 %
        ('rate', 2, truth['progressive_rate'], 0.10),  # issue: within 10 %
        ('running-in', 4, truth['running_in_volume'], 0.10),  # issue: within 10 %
        ('exp w', 6, simulator.truth.progressive_rate, 0.10),
        ('exp V_r', 8, simulator.truth.running_in_volume, 0.10),
    )
    for name, i, tv, tol in checks:
        rel = np.abs(r[:, i] / tv - 1.0)
        assert rel.max() < tol, f'{name}: worst relative error {rel.max():.3f}'
        z = (r[:, i] - tv) / r[:, i + 1]
        # Honest standard errors: z-scores over 50 seeds have sd in [0.7, 1.4]
        # (sampling sd of the sd at n=50 is 0.1) and no bias beyond 3/sqrt(50).
        assert 0.7 <= z.std() <= 1.4, f'{name}: z sd {z.std():.2f}'
        assert abs(z.mean()) < 3.0 / math.sqrt(N_SEEDS) + 0.2, f'{name}: z mean {z.mean():.2f}'


def test_early_points_flagged_not_mixed(simulator: ForwardSimulator) -> None:
    ev = run(simulator, 3)
    mix = simulator.cfg.circuit.mixing_time  # type: ignore[union-attr]
    for p in ev.points:
        assert ('not_mixed' in p.flags) == (p.t_end < mix)
    # Later points agree with the truth within 5 sigma (counting statistics only).
    late = [p for p in ev.points if p.t_end > 3600.0]
    z = [
        (p.volume - float(simulator.true_volume(p.t_mid - simulator.cfg.circuit.lag)))  # type: ignore[union-attr]
        / p.volume_se
        for p in late
    ]
    assert max(abs(x) for x in z) < 5.0


def test_wear_coefficient_conventions(nvct_cfg: NvctConfig, simulator: ForwardSimulator) -> None:
    e = run(simulator, 0).evaluation()
    d_s = nvct_cfg.stroke * nvct_cfg.frequency * 180 * 60.0  # paper Equ. 10
    assert e.sliding_distance == pytest.approx(d_s)
    assert e.k_w_progressive == pytest.approx(e.progressive_volume / (nvct_cfg.load * d_s))
    raw = dict(nvct_cfg.raw)
    raw['sliding_distance'] = 'astm_g133'
    from tribo_nvct.core.config import config_from_dict

    astm = config_from_dict(raw, CONFIG_DIR, 'astm')
    assert astm.sliding_distance(60.0) == pytest.approx(2.0 * nvct_cfg.sliding_distance(60.0))
    assert e.summary(nvct_cfg)['sliding_distance_convention'] == 'paper'


def test_flat_profile_reduces_to_paper_equation_8(nvct_cfg: NvctConfig) -> None:
    # With a flat profile rho, Equ. 8 V_I = A/rho holds exactly.
    rho = 1e16
    flat = DepthProfile.from_density(lambda z: np.full_like(z, rho), 4e-6)
    cfg = NvctConfig(**{**nvct_cfg.__dict__, 'profile': flat})
    A = 500.0
    h, h_se, _ = activity_to_wear(cfg, A, 5.0)
    assert h * cfg.tagged_area == pytest.approx(A / rho, rel=1e-9)
    assert h_se == pytest.approx(5.0 / (cfg.tagged_area * rho), rel=1e-9)


def test_beyond_activated_depth_is_flagged_not_extrapolated(nvct_cfg: NvctConfig) -> None:
    # A wear curve that eats through the 5 um layer: 0.5 um/min mean height.
    truth = TrueWear(0.0, 60.0, 0.5e-6 / 60.0 * nvct_cfg.contact_area)
    sim = ForwardSimulator(nvct_cfg, truth, SimSettings(duration=30 * 60.0))
    ev = WearEvaluator(nvct_cfg)
    pts = [ev.add(d) for d in sim.run(1)]
    beyond = [p for p in pts if p is not None and 'beyond_profile' in p.flags]
    assert beyond, 'wear beyond the profile must be flagged'
    for p in beyond:
        assert math.isnan(p.volume) and math.isnan(p.height)
        assert not p.usable
    for p in pts:
        assert p is not None
        assert math.isnan(p.height) or p.height <= nvct_cfg.profile.max_depth


def test_short_test_gives_nan_and_flag(simulator: ForwardSimulator) -> None:
    ev = WearEvaluator(simulator.cfg)
    for d in simulator.run(0)[:100]:  # 100 min < 180 min
        ev.add(d)
    e = ev.evaluation()
    assert math.isnan(e.total_volume) and 'window_not_covered' in e.flags


def test_exponential_fit_noise_free() -> None:
    t = np.arange(30.0, 240 * 60.0, 60.0)
    v = 2e-13 * -np.expm1(-t / 900.0) + 1e-17 * t
    f = fit_exponential(t, v, np.full(t.size, 1e-16))
    assert f.ok
    assert f.V_r == pytest.approx(2e-13, rel=1e-4)
    assert f.tau == pytest.approx(900.0, rel=1e-4)
    assert f.w == pytest.approx(1e-17, rel=1e-4)


def test_config_errors(tmp_path: Path) -> None:
    raw = yaml.safe_load((CONFIG_DIR / 'nvct.yaml').read_text())
    raw['depth_profile'] = str(CONFIG_DIR / 'depth_profile.csv')

    def write(d: dict[str, object]) -> Path:
        p = tmp_path / 'n.yaml'
        p.write_text(yaml.safe_dump(d))
        return p

    bad = dict(raw)
    del bad['k_det']
    with pytest.raises(NvctConfigError, match="missing key 'k_det'"):
        load_config(write(bad))
    bad = dict(raw, tagged_area_um2=1e8)
    with pytest.raises(NvctConfigError, match='exceeds the contact area'):
        load_config(write(bad))
    bad = dict(raw, load_N=-5)
    with pytest.raises(NvctConfigError, match='load_N'):
        load_config(write(bad))
    bad = dict(raw, sliding_distance='furlongs')
    with pytest.raises(NvctConfigError, match='sliding_distance'):
        load_config(write(bad))
    bad = dict(raw, nuclide='Xx-1')
    with pytest.raises(NvctConfigError, match='unknown nuclide'):
        load_config(write(bad))


def test_dwell_input_validation_in_evaluator(nvct_cfg: NvctConfig) -> None:
    ev = WearEvaluator(nvct_cfg)
    d0 = Dwell(0.0, 60.0, 100, 59.9)
    ev.add(d0)
    assert ev.add(d0) is None  # exact repeat (replay after restart) ignored
    from tribo_nvct.errors import NonMonotonicTimeError

    with pytest.raises(NonMonotonicTimeError):
        ev.add(Dwell(30.0, 90.0, 100, 59.9))
    assert len(ev.points) == 1  # state unchanged by the rejected dwell
    p = ev.add(Dwell(600.0, 660.0, 100, 59.9))
    assert p is not None and 'gap' in p.flags
