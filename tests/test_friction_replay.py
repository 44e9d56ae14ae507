"""Replay of a recorded bag through the friction_estimator node gives the same
estimates as `tribo friction` on the same bag.

The bag is made from the simulator with seeded noise (no DDS needed for that);
the node sees it through `tribo replay` on its own ROS_DOMAIN_ID, and its
/friction/estimate output is recorded with `tribo record`.
"""

from __future__ import annotations

import csv
import math
import subprocess
from pathlib import Path

import pytest
from replay_harness import replay, start_node, start_recorder
from support import ROOT, Proc, bag_so_far, make_rig_bag, requires_ros, tribo_cmd, wait_for

from tribo_bringup import bagio

pytestmark = [requires_ros, pytest.mark.ros]


def _num(text: str) -> float:
    return math.nan if text in ('', 'nan', 'NaN') else float(text)


@pytest.mark.slow
def test_node_on_replayed_bag_matches_offline_cli(tmp_path: Path, procs: list[Proc]) -> None:
    bag = tmp_path / 'session'
    make_rig_bag(bag, 4.0)
    # offline
    out = tmp_path / 'offline'
    r = subprocess.run(
        tribo_cmd(
            'friction',
            str(bag),
            '--rig',
            str(ROOT / 'config' / 'rig.yaml'),
            '--out',
            str(out),
            '--no-plots',
            '--quiet',
        ),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    with (out / 'blocks.csv').open() as f:
        offline = list(csv.DictReader(f))
    assert len(offline) == 4
    # online: node <- replay, estimates recorded
    node = start_node(
        procs, tmp_path, 'friction_estimator', 'friction_estimator.yaml', 'friction_estimator'
    )
    est_bag = tmp_path / 'estimates'
    # the recorder logs each topic once its subscription has matched the node's publisher
    topics = ('/friction/estimate', '/friction/moment')
    rec = start_recorder(procs, tmp_path, est_bag, topics, matched=topics)
    replay(procs, tmp_path, bag, 4.0, wait_subscribers=30.0)

    # the last block is fitted after its final sample arrives: wait until the
    # recorder has flushed every moment sample and one estimate per block
    def complete() -> bool:
        msgs = bag_so_far(est_bag)
        samples = sum(len(m.data) for m in msgs if hasattr(m, 'data'))
        estimates = sum(1 for m in msgs if hasattr(m, 'mu0'))
        return samples >= 40_000 and estimates >= len(offline)

    assert wait_for(complete, 120, interval=0.5), (rec.output(), node.output())
    assert rec.stop() == 0, rec.output()
    online = [m.msg for m in bagio.iter_messages(est_bag, ['/friction/estimate'])]
    moment = [m.msg for m in bagio.iter_messages(est_bag, ['/friction/moment'])]
    # the observer output is continuous: every input sample has its moment sample
    idx = [int(m.first_index) for m in moment]
    assert idx == sorted(idx) and sum(len(m.data) for m in moment) == 40_000, node.output()
    assert len(online) >= 3, node.output()
    by_start = {round(float(row['t_start']), 6): row for row in offline}
    compared = 0
    for est in online:
        row = by_start.get(round(float(est.t_start), 6))
        if row is None:
            continue
        for key in ('mu0', 'mu_inf', 'mu0_se', 'mu_inf_se', 'rms_residual', 'moment_mean'):
            a, b = float(getattr(est, key)), _num(row[key])
            if math.isnan(b):
                assert math.isnan(a), (key, a, b)
            else:
                # blocks.csv keeps 9 significant digits
                assert a == pytest.approx(b, rel=1e-6, abs=1e-12), (key, est.t_start, a, b)
        assert est.motion == row['motion'] and int(est.n_sticks) == int(row['n_sticks'])
        compared += 1
    assert compared >= 3, (len(online), sorted(by_start))
