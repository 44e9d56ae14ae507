"""The input side shared by the nodes fed by the rig's sample streams.

The friction estimator and the model monitor both subscribe the rig's three
SampleBlock streams (``rig/torsion_moment``, ``rig/angular_acceleration``,
``rig/speed``; names from :mod:`tribo_common.topics`) with the data QoS in one
mutually exclusive callback group (so their aligner sees one block at a time) and
hand each block, converted to a :class:`~tribo_common.msgconv.Block` carrying its
channel name, to the node's own aligner; both refuse a rig without contact force.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from rclpy.subscription import Subscription

from tribo_common import topics
from tribo_common.msgconv import Block, block_from_msg
from tribo_common.params import ParameterError
from tribo_common.qos import data_qos
from tribo_msgs.msg import SampleBlock

#: Input topics (relative names) and their channel names.
RIG_INPUTS: dict[str, str] = {t.name: t.channel for t in topics.RIG_STREAMS}


def require_contact(values: Mapping[str, object]) -> None:
    """Refuse a rig without contact: nothing to fit without a normal force.

    Parameters
    ----------
    values : Mapping[str, object]
        The node's declared parameter values (``F_N`` [N]).

    Raises
    ------
    ParameterError
        ``F_N`` is not > 0 N.
    """
    f_n = values['F_N']
    if not (isinstance(f_n, int | float) and f_n > 0.0):
        raise ParameterError("parameter 'F_N' must be > 0 N: no contact, no friction to fit")


def subscribe_rig_streams(node: Node, on_block: Callable[[Block], None]) -> list[Subscription]:
    """Subscribe the rig's sample streams; every block goes to ``on_block``.

    Parameters
    ----------
    node : Node
        The subscribing node.
    on_block : Callable[[Block], None]
        Receives each block (``Block.channel`` = the stream's channel name, e.g.
        ``torsion_moment``), one at a time.

    Returns
    -------
    list of Subscription
        The subscriptions (keep them as long as the node lives).
    """
    group = MutuallyExclusiveCallbackGroup()  # the aligner sees one block at a time
    qos = data_qos()

    def callback(channel: str) -> Callable[[SampleBlock], None]:
        def cb(msg: SampleBlock) -> None:
            on_block(block_from_msg(msg, channel))

        return cb

    return [
        node.create_subscription(SampleBlock, topic, callback(ch), qos, callback_group=group)
        for topic, ch in RIG_INPUTS.items()
    ]
