"""Quality-of-service profiles of the tribo graph (the one place that builds them).

Data streams must not lose samples: reliable delivery with KEEP_ALL history
(a KEEP_LAST queue silently drops samples when a publisher runs fast).
"""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
)

from tribo_common import topics


def data_qos() -> QoSProfile:
    """QoS for data streams (SampleBlock, DetectorCounts, estimates, wear): lossless.

    Reliable, KEEP_ALL, volatile. ``depth`` is ignored under KEEP_ALL but set
    to a deep value for middlewares that size queues from it.
    """
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        depth=10000,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )


def status_qos() -> QoSProfile:
    """QoS for status topics such as ``/diagnostics`` (loss of an old status is harmless)."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=10,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )


#: Depth of the result history kept by :func:`history_qos` publishers (topic table).
HISTORY_DEPTH = topics.HISTORY_DEPTH


def history_qos(depth: int = HISTORY_DEPTH) -> QoSProfile:
    """QoS for low-rate results (friction estimates, wear states): lossless and latched.

    Reliable, TRANSIENT_LOCAL, KEEP_LAST ``depth``: a subscriber that joins late
    (a dashboard opened mid-test, a listener whose discovery finished after the
    first result) still receives the whole result history. A volatile
    subscriber is compatible with it and receives the live results only; the
    graph's own subscribers (recorder, bridge, estimator inputs) stay volatile
    so that they also match volatile publishers (``ros2 bag play`` of a bag
    without QoS metadata, third-party nodes).
    """
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )


def profile(kind: topics.QosKind) -> QoSProfile:
    """Return the QoS profile of a :class:`tribo_common.topics.QosKind`."""
    if kind is topics.QosKind.STATUS:
        return status_qos()
    if kind is topics.QosKind.HISTORY:
        return history_qos()
    return data_qos()


def qos_for_topic(topic: str) -> QoSProfile:
    """Return the QoS a publisher of ``topic`` (fully qualified, any namespace) offers.

    Topics not in :data:`tribo_common.topics.TOPICS` get the lossless data QoS.
    """
    entry = topics.by_full_name(topic)
    return profile(entry.qos) if entry is not None else data_qos()
