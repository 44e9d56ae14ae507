"""Two simulated rigs under two namespaces on one graph: recorded together into one
bag, each analysed on its own (relative topic names from tribo_common.topics).

Uses DDS (own ROS_DOMAIN_ID, localhost discovery, see the root conftest.py).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from support import ROOT, Proc, requires_ros, tribo_cmd, wait_for

from tribo_bringup import bagio

pytestmark = [requires_ros, pytest.mark.ros]


@pytest.mark.slow
def test_two_rigs_in_two_namespaces(tmp_path: Path, procs: list[Proc]) -> None:
    rigs = {}
    for ns in ('rigA', 'rigB'):
        rigs[ns] = Proc(
            tribo_cmd('run', '--nodes', 'sim_rig', '--namespace', ns, '--duration', '60'),
            tmp_path / f'{ns}.log',
        )
        procs.append(rigs[ns])
    for p in rigs.values():
        assert wait_for(lambda p=p: 'streaming started' in p.output(), 300), p.output()
    bag = tmp_path / 'two'
    rec = Proc(
        tribo_cmd(
            'record', '--out', str(bag), '--duration', '4', '--namespace', 'rigA',
            '--namespace', '/rigB', '--topics', *bagio.RIG_TOPICS,
        ),
        tmp_path / 'rec.log',
    )  # fmt: skip
    procs.append(rec)
    assert rec.wait(60) == 0, rec.output()
    for p in rigs.values():
        assert p.stop() == 0, p.output()
    assert bagio.rig_namespaces(bag) == ['/rigA', '/rigB']
    topics = set(bagio.bag_topics(bag))
    assert topics == {f'/{ns}{t}' for ns in rigs for t in bagio.RIG_TOPICS}, topics
    for c in bagio.check_streams(bag):
        # the simulated rigs run in real time: on a loaded 2-core machine they may deliver
        # less than the 4 s recorded, but never with a gap
        assert c.samples >= 5_000 and c.missing == 0, c  # >= 0.5 s of 10 kHz, no gap
    for ns in rigs:
        out = tmp_path / f'fric_{ns}'
        r = subprocess.run(
            tribo_cmd(
                'friction', str(bag), '--rig', str(ROOT / 'config' / 'rig.yaml'),
                '--out', str(out), '--namespace', ns, '--no-plots', '--quiet',
            ),
            capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        assert r.returncode == 0, r.stderr
        rows = (out / 'blocks.csv').read_text().splitlines()
        assert len(rows) >= 3, rows  # header + >= 2 one-second blocks
    # without a choice, a bag of two rigs is refused with one line naming them
    r = subprocess.run(
        tribo_cmd(
            'friction', str(bag), '--rig', str(ROOT / 'config' / 'rig.yaml'),
            '--out', str(tmp_path / 'none'), '--no-plots',
        ),
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 2 and '/rigA, /rigB' in r.stderr, r.stderr
