"""Writing tribo sessions as rosbag2 bags (MCAP by default, sqlite3 on request).

A topic enters the bag with its first message (no empty topic entries), with the
QoS its publishers offer in the graph (``offered_qos_profiles``, so that ``ros2 bag
play`` recreates the latched result topics) and ``ros_distro: jazzy``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, Writer

from tribo_bringup.errors import BagError
from tribo_common.bag_types import ROS_DISTRO, offered_qos, typestore


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
        self._conns: dict[str, Connection] = {}
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
        """Open the bag for writing."""
        return self.open()

    def __exit__(self, *exc: object) -> None:
        """Close the bag."""
        self.close()

    def add_topic(self, topic: str, msgtype: str) -> bool:
        """Register a topic (written into the bag with its first message).

        Parameters
        ----------
        topic : str
            Fully qualified topic name.
        msgtype : str
            Rosbags type name.

        Returns
        -------
        bool
            False (with a warning) for an unknown type.
        """
        if topic in self._types:
            return True
        if msgtype not in typestore().types:
            warnings.warn(f'not recording {topic}: unknown message type {msgtype}', stacklevel=2)
            return False
        self._types[topic] = msgtype
        return True

    def _connection(self, topic: str) -> Connection:
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

    def write_msg(self, topic: str, timestamp_ns: int, msg: object) -> None:
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
