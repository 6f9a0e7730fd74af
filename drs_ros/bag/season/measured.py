"""What a bag measured, as a :class:`drs_model.identify.Record`: the one place ``drs-bag fit``
reads a bag.

Signals are found by role, on the topics of the drs node the bag names
(:mod:`drs_ros.bag.read.nodes`: its name, namespace and remappings as it recorded them), or on the
topics a topic map names (``--topic-map ROLE=TOPIC,...``), which win, for a bag another tool
wrote:

``joint_states`` (``sensor_msgs/JointState``)
    the stroke (the piston joint's ``position``), its rate (``velocity``, when recorded) and the
    piston force (``effort``, when recorded); the piston joint is the node's first joint name,
    ``--joint``, or the message's first joint;
``stroke_acceleration`` (``std_msgs/Float64``), ``spool`` (``std_msgs/Float64``)
``pressure_a``, ``pressure_b``, ``supply_pressure`` (``sensor_msgs/FluidPressure``)

(:data:`NODE_ROLES` names the node's topic of each role.) The joint states set the samples; on
a topic two nodes share, those of another node (other joint names) are left out. A stamped
signal (FluidPressure) is matched to them by header stamp, a Float64 by log time (the node
publishes a tick's messages at one node time); where a signal has no sample at that instant it
is interpolated, and outside its span it is NaN.

A drs bag's samples are placed on the run's simulated time through the node's clock records (the
stamp less the clock origin in force, as ``drs-bag resimulate`` does), each with its physics
step; a bag without them starts at its first stamp and has no steps (so no re-simulation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drs_model.identify.record import Record
from drs_model.params import DRSParams
from drs_ros.bag.read.decoded import decoder
from drs_ros.bag.read.effects import effect_records, model_params_from, recorded_rung
from drs_ros.bag.read.nodes import BagNode, resolve_topics
from drs_ros.bag.read.reader import scan
from drs_ros.bag.read.recorded import MessageCallbackError
from drs_ros.errors import DRSRosError
from drs_ros.names import CLOCK, TOPICS
from drs_ros.timestamps import nearest_steps, ns_of, seconds_from_ns

#: The fit's roles, and the role of :data:`drs_ros.names.NODE_TOPICS` that names the node's
#: topic of each (the hydraulic ones: ``drs_ros.node.publishers.HYDRAULIC_TOPICS``).
NODE_ROLES = {
    "joint_states": "joint_states",
    "stroke_acceleration": "piston_acceleration",
    "pressure_a": "pressure_piston_side",
    "pressure_b": "pressure_rod_side",
    "supply_pressure": "supply_pressure",
    "spool": "valve_spool",
}
#: Roles whose messages carry a header stamp.
STAMPED = ("pressure_a", "pressure_b", "supply_pressure")
#: The message type of each role's topic.
ROLE_TYPES = {role: "std_msgs/msg/Float64" for role in NODE_ROLES}
ROLE_TYPES.update(
    {
        "joint_states": "sensor_msgs/msg/JointState",
        **dict.fromkeys(STAMPED, "sensor_msgs/msg/FluidPressure"),
    }
)


class MeasurementError(DRSRosError, ValueError):
    """The bag holds no usable measurement (no joint states, no piston joint), or a topic map
    item is malformed."""


def parse_topic_map(items) -> dict[str, str]:
    """``ROLE=TOPIC`` items (comma-separated or repeated) as ``role -> topic``; refuses an
    unknown role or a malformed item (:class:`MeasurementError`)."""
    out = {}
    for item in items or ():
        for part in str(item).split(","):
            if not part.strip():
                continue
            role, sep, topic = part.partition("=")
            role, topic = role.strip(), topic.strip()
            if not sep or not topic:
                raise MeasurementError(f"topic map item {part!r} is not ROLE=TOPIC")
            if role not in NODE_ROLES:
                raise MeasurementError(
                    f"unknown role {role!r} in the topic map; roles: {', '.join(NODE_ROLES)}"
                )
            out[role] = topic if topic.startswith("/") else "/" + topic
    return out


def measured_topics(
    node: BagNode | None,
    topic_map: dict[str, str] | None = None,
) -> dict[str, str]:
    """The topic of each role (:data:`NODE_ROLES`) and of the node's effect record
    (``command_events``): the topic map's, else the node's as it recorded them, else (a bag
    that names no drs node) the default names."""
    roles = [*NODE_ROLES.values(), "command_events"]
    named = resolve_topics(node, roles).topics
    topics = {role: named[node_role] for role, node_role in NODE_ROLES.items()}
    topics.update(topic_map or {})
    topics["command_events"] = named["command_events"]
    return topics


@dataclass
class Measured:
    """A bag's measurement: the record, the model parameters it recorded (or the seed's), the
    rung it ran on (None when it does not say), the node's parameters and effect record (None
    and empty for a bag not written by drs), the topics read by role, its first and last log
    times [ns], its messages per topic, the drs node (None: the bag names none) and notes."""

    record: Record
    params: DRSParams
    params_source: str
    rung: str | None
    node_parameters: dict | None
    records: list
    topics: dict[str, str]
    start_ns: int | None
    end_ns: int | None = None
    counts: dict = field(default_factory=dict)
    bag: Path | None = None
    notes: list[str] = field(default_factory=list)
    node: BagNode | None = None


def _series(values: list[tuple[int, float]]) -> tuple[np.ndarray, np.ndarray]:
    if not values:
        return np.zeros(0, dtype=np.int64), np.zeros(0)
    keys, vals = zip(*sorted(values), strict=True)
    return np.asarray(keys, dtype=np.int64), np.asarray(vals, dtype=float)


def _aligned(keys: np.ndarray, series: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The series at ``keys``: exact where it has a sample there, linear between, NaN outside."""
    k, v = series
    if k.size == 0:
        return np.full(keys.size, math.nan)
    out = np.interp(keys.astype(float), k.astype(float), v)
    out[(keys < k[0]) | (keys > k[-1])] = math.nan
    pos = np.searchsorted(k, keys)
    hit = (pos < k.size) & (k[np.minimum(pos, k.size - 1)] == keys)
    out[hit] = v[pos[hit]]
    return out


def _joint_index(msg, joint: str | None) -> int:
    names = list(msg.name)
    if joint is None:
        if not names and msg.position:
            return 0
        joint = names[0] if names else None
    if joint not in names:
        raise MeasurementError(
            f"joint {joint!r} is not in the joint states' names {names}; "
            "name the piston joint with --joint"
        )
    return names.index(joint)


def _value(seq, i: int) -> float:
    return float(seq[i]) if len(seq) > i else math.nan


def _node_joint_names(node: BagNode | None) -> list[str]:
    names = ((node.parameters or {}).get("joint_names") if node is not None else None) or []
    return [str(n) for n in names]


class _Collector:
    """The messages of a measurement as a scan passes them (:meth:`take`): the joint states of
    the node (with the clock origin in force at each), the other roles' samples, and the node's
    effect record."""

    def __init__(
        self, topics: dict[str, str], events: str, node: BagNode | None, joint: str | None
    ) -> None:
        self.events, self.node, self.joint = events, node, joint
        self.node_names = _node_joint_names(node)
        self.decode = decoder()
        self.joints: list[tuple] = []  # (log, stamp, position, velocity, effort)
        self.origins: list[int] = []  # the clock origin in force at each joint state
        self.got: dict[str, list] = {role: [] for role in topics if role != "joint_states"}
        self.by_topic: dict[str, list[str]] = {}
        for role, topic in topics.items():
            self.by_topic.setdefault(topic, []).append(role)
        self.event_messages: list = []
        self.index: int | None = None  # of the piston joint in the joint states
        self.origin: int | None = None

    def take(self, m) -> None:
        """One message of the scan."""
        msg = self.decode(m)
        if m.topic == self.events and self.node is not None:
            self.event_messages.append((m.log_time, msg))
            for r in effect_records([(m.log_time, msg)]):
                if r.outcome == CLOCK:
                    self.origin = int(r.values["t0_ns"])
        for role in self.by_topic.get(m.topic, ()):
            self._take(role, m, msg)

    def _take(self, role: str, m, msg) -> None:
        if m.type_name != ROLE_TYPES[role]:
            raise MeasurementError(
                f"{m.topic} holds {m.type_name} messages; the role {role} "
                f"needs {ROLE_TYPES[role]} (see --topic-map)"
            )
        if role == "joint_states":
            if self.node_names and list(msg.name) != self.node_names:
                return  # another node's, on a topic they share
            if self.index is None:
                self.index = _joint_index(msg, self.joint or (self.node_names or [None])[0])
            i = self.index
            stamp = ns_of(msg.header.stamp)
            self.joints.append(
                (
                    m.log_time,
                    stamp,
                    _value(msg.position, i),
                    _value(msg.velocity, i),
                    _value(msg.effort, i),
                )
            )
            self.origins.append(self.origin)
        elif role in STAMPED:
            stamp = ns_of(msg.header.stamp)
            self.got[role].append((stamp, float(msg.fluid_pressure)))
        else:
            self.got[role].append((m.log_time, float(msg.data)))


def read_measured(
    bag: str | Path,
    node: BagNode | None,
    topic_map: dict[str, str] | None = None,
    joint: str | None = None,
) -> Measured:
    """The measurement of ``node``'s run in ``bag`` (module docstring; ``node`` None: a bag that
    names no drs node); every byte verified as it is read.

    Raises
    ------
    MeasurementError
        No joint states on the topic, or the piston joint not among them.
    BagReadError
        The bag cannot be read.
    """
    topics = measured_topics(node, topic_map)
    events = topics.pop("command_events")
    seen = _Collector(topics, events, node, joint)
    wanted = {*topics.values(), *([events] if node is not None else [])}
    try:
        result = scan(bag, seen.take, exact=False, topics=wanted)
    except MessageCallbackError as exc:  # what the bag holds is no measurement: its error
        if isinstance(exc.__cause__, MeasurementError):
            raise exc.__cause__ from None
        raise
    if not seen.joints:
        raise MeasurementError(
            f"{bag}: no joint states on {topics['joint_states']} (a bag "
            "written by another tool: name its topics with --topic-map)"
        )
    records = effect_records(seen.event_messages)
    out = _assemble(seen.joints, seen.origins, seen.got, node, records, topics)
    out.start_ns, out.end_ns, out.counts = result.start_ns, result.end_ns, dict(result.counts)
    out.bag = Path(bag)
    return out


def _stops_may_hold(node, records) -> bool:
    """Whether a stop may have held the rod against the piston in the run: unless the node's
    own effect record shows no force command (its force topic as resolved, remapping
    included, in the record of its topics), it may have (another tool's bag: unknown)."""
    if node is None:
        return True
    names = {r.values.get("force_cmd") for r in records if r.source == TOPICS}
    names = {n for n in names if n} or {"force_cmd"}
    return any(r.source in names or r.source.endswith("/force_cmd") for r in records)


def _assemble(joints, origins, got, node, records, topics) -> Measured:
    """The record from the collected samples (sorted by stamp, repeated stamps dropped)."""
    node_parameters = None if node is None else node.parameters
    arr = sorted(zip(joints, origins, strict=True), key=lambda jo: jo[0][1])
    keep, seen = [], set()
    for j, o in arr:
        if j[1] not in seen:
            seen.add(j[1])
            keep.append((j, o))
    log = np.array([j[0] for j, _ in keep], dtype=np.int64)
    stamp = np.array([j[1] for j, _ in keep], dtype=np.int64)
    cols = np.array([j[2:] for j, _ in keep], dtype=float)
    notes = []
    steps = None
    if node_parameters is not None and all(o is not None for _, o in keep):
        t = seconds_from_ns(stamp - np.array([o for _, o in keep], dtype=np.int64))
        dt = 1.0 / float(node_parameters["physics_rate_hz"])
        steps = nearest_steps(t, dt)
    else:
        t = seconds_from_ns(stamp - stamp[0])
        notes.append(
            "no clock records: times from the first joint state's stamp, and no re-simulation"
        )
    signals = {"stroke": cols[:, 0]}
    for col, name in ((1, "stroke_rate"), (2, "piston_force")):
        if np.any(np.isfinite(cols[:, col])):
            signals[name] = cols[:, col]
    for role, values in got.items():
        if values:
            signals[role] = _aligned(stamp if role in STAMPED else log, _series(values))
    if node_parameters is not None:
        params = model_params_from(node_parameters)
        source = f"recorded by {node.name} on /parameter_events"
    elif node is not None:
        params, source = DRSParams(), f"the seed's (the bag recorded none for {node.name})"
    else:
        params, source = DRSParams(), "the seed's (the bag names no drs node)"
    rung = recorded_rung(node_parameters, records) if node_parameters is not None else None
    record = Record(t=t, step=steps, stops_hold=_stops_may_hold(node, records), **signals)
    return Measured(
        record,
        params,
        source,
        rung,
        node_parameters,
        records,
        dict(topics),
        None,
        notes=notes,
        node=node,
    )


__all__ = [
    "NODE_ROLES",
    "Measured",
    "MeasurementError",
    "measured_topics",
    "parse_topic_map",
    "read_measured",
]
