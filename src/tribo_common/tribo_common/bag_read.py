"""Reading tribo sessions from rosbag2 bags (rosbags), tolerant of cut-off recordings.

Every good message of a bag is yielded first; a truncated or corrupt bag then
raises :class:`~tribo_common.errors.BagTruncatedError` naming the file and the last
good message (or, with ``on_error='warn'``, warns). Connections of unknown message
types are skipped with a warning. Also: the rigs (namespaces) of a bag and the
continuity checks of its sample streams.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from rosbags.rosbag2 import Reader
from rosbags.typesys.store import Typestore

import tribo_common.topics as topic_table
from tribo_common.bag_salvage import _CorruptError, _iter_raw_mcap, _iter_raw_sqlite, _sqlite_files
from tribo_common.bag_types import RIG_TOPICS, typestore
from tribo_common.errors import BagError, BagTruncatedError

OnError = Literal['raise', 'warn']


@dataclass(frozen=True)
class BagMessage:
    """One message read from a bag.

    Attributes
    ----------
    topic : str
        Topic name.
    msgtype : str
        Rosbags type name, e.g. ``tribo_msgs/msg/SampleBlock``.
    timestamp_ns : int
        Receive time recorded in the bag [ns].
    msg : object
        The deserialised message (rosbags dataclass; arrays are numpy).
    index : int
        Position of the message in the bag's time order (0-based).
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
    start_ns: int | None = None,
    stop_ns: int | None = None,
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
        start_ns, stop_ns: only the messages whose bag time stamp [ns] lies in
            ``[start_ns, stop_ns)`` (a rosbag2 directory seeks there through its
            index; a bare or cut-off file is scanned).
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
            namespace='', start_ns=start_ns, stop_ns=stop_ns,
        )  # fmt: skip
        for m in inner:
            yield BagMessage(m.topic[len(ns) :], m.msgtype, m.timestamp_ns, m.msg, m.index)
        return
    wanted = set(topics) if topics is not None else None
    store = typestore()
    last: BagMessage | None = None
    try:
        if bag.is_dir() and (bag / 'metadata.yaml').is_file():
            source: Iterator[tuple[str, str, int, bytes]] = _iter_rosbag2(
                bag, wanted, store, (start_ns, stop_ns)
            )
        elif _sqlite_files(bag):
            source = _iter_raw_sqlite(bag, wanted, store)
        else:
            source = _iter_raw_mcap(bag, wanted, store)
        count = 0
        for topic, msgtype, stamp, raw in source:
            if (start_ns is not None and stamp < start_ns) or (
                stop_ns is not None and stamp >= stop_ns
            ):
                continue
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
    """Return the namespace to read ``topics`` from: the root if any is there, else the only one.

    Parameters
    ----------
    path : str or Path
        The bag.
    topics : Iterable[str]
        Root-namespace topic names.

    Returns
    -------
    str
        The namespace ('' for the root).

    Raises
    ------
    BagError
        The topics are in several namespaces and none at the root.
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


def _iter_rosbag2(
    bag: Path,
    wanted: set[str] | None,
    store: Typestore,
    window: tuple[int | None, int | None] = (None, None),
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
            for conn, stamp, raw in reader.messages(
                connections=conns, start=window[0], stop=window[1]
            ):
                yield conn.topic, conn.msgtype, int(stamp), bytes(raw)
        except Exception as exc:  # rosbags raises several types
            raise _CorruptError(str(exc)) from exc
    finally:
        reader.close()


@dataclass(frozen=True)
class StreamCheck:
    """Continuity of one SampleBlock topic in a bag.

    Attributes
    ----------
    topic : str
        Topic name.
    messages : int
        Number of messages.
    samples : int
        Number of samples received.
    first_index : int
        Index of the first sample.
    expected : int
        Samples expected from the first to the last index.
    missing : int
        Samples missing (gaps between consecutive first indices).
    gaps : int
        Number of gaps.
    duplicates : int
        Samples received twice (overlaps).
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
