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
