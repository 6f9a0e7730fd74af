"""The node's publishers add no QoS-event waitables to the executor; /tf is computed only
while someone subscribes to it or a bag records it, and at ``tf_rate_hz`` of the published
joint states."""

from __future__ import annotations

import time
from itertools import pairwise
from types import SimpleNamespace

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
    every_state = ("tf_rate_hz", 2000.0)  # above the publish rate: /tf at each joint state
    nodes = {
        "quiet": _node(ros_context, every_state),
        "bag": _node(ros_context, every_state, ("bag_path", str(tmp_path / "bag"))),
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


def test_tf_goes_out_at_tf_rate_hz_with_published_joint_states(ros_context, tmp_path, monkeypatch):  # noqa: F811
    """1 kHz joint states, /tf at 100 Hz: each /tf is stamped like a published joint state, one
    every 10 ms of the states' time; with tf_rate_hz at the publish rate, each joint state.
    The node's clock advances one period a tick (a clock of the test's: no late tick)."""
    from drs_ros.node import tick as tick_module

    stamps = {}
    for tf_hz in (100.0, 1000.0):
        node = _node(
            ros_context,
            ("publish_rate_hz", 1000.0),
            ("tf_rate_hz", tf_hz),
            ("bag_path", str(tmp_path / f"bag{tf_hz:g}")),
        )
        tf_stamps, state_stamps = [], []
        stamps[tf_hz] = tf_stamps, state_stamps
        try:
            now = [time.time_ns()]
            object.__setattr__(node.tick_part.parts, "now_ns", lambda now=now: now[0])
            # the steady clock the tick compares with the node clock moves with it: a busy
            # machine's slow tick is then neither a clock jump nor a missed deadline
            steady = SimpleNamespace(
                monotonic=lambda now=now: now[0] * 1e-9,
                monotonic_ns=lambda now=now: now[0],
                thread_time=time.thread_time,
            )
            monkeypatch.setattr(tick_module, "time", steady)
            packer = node.stack.tf._moving
            pack_tf = packer.pack
            packer.pack = lambda t, v, _p=pack_tf, _s=tf_stamps: _s.append(t) or _p(t, v)
            pack_state = node.outputs._pack_joint_state
            node.outputs._pack_joint_state = lambda st, t, s=None, _p=pack_state, _s=state_stamps: (
                _s.append(t) or _p(st, t, s)
            )
            for _ in range(501):
                now[0] += 1_000_000
                node.tick()
        finally:
            node.close_recordings()
            node.destroy_node()
    tf_stamps, state_stamps = stamps[100.0]
    assert len(state_stamps) == 501
    assert set(tf_stamps) <= set(state_stamps)
    assert [b - a for a, b in pairwise(tf_stamps)] == [10_000_000] * 50
    assert stamps[1000.0][0] == stamps[1000.0][1]  # at the publish rate: every joint state


def test_the_effect_record_goes_to_subscribers_only_and_always_to_the_bag(ros_context, tmp_path):  # noqa: F811
    """No one subscribed: a record is not published (DDS keeps nothing of the volatile topic
    for later) but is recorded; a subscriber then receives the next one, as recorded."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from mcap.reader import make_reader
    from rclpy.serialization import deserialize_message
    from std_srvs.srv import SetBool

    bag = tmp_path / "bag"
    node = _node(ros_context, ("bag_path", str(bag)))
    listener = rclpy.create_node("events_listener", context=ros_context)
    received = []
    try:
        published = []
        pub = node.effects._publisher
        publish = pub.publish
        pub.publish = lambda data: published.append(data) or publish(data)
        node.tick()  # the clock's record
        assert published == []
        listener.create_subscription(
            DiagnosticArray, "/drs/command_events", received.append, 100, raw=True
        )
        end = time.monotonic() + 30
        while pub.get_subscription_count() == 0 and time.monotonic() < end:
            time.sleep(0.01)  # discovery, within this process
        node._on_drs(SetBool.Request(data=True), SetBool.Response())
        assert len(published) == 1
        executor = rclpy.executors.SingleThreadedExecutor(context=ros_context)
        executor.add_node(listener)
        end = time.monotonic() + 10
        while not received and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        executor.shutdown()
        assert received == published
    finally:
        listener.destroy_node()
        node.close_recordings()
        node.destroy_node()
    recorded = []
    for file in sorted(bag.glob("*.mcap")):
        with open(file, "rb") as f:
            reader = make_reader(f)
            for _s, _c, message in reader.iter_messages(topics=["/drs/command_events"]):
                recorded.append(message.data)
    # the clock's record (published to no one) and the call's, each as recorded
    names = [deserialize_message(d, DiagnosticArray).status[0].name for d in recorded]
    clock = recorded[names.index("clock")]
    assert clock not in published and recorded[-1] == published[0]
