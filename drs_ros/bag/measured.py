"""What a bag measured, as a :class:`drs_model.identify.Record`: the one place ``drs-bag fit``
reads a bag.

Signals are found by role, on the topics the drs node publishes (:data:`DRS_TOPICS`), or on the
topics a topic map names (``--topic-map ROLE=TOPIC,...``) for a bag another tool wrote:

``joint_states`` (``sensor_msgs/JointState``)
    the stroke (the piston joint's ``position``), its rate (``velocity``, when recorded) and the
    piston force (``effort``, when recorded); the piston joint is the node's first joint name,
    ``--joint``, or the message's first joint;
``stroke_acceleration`` (``std_msgs/Float64``), ``spool`` (``std_msgs/Float64``)
``pressure_a``, ``pressure_b``, ``supply_pressure`` (``sensor_msgs/FluidPressure``)

The joint states set the samples. A stamped signal (FluidPressure) is matched to them by header
stamp, a Float64 by log time (the node publishes a tick's messages at one node time); where a
signal has no sample at that instant it is interpolated, and outside its span it is NaN.

A drs bag's samples are placed on the run's simulated time through its clock records (the stamp
less the clock origin in force, as ``drs-bag resimulate`` does), each with its physics step; a
bag without them starts at its first stamp and has no steps (so no re-simulation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drs_model.identify.record import Record
from drs_model.params import DRSParams

from ..errors import DRSRosError
from ..names import CLOCK, DEFAULT_TOPICS
from .decoded import decoder
from .effects import (
    effect_records,
    model_params_from,
    recorded_node_parameters,
    recorded_rung,
)
from .reader import scan

#: The node's topics by role (its hydraulic ones: ``drs_ros.node.adapter.HYDRAULIC_TOPICS`` under
#: the node's name).
DRS_TOPICS = {
    "joint_states": DEFAULT_TOPICS["joint_states"],
    "stroke_acceleration": DEFAULT_TOPICS["piston_acceleration"],
    "pressure_a": "/drs/pressure_piston_side",
    "pressure_b": "/drs/pressure_rod_side",
    "supply_pressure": "/drs/supply_pressure",
    "spool": "/drs/valve_spool",
}
#: Roles whose messages carry a header stamp.
STAMPED = ("pressure_a", "pressure_b", "supply_pressure")


class MeasurementError(DRSRosError, ValueError):
    """The bag holds no usable measurement (no joint states, no piston joint, a bad topic
    map)."""


def parse_topic_map(items) -> dict[str, str]:
    """``ROLE=TOPIC`` items (comma-separated or repeated) as ``role -> topic``; refuses an
    unknown role or a malformed item."""
    out = {}
    for item in items or ():
        for part in str(item).split(","):
            if not part.strip():
                continue
            role, sep, topic = part.partition("=")
            role, topic = role.strip(), topic.strip()
            if not sep or not topic:
                raise MeasurementError(f"topic map item {part!r} is not ROLE=TOPIC")
            if role not in DRS_TOPICS:
                raise MeasurementError(f"unknown role {role!r} in the topic map; roles: "
                                       f"{', '.join(DRS_TOPICS)}")  # fmt: skip
            out[role] = topic if topic.startswith("/") else "/" + topic
    return out


@dataclass
class Measured:
    """A bag's measurement: the record, the model parameters it recorded (or the seed's), the
    rung it ran on (None when it does not say), its node parameters and effect record (None
    for a bag not written by drs), the topics read by role, its first and last log times
    [ns], its messages per topic and notes."""

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
        raise MeasurementError(f"joint {joint!r} is not in the joint states' names {names}; "
                               "name the piston joint with --joint")  # fmt: skip
    return names.index(joint)


def _value(seq, i: int) -> float:
    return float(seq[i]) if len(seq) > i else math.nan


def read_measured(bag: str | Path, topic_map: dict[str, str] | None = None,
                  joint: str | None = None) -> Measured:  # fmt: skip
    """The measurement of ``bag`` (module docstring); every byte verified as it is read.

    Raises
    ------
    MeasurementError
        No joint states on the topic, or the piston joint not among them.
    BagReadError
        The bag cannot be read.
    """
    topics = {**DRS_TOPICS, **(topic_map or {})}
    events, params_topic = DEFAULT_TOPICS["command_events"], DEFAULT_TOPICS["parameter_events"]
    decode = decoder()
    joints: list[tuple] = []  # (log, stamp, position, velocity, effort)
    origins: list[int] = []  # the clock origin in force at each joint state
    got = {role: [] for role in topics if role != "joint_states"}
    by_topic = {t: r for r, t in topics.items()}
    meta: dict[str, list] = {events: [], params_topic: []}
    where = {"index": None, "origin": None}

    def take(m) -> None:
        msg = decode(m)
        if m.topic in meta:
            meta[m.topic].append((m.log_time, msg))
            if m.topic == events:
                for r in effect_records([(m.log_time, msg)]):
                    if r.outcome == CLOCK:
                        where["origin"] = int(r.values["t0_ns"])
            return
        role = by_topic[m.topic]
        if role == "joint_states":
            if where["index"] is None:
                where["index"] = _joint_index(msg, joint or _node_joint(meta[params_topic]))
            i = where["index"]
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            joints.append((m.log_time, stamp, _value(msg.position, i), _value(msg.velocity, i),
                           _value(msg.effort, i)))  # fmt: skip
            origins.append(where["origin"])
        elif role in STAMPED:
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            got[role].append((stamp, float(msg.fluid_pressure)))
        else:
            got[role].append((m.log_time, float(msg.data)))

    result = scan(bag, take, exact=False, topics={*topics.values(), events, params_topic})
    if not joints:
        raise MeasurementError(f"{bag}: no joint states on {topics['joint_states']} (a bag "
                               "written by another tool: name its topics with --topic-map)")
    out = _assemble(joints, origins, got, meta, events, params_topic, topics)
    out.start_ns, out.end_ns, out.counts = result.start_ns, result.end_ns, dict(result.counts)
    out.bag = Path(bag)
    return out


def _node_joint(param_events: list) -> str | None:
    values = recorded_node_parameters(param_events)
    names = (values or {}).get("joint_names")
    return str(names[0]) if names else None


def _assemble(joints, origins, got, meta, events, params_topic, topics) -> Measured:
    """The record from the collected samples (sorted by stamp, repeated stamps dropped)."""
    node_parameters = recorded_node_parameters(meta[params_topic])
    records = effect_records(meta[events])
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
        t = (stamp - np.array([o for _, o in keep], dtype=np.int64)) * 1e-9
        dt = 1.0 / float(node_parameters["physics_rate_hz"])
        steps = np.rint(t / dt).astype(np.int64)
    else:
        t = (stamp - stamp[0]) * 1e-9
        notes.append("no clock records: times from the first joint state's stamp, and no "
                     "re-simulation")  # fmt: skip
    signals = {"stroke": cols[:, 0]}
    for col, name in ((1, "stroke_rate"), (2, "piston_force")):
        if np.any(np.isfinite(cols[:, col])):
            signals[name] = cols[:, col]
    for role, values in got.items():
        if values:
            signals[role] = _aligned(stamp if role in STAMPED else log, _series(values))
    if node_parameters is not None:
        params, source = model_params_from(node_parameters), "recorded on /parameter_events"
    else:
        params, source = DRSParams(), "the seed's (the bag recorded none)"
    rung = recorded_rung(node_parameters, records) if node_parameters is not None else None
    record = Record(t=t, step=steps, **signals)
    return Measured(record, params, source, rung, node_parameters, records, dict(topics),
                    None, notes=notes)  # fmt: skip


__all__ = ["DRS_TOPICS", "Measured", "MeasurementError", "parse_topic_map", "read_measured"]
