"""The run of a drs node as a bag recorded it, for a re-run: its parameters, its effect record
(``~/command_events``: when each command took effect) and the commands, read from a verified bag
(:func:`read_run`); the model of the re-run (:func:`run_params`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from drs_model.overrides import (
    assignment_overrides,
    from_file,
)
from drs_model.params import from_dict

from .. import commands
from ..errors import DRSRosError
from ..names import CLOCK, TOPICS
from .decoded import decoder
from .effects import (
    effect_records,
    model_params_from,
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
    "NothingToRerunError",
    "RUN_ROLES",
    "RecordedRun",
    "ResimulationError",
    "read_run",
    "run_params",
]
