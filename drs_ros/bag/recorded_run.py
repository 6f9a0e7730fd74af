"""The run of a drs node as a bag recorded it, for a re-run: its parameters, its effect record
(``~/command_events``: when each command took effect) and the commands, read from a verified bag
(:func:`read_run`); the model of the re-run (:func:`run_params`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from drs_model.fidelity.faults import FAULTS
from drs_model.overrides import (
    assignment_overrides,
    from_file,
)
from drs_model.params import from_dict

from .. import commands
from ..errors import DRSRosError
from ..names import ACCEPTED, CLOCK, FIDELITY, REFUSED, RESET, TOPICS
from ..timestamps import seconds_from_ns
from .decoded import decoder
from .effects import (
    EffectRecord,
    MissingRecordError,
    effect_records,
    fault_of,
    is_fault_record,
    model_params_from,
    parameter_values,
    recorded_rung,
)
from .nodes import (
    bag_nodes,
    resolve_topics,
    select_node,
)
from .reader import scan

#: The roles of the topics a re-run reads: the effect record, the commands, the signals.
RUN_ROLES = ("command_events", *commands.COMMAND_TYPES, "drs_service", "follow_joint_trajectory",
             "joint_states", "piston_force", "flap_gap", "piston_acceleration",
             "parameter_events")  # fmt: skip


class ResimulationError(DRSRosError):
    """The bag cannot be re-simulated (no effect record, no parameters, a missing command)."""


class NothingToRerunError(ResimulationError):
    """The bag holds no run of a drs node to re-run: it names no drs node, or its node took no
    command and never stepped."""


@dataclass
class RecordedRun:
    """What a re-run needs from a bag (the parameters, the effect record, the commands); the
    signals it is compared with are streamed from ``bag`` by :func:`.deviations.compare`."""

    node_parameters: dict
    records: list
    commands: dict = field(default_factory=dict)  # (topic, sequence) -> message
    bag: Path | None = None
    counts: dict = field(default_factory=dict)  # topic -> messages in the bag
    start_ns: int | None = None  # earliest and latest log time [ns]
    end_ns: int | None = None
    node: str = "/drs"  # the node's fully qualified name
    topics: dict = field(default_factory=dict)  # role -> topic (RUN_ROLES)

    def command_key(self, source: str) -> str:
        """The command (a key of :func:`drs_ros.commands.apply`) of an effect record's
        ``source``: its topic, the service or the action, by the node's topic names."""
        if source == self.topics.get("drs_service"):
            return commands.SERVICE_KEY
        keys = (*commands.COMMAND_TYPES, commands.ACTION_KEY)
        by_topic = {self.topics[k]: k for k in keys if k in self.topics}
        return by_topic.get(source, source.rsplit("/", 1)[-1])


#: The physics step [s] of a bag that recorded no ``physics_rate_hz`` (the node's default).
DEFAULT_DT = 1e-3


@dataclass
class FaultSpan:
    """One fault in force during a run: ``fault.<name>`` at ``value`` from the simulated time
    ``sim_from_s`` [s] (log time ``log_from_ns``) to ``sim_to_s`` / ``log_to_ns`` (None: to the
    end of the recording)."""

    fault: str
    value: object
    sim_from_s: float
    log_from_ns: int
    sim_to_s: float | None = None
    log_to_ns: int | None = None


class RunRecord:
    """The run's parameters, rung, clock and faults, fed with :meth:`parameters` (the node's
    ``/parameter_events`` messages) and :meth:`records` (its ``~/command_events`` messages) in
    the bag's order. ``node`` is the node's fully qualified name."""

    def __init__(self, node: str = "/drs") -> None:
        self.node = node
        self.node_parameters: dict | None = None
        self.chosen: str | None = None  # auto's choice (a ``fidelity`` record)
        self.origin_ns: int | None = None  # clock origin t0 [ns] in force
        self.t_reset = 0.0  # simulated time [s] of the last physics reset
        self.spans: list[FaultSpan] = []
        self.notes: list[str] = []
        self._open: dict[str, FaultSpan] = {}

    def parameters(self, event) -> None:
        """A ParameterEvent: the node's first one with parameters is what it ran with."""
        if self.node_parameters is None and event.node == self.node and event.new_parameters:
            self.node_parameters = parameter_values(event)

    @property
    def fidelity(self) -> str:
        """The ``fidelity`` parameter (``rigid`` for a bag recorded before it)."""
        return str((self.node_parameters or {}).get("fidelity", "rigid"))

    @property
    def dt(self) -> float:
        """The physics step [s]."""
        rate = (self.node_parameters or {}).get("physics_rate_hz")
        return DEFAULT_DT if rate is None else 1.0 / float(rate)

    def rung(self) -> str:
        """The rung the run ran on; raises :class:`MissingRecordError` for ``auto`` without the
        record of its choice."""
        records = [] if self.chosen is None else [_chosen(self.chosen)]
        return recorded_rung({"fidelity": self.fidelity}, records)

    def records(self, log_ns: int, msg) -> list[EffectRecord]:
        """One ``~/command_events`` message: its records, after following them."""
        out = effect_records([(log_ns, msg)])
        for r in out:
            if r.outcome == CLOCK:
                self.origin_ns = int(r.values["t0_ns"])
            elif r.outcome == FIDELITY and self.chosen is None:
                self.chosen = r.values.get("rung")
            elif r.outcome == RESET:
                self.t_reset = r.sim_time
            elif is_fault_record(r):
                self._fault(r)
        return out

    def _fault(self, r: EffectRecord) -> None:
        if r.outcome == REFUSED:
            self.notes.append(f"{r.source} = {r.values.get('value', '?')} refused at "
                              f"{r.sim_time:.6f} s (never in force)")  # fmt: skip
            return
        if r.outcome != ACCEPTED:
            return
        try:
            name, value = fault_of(r)
        except (ValueError, SyntaxError):  # judged by the check (a record it cannot read)
            return
        span = self._open.pop(name, None)
        if span is not None:
            span.sim_to_s, span.log_to_ns = r.sim_time, r.log_time
        if value != FAULTS[name][0]:  # the healthy value ends a span and opens none
            self._open[name] = FaultSpan(r.source, value, r.sim_time, r.log_time)
            self.spans.append(self._open[name])

    def sim_time(self, stamp_ns: int) -> float:
        """The simulated time [s] of a state stamped ``stamp_ns`` (``t0 +`` simulated time),
        exactly as the node's physics counts it (``t_reset + steps dt``); NaN before any clock
        record."""
        if self.origin_ns is None:
            return math.nan
        dt = self.dt
        t = seconds_from_ns(stamp_ns - self.origin_ns)
        return self.t_reset + round((t - self.t_reset) / dt) * dt


def _chosen(rung: str) -> EffectRecord:
    return EffectRecord(FIDELITY, FIDELITY, math.nan, {"rung": rung}, 0)


#: :func:`read_run`'s default node: the bag's only one.
_FIND = object()


def read_run(bag: str | Path, node=_FIND, topics: dict[str, str] | None = None) -> RecordedRun:
    """Verify the bag (every byte, :func:`drs_ros.bag.reader.scan`: a damaged bag is its error
    first) and collect the run of ``node`` (a :class:`~drs_ros.bag.nodes.BagNode`, None for a
    bag that names none; default: the bag's only one): its parameters, effect record and
    commands, on ``topics`` (role -> topic; default: the node's). The signals are read by
    :func:`.deviations.compare`.

    Raises
    ------
    NodeSelectionError
        ``node`` not given, and the bag holds several.
    NothingToRerunError
        No drs node (``node`` None), or one that took no command and never stepped.
    ResimulationError
        Commands without an effect record, or no parameters of the node.
    """
    if node is _FIND:
        node = select_node(bag_nodes(bag), None, bag)
    if topics is None:
        topics = resolve_topics(node, RUN_ROLES).topics
    cmd_topics = {topics[k] for k in commands.COMMAND_TYPES} if node is not None else set()
    events_topic = topics["command_events"]
    events: list = []
    cmds: dict = {}
    decode = decoder()

    def keep(m) -> None:
        msg = decode(m)
        if m.topic in cmd_topics:
            cmds[(m.topic, m.sequence)] = msg
        else:
            events.append((m.log_time, msg))

    result = scan(bag, keep, topics={events_topic, *cmd_topics} if node is not None else ())
    if node is None:  # a bag that reads, of another tool
        raise NothingToRerunError(
            f"{bag}: nothing to re-run: the bag names no drs node (no node parameters on "
            "/parameter_events, no topics record): it holds no run of drs-node"
        )
    records = [r for r in effect_records(events) if r.source != TOPICS]
    if not cmds and not any(r.outcome == CLOCK for r in records):
        raise NothingToRerunError(
            f"{bag}: nothing to re-run: {node.name} took no command and never stepped (no "
            f"command, no clock record on {events_topic})"
        )
    if node.parameters is None:
        raise ResimulationError(
            f"{bag}: the bag records no parameters of {node.name} on /parameter_events: it was "
            "recorded before drs recorded what it needs to re-run a bag (see docs/ros.md, "
            "Effect record)"
        )
    if not records:
        raise ResimulationError(
            f"{bag}: the bag has no effect record ({events_topic}): it was recorded before "
            "drs recorded when each command took effect, so it cannot be re-run exactly"
        )
    return RecordedRun(node.parameters, records, cmds, Path(bag), dict(result.counts),
                       result.start_ns, result.end_ns, node.name, dict(topics))  # fmt: skip


def run_params(node_params: dict, sets: Sequence[str] = (), params_file: str | None = None):
    """The model of the re-run: as recorded, then a parameter file's overrides, then ``--set``."""
    model = model_params_from(node_params)
    if params_file:
        model = from_file(params_file, base=model)
    overrides = assignment_overrides(sets)
    return from_dict(overrides, model) if overrides else model


__all__ = [
    "DEFAULT_DT",
    "FaultSpan",
    "MissingRecordError",
    "NothingToRerunError",
    "RUN_ROLES",
    "RecordedRun",
    "ResimulationError",
    "RunRecord",
    "read_run",
    "run_params",
]
