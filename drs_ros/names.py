"""Names shared by the node, the bag tools and the tests (no rclpy, no physics).

Topic names are as the node resolves them in its default namespace (``~`` = ``/drs``).
"""

from __future__ import annotations

from types import MappingProxyType

#: JointState names of ``[s, psi1, psi3]``: the piston (prismatic), the link and the flap.
DEFAULT_JOINT_NAMES = ("drs_piston", "drs_link", "drs_flap")

#: What the node publishes and receives, by role.
DEFAULT_TOPICS = MappingProxyType({
    "joint_states": "/joint_states",
    "piston_force": "/drs/piston_force",
    "flap_gap": "/drs/flap_gap",
    "piston_acceleration": "/drs/piston_acceleration",
    "joint_reactions": "/drs/joint_reactions",
    "pressure_piston_side": "/drs/pressure_piston_side",
    "pressure_rod_side": "/drs/pressure_rod_side",
    "supply_pressure": "/drs/supply_pressure",
    "valve_spool": "/drs/valve_spool",
    "diagnostics": "/diagnostics",
    "command_events": "/drs/command_events",
    "parameter_events": "/parameter_events",
    "stroke_cmd": "/drs/stroke_cmd",
    "force_cmd": "/drs/force_cmd",
    "trajectory_cmd": "/drs/trajectory_cmd",
    "joint_commands": "/drs/joint_commands",
    "follow_joint_trajectory": "/drs/follow_joint_trajectory",
    "robot_description": "/robot_description",
    "tf": "/tf",
    "tf_static": "/tf_static",
    "drs_service": "/drs/drs",
    "drs_service_event": "/drs/drs/_service_event",
})

#: Outcomes of a command in the effect record (``~/command_events``).
ACCEPTED, REFUSED, SUPERSEDED = "accepted", "refused", "superseded"
#: Records of the node's own doings in the effect record: the clock origin, a physics reset.
CLOCK, RESET = "clock", "reset"
#: The record of ``fidelity: auto``'s choice (its ``rung`` and what was ``asked``).
FIDELITY = "fidelity"

__all__ = [
    "ACCEPTED",
    "CLOCK",
    "DEFAULT_JOINT_NAMES",
    "DEFAULT_TOPICS",
    "FIDELITY",
    "REFUSED",
    "RESET",
    "SUPERSEDED",
]
