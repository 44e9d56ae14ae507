"""Streaming evaluator: save/restore equivalence, refusal of foreign or corrupt state."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tribo_nvct.core.config import config_from_dict
from tribo_nvct.core.simulate import ForwardSimulator
from tribo_nvct.core.streaming import WearEvaluator
from tribo_nvct.errors import StateError

from ..conftest import CONFIG_DIR


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def test_restart_loses_nothing(simulator: ForwardSimulator, tmp_path: Path) -> None:
    dwells = simulator.run(11)
    straight = WearEvaluator(simulator.cfg)
    for d in dwells:
        straight.add(d)
    state = tmp_path / 'state.json'
    first = WearEvaluator(simulator.cfg)
    for d in dwells[:137]:
        first.add(d)
        first.save(state)
    # "crash": a new evaluator from the file continues with the remaining dwells,
    # and a replayed last dwell is ignored.
    second = WearEvaluator.load(simulator.cfg, state)
    assert second.add(dwells[136]) is None
    for d in dwells[137:]:
        second.add(d)
    assert second.points == straight.points
    e1, e2 = straight.evaluation(), second.evaluation()
    for f in ('total_volume', 'progressive_rate', 'running_in_volume', 'k_w_progressive'):
        assert _same(getattr(e1, f), getattr(e2, f))


def test_foreign_or_corrupt_state_refused(simulator: ForwardSimulator, tmp_path: Path) -> None:
    ev = WearEvaluator(simulator.cfg)
    for d in simulator.run(2)[:5]:
        ev.add(d)
    p = tmp_path / 's.json'
    ev.save(p)
    other = config_from_dict(dict(simulator.cfg.raw, k_det=12.0), CONFIG_DIR, 'other')
    with pytest.raises(StateError, match='another configuration'):
        WearEvaluator.load(other, p)
    p.write_text('{"version": 1, ')
    with pytest.raises(StateError, match='not valid JSON'):
        WearEvaluator.load(simulator.cfg, p)
    st = ev.state_dict()
    st['dwells'][2][2] = -4
    p.write_text(json.dumps(st))
    with pytest.raises(StateError, match='dwell 2 is corrupt'):
        WearEvaluator.load(simulator.cfg, p)
