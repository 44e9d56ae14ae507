"""The graph end to end: simulated rig -> topics -> bag (tribo record) -> replay.

Uses DDS (own ROS_DOMAIN_ID, localhost discovery, see conftest).
"""

from __future__ import annotations

import os
import shutil
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from replay_harness import replay, start_recorder, start_replay
from support import Proc, bag_so_far, requires_ros, tribo_cmd, wait_for

from tribo_bringup import bagio

pytestmark = [requires_ros, pytest.mark.ros]


def _sim_rig(tmp_path: Path, name: str, *extra: str) -> Proc:
    exe = shutil.which('sim_rig')
    assert exe, 'sim_rig not on PATH (env.sh)'
    return Proc([exe, '--ros-args', '-p', 'seed:=7', *extra], tmp_path / f'{name}.log')


@pytest.mark.slow
def test_record_sim_rig_no_missing_samples(tmp_path: Path, procs: list[Proc]) -> None:
    bag = tmp_path / 'session'
    sim = _sim_rig(tmp_path, 'sim')
    procs.append(sim)
    # the numba kernel may compile on first use: wait until the stream runs
    assert wait_for(lambda: 'streaming started' in sim.output(), 300), sim.output()
    rec = Proc(
        tribo_cmd('record', '--duration', '6', '--out', str(bag), '--topics', *bagio.RIG_TOPICS),
        tmp_path / 'record.log',
    )
    procs.append(rec)
    assert rec.wait(60) == 0, rec.output()
    checks = {c.topic: c for c in bagio.check_streams(bag)}
    assert set(checks) == set(bagio.RIG_TOPICS), rec.output()
    for c in checks.values():
        # about 5 s of 10 kHz data, contiguous from the first block received
        assert c.samples >= 30_000, c
        assert c.missing == 0 and c.duplicates == 0, c
    # the bag opens with rosbags' AnyReader too (what ros2 bag info / other tools read)
    from rosbags.highlevel import AnyReader

    with AnyReader([bag], default_typestore=bagio.typestore()) as reader:
        conns = [c for c in reader.connections if c.topic == '/rig/torsion_moment']
        n = 0
        for conn, _t, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            assert msg.sample_rate == 10000.0
            assert np.all(np.isfinite(msg.data))
            n += 1
        assert n == checks['/rig/torsion_moment'].messages


def _speed_bag(src: Path) -> None:
    """A small synthetic bag: 200 blocks of 50 samples on /rig/speed, 1 s long."""
    store = bagio.typestore()
    SB = store.types['tribo_msgs/msg/SampleBlock']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    with bagio.BagWriter(src) as w:
        w.add_topic('/rig/speed', 'tribo_msgs/msg/SampleBlock')
        for k in range(200):
            m = SB(
                header=Header(stamp=Time(sec=0, nanosec=k * 5_000_000), frame_id='speed'),
                sample_rate=1e4,
                first_index=k * 50,
                unit='rad/s',
                data=np.full(50, float(k)),
            )
            w.write_msg('/rig/speed', 1_000_000_000 + k * 5_000_000, m)


def _record_replayed_speed_bag(
    tmp_path: Path, procs: list[Proc], out: Path, *record_args: str
) -> Proc:
    """`tribo record` into ``out`` while `tribo replay` publishes the speed bag; returns
    the still running recorder once all 200 messages are flushed to ``out``."""
    src = tmp_path / 'src_bag'
    _speed_bag(src)
    rec = start_recorder(procs, tmp_path, out, ('/rig/speed',), *record_args)
    # replay waits until the recorder's subscription has matched, however slow its start
    replay(procs, tmp_path, src, 2.0)
    assert wait_for(lambda: len(bag_so_far(out)) == 200, 60, interval=0.5), rec.output()
    return rec


def test_replay_republishes_every_message(tmp_path: Path, procs: list[Proc]) -> None:
    out = tmp_path / 'copy'
    rec = _record_replayed_speed_bag(tmp_path, procs, out, '--idle-stop', '3')
    # the recorder stops by itself 3 s after the last message it received
    assert rec.wait(120) == 0, rec.output()
    assert 'no message for 3 s' in rec.output()
    got = [m.msg for m in bagio.iter_messages(out)]
    assert [int(m.first_index) for m in got] == [k * 50 for k in range(200)]
    assert all(float(m.data[0]) == k for k, m in enumerate(got))


def test_replay_without_subscribers_says_so(tmp_path: Path, procs: list[Proc]) -> None:
    src = tmp_path / 'src_bag'
    _speed_bag(src)
    rep = start_replay(procs, tmp_path, src, 0.0, wait_subscribers=0.5)
    assert rep.wait(60) == 0, rep.output()
    # nobody subscribes on this test's domain: the wait ends, the replay says which
    # topic lacked subscribers and publishes all the same
    assert 'fewer than 1 subscriber(s) after 0.5 s on /rig/speed (0)' in rep.output()
    assert 'published 200 messages' in rep.output(), rep.output()


def test_record_rejects_existing_output(tmp_path: Path) -> None:
    import subprocess

    (tmp_path / 'exists').mkdir()
    r = subprocess.run(
        tribo_cmd('record', '--duration', '1', '--out', str(tmp_path / 'exists')),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2
    assert 'already exists' in r.stderr and r.stderr.count('\n') == 1


def test_wait_for_helper() -> None:
    assert wait_for(lambda: True, 0.1)


def test_killed_recorder_keeps_what_it_flushed(tmp_path: Path, procs: list[Proc]) -> None:
    """SIGKILL (no clean close, no metadata.yaml): every message the recorder had
    flushed (it flushes every second) is read back from the cut-off bag."""
    out = tmp_path / 'killed'
    rec = _record_replayed_speed_bag(tmp_path, procs, out)
    os.killpg(rec.popen.pid, signal.SIGKILL)
    rec.popen.wait()
    assert not (out / 'metadata.yaml').exists()
    got = [m.msg for m in bagio.iter_messages(out)]
    assert [int(m.first_index) for m in got] == [k * 50 for k in range(200)]


@pytest.mark.slow
def test_tribo_run_records_the_graph_without_loss(tmp_path: Path, procs: list[Proc]) -> None:
    """`tribo run` (the graph runner): simulated rig + friction estimator + recorder
    in one process and one executor, no sample missing."""
    bag = tmp_path / 'run'
    run = Proc(
        tribo_cmd(
            'run',
            '--nodes',
            'sim_rig',
            'friction_estimator',
            '--duration',
            '5',
            '--record',
            str(bag),
        ),
        tmp_path / 'run.log',
    )
    procs.append(run)
    assert run.wait(180) == 0, run.output()
    checks = {c.topic: c for c in bagio.check_streams(bag)}
    for topic in (*bagio.RIG_TOPICS, '/friction/moment'):
        c = checks[topic]
        # the stream starts when the rig's numba kernel is loaded: >= 2 s of the 5 s
        assert c.samples >= 20_000 and c.missing == 0 and c.duplicates == 0, (c, run.output())
    estimates = [m.msg for m in bagio.iter_messages(bag, ['/friction/estimate'])]
    assert estimates, run.output()
    assert all(0.05 < e.mu0 < 0.3 for e in estimates if e.quality == 'ok'), estimates


def test_record_sqlite3_holds_the_data(tmp_path: Path, procs: list[Proc]) -> None:
    """`tribo record --storage sqlite3` writes every message (the writer thread owns the
    sqlite connection); the bag opens with rosbags' AnyReader."""
    from rosbags.highlevel import AnyReader

    src, out = tmp_path / 'src_bag', tmp_path / 'copy_sqlite'
    _speed_bag(src)
    rec = start_recorder(
        procs, tmp_path, out, ('/rig/speed',), '--storage', 'sqlite3', '--idle-stop', '3'
    )
    replay(procs, tmp_path, src, 2.0)
    assert rec.wait(120) == 0, rec.output()
    assert list(out.glob('*.db3')), rec.output()
    with AnyReader([out], default_typestore=bagio.typestore()) as reader:
        got = [
            reader.deserialize(raw, conn.msgtype)
            for conn, _t, raw in reader.messages(connections=reader.connections)
        ]
    assert [int(m.first_index) for m in got] == [k * 50 for k in range(200)], rec.output()


_FSIZE_LIMITED = (
    'import resource, runpy, sys; '
    'resource.setrlimit(resource.RLIMIT_FSIZE, ({0}, {0})); '
    "sys.argv = ['tribo', *sys.argv[1:]]; "
    "runpy.run_module('tribo_bringup.cli', run_name='__main__')"
)


@pytest.mark.parametrize('storage', ['sqlite3', 'mcap'])
def test_recording_error_ends_with_nonzero_exit(
    tmp_path: Path, procs: list[Proc], storage: str
) -> None:
    """A storage failure while recording (here: the file size limit, as a full disk
    would) ends `tribo record` with one clear line and exit 2; the messages written
    before stay readable."""
    src, out = tmp_path / 'src_bag', tmp_path / 'limited'
    _speed_bag(src)
    limited = [sys.executable, '-c', _FSIZE_LIMITED.format(60_000)]
    rec = start_recorder(
        procs, tmp_path, out, ('/rig/speed',), '--storage', storage, command=limited
    )
    start_replay(procs, tmp_path, src, 0.25)
    assert rec.wait(120) == 2, rec.output()
    assert 'tribo record: error: recording into' in rec.output(), rec.output()
    assert 'Traceback' not in rec.output()
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        got = [m.msg for m in bagio.iter_messages(out, on_error='warn')]
    assert got, rec.output()
    assert [int(m.first_index) for m in got] == [k * 50 for k in range(len(got))]


@pytest.mark.slow
def test_sim_rig_waits_for_the_recorder(tmp_path: Path, procs: list[Proc]) -> None:
    """With min_subscribers the rig holds its stream until the recorder has matched:
    the bag starts at sample 0 (a launch with record:=true lost the first 0.6 s)."""
    sim = _sim_rig(tmp_path, 'sim', '-p', 'min_subscribers:=1', '-p', 'wait_subscribers:=300.0')
    procs.append(sim)
    assert wait_for(lambda: 'simulated rig at' in sim.output(), 60), sim.output()
    wait_for(lambda: False, 3.0)  # the kernel is loaded by now; the rig must still wait
    assert 'streaming started' not in sim.output(), sim.output()
    bag = tmp_path / 'from_start'
    rec = Proc(
        tribo_cmd('record', '--duration', '4', '--out', str(bag), '--topics', *bagio.RIG_TOPICS),
        tmp_path / 'record.log',
    )
    procs.append(rec)
    assert rec.wait(60) == 0, rec.output()
    checks = {c.topic: c for c in bagio.check_streams(bag)}
    assert set(checks) == set(bagio.RIG_TOPICS), rec.output() + sim.output()
    for c in checks.values():
        # the point is the start at sample 0 without loss; how many samples fit into the
        # recorder's 4 s after its own start-up and the match depends on the machine's load
        # (0.1 s of data shows that the stream really ran)
        assert c.first_index == 0 and c.missing == 0 and c.samples >= 1_000, c
