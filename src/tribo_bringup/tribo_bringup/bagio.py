"""Reading and writing tribo sessions as rosbag2 bags with the ``rosbags`` library.

No rosbag2 or ROS CLI is needed: bags are written as rosbag2 directories
(``metadata.yaml`` + MCAP by default, sqlite3 on request) that ``ros2 bag
info`` opens on a full ROS install, and read back with rosbags.

The tribo_msgs types are registered in a rosbags typestore from the
``.msg`` files (installed share directory, or the source tree).

Robustness:
- A bag whose recording was cut off (no ``metadata.yaml``, or an MCAP file
  without its summary, or a file that ends in the middle of a record) is read
  up to the last complete message: every good message is yielded first, then
  :class:`~tribo_bringup.errors.BagTruncatedError` names the file and the last
  good message (or, with ``on_error='warn'``, a warning is issued instead).
- Connections of unknown message types are skipped with a warning.

Namespaces: the graph's topic names are relative (:mod:`tribo_common.topics`), so a
rig started in namespace ``/rigB`` is recorded as ``/rigB/rig/torsion_moment``.
:func:`rig_namespaces` lists the rigs of a bag; :func:`iter_messages` with
``namespace`` reads one rig under the root-namespace names (``/rig/...``), and
without it finds the only rig of a bag by itself.

Writing: a topic enters the bag with its first message (no empty topic entries),
with the QoS its publishers offer in the graph (``offered_qos_profiles``, so that
``ros2 bag play`` recreates the latched result topics) and ``ros_distro: jazzy``.
"""

from __future__ import annotations

import struct
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from tribo_bringup.errors import BagError, BagTruncatedError
from tribo_common import topics as topic_table

#: Message types of this project, by rosbags name.
TRIBO_TYPES = ('SampleBlock', 'DetectorCounts', 'FrictionEstimate', 'WearState', 'ModelDiscrepancy')

#: The graph's topics (root-namespace names) and their types, from the topic table.
TOPIC_TYPES: dict[str, str] = {t.resolve(): t.msgtype for t in topic_table.TOPICS}

#: The rig's raw sample streams (root-namespace names).
RIG_TOPICS = tuple(t.resolve() for t in topic_table.RIG_STREAMS)

#: ``ros_distro`` written into the bags (the one the workspace targets).
ROS_DISTRO = 'jazzy'

_INFINITE = QosTime(sec=9223372036, nsec=854775807)


def offered_qos(topic: str) -> list[Qos]:
    """The ``offered_qos_profiles`` of a topic (fully qualified, any namespace) in a bag.

    What a publisher of the topic offers in the graph (:mod:`tribo_common.qos`):
    reliable KEEP_ALL volatile streams, reliable TRANSIENT_LOCAL results with a
    history of :data:`tribo_common.topics.HISTORY_DEPTH`, KEEP_LAST 10
    status. Unknown topics: the stream QoS.
    """
    entry = topic_table.by_full_name(topic)
    kind = entry.qos if entry is not None else topic_table.QosKind.DATA
    if kind is topic_table.QosKind.HISTORY:
        history, depth, durability = (
            QosHistory.KEEP_LAST,
            topic_table.HISTORY_DEPTH,
            QosDurability.TRANSIENT_LOCAL,
        )
    elif kind is topic_table.QosKind.STATUS:
        history, depth, durability = QosHistory.KEEP_LAST, 10, QosDurability.VOLATILE
    else:
        history, depth, durability = QosHistory.KEEP_ALL, 0, QosDurability.VOLATILE
    return [
        Qos(
            history=history,
            depth=depth,
            reliability=QosReliability.RELIABLE,
            durability=durability,
            deadline=_INFINITE,
            lifespan=_INFINITE,
            liveliness=QosLiveliness.AUTOMATIC,
            liveliness_lease_duration=_INFINITE,
            avoid_ros_namespace_conventions=False,
        )
    ]


OnError = Literal['raise', 'warn']


def msg_dir() -> Path:
    """Directory holding the tribo_msgs ``.msg`` files (installed or source)."""
    try:
        from ament_index_python.packages import get_package_share_directory

        share = Path(get_package_share_directory('tribo_msgs')) / 'msg'
        if share.is_dir():
            return share
    except Exception:  # not on an ament path: fall back to the source tree
        pass
    src = Path(__file__).resolve().parents[2] / 'tribo_msgs' / 'msg'
    if src.is_dir():
        return src
    raise BagError('cannot find the tribo_msgs .msg files (workspace not built?)')


@lru_cache(maxsize=1)
def typestore() -> Typestore:
    """A ROS 2 Jazzy typestore with the tribo_msgs types registered."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    base = msg_dir()
    for name in TRIBO_TYPES:
        text = (base / f'{name}.msg').read_text(encoding='utf-8')
        types.update(get_types_from_msg(text, f'tribo_msgs/msg/{name}'))
    store.register(types)
    return store


@dataclass(frozen=True)
class BagMessage:
    """One message read from a bag.

    Attributes:
        topic: topic name.
        msgtype: rosbags type name, e.g. ``tribo_msgs/msg/SampleBlock``.
        timestamp_ns: receive time recorded in the bag [ns].
        msg: the deserialised message (rosbags dataclass; arrays are numpy).
        index: position of the message in the bag's time order (0-based).
    """

    topic: str
    msgtype: str
    timestamp_ns: int
    msg: Any
    index: int


def _describe(last: BagMessage | None) -> str:
    if last is None:
        return 'no good message before it'
    return f'last good message #{last.index} on {last.topic} at t={last.timestamp_ns * 1e-9:.6f} s'


def iter_messages(
    path: str | Path,
    topics: Iterable[str] | None = None,
    *,
    on_error: OnError = 'raise',
    deserialize: bool = True,
    namespace: str | None = None,
) -> Iterator[BagMessage]:
    """Yield the messages of a bag in time order.

    Args:
        path: bag directory (rosbag2) or a single ``.mcap`` file.
        topics: restrict to these topics (default: all known ones).
        on_error: ``'raise'`` a BagTruncatedError after the last good message
            of a truncated/corrupt bag, or ``'warn'`` and stop there.
        namespace: read the rig of this namespace (e.g. ``/rigB``): ``topics``
            are root-namespace names (``/rig/speed``) looked up in it, and the
            messages are yielded under the root-namespace names. ``None`` with
            ``topics`` given: when none of them is in the bag but they are in
            exactly one namespace, that one (:func:`find_namespace`).
    """
    bag = Path(path)
    if not bag.exists():
        raise BagError(f'{bag}: no such bag')
    if topics is not None:
        topics = list(topics)
        if namespace is None:
            namespace = find_namespace(bag, topics)
    ns = topic_table.normalize_namespace(namespace)
    if ns:
        if topics is None:
            raise BagError('reading a namespace needs the list of topics to read')
        inner = iter_messages(
            bag, [ns + t for t in topics], on_error=on_error, deserialize=deserialize,
            namespace='',
        )  # fmt: skip
        for m in inner:
            yield BagMessage(m.topic[len(ns) :], m.msgtype, m.timestamp_ns, m.msg, m.index)
        return
    wanted = set(topics) if topics is not None else None
    store = typestore()
    last: BagMessage | None = None
    try:
        if bag.is_dir() and (bag / 'metadata.yaml').is_file():
            source: Iterator[tuple[str, str, int, bytes]] = _iter_rosbag2(bag, wanted, store)
        elif _sqlite_files(bag):
            source = _iter_raw_sqlite(bag, wanted, store)
        else:
            source = _iter_raw_mcap(bag, wanted, store)
        count = 0
        for topic, msgtype, stamp, raw in source:
            if not deserialize:
                last = BagMessage(topic, msgtype, stamp, raw, count)
                count += 1
                yield last
                continue
            try:
                msg = store.deserialize_cdr(raw, msgtype)
            except Exception as exc:  # any decode failure is corruption
                raise _CorruptError(f'message on {topic} cannot be decoded ({exc})') from exc
            last = BagMessage(topic, msgtype, stamp, msg, count)
            count += 1
            yield last
    except _CorruptError as exc:
        text = f'{bag}: bag is truncated or corrupt ({exc}); {_describe(last)}'
        if on_error == 'warn':
            warnings.warn(text, stacklevel=2)
            return
        raise BagTruncatedError(text) from None


def bag_topics(path: str | Path) -> dict[str, str]:
    """Topic name -> message type of every topic in a bag (metadata, else a raw scan)."""
    bag = Path(path)
    if bag.is_dir() and (bag / 'metadata.yaml').is_file():
        try:
            with Reader(bag) as reader:
                return {c.topic: c.msgtype for c in reader.connections}
        except Exception:  # damaged storage: fall back to the scan below
            pass
    found: dict[str, str] = {}
    with warnings.catch_warnings():
        warnings.simplefilter('ignore')
        for m in iter_messages(bag, on_error='warn', deserialize=False, namespace=''):
            found.setdefault(m.topic, m.msgtype)
    return found


def rig_namespaces(path: str | Path, topics: Iterable[str] = RIG_TOPICS) -> list[str]:
    """Namespaces holding any of ``topics`` (root-namespace names) in a bag, sorted.

    ``''`` is the root namespace; ``'/rigB'`` a rig started in namespace ``rigB``.
    """
    wanted = {t.lstrip('/') for t in topics}
    found = set()
    for name in bag_topics(path):
        for rel in wanted:
            if name == '/' + rel:
                found.add('')
            elif name.endswith('/' + rel):
                found.add(name[: -len(rel) - 1])
    return sorted(found)


def find_namespace(path: str | Path, topics: Iterable[str]) -> str:
    """The namespace to read ``topics`` from: the root if any is there, else the only one.

    Raises:
        BagError: the topics are in several namespaces and none at the root.
    """
    names = list(topics)
    bag = Path(path)
    if not bag.exists():
        raise BagError(f'{bag}: no such bag')
    try:
        spaces = rig_namespaces(bag, names)
    except BagError:
        return ''
    if not spaces or '' in spaces:
        return ''
    if len(spaces) == 1:
        return spaces[0]
    raise BagError(
        f'{bag}: holds {", ".join(names)} of several rigs (namespaces {", ".join(spaces)}); '
        'choose one with --namespace'
    )


class _CorruptError(Exception):
    """Internal: the byte stream of a bag ends or breaks here."""


def _iter_rosbag2(
    bag: Path, wanted: set[str] | None, store: Typestore
) -> Iterator[tuple[str, str, int, bytes]]:
    try:
        reader = Reader(bag)
        reader.open()
    except Exception as exc:  # rosbags raises several types
        # metadata present but the storage file is damaged: scan it raw
        files = sorted(bag.glob('*.mcap'))
        if files:
            for f in files:
                yield from _iter_raw_mcap(f, wanted, store)
            return
        raise BagError(f'{bag}: cannot open bag: {exc}') from exc
    try:
        conns = []
        for conn in reader.connections:
            if wanted is not None and conn.topic not in wanted:
                continue
            if conn.msgtype not in store.types:
                warnings.warn(
                    f'{bag}: skipping topic {conn.topic}: unknown message type {conn.msgtype}',
                    stacklevel=3,
                )
                continue
            conns.append(conn)
        if not conns:
            return
        try:
            for conn, stamp, raw in reader.messages(connections=conns):
                yield conn.topic, conn.msgtype, int(stamp), bytes(raw)
        except Exception as exc:  # rosbags raises several types
            raise _CorruptError(str(exc)) from exc
    finally:
        reader.close()


# --- tolerant MCAP scanner -------------------------------------------------
# Used when a recording was cut off (no metadata.yaml / no summary / torn
# record). Reads records front to back; chunks are decompressed if needed.

_MAGIC = b'\x89MCAP0\r\n'
_OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_FOOTER, _OP_DATA_END = (
    0x03,
    0x04,
    0x05,
    0x06,
    0x02,
    0x0F,
)


@dataclass
class _McapState:
    schemas: dict[int, str] = field(default_factory=dict)
    channels: dict[int, tuple[str, str]] = field(default_factory=dict)


def _read_str(buf: memoryview, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from('<I', buf, pos)
    pos += 4
    return bytes(buf[pos : pos + n]).decode('utf-8'), pos + n


def _records(data: memoryview) -> Iterator[tuple[int, memoryview]]:
    pos = 0
    end = len(data)
    while pos < end:
        if end - pos < 9:
            raise _CorruptError(f'record header cut off at byte {pos}')
        op = data[pos]
        (length,) = struct.unpack_from('<Q', data, pos + 1)
        body_start = pos + 9
        if body_start + length > end:
            raise _CorruptError(f'record (op 0x{op:02x}) cut off at byte {pos}')
        yield op, data[body_start : body_start + length]
        pos = body_start + length


def _decompress(compression: str, payload: bytes, size: int) -> bytes:
    if compression == '':
        return payload
    if compression == 'zstd':
        try:
            from compression import zstd  # type: ignore[import-not-found]
        except ImportError:
            from backports import zstd  # type: ignore[import-not-found,no-redef]
        return bytes(zstd.decompress(payload))
    if compression == 'lz4':
        import lz4.frame

        return bytes(lz4.frame.decompress(payload))
    raise _CorruptError(f'unsupported chunk compression {compression!r}')


def _iter_raw_mcap(
    path: Path, wanted: set[str] | None, store: Typestore
) -> Iterator[tuple[str, str, int, bytes]]:
    files = sorted(path.glob('*.mcap')) if path.is_dir() else [path]
    if not files:
        raise BagError(f'{path}: not a bag (no metadata.yaml and no .mcap file)')
    for file in files:
        data = memoryview(file.read_bytes())
        if len(data) == 0:
            raise BagError(f'{file}: empty MCAP file (recording cut off before its first flush)')
        if bytes(data[:8]) != _MAGIC:
            raise BagError(f'{file}: not an MCAP file (bad magic)')
        state = _McapState()
        yield from _scan(data[8:], state, wanted, store, file)


def _scan(
    data: memoryview,
    state: _McapState,
    wanted: set[str] | None,
    store: Typestore,
    file: Path,
) -> Iterator[tuple[str, str, int, bytes]]:
    for op, body in _records(data):
        if op == _OP_SCHEMA:
            (sid,) = struct.unpack_from('<H', body, 0)
            name, _ = _read_str(body, 2)
            state.schemas[sid] = name
        elif op == _OP_CHANNEL:
            cid, sid = struct.unpack_from('<HH', body, 0)
            topic, _ = _read_str(body, 4)
            msgtype = state.schemas.get(sid, '')
            if msgtype and msgtype not in store.types:
                warnings.warn(
                    f'{file}: skipping topic {topic}: unknown message type {msgtype}',
                    stacklevel=4,
                )
            state.channels[cid] = (topic, msgtype)
        elif op == _OP_MESSAGE:
            cid, _seq, log_time, _pub = struct.unpack_from('<HIQQ', body, 0)
            topic, msgtype = state.channels.get(cid, ('', ''))
            if not topic or msgtype not in store.types:
                continue
            if wanted is not None and topic not in wanted:
                continue
            yield topic, msgtype, int(log_time), bytes(body[22:])
        elif op == _OP_CHUNK:
            # start u64, end u64, uncompressed size u64, crc u32, compression str, records
            (usize,) = struct.unpack_from('<Q', body, 16)
            compression, pos = _read_str(body, 28)
            (rlen,) = struct.unpack_from('<Q', body, pos)
            payload = bytes(body[pos + 8 : pos + 8 + rlen])
            inner = memoryview(_decompress(compression, payload, usize))
            yield from _scan(inner, state, wanted, store, file)
        elif op in (_OP_DATA_END, _OP_FOOTER):
            return


# --- sqlite3 bag without metadata.yaml (recording cut off) -------------------


def _sqlite_files(path: Path) -> list[Path]:
    if path.is_dir():
        return sorted(path.glob('*.db3'))
    return [path] if path.suffix == '.db3' else []


def _iter_raw_sqlite(
    path: Path, wanted: set[str] | None, store: Typestore
) -> Iterator[tuple[str, str, int, bytes]]:
    import sqlite3

    for file in _sqlite_files(path):
        try:
            con = sqlite3.connect(f'file:{file}?mode=ro', uri=True)
        except sqlite3.Error as exc:
            raise BagError(f'{file}: cannot open sqlite3 bag ({exc})') from None
        try:
            topics = {
                int(tid): (str(name), str(kind))
                for tid, name, kind in con.execute('SELECT id, name, type FROM topics')
            }
            for tid, (topic, msgtype) in topics.items():
                if msgtype not in store.types:
                    warnings.warn(
                        f'{file}: skipping topic {topic}: unknown message type {msgtype}',
                        stacklevel=4,
                    )
                    topics[tid] = (topic, '')
            rows = con.execute('SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp')
            for tid, stamp, data in rows:
                topic, msgtype = topics.get(int(tid), ('', ''))
                if not msgtype or (wanted is not None and topic not in wanted):
                    continue
                yield topic, msgtype, int(stamp), bytes(data)
        except sqlite3.DatabaseError as exc:
            raise _CorruptError(f'sqlite3 file {file.name}: {exc}') from exc
        finally:
            con.close()


# --- writing ----------------------------------------------------------------


class BagWriter:
    """Write raw CDR messages into a rosbag2 bag (MCAP by default, or sqlite3).

    Use as a context manager; ``write`` takes already-serialised CDR bytes
    (as an rclpy raw subscription delivers them), so recording costs no
    deserialisation. A topic is registered with :meth:`add_topic` but enters
    the bag only with its first message. Not thread-safe: open, write and
    close from one thread (sqlite3 connections refuse any other thread).
    """

    def __init__(self, path: str | Path, *, storage: str = 'mcap') -> None:
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f'{self.path}: already exists (choose a new --out)')
        if storage not in ('mcap', 'sqlite3'):
            raise BagError(f'unknown bag storage {storage!r} (mcap or sqlite3)')
        self.storage = storage
        plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
        self._writer: Writer | None = Writer(self.path, version=9, storage_plugin=plugin)
        self._types: dict[str, str] = {}
        self._conns: dict[str, Any] = {}
        self._opened = False
        #: messages written per topic (topics without a message are not listed)
        self.counts: dict[str, int] = {}

    @property
    def is_open(self) -> bool:
        """True between :meth:`open` and :meth:`close`."""
        return self._opened and self._writer is not None

    def open(self) -> BagWriter:
        """Create the bag directory and its storage file."""
        if self._writer is None:
            raise BagError(f'{self.path}: bag already closed')
        if not self._opened:
            try:
                self._writer.open()
            except Exception as exc:  # rosbags raises several types
                raise BagError(f'{self.path}: cannot create bag: {exc}') from exc
            self._opened = True
        return self

    def __enter__(self) -> BagWriter:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def add_topic(self, topic: str, msgtype: str) -> bool:
        """Register a topic (written with its first message); False (with a warning)
        for an unknown type."""
        if topic in self._types:
            return True
        if msgtype not in typestore().types:
            warnings.warn(f'not recording {topic}: unknown message type {msgtype}', stacklevel=2)
            return False
        self._types[topic] = msgtype
        return True

    def _connection(self, topic: str) -> Any:
        conn = self._conns.get(topic)
        if conn is None:
            if self._writer is None or not self._opened:
                raise BagError(f'{self.path}: bag is not open')
            msgtype = self._types.get(topic)
            if msgtype is None:
                raise BagError(f'{self.path}: topic {topic} was not added')
            conn = self._writer.add_connection(
                topic, msgtype, typestore=typestore(), offered_qos_profiles=offered_qos(topic)
            )
            self._conns[topic] = conn
            self.counts[topic] = 0
        return conn

    def write(self, topic: str, timestamp_ns: int, raw: bytes) -> None:
        """Write one serialised message received at ``timestamp_ns`` [ns]."""
        self._writer_or_raise().write(self._connection(topic), int(timestamp_ns), raw)
        self.counts[topic] += 1

    def write_msg(self, topic: str, timestamp_ns: int, msg: Any) -> None:
        """Serialise a rosbags message object and write it."""
        msgtype = self._types.get(topic)
        if msgtype is None:
            raise BagError(f'{self.path}: topic {topic} was not added')
        self.write(topic, timestamp_ns, bytes(typestore().serialize_cdr(msg, msgtype)))

    def _writer_or_raise(self) -> Writer:
        if self._writer is None or not self._opened:
            raise BagError(f'{self.path}: bag is not open')
        return self._writer

    def flush(self) -> None:
        """Put everything written so far into the bag file, readable after a crash.

        MCAP: the pending chunk (up to 1 MiB in memory) is closed and the file
        buffer flushed to the OS. sqlite3: the open transaction is committed.
        A bag cut off after a flush (no ``metadata.yaml``) is read by
        :func:`iter_messages` up to this point.
        """
        storage = getattr(self._writer, 'storage', None)
        if storage is None:
            return
        chunk = getattr(storage, 'chunk', None)
        if chunk is not None and hasattr(storage, 'close_chunk'):  # rosbags McapWriter
            if chunk.bio.tell():
                storage.close_chunk()
            storage.bio.flush()
        conn = getattr(storage, 'conn', None)
        if conn is not None:  # rosbags Sqlite3Writer
            conn.commit()

    def close(self) -> None:
        """Finish the bag (writes metadata.yaml with ``ros_distro: jazzy``); idempotent."""
        writer, self._writer = self._writer, None
        if writer is None or not self._opened:
            return
        storage = writer.storage
        if storage is not None:
            cursor = getattr(storage, 'cursor', None)
            if cursor is not None:  # sqlite3: the schema table names the distro
                cursor.execute('UPDATE schema SET ros_distro = ?', (ROS_DISTRO,))
            close_storage = storage.close

            def close_with_distro(version: int, metadata: str) -> None:
                close_storage(version, _with_distro(metadata))

            storage.close = close_with_distro  # type: ignore[method-assign]
        writer.close()
        meta = self.path / 'metadata.yaml'
        if meta.is_file():
            meta.write_text(_with_distro(meta.read_text(encoding='utf-8')), encoding='utf-8')


def _with_distro(metadata: str) -> str:
    return metadata.replace('ros_distro: rosbags', f'ros_distro: {ROS_DISTRO}')


# --- checks -----------------------------------------------------------------


@dataclass(frozen=True)
class StreamCheck:
    """Continuity of one SampleBlock topic in a bag.

    Attributes:
        topic: topic name.
        messages: number of messages.
        samples: number of samples received.
        first_index: index of the first sample.
        expected: samples expected from the first to the last index.
        missing: samples missing (gaps between consecutive first indices).
        gaps: number of gaps.
        duplicates: samples received twice (overlaps).
    """

    topic: str
    messages: int
    samples: int
    first_index: int
    expected: int
    missing: int
    gaps: int
    duplicates: int


def check_streams(path: str | Path, topics: Iterable[str] | None = None) -> list[StreamCheck]:
    """Check the first-sample indices of every SampleBlock topic for gaps."""
    state: dict[str, list[int]] = {}
    for m in iter_messages(path, topics):
        if m.msgtype != 'tribo_msgs/msg/SampleBlock':
            continue
        n = len(m.msg.data)
        first = int(m.msg.first_index)
        s = state.setdefault(m.topic, [0, 0, first, first, 0, 0, 0])
        # s = [messages, samples, first, next_expected, missing, gaps, duplicates]
        if s[0] > 0:
            if first > s[3]:
                s[4] += first - s[3]
                s[5] += 1
            elif first < s[3]:
                s[6] += s[3] - first
        s[0] += 1
        s[1] += n
        s[3] = max(s[3], first + n)
    return [
        StreamCheck(t, s[0], s[1], s[2], s[3] - s[2], s[4], s[5], s[6])
        for t, s in sorted(state.items())
    ]


def bag_summary(path: str | Path) -> dict[str, int]:
    """Message count per topic (reads the whole bag; tolerant of truncation)."""
    counts: dict[str, int] = {}
    for m in iter_messages(path, on_error='warn'):
        counts[m.topic] = counts.get(m.topic, 0) + 1
    return counts
