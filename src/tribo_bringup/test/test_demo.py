"""``tribo demo`` set-up: rig file with the hidden effect, output directory safety.

The demo itself (a minute on the live graph) runs with ``make demo``; these
tests cover what it decides before the graph starts.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
import yaml

from tribo_bringup.commands import demo
from tribo_bringup.errors import ConfigError


def test_builtin_effect_is_merged_into_the_rig(tmp_path: Path) -> None:
    base = tmp_path / 'rig.yaml'
    base.write_text(yaml.safe_dump({**demo.DEFAULT_RIG, 'mu0': 0.2}))
    if (demo.CONFIG / 'rig_hidden_frictional_lag.yaml').exists():
        pytest.skip('config/rig_hidden_frictional_lag.yaml overrides the built-in effect')
    rig, source = demo.rig_for_demo(str(base), 'frictional_lag')
    assert rig['mu0'] == 0.2  # the base file wins over the defaults
    assert rig['effects'] == demo.EFFECTS['frictional_lag']
    assert 'built-in' in source


def test_every_builtin_effect_names_model_extensions() -> None:
    model = pytest.importorskip('tribo_estimation.core.model')
    for name, effects in demo.EFFECTS.items():
        model.Extensions(**effects)  # unknown field names or bad values raise here
        assert name == 'none' or effects, name


def test_unknown_effect_is_rejected() -> None:
    with pytest.raises(ConfigError, match='unknown effect'):
        demo.rig_for_demo(None, 'no_such_effect')


def test_out_dir_of_someone_else_is_never_cleared(tmp_path: Path) -> None:
    foreign = tmp_path / 'results'
    foreign.mkdir()
    (foreign / 'thesis.txt').write_text('keep me')
    with pytest.raises(ConfigError, match='not a tribo demo directory'):
        demo.prepare_out(foreign)
    assert (foreign / 'thesis.txt').read_text() == 'keep me'


def test_previous_demo_bag_and_report_are_replaced(tmp_path: Path) -> None:
    out = tmp_path / 'demo_output'
    demo.prepare_out(out)
    (out / 'bag').mkdir()
    (out / 'report').mkdir()
    (out / 'report' / 'report.html').write_text('old')
    (out / 'notes.txt').write_text('kept')
    demo.prepare_out(out)
    assert not (out / 'bag').exists() and not (out / 'report').exists()
    assert (out / 'notes.txt').read_text() == 'kept'


def test_duration_is_checked() -> None:
    args = argparse.Namespace(duration=0.5, discrepancy_seconds=5.0)
    with pytest.raises(ConfigError, match='--duration'):
        demo.run(args)
