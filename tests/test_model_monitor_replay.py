"""The model_monitor node on a replayed bag publishes the core's windows.

An 8 s bag of the simulated rig (config/rig.yaml, seeded noise, 5 kHz) is replayed in
real time with `tribo replay` into the ``model_monitor`` executable on this
test's ROS_DOMAIN_ID; `tribo record` records its /model/discrepancy windows
together with the torsion stream. A 6 s window is due every 2 s of stream (ending
at 6 and 8 s). Checked: the node publishes both windows (the newest due window is
evaluated even after an overrun); each window is published after the recorder
received its last sample, and carries the same numbers as the core
:class:`~tribo_estimation.core.discrepancy.monitor.WindowMonitor` on the same
samples offline (the second window pools its null law with the first one's).
How fast a window is evaluated is the benchmark's (bench/bench_model_monitor.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from replay_harness import replay, start_node, start_recorder
from support import ROOT, Proc, bag_so_far, make_rig_bag, requires_ros, wait_for

from tribo_bringup import bagio

pytestmark = [requires_ros, pytest.mark.ros]

SECONDS = 8.0
#: Sample rate [Hz]: half the rig's, the node's and the core's windows cost half as much
FS = 5_000.0


def _offline(bag: Path) -> list:  # type: ignore[type-arg]
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.discrepancy.monitor import WindowMonitor

    cfg = load_rig_config(ROOT / 'config' / 'rig.yaml')
    chans: dict[str, list[np.ndarray]] = {t: [] for t in bagio.RIG_TOPICS}
    for m in bagio.iter_messages(bag, list(bagio.RIG_TOPICS)):
        chans[m.topic].append(np.asarray(m.msg.data))
    tq, acc, sp = (np.concatenate(chans[t]) for t in bagio.RIG_TOPICS)
    mon = WindowMonitor(cfg.rig, cfg.drive, k=cfg.friction.k)
    t = np.arange(tq.size) / FS
    out = []
    for a in range(0, t.size, 100):
        s = slice(a, a + 100)
        out += mon.push(t[s], tq[s], acc[s], sp[s])
    return out


@pytest.mark.slow
def test_monitor_node_on_replayed_bag(tmp_path: Path, procs: list[Proc]) -> None:
    bag = tmp_path / 'session'
    make_rig_bag(bag, SECONDS, fs=FS)
    node = start_node(procs, tmp_path, 'model_monitor', 'model_monitor.yaml', 'model monitor:')
    out_bag = tmp_path / 'windows'
    rec = start_recorder(
        procs, tmp_path, out_bag, ('/model/discrepancy', '/rig/torsion_moment'),
        matched=('/model/discrepancy',),
    )  # fmt: skip
    replay(procs, tmp_path, bag, 1.0, wait_subscribers=30.0)
    last_end = 1.0 + SECONDS - 1 / FS  # stream time of the bag: 1 s + index/fs
    assert wait_for(
        lambda: any(
            abs(m.t_end - last_end) < 1e-6 for m in bag_so_far(out_bag) if hasattr(m, 'ratio')
        ),
        60,
        0.5,
    ), (rec.output(), node.output(), (tmp_path / 'replay.log').read_text())
    assert rec.stop() == 0, rec.output()
    windows = list(bagio.iter_messages(out_bag, ['/model/discrepancy']))
    torsion = list(bagio.iter_messages(out_bag, ['/rig/torsion_moment']))
    # receive time of the block holding each sample index
    first = np.array([int(m.msg.first_index) for m in torsion])
    recv = np.array([m.timestamp_ns for m in torsion]) * 1e-9
    hop = 2.0
    offline = _offline(bag)
    assert len(offline) == 2
    ends = [round(w.msg.t_end - 1.0, 3) for w in windows]
    assert ends == [6.0, 8.0], (ends, node.output())
    for w in windows:
        x = w.msg
        k = round((x.t_end - 1.0 - 6.0) / hop)
        off = offline[k]
        assert x.n_samples == round(6.0 * FS) and x.quality in ('ok', 'over_budget'), x
        assert x.t_end - 1.0 == pytest.approx(6.0 + hop * k - 1 / FS, abs=1e-6)
        assert x.t_end - x.t_start == pytest.approx(6.0 - 1 / FS, abs=1e-6)
        last_index = round((x.t_end - 1.0) * FS)
        j = int(np.searchsorted(first, last_index, side='right')) - 1
        latency = w.timestamp_ns * 1e-9 - recv[j]
        # published after its last block arrived, and its processing time is in the
        # latency
        assert latency > 0.0 and x.processing_time < latency + 0.5, (k, latency, x)
        # the node computes what the core computes on the same samples
        assert x.residual_rms == pytest.approx(off.residual_rms, rel=1e-9)
        assert x.noise_floor == pytest.approx(off.noise_floor, rel=1e-9)
        assert x.mu0 == pytest.approx(off.mu0, rel=1e-9)
        assert x.candidate == off.candidate == ''
        assert 0.9 < x.ratio < 1.3
