"""Bag I/O without DDS: write, read, continuity check, truncation, unknown types."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from tribo_bringup import bagio
from tribo_bringup.errors import BagError, BagTruncatedError


def _write(
    path: Path, n: int, skip: int | None = None, storage: str = 'mcap', samples: int = 100
) -> None:
    store = bagio.typestore()
    SB = store.types['tribo_msgs/msg/SampleBlock']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    with bagio.BagWriter(path, storage=storage) as w:
        w.add_topic('/rig/speed', 'tribo_msgs/msg/SampleBlock')
        for k in range(n):
            if k == skip:
                continue
            m = SB(
                header=Header(stamp=Time(sec=k, nanosec=0), frame_id='speed'),
                sample_rate=1e4,
                first_index=k * samples,
                unit='rad/s',
                data=np.arange(samples, dtype=float) + k,
            )
            w.write_msg('/rig/speed', k * 10_000_000, m)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_roundtrip_and_gap_check(tmp_path: Path, storage: str) -> None:
    bag = tmp_path / 'b'
    _write(bag, 30, skip=10, storage=storage)
    msgs = list(bagio.iter_messages(bag))
    assert len(msgs) == 29
    assert msgs[0].msg.data[5] == 5.0 and msgs[-1].msg.first_index == 2900
    (c,) = bagio.check_streams(bag)
    assert (c.messages, c.samples, c.missing, c.gaps, c.duplicates) == (29, 2900, 100, 1, 0)


def test_truncated_bag_yields_good_messages_then_names_last(tmp_path: Path) -> None:
    bag = tmp_path / 'b'
    # ~6 MB of samples: several 1 MiB MCAP chunks
    _write(bag, 800, samples=1000)
    mcap = next(bag.glob('*.mcap'))
    cut = tmp_path / 'cut'
    cut.mkdir()
    data = mcap.read_bytes()
    (cut / mcap.name).write_bytes(data[: int(len(data) * 0.6)])  # no metadata, torn chunk
    good = []
    with pytest.raises(BagTruncatedError) as err:
        for m in bagio.iter_messages(cut):
            good.append(int(m.msg.first_index))
    # every complete chunk before the cut was read, in order, without loss
    assert len(good) > 200
    assert good == [k * 1000 for k in range(len(good))]
    text = str(err.value)
    assert str(cut) in text and f'#{len(good) - 1}' in text and '/rig/speed' in text
    # with on_error='warn' the same good messages come back and a warning is issued
    with pytest.warns(UserWarning, match='truncated'):
        again = [int(m.msg.first_index) for m in bagio.iter_messages(cut, on_error='warn')]
    assert again == good


def test_missing_bag_and_not_a_bag(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='no such bag'):
        list(bagio.iter_messages(tmp_path / 'nope'))
    junk = tmp_path / 'junk.mcap'
    junk.write_bytes(b'not an mcap file at all')
    with pytest.raises(BagError, match='bad magic'):
        list(bagio.iter_messages(junk))
    empty = tmp_path / 'empty.mcap'
    empty.write_bytes(b'')
    with pytest.raises(BagError, match='empty MCAP file'):
        list(bagio.iter_messages(empty))


def test_unknown_type_is_skipped_with_warning(tmp_path: Path) -> None:
    bag = tmp_path / 'b'
    with bagio.BagWriter(bag) as w, pytest.warns(UserWarning, match='unknown message type'):
        assert not w.add_topic('/x', 'nosuch_msgs/msg/Thing')
    assert list(bagio.iter_messages(bag)) == []


def test_existing_output_refused(tmp_path: Path) -> None:
    _write(tmp_path / 'b', 2)
    with pytest.raises(BagError, match='already exists'):
        bagio.BagWriter(tmp_path / 'b')
    shutil.rmtree(tmp_path / 'b')


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_flushed_messages_survive_a_crash_of_the_writer(tmp_path: Path, storage: str) -> None:
    """What a killed recorder leaves on disk (no close, no metadata.yaml) reads back
    up to the last flush: nothing flushed is lost, nothing unflushed is invented."""
    store = bagio.typestore()
    SB = store.types['tribo_msgs/msg/SampleBlock']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    bag = tmp_path / 'live'
    w = bagio.BagWriter(bag, storage=storage)
    w.__enter__()
    w.add_topic('/rig/speed', 'tribo_msgs/msg/SampleBlock')
    for k in range(300):
        m = SB(
            header=Header(stamp=Time(sec=k, nanosec=0), frame_id='speed'),
            sample_rate=1e4,
            first_index=k * 100,
            unit='rad/s',
            data=np.full(100, float(k)),
        )
        w.write_msg('/rig/speed', (k + 1) * 10_000_000, m)
        if k == 199:
            w.flush()  # 200 blocks (~170 kB, well inside one 1 MiB MCAP chunk)
            crashed = tmp_path / 'crashed'
            shutil.copytree(bag, crashed)  # the files as a crash at this instant leaves them
    assert not (crashed / 'metadata.yaml').exists()
    got = [int(m.msg.first_index) for m in bagio.iter_messages(crashed)]
    assert got == [k * 100 for k in range(200)]
    w.close()
    assert len(list(bagio.iter_messages(bag))) == 300


def _cdr(msgtype: str) -> bytes:
    """CDR bytes of a default message (rclpy serialisation, no DDS)."""
    pytest.importorskip('tribo_msgs', reason='needs the built workspace')
    from rclpy.serialization import serialize_message

    from tribo_bringup.recorder import msg_class

    return bytes(serialize_message(msg_class(msgtype)()))


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_metadata_qos_distro_and_no_empty_topics(tmp_path: Path, storage: str) -> None:
    """What `ros2 bag info/play` read: the offered QoS per topic (latched results as
    TRANSIENT_LOCAL), the distro, and only topics that hold messages."""
    import sqlite3

    import yaml
    from rosbags.interfaces import QosDurability, QosHistory
    from rosbags.rosbag2 import Reader

    bag = tmp_path / 'b'
    with bagio.BagWriter(bag, storage=storage) as w:
        for topic in ('/rig/speed', '/friction/estimate', '/nvct/wear', '/rigB/nvct/wear'):
            assert w.add_topic(
                topic,
                bagio.TOPIC_TYPES['/' + topic.split('/', 2)[-1]]
                if topic.startswith('/rigB')
                else bagio.TOPIC_TYPES[topic],
            )
        w.write('/friction/estimate', 1_000_000_000, _cdr('tribo_msgs/msg/FrictionEstimate'))
        w.write('/rigB/nvct/wear', 1_000_000_000, _cdr('tribo_msgs/msg/WearState'))
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['ros_distro'] == 'jazzy'
    names = [t['topic_metadata']['name'] for t in meta['topics_with_message_count']]
    assert sorted(names) == ['/friction/estimate', '/rigB/nvct/wear']  # no 0-message entries
    with Reader(bag) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
    for topic in names:
        (q,) = qos[topic]
        assert q.durability == QosDurability.TRANSIENT_LOCAL, topic
        assert q.history == QosHistory.KEEP_LAST and q.depth == 20_000, topic
    if storage == 'sqlite3':
        (db,) = bag.glob('*.db3')
        con = sqlite3.connect(db)
        try:
            assert con.execute('SELECT ros_distro FROM schema').fetchone() == ('jazzy',)
        finally:
            con.close()


def test_stream_topics_offer_keep_all_volatile() -> None:
    from rosbags.interfaces import QosDurability, QosHistory, QosReliability

    for topic in ('/rig/torsion_moment', '/rigA/rig/speed', '/friction/moment'):
        (q,) = bagio.offered_qos(topic)
        assert q.history == QosHistory.KEEP_ALL and q.durability == QosDurability.VOLATILE
        assert q.reliability == QosReliability.RELIABLE


def test_namespace_discovery_and_selection(tmp_path: Path) -> None:
    """Rigs recorded in namespaces: listed, read one by one under the root names; the
    only rig of a bag found by itself; several rigs without a choice refused."""
    store = bagio.typestore()
    SB = store.types['tribo_msgs/msg/SampleBlock']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    two, one = tmp_path / 'two', tmp_path / 'one'
    for bag, spaces in ((two, ('/rigA', '/rigB')), (one, ('/rigB',))):
        with bagio.BagWriter(bag) as w:
            for k, ns in enumerate(spaces):
                w.add_topic(f'{ns}/rig/speed', 'tribo_msgs/msg/SampleBlock')
                m = SB(
                    header=Header(stamp=Time(sec=1, nanosec=0), frame_id='speed'),
                    sample_rate=1e4, first_index=0, unit='rad/s', data=np.full(10, float(k)),
                )  # fmt: skip
                w.write_msg(f'{ns}/rig/speed', 1_000_000_000, m)
    assert bagio.rig_namespaces(two) == ['/rigA', '/rigB']
    got = list(bagio.iter_messages(two, ['/rig/speed'], namespace='rigB'))
    assert [(m.topic, float(m.msg.data[0])) for m in got] == [('/rig/speed', 1.0)]
    got = list(bagio.iter_messages(one, ['/rig/speed']))
    assert [(m.topic, float(m.msg.data[0])) for m in got] == [('/rig/speed', 0.0)]
    with pytest.raises(BagError, match='rigA, /rigB'):
        list(bagio.iter_messages(two, ['/rig/speed']))
