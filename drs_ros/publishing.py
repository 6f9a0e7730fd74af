"""How the node makes its publishers and subscriptions and asks whether anyone listens.

Each rclpy publisher or subscription made with the default event callbacks adds QoS-event
waitables to the executor's wait set (two a publisher, two a subscription), rebuilt at every
wake-up: the executor's cost grows with them (docs/ros.md, "Rate"). The node's endpoints take no
event callbacks, so that the executor waits on what the node serves only. What is lost: rclpy's
default warnings of an offered QoS incompatible with a subscriber's, and of a publisher of
another type on a topic the node subscribes to. The second, for the topics the node takes
commands on, the node checks itself with its diagnostics (:mod:`drs_ros.node.publisher_check`);
``ros2 topic info --verbose`` shows both sides.
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks

#: Ticks between two questions to DDS whether an optional topic has listeners (asking costs
#: ~25 us: not every tick; a new subscriber is seen within this many ticks).
LISTENER_CHECK_TICKS = 25


def create_publisher(node, msg_type, topic: str, qos):
    """``node.create_publisher(msg_type, topic, qos)`` without QoS-event waitables."""
    return node.create_publisher(
        msg_type, topic, qos,
        event_callbacks=PublisherEventCallbacks(use_default_callbacks=False),
    )  # fmt: skip


def create_subscription(node, msg_type, topic: str, callback, qos, raw: bool = False):
    """``node.create_subscription(msg_type, topic, callback, qos, raw=raw)`` without QoS-event
    waitables (each wake-up of the executor ~30 % cheaper for the node's five subscriptions)."""
    return node.create_subscription(
        msg_type, topic, callback, qos, raw=raw,
        event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
    )  # fmt: skip


__all__ = ["LISTENER_CHECK_TICKS", "create_publisher", "create_subscription"]
