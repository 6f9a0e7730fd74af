"""Which drs nodes a bag holds, and each one's name, topics and parameters, from what the bag
recorded: the one place the bag tools learn them (nothing assumes ``/drs`` or a default topic).

A drs node records at its start (docs/ros.md, "Effect record"):

* on ``/parameter_events``, a ``ParameterEvent`` from its fully qualified name listing every
  parameter as new, the ``model.*`` and ``hydraulic.*`` ones at the values the model ran with;
* as the first record of its effect record (``~/command_events``), a ``topics`` record
  (:data:`drs_ros.names.TOPICS`): its name and the name each role of
  :data:`drs_ros.names.NODE_TOPICS` resolved to, remapping included.

:func:`bag_nodes` reads these by a look-ahead (:mod:`drs_ros.bag.read.look_ahead`: the chunks that
hold
parameter events, and the first message of each ``DiagnosticArray`` topic, wherever a remapping
put it). A node is a drs node if its first parameter event lists ``model.*`` parameters, or if it
wrote a ``topics`` record. A bag recorded before nodes wrote that record names its node on
``/parameter_events`` only: its topics are then the ones that name gives without remapping (its
``joint_states_topic`` and ``joint_commands_topic`` parameters included), and a remapped one
cannot be seen: :func:`resolve_topics` says which of them the bag does not hold and which option
names it. A bag with no drs node (another tool's) leaves the topics to the options' defaults.

:func:`select_node` picks the node a verb works on: the one ``--node`` names, else the bag's only
one; a bag of several nodes without ``--node`` is a usage error that lists them.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from drs_ros.bag.read import look_ahead
from drs_ros.bag.read.effects import parameter_values
from drs_ros.bag.read.files import BagFiles
from drs_ros.errors import UsageError
from drs_ros.names import DEFAULT_TOPICS, NODE_TOPICS, TOPICS, expand_topic

PARAMETER_EVENT = "rcl_interfaces/msg/ParameterEvent"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
#: Keys of a ``topics`` record that are no role: the record's own bookkeeping.
_RECORD_KEYS = frozenset({"outcome", "sim_time", "step", "node"})
#: Roles whose name a node parameter gives (the node's ``<role>_topic``).
_TOPIC_PARAMETERS = {"joint_states": "joint_states_topic", "joint_commands": "joint_commands_topic"}


class NodeSelectionError(UsageError):
    """A usage error: ``--node`` names no drs node of the bag, or the bag holds several drs nodes
    and ``--node`` names none (the message, which starts with ``--node``, lists the bag's
    nodes)."""


@dataclass(frozen=True)
class BagNode:
    """A drs node as its bag recorded it.

    Attributes
    ----------
    name : str
        Fully qualified, e.g. ``/car7/drs_rear``.
    topics : Mapping
        Role (of :data:`drs_ros.names.NODE_TOPICS`) -> the topic (service, action) name.
    parameters : dict or None
        The parameters of its first parameter event (name -> value), None if the bag recorded
        none.
    from_record : bool
        ``topics`` come from the node's ``topics`` record (True), or from its name alone.
    """

    name: str
    topics: Mapping[str, str]
    parameters: dict | None = None
    from_record: bool = False

    @property
    def topics_origin(self) -> str:
        """Where :attr:`topics` come from, for a report."""
        if self.from_record:
            return "its topics record"
        return "its name, unremapped: the bag records no topic names"

    @property
    def diagnostics_name(self) -> str:
        """The name of its status in ``/diagnostics`` (``<node name>: actuator``)."""
        return f"{self.name.rsplit('/', 1)[-1]}: actuator"

    def describe(self) -> str:
        """One line: the name and where its topics come from."""
        return f"{self.name} (topics from {self.topics_origin})"

    def summary(self) -> dict:
        """``name``, ``topics`` (role -> topic) and ``topics_from``, JSON-ready."""
        return {"name": self.name, "topics": dict(self.topics), "topics_from": self.topics_origin}


def bag_nodes(path: str | Path | BagFiles) -> list[BagNode]:
    """The drs nodes ``path`` holds, by name (see the module docstring); empty for a bag that
    names none. Unverified: a damaged part of the bag is not read (the verifying scan says
    why)."""
    from drs_ros.bag.read.decoded import decoder

    files = look_ahead.bag_files(path)
    if files is None:
        return []
    types = look_ahead.channels(files)
    events = [t for t, type_name in types.items() if type_name == PARAMETER_EVENT]
    arrays = [t for t, type_name in types.items() if type_name == DIAGNOSTIC_ARRAY]
    decode = decoder()
    starts: dict[str, dict] = {}
    records: dict[str, dict[str, str]] = {}
    for m in look_ahead.messages(files, events + arrays, first_only=arrays):
        msg = _decoded(decode, m)
        if msg is None:
            continue
        if m.type_name == PARAMETER_EVENT:
            if msg.node not in starts and msg.new_parameters:
                values = parameter_values(msg)
                if any(name.startswith("model.") for name in values):
                    starts[msg.node] = values
            continue
        for status in msg.status[:1]:
            values = {kv.key: kv.value for kv in status.values}
            if status.name == TOPICS and values.get("node", "").startswith("/"):
                records.setdefault(
                    values["node"], {k: v for k, v in values.items() if k not in _RECORD_KEYS}
                )
    out = []
    for name in sorted(set(starts) | set(records)):
        params = starts.get(name)
        if name in records:
            out.append(BagNode(name, records[name], params, True))
        else:
            out.append(BagNode(name, _unremapped_topics(name, params or {}), params, False))
    return out


def _decoded(decode, m):
    """The message, or None where its bytes do not decode (unverified bytes: the verifying
    scan reports them)."""
    try:
        return decode(m)
    except Exception:  # noqa: BLE001 - rclpy's type support on bytes nobody verified yet
        return None


def _unremapped_topics(name: str, params: dict) -> dict[str, str]:
    """The topics node ``name`` has without remapping: :data:`NODE_TOPICS` expanded under its
    name, the ones a parameter gives from that parameter."""
    topics = {role: expand_topic(topic, name) for role, topic in NODE_TOPICS.items()}
    for role, parameter in _TOPIC_PARAMETERS.items():
        if isinstance(params.get(parameter), str) and params[parameter]:
            topics[role] = expand_topic(params[parameter], name)
    return topics


def select_node(nodes: Sequence[BagNode], name: str | None, bag: str | Path = "the bag"):
    """The node ``--node name`` picks (its fully qualified name, or its name relative to ``/``,
    or its own name if no other node has it), or with no ``name`` the bag's only drs node; None
    for a bag of no drs node and no ``name``.

    Raises
    ------
    NodeSelectionError
        ``name`` matches no node of the bag (or several), or several nodes and no ``name``.
    """
    held = ", ".join(n.name for n in nodes) or "none"
    if name is None:
        if len(nodes) > 1:
            raise NodeSelectionError(
                f"--node: {bag} holds {len(nodes)} drs nodes ({held}): name the one to use with "
                "--node NAME"
            )
        return nodes[0] if nodes else None
    wanted = name if name.startswith("/") else f"/{name}"
    found = [n for n in nodes if n.name == wanted]
    if not found:
        found = [n for n in nodes if n.name.rsplit("/", 1)[-1] == name]
    if len(found) != 1:
        how = "names several" if found else "names none"
        raise NodeSelectionError(f"--node {name!r} {how} of the drs nodes {bag} holds: {held}")
    return found[0]


def find_node(bag: str | Path, name: str | None) -> BagNode | None:
    """:func:`select_node` of :func:`bag_nodes`."""
    return select_node(bag_nodes(bag), name, bag)


def node_note(node: BagNode | None) -> str:
    """What a report says of the node whose run it read."""
    if node is None:
        return (
            "node: none named by the bag (no node parameters, no topics record): topics by "
            "their default names or the --*-topic options"
        )
    return f"node: {node.describe()}"


@dataclass
class NodeTopics:
    """The topics a verb reads, by role, and the notes a report should make of them (a topic the
    bag does not hold, and the option that names it)."""

    topics: dict[str, str]
    notes: list[str] = field(default_factory=list)


def resolve_topics(
    node: BagNode | None,
    roles: Sequence[str],
    given: Mapping[str, str | None] | None = None,
    held: Mapping[str, str] | None = None,
) -> NodeTopics:
    """The topic of each role in ``roles``: the one ``given`` (an option ``--<role>-topic``),
    else the node's, else (a bag of no drs node) the default name's.

    ``held`` (topic -> type, the bag's channels): for the roles of ``given`` (those with an
    option) whose topic the node's name alone gave and the bag does not hold, a note naming the
    option (a remapping the bag cannot reveal)."""
    given = given or {}
    out = NodeTopics({})
    for role in roles:
        if given.get(role):
            out.topics[role] = str(given[role])
            continue
        if node is None:
            out.topics[role] = DEFAULT_TOPICS[role]
        else:  # a role its record does not list: where its name puts it
            out.topics[role] = node.topics.get(role) or expand_topic(NODE_TOPICS[role], node.name)
    if node is not None and not node.from_record and held is not None:
        missing = [r for r in given if not given[r] and out.topics[r] not in held]
        for role in missing:
            out.notes.append(
                f"the bag holds no {out.topics[role]} ({role} of {node.name} unremapped): if "
                f"it was remapped, name it with --{role.replace('_', '-')}-topic"
            )
    return out


def add_node_arguments(ap: argparse.ArgumentParser, roles: Sequence[str] = ()) -> None:
    """``--node`` and, for each of ``roles``, ``--<role>-topic`` (``dest`` ``topic_<role>``):
    what a verb's user gives where the bag does not say."""
    ap.add_argument(
        "--node",
        default=None,
        metavar="NAME",
        help="the drs node, by its fully qualified name (/car7/drs_rear) or its "
        "name, when the bag holds several (default: the bag's only one)",
    )
    for role in roles:
        ap.add_argument(
            f"--{role.replace('_', '-')}-topic",
            dest=f"topic_{role}",
            default=None,
            help=f"the node's {role} topic (default: as the bag recorded it; for a bag that "
            f"names no drs node, {DEFAULT_TOPICS[role]})",
        )


def given_topics(args: argparse.Namespace, roles: Sequence[str]) -> dict[str, str | None]:
    """``role -> --<role>-topic`` of parsed ``args`` (None where not given)."""
    return {role: getattr(args, f"topic_{role}", None) for role in roles}


def nodes_text(nodes: Sequence[dict], held: Iterable[str] | None = None) -> list[str]:
    """Lines naming each node (:meth:`BagNode.summary`) and its topics by role, for a report;
    with ``held`` (the bag's topics), a name that is no topic of the bag says so (a service, an
    action, a topic nothing was recorded on)."""
    held = None if held is None else set(held)
    lines = []
    for node in nodes:
        lines.append(f"{node['name']} (topics from {node['topics_from']})")
        width = max(map(len, node["topics"]), default=0)
        for role, topic in sorted(node["topics"].items()):
            absent = held is not None and topic not in held
            lines.append(f"  {role:<{width}}  {topic}" + ("  (not in the bag)" if absent else ""))
    return lines


__all__ = [
    "BagNode",
    "NodeSelectionError",
    "NodeTopics",
    "add_node_arguments",
    "bag_nodes",
    "find_node",
    "given_topics",
    "node_note",
    "nodes_text",
    "resolve_topics",
    "select_node",
]
