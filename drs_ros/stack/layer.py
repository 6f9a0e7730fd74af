"""What the node offers a vehicle stack, as one object the node drives.

* the robot description and TF (:mod:`drs_ros.stack.tf_tree`, :mod:`drs_ros.stack.description`);
* ``~/follow_joint_trajectory``, joint_trajectory_controller's action
  (:mod:`drs_ros.stack.follow_trajectory`);
* ros2_control's topic interface: JointState commands in on ``joint_commands_topic``
  (:mod:`drs_ros.stack.joint_commands`), the joint states out on ``joint_states_topic``.

The node builds one :class:`StackLayer` in ``configure``, and calls it in ``activate``,
``deactivate``, ``cleanup`` and at every publish (``publish``). The layer owns its publishers,
its subscription and the action server; it reaches the node's effect record, recorder and
command queue only through the :class:`NodeHooks` it is given, so the node's own structure can
change around it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState

from ..commands import COMMAND_QOS_DEPTH
from . import description
from .follow_trajectory import FollowJointTrajectoryServer, Tolerances
from .tf_tree import TfPublisher

#: The node parameters of these features: (name, default, description, valid range or choices),
#: as the node's table holds its own. JTC's ``constraints.*`` are the tolerance defaults.
STACK_PARAMETERS = (
    (
        "publish_tf",
        True,
        "publish /tf, /tf_static and /robot_description (false when "
        "robot_state_publisher does it from ros2_control's joint states)",
        None,
    ),
    (
        "tf_rate_hz",
        100.0,
        "/tf rate [Hz] (robot_state_publisher's publish_frequency): the joints' transforms of "
        "one published joint state a period; at or above publish_rate_hz, of each",
        (1.0, 2000.0),
    ),
    ("mount_frame", "base_link", "parent frame of frame_id on the car (REP 105); '' = none", None),
    ("mount_xyz", (0.0, 0.0, 0.0), "position of frame_id in mount_frame [m]", None),
    (
        "mount_rpy",
        description.SEED_FRAME_IN_REP103_RPY,
        "roll, pitch, yaw of frame_id in mount_frame [rad] (default: the seed's x rearwards, "
        "y up in REP 103's x forward, z up)",
        None,
    ),
    (
        "joint_commands_topic",
        "~/joint_commands",
        "sensor_msgs/JointState commands by joint name (ros2_control's JointStateTopicSystem "
        "joint_commands_topic)",
        None,
    ),
    (
        "joint_states_topic",
        "/joint_states",
        "where the joint states go (JointStateTopicSystem's joint_states_topic)",
        None,
    ),
    (
        "path_tolerance",
        0.0,
        "default path tolerance of the piston [m] (0 = none; JTC's constraints.<joint>.trajectory)",
        (0.0, 1.0),
    ),
    (
        "goal_tolerance",
        0.0,
        "default goal tolerance of the piston [m] (0 = none; JTC's constraints.<joint>.goal)",
        (0.0, 1.0),
    ),
    (
        "stopped_velocity_tolerance",
        0.01,
        "default goal velocity tolerance [m/s] (JTC's constraints.stopped_velocity_tolerance)",
        (0.0, 100.0),
    ),
    (
        "goal_time_tolerance",
        0.0,
        "default time past a trajectory's end to reach the goal "
        "tolerance [s] (0 = wait; JTC's constraints.goal_time)",
        (0.0, 3600.0),
    ),
)


@dataclass(frozen=True)
class NodeHooks:
    """What the layer needs of the node.

    ``event(source, outcome, level, reason, values, now_ns)``: a record of the effect log;
    ``record(topic, data, now_ns)``: exact bytes into the bag; ``receive(key, data)``: raw bytes
    of a command topic, into the node's latest-wins queue; ``now_ns()``: the node clock;
    ``actuator()``: the actuator the node runs now (``fidelity: auto`` may replace it).
    """

    event: Callable[..., None]
    record: Callable[[str, bytes, int], object]
    receive: Callable[[str, bytes], None]
    now_ns: Callable[[], int]
    actuator: Callable[[], object]


@dataclass(frozen=True)
class StackModel:
    """What the layer draws and moves: the model's parameters, the joint names (piston, link,
    flap) and the frame of the mechanism (the node's ``frame_id``)."""

    params: object
    joint_names: tuple[str, ...]
    frame_id: str


class StackLayer:
    """The features of :mod:`drs_ros.stack` for one configured node."""

    def __init__(self, node, model: StackModel, hooks: NodeHooks) -> None:
        """``node``: the rclpy node the layer creates its publishers, subscription and action
        server on, and reads its parameters (:data:`STACK_PARAMETERS`) from."""
        gp = node.get_parameter
        self.node, self.hooks = node, hooks
        self.joint_names = list(model.joint_names)
        self.commands_topic = node.resolve_topic_name(gp("joint_commands_topic").value)
        self.states_topic = node.resolve_topic_name(gp("joint_states_topic").value)
        for name in ("mount_xyz", "mount_rpy"):
            value = list(gp(name).value)
            if len(value) != 3 or not all(math.isfinite(v) for v in value):
                from rclpy.exceptions import ParameterException

                raise ParameterException(f"{name} must be 3 finite numbers, got {value}", [name])
        self.tf = None
        if gp("publish_tf").value:
            mount_frame = gp("mount_frame").value
            mount = (
                (mount_frame, list(gp("mount_xyz").value), list(gp("mount_rpy").value))
                if mount_frame
                else None
            )
            control = description.ros2_control_block(
                self.joint_names, self.commands_topic, self.states_topic
            )
            self.tf = TfPublisher(
                node,
                model.params,
                self.joint_names,
                model.frame_id,
                hooks.actuator().force_limit,
                mount,
                control,
                hooks.record,
                1.0 / gp("tf_rate_hz").value,
                1.0 / gp("publish_rate_hz").value,
            )
        self.defaults = Tolerances(
            path_position=gp("path_tolerance").value,
            goal_position=gp("goal_tolerance").value,
            goal_velocity=gp("stopped_velocity_tolerance").value,
            goal_time=gp("goal_time_tolerance").value,
        )
        self.action = FollowJointTrajectoryServer(
            node,
            hooks.actuator,
            self.joint_names[0],
            self.defaults,
            self._action_event,
            hold_duration=model.params.T_opening,
            now_ns=hooks.now_ns,
        )
        self.sub_commands = None

    # ---- what the node asks ----------------------------------------------------------------------
    @property
    def command_topics(self) -> dict[str, str]:
        """Command key -> resolved topic (merged into the node's ``command_topics``)."""
        return {"joint_commands": self.commands_topic}

    def topic_names(self) -> dict[str, str]:
        """Role -> resolved name of what the layer publishes and serves (the node's ``topics``
        record)."""
        names = {"follow_joint_trajectory": self.action.name}
        if self.tf is not None:
            names.update(
                tf=self.tf.pub_tf.topic_name,
                tf_static=self.tf.pub_static.topic_name,
                robot_description=self.tf.pub_description.topic_name,
            )
        return names

    def recorded_topics(self) -> list[tuple[str, type, QoSProfile]]:
        """The topics the layer publishes and records, with their types and offered QoS."""
        return [] if self.tf is None else self.tf.recorded_topics()

    def start(self, now_ns: int) -> None:
        """After the recorder knows the topics: the description and the static transforms."""
        if self.tf is not None:
            self.tf.start(now_ns, now_ns)

    def activate(self) -> None:
        self.sub_commands = self.node.create_subscription(
            JointState,
            self.commands_topic,
            self._on_joint_command,
            QoSProfile(depth=COMMAND_QOS_DEPTH),
            raw=True,
        )
        self.action.active_flag = True

    def _on_joint_command(self, data: bytes) -> None:
        """A JointState command's bytes into the node's queue: the node's intake decodes them,
        takes any alignment padding (Fast DDS leaves it uninitialised in what rclpy publishers
        send) and records the exact CDR, or refuses them with the reason."""
        self.hooks.receive("joint_commands", data)

    def deactivate(self) -> None:
        self.action.deactivate(self.hooks.now_ns())
        if self.sub_commands is not None:
            self.node.destroy_subscription(self.sub_commands)
            self.sub_commands = None

    def cleanup(self) -> None:
        if self.sub_commands is not None:
            self.deactivate()
        self.action.destroy()
        if self.tf is not None:
            self.tf.destroy()

    def transforms(self, state, stamp_ns: int, recording: bool = True) -> list[tuple[str, bytes]]:
        """At every published joint state: TF at ``tf_rate_hz`` (while listened to or
        ``recording`` in a bag), published; its record for the bag returned (``[]``: none),
        written by the caller with the tick's other states."""
        if self.tf is None:
            return []
        return self.tf.publish(state.q, state.t, stamp_ns, recording)

    def update_action(self, stamp_ns: int, now_ns: int) -> None:
        """After the states of a tick are out: the action's goals and feedback."""
        self.action.update(stamp_ns, now_ns)

    def _action_event(
        self, outcome: str, level: bytes, reason: str, values: dict, now_ns: int
    ) -> None:
        self.hooks.event(self.action.name, outcome, level, reason, values, now_ns)


__all__ = ["STACK_PARAMETERS", "NodeHooks", "StackLayer", "StackModel"]
