"""How a received command acts on the actuator: one place for the node and the re-simulation.

A command is known by its key (the topic's last name: ``stroke_cmd``, ``force_cmd``,
``trajectory_cmd``, ``joint_commands``), ``drs`` (the service) or ``follow_joint_trajectory``
(the action: a :class:`TrajectoryMove` or :class:`StrokeMove` the action server decided on,
rebuilt from its effect record by :func:`move_from_record`). :func:`apply` hands its content to
:class:`drs_model.actuator.ActuatorSim`; a refusal raises the model's :class:`DRSError` with the
reason, and leaves the actuator unchanged.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass

from .conversions import stamp_of, started_points
from .stack import joint_commands

#: key -> message type name of the command topics.
COMMAND_TYPES = {
    "stroke_cmd": "std_msgs/msg/Float64",
    "force_cmd": "std_msgs/msg/Float64",
    "trajectory_cmd": "trajectory_msgs/msg/JointTrajectory",
    "joint_commands": "sensor_msgs/msg/JointState",
}
SERVICE_KEY = "drs"
#: The FollowJointTrajectory action's moves (no topic: the effect record holds them).
ACTION_KEY = "follow_joint_trajectory"
#: The depth of every command topic's queue: commands are latest-wins, a short keep-last queue
#: so that nothing waits in DDS to go stale.
COMMAND_QOS_DEPTH = 10


@dataclass(frozen=True)
class TrajectoryMove:
    """A trajectory of the piston as the actuator takes it: reach ``strokes[k]`` [m] at
    ``times[k]`` [s from now] with ``rates[k]`` [m/s] (None: the actuator's default rates)."""

    times: tuple[float, ...]
    strokes: tuple[float, ...]
    rates: tuple[float, ...] | None = None

    def plan(self, sim):
        """The state-independent part (:meth:`ActuatorSim.plan_trajectory`): outside the tick."""
        return sim.plan_trajectory(self.times, self.strokes, self.rates)

    def apply(self, sim, plan=None):
        """Follow it from the current state; ``plan`` from :meth:`plan` (same result to the bit)."""
        if plan is not None:
            return sim.command_trajectory(plan)
        return sim.command_trajectory(self.times, self.strokes, self.rates)

    def record(self) -> dict[str, str]:
        """The effect record's values: exact (Python repr), so a re-run takes the same move."""
        return {
            "value": f"<{len(self.times)} points>",
            "times": repr(list(self.times)),
            "strokes": repr(list(self.strokes)),
            "rates": repr(None if self.rates is None else list(self.rates)),
        }


@dataclass(frozen=True)
class PointNow:
    """A trajectory whose only point is at 0 s: joint_trajectory_controller takes that
    position at once (it samples the point at the trajectory's start: a jump the piston cannot
    make). The piston moves there in the time a stroke command given none takes from the state
    it is in when the command acts (:meth:`~drs_model.commanded.CommandedActuator.stroke_duration`:
    the seed's opening time scaled by the distance, longer where the move needs more than
    ``force_limit``), as a one-point trajectory (:meth:`now`), which its record holds."""

    stroke: float

    def plan(self, sim) -> None:
        """Nothing to plan before the state is known."""
        return None

    def now(self, sim) -> TrajectoryMove:
        """The one-point trajectory it is from the actuator's present state."""
        return TrajectoryMove((sim.stroke_duration(self.stroke),), (self.stroke,), None)

    def apply(self, sim, plan=None):
        return self.now(sim).apply(sim)


def trajectory_move(times, strokes, rates) -> TrajectoryMove | PointNow:
    """The move of a validated trajectory's points (times [s from now]): a single point at 0 s
    is a :class:`PointNow`, any other a :class:`TrajectoryMove` (the actuator checks its times)."""
    if len(times) == 1 and times[0] == 0.0:
        return PointNow(float(strokes[0]))
    return TrajectoryMove(tuple(times), tuple(strokes), None if rates is None else tuple(rates))


@dataclass(frozen=True)
class StrokeMove:
    """Move to ``target`` [m] in ``duration`` [s] from the current state: the action's ``hold``
    (joint_trajectory_controller's: a planned stop where the piston is, recorded as ``hold``)."""

    target: float
    duration: float

    def apply(self, sim):
        return sim.command_stroke(self.target, self.duration)

    def record(self) -> dict[str, str]:
        return {"value": "hold", "target": repr(self.target), "duration": repr(self.duration)}


def move_from_record(values: dict[str, str]) -> TrajectoryMove | StrokeMove:
    """The move an effect record of the action holds (the inverse of ``record()``)."""
    if values.get("value") == "hold":
        return StrokeMove(float(values["target"]), float(values["duration"]))
    rates = ast.literal_eval(values["rates"])
    return TrajectoryMove(
        tuple(ast.literal_eval(values["times"])),
        tuple(ast.literal_eval(values["strokes"])),
        None if rates is None else tuple(rates),
    )


@dataclass(frozen=True)
class _Data:
    data: float


def describe(key: str, msg) -> object:
    """The value a record shows for a command (the number, or the size of a trajectory)."""
    if key == "trajectory_cmd":
        return f"<{len(msg.points)} points>"
    if key == SERVICE_KEY:
        return bool(msg.data)
    if key == "joint_commands":
        return (
            f"<JointState {list(msg.name)} position {list(msg.position)} effort {list(msg.effort)}>"
        )
    if key == ACTION_KEY:
        return msg.record()["value"]
    return msg.data


def prepare(sim, key: str, msg, piston_joint: str, now_ns: int | None = None):
    """The part of applying ``msg`` that does not depend on the actuator's state, done before
    the physics step that applies it (in the node, outside its real-time tick): a trajectory's
    plan (:meth:`~drs_model.actuator.ActuatorSim.plan_trajectory`, bounded work, refusals
    raised here), its times from ``header.stamp`` when ``now_ns`` [ns] gives the node time
    it is read against (the node: the stamp of the state the next tick applies it to;
    :func:`drs_ros.conversions.started_points`; None: from the step that applies it); a
    :class:`PointNow` for a single point at 0 s. None for the other commands."""
    if key == "trajectory_cmd":
        move = trajectory_move(*started_points(msg, piston_joint, now_ns))
        return move if isinstance(move, PointNow) else move.plan(sim)
    return None


def reads_stamp(key: str, msg) -> bool:
    """Whether the command's times start at its ``header.stamp`` (a stamped trajectory): its
    effect record then holds the node time it was read against (``planned_ns``)."""
    return key == "trajectory_cmd" and stamp_of(msg) != 0


def apply(sim, key: str, msg, piston_joint: str, prepared=None, planned_ns: int | None = None):
    """Apply command ``msg`` of kind ``key`` to ``sim`` (an ActuatorSim); returns what the
    actuator returns (the move's segments, or None for a force). ``prepared``: what
    :func:`prepare` returned for it, if it was called (the result is the same to the bit);
    else ``planned_ns``: the node time [ns] a stamped trajectory's times are read against (its
    effect record's), None to ignore the stamp."""
    if key == "stroke_cmd":
        return sim.command_stroke(msg.data)
    if key == "force_cmd":
        return sim.command_force(msg.data)
    if key == "trajectory_cmd":
        if prepared is None:
            prepared = prepare(sim, key, msg, piston_joint, planned_ns)
        if isinstance(prepared, PointNow):
            return prepared.apply(sim)
        return sim.command_trajectory(prepared)
    if key == SERVICE_KEY:
        return sim.command_drs(bool(msg.data))
    if key == "joint_commands":
        sub, value = joint_commands.to_command(msg, piston_joint)
        return apply(sim, sub, _Data(value), piston_joint)
    if key == ACTION_KEY:
        return msg.apply(sim)
    known = sorted([*COMMAND_TYPES, SERVICE_KEY, ACTION_KEY])
    raise KeyError(f"unknown command {key!r}; known: {known}")


def reset_at_rest(sim) -> float:
    """What the node does when the model refuses a physics step: reset the actuator at rest
    where it is, its stroke kept within ``[s_min, s_max]``, at the present time (the
    re-simulation does the same). Not a move (the action's ``hold``, a :class:`StrokeMove`,
    plans a stop): velocity and force are gone at once. Returns the stroke [m]."""
    s_rest = float(min(max(sim.state.q[0], sim.s_min), sim.s_max))
    sim.reset(sim.t, s_rest)
    return s_rest


__all__ = [
    "ACTION_KEY",
    "COMMAND_QOS_DEPTH",
    "COMMAND_TYPES",
    "SERVICE_KEY",
    "PointNow",
    "StrokeMove",
    "TrajectoryMove",
    "apply",
    "describe",
    "move_from_record",
    "prepare",
    "reads_stamp",
    "reset_at_rest",
    "trajectory_move",
]
