"""Names shared by the node, the bag tools and the tests (no rclpy, no physics).

The node's topics by role (:data:`NODE_TOPICS`), and as a node of the default name resolves them
(:data:`DEFAULT_TOPICS`, ``~`` = ``/drs``).
"""

from __future__ import annotations

from types import MappingProxyType

#: JointState names of ``[s, psi1, psi3]``: the piston (prismatic), the link and the flap.
DEFAULT_JOINT_NAMES = ("drs_piston", "drs_link", "drs_flap")

#: What the node publishes and receives, by role, as it names them before any remapping: ``~/``
#: is under the node's fully qualified name, an absolute name stays as it is. The node records
#: how it resolved each (its ``topics`` record); a bag's tools read that (drs_ros.bag.read.nodes).
NODE_TOPICS = MappingProxyType(
    {
        "joint_states": "/joint_states",  # the joint_states_topic parameter's default
        "piston_force": "~/piston_force",
        "flap_gap": "~/flap_gap",
        "piston_acceleration": "~/piston_acceleration",
        "joint_reactions": "~/joint_reactions",
        "markers": "~/markers",
        "diagnostics": "/diagnostics",
        "command_events": "~/command_events",
        "parameter_events": "/parameter_events",
        "stroke_cmd": "~/stroke_cmd",
        "force_cmd": "~/force_cmd",
        "trajectory_cmd": "~/trajectory_cmd",
        "joint_commands": "~/joint_commands",  # the joint_commands_topic parameter's default
        "follow_joint_trajectory": "~/follow_joint_trajectory",
        "pressure_piston_side": "~/pressure_piston_side",
        "pressure_rod_side": "~/pressure_rod_side",
        "supply_pressure": "~/supply_pressure",
        "valve_spool": "~/valve_spool",
        "robot_description": "/robot_description",
        "tf": "/tf",
        "tf_static": "/tf_static",
        "drs_service": "~/drs",
        "drs_service_event": "~/drs/_service_event",
    }
)

#: The node's name when none is given (``drs-node`` without ``-r __node:=`` or ``__ns:=``).
DEFAULT_NODE = "/drs"


def expand_topic(name: str, node: str) -> str:
    """``name`` as the node whose fully qualified name is ``node`` (``/car7/drs_rear``) expands
    it, without remapping: ``~`` is the node's name, a relative name is in the node's
    namespace, an absolute name stays."""
    if name == "~" or name.startswith("~/"):
        return node + name[1:]
    if name.startswith("/"):
        return name
    namespace = node.rsplit("/", 1)[0]
    return f"{namespace}/{name}"


#: The topics of a node of the default name (:data:`DEFAULT_NODE`) that nobody remapped.
DEFAULT_TOPICS = MappingProxyType(
    {role: expand_topic(name, DEFAULT_NODE) for role, name in NODE_TOPICS.items()}
)

#: Outcomes of a command in the effect record (``~/command_events``).
ACCEPTED, REFUSED, SUPERSEDED = "accepted", "refused", "superseded"
#: Records of the node's own doings in the effect record: the clock origin, a physics reset.
CLOCK, RESET = "clock", "reset"
#: The record of ``fidelity: auto``'s choice (its ``rung`` and what was ``asked``).
FIDELITY = "fidelity"
#: The record the node writes first: its fully qualified name (``node``) and the topic each role
#: of :data:`NODE_TOPICS` resolved to, remapping included (the bag's own account of its names).
TOPICS = "topics"
#: The prefix of the node's fault parameters (``fault.<name>``), the source of their effect records.
FAULT_PREFIX = "fault."

__all__ = [
    "ACCEPTED",
    "CLOCK",
    "DEFAULT_JOINT_NAMES",
    "DEFAULT_NODE",
    "DEFAULT_TOPICS",
    "FAULT_PREFIX",
    "FIDELITY",
    "NODE_TOPICS",
    "REFUSED",
    "RESET",
    "SUPERSEDED",
    "TOPICS",
    "expand_topic",
]
