"""The node's publishers add no QoS-event waitables to the executor, and /tf is computed only
while someone subscribes to it or a bag records it."""

from __future__ import annotations

import time

import pytest
from node_support import ros_context  # noqa: F401

pytestmark = pytest.mark.ros


def _node(ctx, *overrides):
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode

    return DRSNode(
        context=ctx,
        tick_timer=False,
        parameter_overrides=[Parameter(k, value=v) for k, v in overrides],
    )


def test_the_nodes_publishers_have_no_event_handlers(ros_context):  # noqa: F811
    node = _node(ros_context)
    try:
        pubs = [*node.outputs.all, *node.stack.tf.publishers]
        assert pubs and all(pub.event_handlers == [] for pub in pubs)
        # what rclpy does by default, for contrast: two waitables (matched, incompatible QoS)
        from std_msgs.msg import Float64

        default = node.create_publisher(Float64, "~/default_events", 10)
        assert len(default.event_handlers) >= 1
    finally:
        node.close_recordings()
        node.destroy_node()


def test_tf_is_computed_only_while_listened_to_or_recorded(ros_context, tmp_path):  # noqa: F811
    import rclpy
    from tf2_msgs.msg import TFMessage

    from drs_ros.publishing import LISTENER_CHECK_TICKS

    packed = {}
    nodes = {
        "quiet": _node(ros_context),
        "bag": _node(ros_context, ("bag_path", str(tmp_path / "bag"))),
    }
    listener = None
    try:
        for name, node in nodes.items():
            packer, packed[name] = node.stack.tf._moving, []
            pack = packer.pack
            packer.pack = lambda *a, _p=pack, _n=name: packed[_n].append(1) or _p(*a)
        period = nodes["quiet"].publish_period
        for _ in range(2 * LISTENER_CHECK_TICKS):
            time.sleep(period)  # a tick publishes once the simulation has a step to show
            for node in nodes.values():
                node.tick()
        assert packed["quiet"] == []  # no subscriber, no bag: nothing computed
        assert len(packed["bag"]) > LISTENER_CHECK_TICKS  # recorded though no one listens
        listener = rclpy.create_node("tf_listener", context=ros_context)
        listener.create_subscription(TFMessage, "/tf", lambda _m: None, 10)
        pub_tf = nodes["quiet"].stack.tf.pub_tf
        end = time.monotonic() + 30
        while pub_tf.get_subscription_count() == 0 and time.monotonic() < end:
            time.sleep(0.01)  # discovery, within this process
        for _ in range(2 * LISTENER_CHECK_TICKS):
            time.sleep(period)
            nodes["quiet"].tick()
        assert len(packed["quiet"]) >= LISTENER_CHECK_TICKS  # a subscriber: computed again
    finally:
        if listener is not None:
            listener.destroy_node()
        for node in nodes.values():
            node.close_recordings()
            node.destroy_node()
