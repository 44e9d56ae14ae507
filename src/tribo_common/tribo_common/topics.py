"""The tribo graph's topics: the one table of names, types, QoS, rates and meanings.

Every node, the recorder, the bag I/O (:data:`tribo_bringup.bagio.TOPIC_TYPES`),
the live bridge and the documentation take their topic names from here.

Names are *relative* (``rig/torsion_moment``): a node started in a namespace
(``--ros-args -r __ns:=/rigB``, a launch ``namespace``, ``tribo run --namespace
rigB``) publishes ``/rigB/rig/torsion_moment``, so a whole rig moves with its
namespace and two rigs share one graph. ``/diagnostics`` stays absolute (the
ROS convention for the diagnostics aggregator).

This module imports no rclpy (the offline bag tools use it); the QoS profiles
themselves are built by :mod:`tribo_common.qos` from the :class:`QosKind`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class QosKind(enum.Enum):
    """Which QoS profile a topic's publishers offer (see :mod:`tribo_common.qos`)."""

    #: reliable, KEEP_ALL, volatile: sample streams, lossless
    DATA = 'data'
    #: reliable, KEEP_LAST 20000, TRANSIENT_LOCAL: latched result history
    HISTORY = 'history'
    #: reliable, KEEP_LAST 10, volatile: status that may lose an old value
    STATUS = 'status'


@dataclass(frozen=True)
class Topic:
    """One topic of the graph.

    Attributes
    ----------
    name
        name relative to the node namespace (absolute when it starts with ``/``).
    msgtype
        message type, ``package/msg/Name``.
    qos
        QoS profile offered by its publishers.
    rate
        nominal message rate [1/s] (0: irregular or event-driven).
    unit
        SI unit of the samples ('' for structured messages).
    description
        what the topic carries.
    """

    name: str
    msgtype: str
    qos: QosKind
    rate: float
    unit: str
    description: str

    def resolve(self, namespace: str = '') -> str:
        """Fully qualified name in ``namespace`` (``''`` or ``/``: the root namespace)."""
        return resolve(self.name, namespace)

    @property
    def channel(self) -> str:
        """Last name component (the SampleBlock channel name, e.g. ``torsion_moment``)."""
        return self.name.rsplit('/', 1)[-1]


SAMPLE_BLOCK = 'tribo_msgs/msg/SampleBlock'

#: Depth of the latched result history (:attr:`QosKind.HISTORY`): 20000 1 s friction
#: estimates (5.5 h) or 1 min wear states (two weeks).
HISTORY_DEPTH = 20_000

TORSION_MOMENT = Topic(
    'rig/torsion_moment', SAMPLE_BLOCK, QosKind.DATA, 100.0, 'N m',
    'torsion moment C1*phi1 of the chamber (Equ. 1-4), SampleBlocks at 10 kHz',
)  # fmt: skip
ANGULAR_ACCELERATION = Topic(
    'rig/angular_acceleration', SAMPLE_BLOCK, QosKind.DATA, 100.0, 'rad/s^2',
    "chamber angular acceleration w1' (Equ. 1-4), SampleBlocks at 10 kHz",
)  # fmt: skip
SPEED = Topic(
    'rig/speed', SAMPLE_BLOCK, QosKind.DATA, 100.0, 'rad/s',
    'drive shaft speed w2, SampleBlocks at 10 kHz',
)  # fmt: skip
NORMAL_FORCE = Topic(
    'rig/normal_force', SAMPLE_BLOCK, QosKind.DATA, 100.0, 'N',
    'normal force F_N (CAN sensor module)',
)  # fmt: skip
OIL_TEMPERATURE = Topic(
    'rig/oil_temperature', SAMPLE_BLOCK, QosKind.DATA, 10.0, 'K',
    'oil temperature (CAN sensor module)',
)  # fmt: skip
FRICTION_MOMENT = Topic(
    'friction/moment', SAMPLE_BLOCK, QosKind.DATA, 100.0, 'N m',
    "observer friction moment I1*w1' + K1*w1 + C1*phi1, SampleBlocks",
)  # fmt: skip
FRICTION_ESTIMATE = Topic(
    'friction/estimate', 'tribo_msgs/msg/FrictionEstimate', QosKind.HISTORY, 1.0, '',
    'mu0, mu_inf (Equ. 8) and motion type per 1 s block, latched history',
)  # fmt: skip
NVCT_COUNTS = Topic(
    'nvct/counts', 'tribo_msgs/msg/DetectorCounts', QosKind.DATA, 0.0, '',
    'detector counts of one dwell (nVCT)',
)  # fmt: skip
NVCT_WEAR = Topic(
    'nvct/wear', 'tribo_msgs/msg/WearState', QosKind.HISTORY, 0.0, '',
    'wear volume, height and rate per dwell (Equ. 8-10 of section 3), latched history',
)  # fmt: skip
MODEL_DISCREPANCY = Topic(
    'model/discrepancy', 'tribo_msgs/msg/ModelDiscrepancy', QosKind.HISTORY, 0.5, '',
    'live model monitor: residual rms vs noise floor over a rolling window, the named effect '
    'family or the best partial explanation, latched history',
)  # fmt: skip
DIAGNOSTICS = Topic(
    '/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray', QosKind.STATUS, 1.0, '',
    'driver status (port, rates, errors), absolute name',
)  # fmt: skip

#: Every topic of the graph, in documentation order.
TOPICS: tuple[Topic, ...] = (
    TORSION_MOMENT,
    ANGULAR_ACCELERATION,
    SPEED,
    NORMAL_FORCE,
    OIL_TEMPERATURE,
    FRICTION_MOMENT,
    FRICTION_ESTIMATE,
    NVCT_COUNTS,
    NVCT_WEAR,
    MODEL_DISCREPANCY,
    DIAGNOSTICS,
)

#: The rig's raw sample streams (the inputs of the friction estimation).
RIG_STREAMS: tuple[Topic, ...] = (TORSION_MOMENT, ANGULAR_ACCELERATION, SPEED)

#: SampleBlock topics (down-sampled by the live bridge).
SAMPLE_STREAMS: tuple[Topic, ...] = tuple(t for t in TOPICS if t.msgtype == SAMPLE_BLOCK)


def normalize_namespace(namespace: str | None) -> str:
    """``'rigB'``, ``'/rigB/'`` -> ``'/rigB'``; ``None``, ``''``, ``'/'`` -> ``''`` (root)."""
    ns = (namespace or '').strip().strip('/')
    return f'/{ns}' if ns else ''


def resolve(name: str, namespace: str | None = '') -> str:
    """Fully qualified topic name of a relative ``name`` in ``namespace``."""
    if name.startswith('/'):
        return name
    return f'{normalize_namespace(namespace)}/{name}'


def split(full_name: str) -> tuple[str, Topic] | None:
    """``'/rigB/rig/speed'`` -> ``('/rigB', SPEED)``; None for a name not in the table."""
    for t in TOPICS:
        if t.name.startswith('/'):
            if full_name == t.name:
                return '', t
            continue
        suffix = '/' + t.name
        if full_name.endswith(suffix):
            return full_name[: -len(suffix)], t
    return None


def by_full_name(full_name: str) -> Topic | None:
    """Look up the table entry of a fully qualified name in any namespace (None if unknown)."""
    hit = split(full_name)
    return hit[1] if hit is not None else None
