"""How a received command acts on the actuator: one place for the node and the re-simulation.

A command is known by its key (the topic's last name: ``stroke_cmd``, ``force_cmd``,
``trajectory_cmd``) or ``drs`` (the service). :func:`apply` hands its content to
:class:`drs_model.actuator.ActuatorSim`; a refusal raises the model's :class:`DRSError` with the
reason, and leaves the actuator unchanged.
"""

from __future__ import annotations

from .conversions import trajectory_points

#: key -> message type name of the command topics.
COMMAND_TYPES = {
    "stroke_cmd": "std_msgs/msg/Float64",
    "force_cmd": "std_msgs/msg/Float64",
    "trajectory_cmd": "trajectory_msgs/msg/JointTrajectory",
}
SERVICE_KEY = "drs"


def describe(key: str, msg) -> object:
    """The value a record shows for a command (the number, or the size of a trajectory)."""
    if key == "trajectory_cmd":
        return f"<{len(msg.points)} points>"
    if key == SERVICE_KEY:
        return bool(msg.data)
    return msg.data


def prepare(sim, key: str, msg, piston_joint: str):
    """The part of applying ``msg`` that does not depend on the actuator's state, done before
    the physics step that applies it (in the node, outside its real-time tick): a trajectory's
    plan (:meth:`~drs_model.actuator.ActuatorSim.plan_trajectory`, bounded work, refusals
    raised here). None for the other commands."""
    if key == "trajectory_cmd":
        return sim.plan_trajectory(*trajectory_points(msg, piston_joint))
    return None


def apply(sim, key: str, msg, piston_joint: str, prepared=None):
    """Apply command ``msg`` of kind ``key`` to ``sim`` (an ActuatorSim); returns what the
    actuator returns (the move's segments, or None for a force). ``prepared``: what
    :func:`prepare` returned for it, if it was called (the result is the same to the bit)."""
    if key == "stroke_cmd":
        return sim.command_stroke(msg.data)
    if key == "force_cmd":
        return sim.command_force(msg.data)
    if key == "trajectory_cmd":
        if prepared is None:
            prepared = prepare(sim, key, msg, piston_joint)
        return sim.command_trajectory(prepared)
    if key == SERVICE_KEY:
        return sim.command_drs(bool(msg.data))
    raise KeyError(f"unknown command {key!r}; known: {sorted([*COMMAND_TYPES, SERVICE_KEY])}")


def hold(sim) -> float:
    """What the node does when the model refuses a physics step: hold the flap where it is, its
    stroke kept within ``[s_min, s_max]``, at the present time (the re-simulation does the same).
    Returns the stroke held [m]."""
    s_hold = float(min(max(sim.state.q[0], sim.s_min), sim.s_max))
    sim.reset(sim.t, s_hold)
    return s_hold


__all__ = ["COMMAND_TYPES", "SERVICE_KEY", "apply", "describe", "hold", "prepare"]
