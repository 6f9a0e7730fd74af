"""The robot description and TF, as robot_state_publisher would publish them for drs.

* ``/robot_description`` (std_msgs/String, transient local, depth 1): the URDF
  (:func:`drs_ros.stack.description.robot_description`) of the ``DRSParams`` the node runs, once;
* ``/tf_static`` (tf2_msgs/TFMessage, transient local, depth 1): the fixed frames, once: the base
  frame on the car (``mount_frame``, ``mount_xyz``, ``mount_rpy``; none when ``mount_frame`` is
  ``""``) and the fixed frames of the description (the two halves of the cut pin, the flap tip);
* ``/tf`` (tf2_msgs/TFMessage, depth 100): the three joints' transforms at ``tf_rate_hz``
  (robot_state_publisher's ``publish_frequency``), each stamped with the joint state it is taken
  from: at most one per published joint state.

Messages are serialised once by :mod:`drs_ros.recording.cdr`, published as those bytes and
handed to the caller's recorder as the same bytes.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from geometry_msgs.msg import TransformStamped
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from drs_model.params import DRSParams

from ..conversions import time_msg
from ..publishing import LISTENER_CHECK_TICKS, create_publisher
from ..rate_schedule import RateSchedule
from ..recording import cdr
from ..timestamps import split_ns
from . import description

#: QoS of /tf_static and /robot_description: tf2's StaticTransformBroadcaster and
#: robot_state_publisher publish them transient local, depth 1 (a late subscriber gets them).
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: QoS of /tf: tf2's TransformBroadcaster (keep last 100).
TF_QOS = QoSProfile(depth=100)


def transform_msg(transform: description.Transform, stamp_ns: int) -> TransformStamped:
    parent, child, (x, y, z), (qx, qy, qz, qw) = transform
    msg = TransformStamped(child_frame_id=child)
    msg.header.frame_id = parent
    msg.header.stamp = time_msg(stamp_ns)
    t = msg.transform
    t.translation.x, t.translation.y, t.translation.z = x, y, z
    t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w = qx, qy, qz, qw
    return msg


class MovingTransformsPacker:
    """The exact CDR of a TFMessage of transforms whose frames never change:
    ``pack(stamp_ns, [(x, y, z, qx, qy, qz, qw), ...])`` packs the numbers into the layout
    (:meth:`drs_ros.recording.cdr.Layout.packer`) of a prototype message with those frames: each
    transform's stamp, translation and rotation, the frames' strings between them fixed (~2 us,
    against ~30 us to fill the message and serialise it field by field, at every published joint
    state)."""

    def __init__(self, frame_pairs: Sequence[tuple[str, str]]) -> None:
        prototype = TFMessage(
            transforms=[
                transform_msg((parent, child, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)), 0)
                for parent, child in frame_pairs
            ]
        )
        self._count = len(frame_pairs)
        block = ("header.stamp.sec", "header.stamp.nanosec", "transform.translation")
        block += ("transform.rotation",)
        self._pack = cdr.Layout(prototype).packer(
            [f"transforms.{k}.{field}" for k in range(self._count) for field in block]
        )

    def pack(self, stamp_ns: int, values: Sequence[Sequence[float]]) -> bytes:
        """CDR bytes of the transforms, all stamped ``stamp_ns`` [ns], with ``values[k]`` the
        translation [m] and rotation quaternion of the k-th frame pair."""
        stamp = split_ns(stamp_ns)
        if len(values) == self._count and all(len(v) == 7 for v in values):
            return self._pack(*[x for v in values for x in (*stamp, *v)])
        raise ValueError(
            f"{self._count} transforms of 7 numbers each are packed, got {[len(v) for v in values]}"
        )


class TfPublisher:
    """Publishes the description, the static and the moving transforms of one node.

    Parameters
    ----------
    node : rclpy.node.Node
        Creates the publishers.
    params : DRSParams
    joint_names : sequence of 3 str
    base_frame : str
        The description's root (the node's ``frame_id``).
    force_limit : float
        The piston joint's effort limit [N].
    mount : tuple or None
        ``(mount_frame, xyz, rpy)``, or None for no mount transform.
    ros2_control : str
        A ``<ros2_control>`` element for the description.
    record : callable
        ``record(topic, data, now_ns)``: the node's recorder (exact bytes), for the description
        and the static transforms (the moving ones go back to the caller: :meth:`publish`).
    period_s : float
        Simulated time [s] between two ``/tf`` messages, on average (1 / ``tf_rate_hz``).
    states_period_s : float
        The published joint states' period [s] (1 / ``publish_rate_hz``): /tf takes one of
        them each ``period_s``, every one when ``period_s`` is no longer.
    """

    def __init__(
        self,
        node,
        params: DRSParams,
        joint_names: Sequence[str],
        base_frame: str,
        force_limit: float,
        mount,
        ros2_control: str,
        record: Callable[[str, bytes, int], object],
        period_s: float,
        states_period_s: float,
    ) -> None:
        self.params = params
        self.schedule = RateSchedule(period_s, states_period_s)
        self.frames = description.Frames.of(joint_names, base_frame)
        self.origins = description.JointOrigins.of(params)
        self.urdf = description.robot_description(
            params, joint_names, base_frame, force_limit, ros2_control
        )
        self.static = description.fixed_transforms(params, self.frames)
        if mount is not None:
            self.static.insert(0, description.mount_transform(mount[0], base_frame, *mount[1:]))
        self._record = record
        self._node = node
        self.pub_description = create_publisher(node, String, "/robot_description", LATCHED_QOS)
        self.pub_static = create_publisher(node, TFMessage, "/tf_static", LATCHED_QOS)
        self.pub_tf = create_publisher(node, TFMessage, "/tf", TF_QOS)
        self._tf = cdr.serializer(TFMessage)
        zero = description.moving_transforms([0.0, 0.0, 0.0], self.origins, self.frames)
        self._moving = MovingTransformsPacker([(parent, child) for parent, child, *_ in zero])
        self._calls, self._listened = 0, False
        self._tf_topic = self.pub_tf.topic_name  # asked of rcl at each call otherwise

    @property
    def publishers(self) -> tuple:
        return self.pub_description, self.pub_static, self.pub_tf

    def recorded_topics(self) -> list[tuple[str, type, QoSProfile]]:
        return [
            (pub.topic_name, pub.msg_type, LATCHED_QOS if pub is not self.pub_tf else TF_QOS)
            for pub in self.publishers
        ]

    def start(self, stamp_ns: int, now_ns: int) -> None:
        """Publish (and record) the description and the static transforms, once."""
        out = [
            (self.pub_description, cdr.serializer(String)(String(data=self.urdf))),
            (
                self.pub_static,
                self._tf(TFMessage(transforms=[transform_msg(t, stamp_ns) for t in self.static])),
            ),
        ]
        for pub, data in out:
            pub.publish(data)
            self._record(pub.topic_name, data, now_ns)

    def publish(
        self, q, t: float, stamp_ns: int, recording: bool = True
    ) -> list[tuple[str, bytes]]:
        """Publish the joints' transforms at configuration ``q``, the state at simulated time
        ``t`` [s] stamped ``stamp_ns``, when one is due (:attr:`schedule`), and return their record
        for the bag, ``[(topic, bytes)]``, which the caller writes with the tick's other states
        (one write for them all); nothing is computed while no one subscribes to /tf and no bag
        is ``recording``, nor between two due states (``[]``), and nothing is published while no
        one subscribes (asked every :data:`LISTENER_CHECK_TICKS` calls)."""
        if self._calls % LISTENER_CHECK_TICKS == 0:  # asking DDS: not every tick
            self._listened = self.pub_tf.get_subscription_count() > 0
        self._calls += 1
        if not (recording or self._listened) or not self.schedule.due(t):
            return []
        moving = description.moving_transforms(q, self.origins, self.frames)
        data = self._moving.pack(stamp_ns, [(*xyz, *quat) for _p, _c, xyz, quat in moving])
        if self._listened:  # recorded only: DDS would deliver it to no one
            self.pub_tf.publish(data)
        return [(self._tf_topic, data)]

    def destroy(self) -> None:
        for pub in self.publishers:
            self._node.destroy_publisher(pub)


__all__ = ["LATCHED_QOS", "TF_QOS", "MovingTransformsPacker", "TfPublisher", "transform_msg"]
