"""Pure converters between drs_model values and ROS 2 messages (no physics, no node state)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from drs_model.actuator import ActuatorState
from drs_model.inverse import NE_UNKNOWNS

#: Order of the reactions on ``~/joint_reactions``: the Newton-Euler unknowns without the piston
#: force (the seed's names; N, except Tp in N m).
REACTION_NAMES = tuple(name for name in NE_UNKNOWNS if name != "F")


def time_msg(ns: int) -> Time:
    """builtin_interfaces/Time from integer nanoseconds."""
    return Time(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def joint_state_msg(state: ActuatorState, names: Sequence[str], stamp_ns: int) -> JointState:
    """JointState like ros2_control's joint_state_broadcaster: the piston (prismatic: m, m/s,
    effort = piston force N), the link and the flap (revolute: rad, rad/s, effort unknown = NaN)."""
    msg = JointState()
    msg.header.stamp = time_msg(stamp_ns)
    msg.name = list(names)
    msg.position = [float(x) for x in state.q]
    msg.velocity = [float(x) for x in state.qd]
    msg.effort = [float(state.piston_force), math.nan, math.nan]
    return msg


def reactions_msg(reactions: Mapping[str, float], stamp_ns: int) -> JointState:
    """The joint reactions as a JointState whose names are the reactions and efforts their values
    (self-describing and stamped; N, Tp in N m)."""
    msg = JointState()
    msg.header.stamp = time_msg(stamp_ns)
    msg.name = list(REACTION_NAMES)
    msg.effort = [float(reactions[k]) for k in REACTION_NAMES]
    return msg


def trajectory_points(msg, joint: str) -> tuple[list[float], list[float], list[float] | None]:
    """``(times [s from now], strokes [m], rates [m/s] or None)`` of joint ``joint`` in a
    trajectory_msgs/JointTrajectory. Rates are used only when every point gives one.

    Raises :class:`drs_model.errors.InputError` when the joint is missing or a point lacks its
    position.
    """
    from drs_model.errors import InputError

    names = list(msg.joint_names)
    if joint not in names:
        raise InputError(f"trajectory must name joint {joint!r}, got joint_names {names}")
    j = names.index(joint)
    times, strokes, rates = [], [], []
    for k, pt in enumerate(msg.points):
        if len(pt.positions) <= j:
            raise InputError(f"trajectory point {k} has no position for joint {joint!r}")
        times.append(pt.time_from_start.sec + 1e-9 * pt.time_from_start.nanosec)
        strokes.append(float(pt.positions[j]))
        rates.append(float(pt.velocities[j]) if len(pt.velocities) > j else None)
    use_rates = bool(rates) and all(r is not None for r in rates)
    return times, strokes, (rates if use_rates else None)


def float_msg(value: float) -> Float64:
    return Float64(data=float(value))


def diagnostics_msg(
    stamp_ns: int, node_name: str, level: bytes, message: str, values: Mapping[str, object]
) -> DiagnosticArray:
    """One DiagnosticStatus named ``<node>: actuator`` with the given key/values."""
    status = DiagnosticStatus(
        level=level,
        name=f"{node_name}: actuator",
        message=message,
        hardware_id="drs",
        values=[KeyValue(key=str(k), value=str(v)) for k, v in values.items()],
    )
    arr = DiagnosticArray()
    arr.header.stamp = time_msg(stamp_ns)
    arr.status = [status]
    return arr
