"""Messages built field by field as rclpy objects and serialised whole: the references tests
compare the node's packed bytes with (the product packs its numbers into layouts instead,
drs_ros.recording.cdr.Layout). Importing this module imports rclpy's message classes."""

from __future__ import annotations

from array import array
from collections.abc import Sequence

from sensor_msgs.msg import JointState

from drs_ros.conversions import joint_state_values, time_msg
from drs_ros.recording import cdr


def serialize(msg) -> bytes:
    """The exact CDR bytes of one rclpy message (drs_ros.recording.cdr.serializer)."""
    return cdr.serializer(type(msg))(msg)


def joint_state_msg(state, names: Sequence[str], stamp_ns: int) -> JointState:
    """The JointState the node publishes for ``state``, built as a message: like ros2_control's
    joint_state_broadcaster, the piston (prismatic: m, m/s, effort = piston force N), the link
    and the flap (revolute: rad, rad/s, effort unknown = NaN), stamped ``stamp_ns``."""
    msg = JointState(name=list(names))
    msg.header.stamp = time_msg(stamp_ns)
    position, velocity, effort = joint_state_values(state)
    msg.position = array("d", position)
    msg.velocity = array("d", velocity)
    msg.effort = array("d", effort)
    return msg
