"""Shared fixtures of the tribo_nvct tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from tribo_nvct.core.config import NvctConfig, load_config
from tribo_nvct.core.simulate import ForwardSimulator, load_sim_config

REPO = Path(__file__).resolve().parents[3]
CONFIG_DIR = REPO / 'config'


@pytest.fixture(scope='session')
def nvct_cfg() -> NvctConfig:
    """The shipped config/nvct.yaml (Co-56, 60 kBq tagged, line contact at 100 N)."""
    return load_config(CONFIG_DIR / 'nvct.yaml')


@pytest.fixture(scope='session')
def simulator() -> ForwardSimulator:
    """Forward simulator of the shipped sim_detector.yaml test (240 min, 60 s dwell)."""
    sc = load_sim_config(CONFIG_DIR / 'sim_detector.yaml')
    return ForwardSimulator(sc.nvct, sc.truth, sc.settings)
