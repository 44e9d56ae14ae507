"""The shipped config/ examples are true to the code: they load and agree with each other."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tribo_bringup.graph import rig_overrides
from tribo_estimation.core.config import OPTIONAL_KEYS, REQUIRED_KEYS
from tribo_estimation.core.rigspec import ESTIMATOR_RIG_KEYS

CONFIG = Path(__file__).resolve().parents[1] / 'config'


def test_sim_rig_params_file_matches_rig_yaml() -> None:
    rig = yaml.safe_load((CONFIG / 'rig.yaml').read_text())
    params = yaml.safe_load((CONFIG / 'sim_rig.yaml').read_text())['/**/sim_rig']['ros__parameters']
    for key in (*REQUIRED_KEYS, *[k for k in OPTIONAL_KEYS if k != 'effects']):
        assert params[key] == pytest.approx(rig[key], rel=0, abs=0), key


@pytest.mark.parametrize('path', sorted(CONFIG.glob('rig*.yaml')), ids=lambda p: p.name)
def test_every_rig_file_gives_node_parameters(path: Path) -> None:
    over = rig_overrides(path)
    assert set(REQUIRED_KEYS) <= set(over['sim_rig'])
    assert set(over['friction_estimator']) == set(ESTIMATOR_RIG_KEYS)


@pytest.mark.parametrize('path', sorted(CONFIG.glob('rig*.yaml')), ids=lambda p: p.name)
def test_every_rig_file_loads_in_core(path: Path) -> None:
    from tribo_estimation.core.config import load_rig_config

    cfg = load_rig_config(path)
    assert cfg is not None


def test_ros_param_files_are_node_keyed() -> None:
    for path in CONFIG.glob('*.yaml'):
        data = yaml.safe_load(path.read_text())
        if not isinstance(data, dict):
            continue
        for node, body in data.items():
            if isinstance(body, dict) and 'ros__parameters' in body:
                assert isinstance(body['ros__parameters'], dict), f'{path}: {node}'
