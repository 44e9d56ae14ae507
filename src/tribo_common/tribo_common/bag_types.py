"""The bag type table: the project's message types, topic types and offered QoS.

The tribo_msgs types are registered in a rosbags typestore from the ``.msg`` files
(installed share directory, or the source tree); topic names and types come from
:mod:`tribo_common.topics`.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

import tribo_common.topics as topic_table
from tribo_common.errors import BagError

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
    """Return the ``offered_qos_profiles`` of a topic (fully qualified, any namespace) in a bag.

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
    """Return a ROS 2 Jazzy typestore with the tribo_msgs types registered."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    base = msg_dir()
    for name in TRIBO_TYPES:
        text = (base / f'{name}.msg').read_text(encoding='utf-8')
        types.update(get_types_from_msg(text, f'tribo_msgs/msg/{name}'))
    store.register(types)
    return store
