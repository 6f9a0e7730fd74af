"""The node's publishers and subscriptions add no QoS-event waitables to the executor (the
node tells of a publisher its subscriptions cannot take itself), and /tf is computed only while
someone subscribes to it or a bag records it."""

from __future__ import annotations

import time

import pytest
from node_support import ros_context  # noqa: F401

pytestmark = pytest.mark.ros


def _node(ctx, *overrides):
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode

    return DRSNode(context=ctx, tick_timer=False,
                   parameter_overrides=[Parameter(k, value=v) for k, v in overrides])  # fmt: skip


def test_the_nodes_publishers_and_subscriptions_have_no_event_handlers(ros_context):  # noqa: F811
    node = _node(ros_context, ("bag_path", ""))
    try:
        pubs = [*node.outputs.all, *node.stack.tf.publishers]
        assert pubs and all(pub.event_handlers == [] for pub in pubs)
        subs = list(node.subscriptions)
        assert len(subs) >= 4 and all(sub.event_handlers == [] for sub in subs)
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
    nodes = {"quiet": _node(ros_context),
             "bag": _node(ros_context, ("bag_path", str(tmp_path / "bag")))}  # fmt: skip
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


def test_a_publisher_the_commands_cannot_reach_is_logged_once_and_reported(ros_context):  # noqa: F811
    """What the subscriptions' event handlers warned of: a best-effort publisher to the reliable
    command subscription, and a publisher of another type on a command topic. Each is found by
    the diagnostics' check, logged once (not at every check) and reported as long as it stays;
    a compatible publisher is not."""
    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64, String

    from drs_ros.node.publisher_check import INCOMPATIBLE_PUBLISHER

    node = _node(ros_context)
    # another participant: DDS refuses two types on one topic within one
    source = rclpy.Context()
    rclpy.init(context=source, domain_id=ros_context.get_domain_id())
    other = rclpy.create_node("command_source", context=source)
    try:
        stroke, force = node.sub_stroke.topic_name, node.sub_force.topic_name
        best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        other.create_publisher(Float64, stroke, best_effort)
        other.create_publisher(Float64, stroke, 10)  # compatible: not reported
        other.create_publisher(String, force, 10)
        warned = []
        node.publisher_check._warn = warned.append

        def named() -> dict[str, str]:
            return {text.split(" publishes on ")[1].split(",")[0]: text for text in warned
                    if text.startswith("/command_source publishes on")}  # fmt: skip

        deadline = time.monotonic() + 10.0
        while len(named()) < 2 and time.monotonic() < deadline:
            node._on_diagnostics()
            time.sleep(0.1)
        by_topic = named()
        assert set(by_topic) == {stroke, force}, warned
        assert "incompatible QoS" in by_topic[stroke] and "reliab" in by_topic[stroke].lower()
        assert "its type is std_msgs/msg/String, the node's std_msgs/msg/Float64" in by_topic[force]
        # at most once before its node was known and once after, for each of the two
        assert len(warned) <= 4 and all("publishes on /drs/" in text for text in warned), warned
        logged = len(warned)
        for _ in range(3):
            node._on_diagnostics()
        assert len(warned) == logged  # not at every check
        level, message = node.diagnostics_level(node._now_ns())
        assert INCOMPATIBLE_PUBLISHER.replace("_", " ") in message
    finally:
        other.destroy_node()
        rclpy.try_shutdown(context=source)
        node.close_recordings()
        node.destroy_node()
