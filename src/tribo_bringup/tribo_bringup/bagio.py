"""Reading and writing tribo sessions as rosbag2 bags with the ``rosbags`` library.

No rosbag2 or ROS CLI is needed: bags are written as rosbag2 directories
(``metadata.yaml`` + MCAP by default, sqlite3 on request) that ``ros2 bag
info`` opens on a full ROS install, and read back with rosbags.

One job per module; this module is the facade that names them all
(``from tribo_bringup import bagio``; ``bagio.iter_messages`` etc.):

- :mod:`tribo_common.bag_types`: the type table (:data:`TRIBO_TYPES`,
  :data:`TOPIC_TYPES` and :data:`RIG_TOPICS` from :mod:`tribo_common.topics`, the
  offered QoS, the typestore with the tribo_msgs types registered from the ``.msg``
  files).
- :mod:`tribo_common.bag_read`: reading (:func:`iter_messages`, :func:`bag_topics`,
  :func:`rig_namespaces`, :func:`find_namespace`) and the stream checks
  (:func:`check_streams`, :func:`bag_summary`).
- :mod:`tribo_common.bag_salvage`: tolerant raw scanners of cut-off MCAP and
  sqlite3 files.
- :mod:`tribo_bringup.bag_write`: :class:`BagWriter`.

Robustness:
- A bag whose recording was cut off (no ``metadata.yaml``, or an MCAP file
  without its summary, or a file that ends in the middle of a record) is read
  up to the last complete message: every good message is yielded first, then
  :class:`~tribo_common.errors.BagTruncatedError` names the file and the last
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

from tribo_bringup.bag_write import BagWriter
from tribo_common.bag_read import (
    BagMessage,
    OnError,
    StreamCheck,
    bag_summary,
    bag_topics,
    check_streams,
    find_namespace,
    iter_messages,
    rig_namespaces,
)
from tribo_common.bag_types import (
    RIG_TOPICS,
    ROS_DISTRO,
    TOPIC_TYPES,
    TRIBO_TYPES,
    msg_dir,
    offered_qos,
    typestore,
)

__all__ = [
    'RIG_TOPICS',
    'ROS_DISTRO',
    'TOPIC_TYPES',
    'TRIBO_TYPES',
    'BagMessage',
    'BagWriter',
    'OnError',
    'StreamCheck',
    'bag_summary',
    'bag_topics',
    'check_streams',
    'find_namespace',
    'iter_messages',
    'msg_dir',
    'offered_qos',
    'rig_namespaces',
    'typestore',
]
