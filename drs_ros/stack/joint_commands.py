"""ros2_control's topic interface: ``sensor_msgs/JointState`` commands, by joint name.

``joint_state_topic_hardware_interface/JointStateTopicSystem`` (ros2_control, Jazzy) drives its
hardware by publishing, every control cycle in which a command changed, one JointState whose
``name`` lists every joint of its ``<ros2_control>`` block and whose ``position``, ``velocity``
and ``effort`` hold, in that order, the commands of the joints that have such a command
interface. It reads the hardware's state back from a JointState topic. So drs takes:

* ``name``: must hold the piston joint; other names are joints that take no command (the link and
  the flap are passive joints of the closed loop): a finite value for one of them is refused;
* ``position`` or ``effort``: either one value per name (a plain JointState), or one value only,
  the piston's (JointStateTopicSystem's form: only the piston has command interfaces). The
  piston's position [m] moves the piston as ``~/stroke_cmd`` does; its effort [N] pushes it as
  ``~/force_cmd`` does. A NaN is no command (ros2_control leaves an unclaimed command interface
  at NaN), so a message may carry both fields as long as exactly one of them is finite;
* ``velocity``: refused when it holds a finite value (no velocity command interface).

What the command does, and its refusals (range, path, force limit, NaN), are those of the other
command paths: :func:`to_command` only picks the value, :mod:`drs_ros.commands` applies it.
"""

from __future__ import annotations

import math

from drs_model.errors import InputError

#: What a JointState command becomes: the key of the command path it takes.
STROKE, FORCE = "stroke_cmd", "force_cmd"


def _piston_value(msg, field: str, piston: str, index: int) -> float:
    """The piston's entry of ``msg.<field>`` (NaN when the field is empty); refuses a field whose
    length is neither 0, 1 (the piston's only) nor one per name, and a finite value for any
    other joint."""
    values = list(getattr(msg, field))
    names = list(msg.name)
    if not values:
        return math.nan
    if len(values) == 1:
        return float(values[0])
    if len(values) != len(names):
        raise InputError(
            f"joint command {field} has {len(values)} values for {len(names)} names {names}: "
            f"give one per name, or the piston's ({piston}) only"
        )
    for name, value in zip(names, values, strict=True):
        if name != piston and math.isfinite(value):
            raise InputError(
                f"joint command gives {name} a {field} of {value!r}: only {piston} takes "
                "commands (the link and the flap are passive joints of the closed loop); give NaN "
                "or leave it out"
            )
    return float(values[index])


def to_command(msg, piston: str) -> tuple[str, float]:
    """``(key, value)`` of a JointState command: ``("stroke_cmd", s [m])`` or
    ``("force_cmd", F [N])``.

    Raises :class:`drs_model.errors.InputError` with the reason when the message names no
    piston, names a joint twice, commands another joint or a velocity, or gives neither or both a
    position and an effort.
    """
    names = list(msg.name)
    if len(set(names)) != len(names):
        raise InputError(f"joint command names must be unique, got {names}")
    if piston not in names:
        raise InputError(f"joint command must name {piston!r} (the actuated joint), got {names}")
    index = names.index(piston)
    position = _piston_value(msg, "position", piston, index)
    effort = _piston_value(msg, "effort", piston, index)
    velocity = [v for v in msg.velocity if math.isfinite(v)]
    if velocity:
        raise InputError(
            f"joint command gives a velocity {velocity[0]!r}: drs takes a position [m] or an "
            f"effort [N] command for {piston}, no velocity"
        )
    given = [(key, v) for key, v in ((STROKE, position), (FORCE, effort)) if math.isfinite(v)]
    if len(given) != 1:
        raise InputError(
            f"joint command must give {piston} exactly one finite value, a position [m] or an "
            f"effort [N]; got position {position!r}, effort {effort!r}"
        )
    return given[0]


__all__ = ["FORCE", "STROKE", "to_command"]
