"""How the node makes its publishers and asks whether anyone listens to them.

Each rclpy publisher made with the default event callbacks adds two QoS-event waitables to the
executor's wait set, rebuilt at every wake-up: the executor's cost grows with them
(docs/ros.md, "Rate"). The node's publishers take no event callbacks, so that the executor
waits on what the node serves only. What is lost: rclpy's default warning of an offered QoS
incompatible with a subscriber's (``ros2 topic info --verbose`` still shows both).
"""

from __future__ import annotations

from rclpy.event_handler import PublisherEventCallbacks

#: Ticks between two questions to DDS whether an optional topic has listeners (not every tick:
#: ~1 us a publisher warm, measured 2026-11-29, more on a cold tick, for each optional topic; a
#: new subscriber is seen within this many ticks).
LISTENER_CHECK_TICKS = 25


def create_publisher(node, msg_type, topic: str, qos):
    """``node.create_publisher(msg_type, topic, qos)`` without QoS-event waitables."""
    return node.create_publisher(
        msg_type,
        topic,
        qos,
        event_callbacks=PublisherEventCallbacks(use_default_callbacks=False),
    )


__all__ = ["LISTENER_CHECK_TICKS", "create_publisher"]
