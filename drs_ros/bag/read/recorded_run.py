"""The run of a drs node as a bag recorded it (:class:`RecordedRun`), one type for every tool
that reads it: the node's parameters (its first ``/parameter_events`` message), the rung it ran
on (its ``fidelity`` parameter, or ``auto``'s choice in the effect record), its physics step, its
clock origin (``clock`` records), the simulated time of each published state, the faults set at
run time with their spans (``fault.<name>`` records of ``~/command_events``), and, for a re-run,
its effect record and commands.

``drs-bag check`` follows it as the bag streams past, keeping no message: a few numbers and one
span per fault set (what the check makes of it: :mod:`drs_ros.bag.check.run_checks`). ``drs-bag
resimulate`` and ``fit`` read it whole from a verified bag (:func:`read_run`), effect record and
commands kept; :func:`run_models` is the model of the re-run (DRSParams and HydraulicParams).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from drs_model.fidelity.faults import FAULTS
from drs_model.overrides import apply_overrides, assignment_overrides, both_from_file
from drs_ros import commands
from drs_ros.bag.read.decoded import decoder
from drs_ros.bag.read.effects import (
    EffectRecord,
    MissingRecordError,
    effect_records,
    fault_of,
    hydraulic_params_from,
    is_fault_record,
    model_params_from,
    parameter_values,
    recorded_rung,
)
from drs_ros.bag.read.nodes import (
    bag_nodes,
    resolve_topics,
    select_node,
)
from drs_ros.bag.read.reader import scan
from drs_ros.errors import DRSRosError
from drs_ros.names import ACCEPTED, CLOCK, FIDELITY, REFUSED, RESET, TOPICS
from drs_ros.timestamps import nearest_step, seconds_from_ns

#: The roles of the topics a re-run reads: the effect record, the commands, the signals.
RUN_ROLES = (
    "command_events",
    *commands.COMMAND_TYPES,
    "drs_service",
    "follow_joint_trajectory",
    "joint_states",
    "piston_force",
    "flap_gap",
    "piston_acceleration",
    "parameter_events",
)


class ResimulationError(DRSRosError):
    """The bag cannot be re-simulated (no effect record, no parameters, a missing command)."""


class NothingToRerunError(ResimulationError):
    """The bag holds no run of a drs node to re-run: it names no drs node, or its node took no
    command and never stepped."""


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


class RecordedRun:
    """The run of the node ``node`` (its fully qualified name) as its bag recorded it, followed
    in the bag's order: :meth:`take_parameters` with the ``/parameter_events`` messages,
    :meth:`take_effects` with the ``~/command_events`` messages. With ``keep_records`` the
    effect records are kept (``records``, the ``topics`` record left out), as a re-run needs
    them; :func:`read_run` also fills ``commands`` ((topic, sequence) -> message), ``bag``,
    ``counts`` (topic -> messages in the bag), ``start_ns`` / ``end_ns`` (the earliest and
    latest log time [ns]) and ``topics`` (role -> topic, :data:`RUN_ROLES`).
    ``fault_notes`` says which faults were refused (never in force)."""

    def __init__(
        self, node: str = "/drs", *, keep_records: bool = False, node_parameters: dict | None = None
    ) -> None:
        self.node = node
        self.node_parameters = node_parameters
        self.keep_records = keep_records
        self.records: list[EffectRecord] = []
        self.commands: dict = {}
        self.bag: Path | None = None
        self.counts: dict = {}
        self.start_ns: int | None = None
        self.end_ns: int | None = None
        self.topics: dict = {}
        self.chosen: str | None = None  # auto's choice (a ``fidelity`` record)
        self.origin_ns: int | None = None  # clock origin t0 [ns] in force
        self.t_reset = 0.0  # simulated time [s] of the last physics reset
        self.spans: list[FaultSpan] = []
        self.fault_notes: list[str] = []
        self._open: dict[str, FaultSpan] = {}

    # ---- followed as the bag streams past -------------------------------------------------------
    def take_parameters(self, event) -> None:
        """A ParameterEvent: the node's first one with parameters is what it ran with."""
        if self.node_parameters is None and event.node == self.node and event.new_parameters:
            self.node_parameters = parameter_values(event)

    def take_effects(self, log_ns: int, msg) -> list[EffectRecord]:
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
        if self.keep_records:
            self.records += [r for r in out if r.source != TOPICS]
        return out

    def _fault(self, r: EffectRecord) -> None:
        if r.outcome == REFUSED:
            self.fault_notes.append(
                f"{r.source} = {r.values.get('value', '?')} refused at "
                f"{r.sim_time:.6f} s (never in force)"
            )
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

    # ---- what it says ---------------------------------------------------------------------------
    @property
    def fidelity(self) -> str:
        """The ``fidelity`` parameter (``rigid`` for a bag recorded before it)."""
        return str((self.node_parameters or {}).get("fidelity", "rigid"))

    @property
    def fidelity_recorded(self) -> bool:
        """Whether the node recorded its ``fidelity`` parameter (else :attr:`fidelity` is the
        node's default, assumed)."""
        return "fidelity" in (self.node_parameters or {})

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

    def sim_time(self, stamp_ns: int) -> float:
        """The simulated time [s] of a state stamped ``stamp_ns`` (``t0 +`` simulated time),
        exactly as the node's physics counts it (``t_reset + steps dt``); NaN before any clock
        record."""
        if self.origin_ns is None:
            return math.nan
        dt = self.dt
        t = seconds_from_ns(stamp_ns - self.origin_ns)
        return self.t_reset + nearest_step(t - self.t_reset, dt) * dt

    def command_key(self, source: str) -> str:
        """The command (a key of :func:`drs_ros.commands.apply`) of an effect record's
        ``source``: its topic, the service or the action, by the node's topic names."""
        if source == self.topics.get("drs_service"):
            return commands.SERVICE_KEY
        keys = (*commands.COMMAND_TYPES, commands.ACTION_KEY)
        by_topic = {self.topics[k]: k for k in keys if k in self.topics}
        return by_topic.get(source, source.rsplit("/", 1)[-1])


def _chosen(rung: str) -> EffectRecord:
    return EffectRecord(FIDELITY, FIDELITY, math.nan, {"rung": rung}, 0)


#: :func:`read_run`'s default node: the bag's only one.
_FIND = object()


def read_run(bag: str | Path, node=_FIND, topics: dict[str, str] | None = None) -> RecordedRun:
    """Verify the bag (every byte, :func:`drs_ros.bag.read.reader.scan`: a damaged bag is its error
    first) and collect the run of ``node`` (a :class:`~drs_ros.bag.read.nodes.BagNode`, None for a
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
    run = (
        RecordedRun(keep_records=True)
        if node is None
        else RecordedRun(node.name, keep_records=True, node_parameters=node.parameters)
    )
    decode = decoder()

    def keep(m) -> None:
        msg = decode(m)
        if m.topic in cmd_topics:
            run.commands[(m.topic, m.sequence)] = msg
        else:
            run.take_effects(m.log_time, msg)

    result = scan(bag, keep, topics={events_topic, *cmd_topics} if node is not None else ())
    if node is None:  # a bag that reads, of another tool
        raise NothingToRerunError(
            f"{bag}: nothing to re-run: the bag names no drs node (no node parameters on "
            "/parameter_events, no topics record): it holds no run of drs-node"
        )
    if not run.commands and not any(r.outcome == CLOCK for r in run.records):
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
    if not run.records:
        raise ResimulationError(
            f"{bag}: the bag has no effect record ({events_topic}): it was recorded before "
            "drs recorded when each command took effect, so it cannot be re-run exactly"
        )
    run.bag, run.counts, run.topics = Path(bag), dict(result.counts), dict(topics)
    run.start_ns, run.end_ns = result.start_ns, result.end_ns
    return run


def run_models(node_params: dict, sets: Sequence[str] = (), params_file: str | None = None):
    """The model of the re-run, DRSParams and HydraulicParams: as recorded (``model.*``,
    ``hydraulic.*``), then a parameter file's overrides, then ``--set`` (names of either)."""
    models = model_params_from(node_params), hydraulic_params_from(node_params)
    if params_file:
        models = both_from_file(params_file, *models)
    overrides = assignment_overrides(sets)
    return apply_overrides(overrides, *models) if overrides else models


def run_params(node_params: dict, sets: Sequence[str] = (), params_file: str | None = None):
    """The DRSParams of the re-run (:func:`run_models`)."""
    return run_models(node_params, sets, params_file)[0]


__all__ = [
    "DEFAULT_DT",
    "FaultSpan",
    "MissingRecordError",
    "NothingToRerunError",
    "RUN_ROLES",
    "RecordedRun",
    "ResimulationError",
    "read_run",
    "run_models",
    "run_params",
]
