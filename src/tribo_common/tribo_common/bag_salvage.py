"""Salvage of cut-off bags: tolerant raw scanners for MCAP and sqlite3 storage files.

A recording that was cut off (no ``metadata.yaml``, an MCAP file without its
summary, a file that ends in the middle of a record) is read record by record up
to the last complete message; :class:`_CorruptError` marks where the byte stream
ends or breaks.
"""

from __future__ import annotations

import struct
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from rosbags.typesys.store import Typestore

from tribo_common.errors import BagError


class _CorruptError(Exception):
    """Internal: the byte stream of a bag ends or breaks here."""


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
            from compression import zstd
        except ImportError:
            from backports import zstd
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
