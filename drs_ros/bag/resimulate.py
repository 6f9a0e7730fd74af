"""``drs-bag resimulate BAG``: the model against a recorded run.

Re-runs a recorded run in a fresh :class:`drs_model.actuator.ActuatorSim` (no DDS), on the rung
of :mod:`drs_model.fidelity` the node recorded (``--fidelity`` picks another): with the
parameters the node recorded at start (``/parameter_events``; ``--set`` / ``--params`` change
them), it feeds the recorded commands in at the simulated instants the effect record
(``~/command_events``) says they took effect: the stroke, force and trajectory commands (their
recorded bytes, by sequence number), the service calls, and the node's own physics resets (a
``reset`` record: the flap held at its recorded stroke at its recorded time, as the node did when
its model refused a step; a step the re-run's model refuses is held the same way, with a note if
the run did not).
Superseded and refused commands are left out, as they were in the run. It then compares the
recorded ``/joint_states``, piston force and gap with the re-simulated ones, sample by sample
(each recorded stamp is ``t0 + simulated time``; the clock records give ``t0``), and reports the
largest deviation per signal with its time.

The bag is read twice, a chunk at a time: first (verifying every byte) the parameters, the effect
record and the commands; then the signals, while the re-run advances as they ask and keeps only
the last :data:`STATE_WINDOW` steps. Many bags run on Dask, one row per bag (:func:`fleet_row`,
:mod:`drs_ros.bag.fleet`).

The run is the one of the drs node the bag names (:mod:`drs_ros.bag.nodes`: ``--node`` picks one
of several), with its topics as it recorded them, whatever its name and remapping.

Exit status (docs/cli.md): 0 every deviation within its tolerance; 1 past a tolerance; 2 a bad
option (or ``--node`` naming no drs node of the bag, or none of its several), the bag cannot be
read (or its ``metadata.yaml`` is malformed), holds commands but no effect record (it was
recorded before drs recorded when commands took effect) or no parameters of its node, or the
model refuses the parameters of the re-run (the recorded ones with ``--params`` / ``--set``); 4
decoding a message that passed every check of the file failed (a type that is not installed):
one line ``internal error``, no verdict on the bag; 5 nothing to re-run: the bag names no drs
node (another tool's bag), or its node took no command and never stepped (a bag that ``-o``
wrote, say).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
from collections.abc import Callable, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from drs_model.cli.exit_status import (
    EXIT_FAILED,
    EXIT_INTERNAL,
    EXIT_NOTHING_TO_RERUN,
    EXIT_OK,
    EXIT_UNREADABLE,
    EXIT_USAGE,
)
from drs_model.errors import DRSError
from drs_model.fidelity import RUNGS, make_rung
from drs_model.fidelity.faults import RunFaults
from drs_model.overrides import (
    assignment_argument,
    assignment_overrides,
    from_file,
    parameter_file_argument,
)
from drs_model.params import NUMERIC_FIELDS, DRSParams, from_dict

from .. import commands
from ..errors import DRSRosError
from ..names import ACCEPTED, CLOCK, RESET, TOPICS
from ..recording.errors import RecordingError
from ..timestamps import ns_of, seconds_from_ns
from . import fleet, look_ahead
from .decoded import decoder
from .effects import (
    MissingRecordError,
    apply_fault_record,
    effect_records,
    is_fault_record,
    model_params_from,
    recorded_rung,
)
from .files import BagReadError
from .nodes import (
    BagNode,
    NodeSelectionError,
    add_node_arguments,
    bag_nodes,
    given_topics,
    resolve_topics,
    select_node,
)
from .reader import MessageCallbackError, scan

#: signal -> (unit, default tolerance)
SIGNALS = {
    "stroke": ("m", 1e-9), "link_angle": ("rad", 1e-9), "flap_angle": ("rad", 1e-9),
    "stroke_rate": ("m/s", 1e-9), "link_rate": ("rad/s", 1e-9), "flap_rate": ("rad/s", 1e-9),
    "piston_force": ("N", 1e-6), "gap": ("m", 1e-9),
}  # fmt: skip


#: Re-simulated steps kept behind the latest one asked for (a recorded state is compared with
#: the step its stamp names; a bag in the node's order never looks back more than a few).
STATE_WINDOW = 65536


#: The roles of the topics a re-run reads: the effect record, the commands, the signals.
RUN_ROLES = ("command_events", *commands.COMMAND_TYPES, "drs_service", "follow_joint_trajectory",
             "joint_states", "piston_force", "flap_gap", "piston_acceleration",
             "parameter_events")  # fmt: skip
#: The roles with a ``--<role>-topic`` option.
TOPIC_OPTIONS = ("command_events", "joint_states", "piston_force", "flap_gap")


class ResimulationError(DRSRosError):
    """The bag cannot be re-simulated (no effect record, no parameters, a missing command)."""


class NothingToRerunError(ResimulationError):
    """The bag holds no run of a drs node to re-run: it names no drs node, or its node took no
    command and never stepped."""


@dataclass
class RecordedRun:
    """What a re-run needs from a bag (the parameters, the effect record, the commands); the
    signals it is compared with are streamed from ``bag`` by :func:`compare`."""

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
    :func:`compare`.

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


def resimulate(run: RecordedRun, model: DRSParams, fidelity: str | None = None, *,
               rung_options: dict | None = None, replay_faults: bool = True) -> dict:  # fmt: skip
    """The re-run of the recorded commands on the recorded rung (``rigid`` for a bag recorded
    before the ``fidelity`` parameter), or on ``fidelity``, step by step as :func:`compare` asks
    for its states (``state_at(step)``), and its notes: memory holds the last
    :data:`STATE_WINDOW` steps. ``rung_options`` go to the rung (``hydraulic=`` its
    HydraulicParams); without ``faults`` the recorded fault records are not applied (a fit
    treats the actuator's faults as what it estimates)."""
    np_ = run.node_parameters
    dt = 1.0 / float(np_["physics_rate_hz"])
    sim = make_rung(
        fidelity or recorded_rung(np_, run.records),
        model,
        dt,
        force_limit=float(np_["force_limit"]),
        integrator=str(np_["integrator"]),
        force_method=str(np_["force_method"]),
        **(rung_options or {}),
    )
    piston = list(np_["joint_names"])[0]
    faults = RunFaults(sim)  # the faults set at run time, and the stroke as published
    states: dict[int, tuple] = {}
    notes: list[str] = []

    # the steps at which the run's model refused to go on and the node held the flap
    reset_steps = {int(round(r.sim_time / dt)) for r in run.records if r.outcome == RESET}

    def keep() -> None:
        st = sim.state
        q = st.q.copy()
        q[0] = faults.published_stroke(st.t, q[0])  # a sensor fault changes what was published
        states[int(round(st.t / dt))] = (q, st.qd.copy(), st.piston_force, st.gap,
                                         st.qdd[0])  # fmt: skip

    def advance_to(t: float) -> None:
        while sim.t < t - 0.5 * dt:
            try:
                sim.step()
            except DRSError as exc:
                # the re-run's model refuses to go on: hold where it is, as the node does; the
                # run's RESET record, if it has one here, follows
                s_hold = commands.reset_at_rest(sim)
                if int(round(sim.t / dt)) not in reset_steps:
                    notes.append(f"at {sim.t:.6f} s the re-run's model refuses a step the "
                                 f"run took ({exc}); held at {s_hold!r} m as the node "
                                 "would")  # fmt: skip
            keep()

    keep()

    def apply(r) -> None:
        """Advance to the instant ``r`` took effect and act on it as the node did."""
        advance_to(r.sim_time)
        if r.outcome == RESET:
            # the node's model refused a step; the node held the flap at the recorded stroke at
            # that step's time and published that state: the same here, whether or not this
            # model refuses the step (a later model may take it)
            if abs(sim.t - r.sim_time) > 0.5 * dt:
                raise ResimulationError(
                    f"the effect record resets at {r.sim_time!r} s, which the re-run passed "
                    f"({sim.t!r} s): the records are out of order"
                )
            sim.reset(r.sim_time, float(r.values["stroke"]))
            keep()
            return
        if is_fault_record(r):  # a fault set at run time, applied at its tick as the node did
            if not replay_faults:
                return
            try:
                apply_fault_record(faults, r)
            except DRSError as exc:
                notes.append(f"at {r.sim_time:.6f} s the re-run refuses {r.source} "
                             f"{r.values.get('value', '')}: {exc}")  # fmt: skip
            if sim.steps == 0 and sim.t == 0.0:  # given at start: the node's first tick
                keep()  # applies it before it publishes the first state
            return
        key = run.command_key(r.source)
        if key == commands.SERVICE_KEY:
            msg = _Value(r.values["value"] == "True")
        elif key == commands.ACTION_KEY:  # the action's moves are in the record itself
            msg = commands.move_from_record(r.values)
        else:
            msg = run.commands.get((r.source, int(r.values["sequence"])))
            if msg is None:
                raise ResimulationError(
                    f"the effect record names {r.source} message {r.values['sequence']}, which "
                    "the bag does not hold"
                )
        try:
            commands.apply(sim, key, msg, piston)
        except DRSError as exc:
            notes.append(f"at {r.sim_time:.6f} s the re-run refuses {r.source} "
                         f"{r.values.get('value', '')}: {exc}")  # fmt: skip
        # no keep(): the node published this step's state before the command acted on it

    pending = [r for r in run.records if r.outcome in (ACCEPTED, RESET)]
    applied = [0]  # records of ``pending`` acted on so far

    def state_at(k: int):
        """The re-simulated state of step ``k`` (None if the re-run has none there): every
        record up to that step acted on first (a reset at ``k`` replaces its state); states more
        than :data:`STATE_WINDOW` steps before ``k`` are forgotten."""
        while applied[0] < len(pending) and int(round(pending[applied[0]].sim_time / dt)) <= k:
            applied[0] += 1
            apply(pending[applied[0] - 1])
        advance_to(k * dt)
        while states and next(iter(states)) < k - STATE_WINDOW:
            del states[next(iter(states))]
        return states.get(k)

    def finish() -> None:
        """Act on the records after the last compared state (their notes belong to the run)."""
        while applied[0] < len(pending):
            applied[0] += 1
            apply(pending[applied[0] - 1])

    return {"sim": sim, "states": states, "dt": dt, "notes": notes, "advance_to": advance_to,
            "state_at": state_at, "finish": finish}  # fmt: skip


@dataclass
class _Value:
    data: object


def _stamp_ns(msg) -> int:
    """A message's header stamp [ns]."""
    return ns_of(msg.header.stamp)


def _deviation(recorded: float, rerun: float) -> float:
    """``|recorded - rerun|``; 0 where both are NaN (a sensor's dropout, a kinematic rung's
    force: the same sample), NaN where one only is."""
    if math.isnan(recorded) and math.isnan(rerun):
        return 0.0
    return abs(recorded - rerun)


def compare(run: RecordedRun, result: dict, tolerances: dict[str, float],
            on_state: Callable | None = None) -> list[dict]:  # fmt: skip
    """Largest deviation per signal between the recorded and the re-simulated samples, the
    recorded ones streamed from the bag (a second read, a chunk at a time).

    Each recorded joint state's step: its stamp is ``t0 +`` simulated time, ``t0`` being the
    clock origin in force when the node wrote it (a clock record is written before the states
    of its tick; a stall or a clock jump moves it, so log times alone cannot say it).
    ``on_state(log_ns, joint_state, state)`` is called for each joint state with its
    re-simulated state (None where the re-run has none).
    """
    tp = run.topics
    names = list(run.node_parameters.get("joint_names", []))
    dt, state_at = result["dt"], result["state_at"]
    rows = {name: {"signal": name, "unit": unit, "max_deviation": 0.0, "at_time_s": math.nan,
                   "samples": 0, "tol": tolerances[name]}
            for name, (unit, _) in SIGNALS.items()}  # fmt: skip
    missing = [0]
    origin: list = [None]
    seen = [0]
    recent: dict[int, int] = {}  # log time -> step of the latest joint states
    decode = decoder()

    def note(name: str, dev: float, t: float) -> None:
        row = rows[name]
        row["samples"] += 1
        if not dev <= row["max_deviation"]:  # NaN counts as the worst
            row["max_deviation"], row["at_time_s"] = dev, t

    scalar = {tp["piston_force"]: ("piston_force", 2), tp["flap_gap"]: ("gap", 3)}

    def take(m) -> None:
        msg = decode(m)
        if m.topic == tp["command_events"]:
            for r in effect_records([(m.log_time, msg)]):
                if r.outcome == CLOCK:
                    origin[0] = int(r.values["t0_ns"])
            return
        if m.topic == tp["joint_states"]:
            if names and list(msg.name) != names:
                return  # another node's, on a topic they share
            if seen[0] == 0 and origin[0] is None:
                raise ResimulationError(
                    "the effect record holds no clock origin (t0) before the states"
                )
            seen[0] += 1
            k = round(seconds_from_ns(_stamp_ns(msg) - origin[0]) / dt)
            recent[m.log_time] = k
            if len(recent) > STATE_WINDOW:
                del recent[next(iter(recent))]
            state = state_at(k)
            if on_state is not None:
                on_state(m.log_time, msg, state)
            if state is None:
                missing[0] += 1
                return
            q, qd, force, _gap, _acc = state
            for i, name in enumerate(("stroke", "link_angle", "flap_angle")):
                note(name, _deviation(msg.position[i], q[i]), k * dt)
            for i, name in enumerate(("stroke_rate", "link_rate", "flap_rate")):
                note(name, _deviation(msg.velocity[i], qd[i]), k * dt)
            note("piston_force", _deviation(msg.effort[0], force), k * dt)
            return
        # the Float64 topics are published in the same tick, logged at the same node time
        name, idx = scalar[m.topic]
        k = recent.get(m.log_time)
        state = None if k is None else state_at(k)
        if state is not None:
            note(name, _deviation(msg.data, state[idx]), k * dt)

    topics = {tp["command_events"], tp["joint_states"], *scalar}
    try:
        scan(run.bag, take, exact=False, topics=topics)
    except MessageCallbackError as exc:  # the re-run's own refusal: a verdict, not a crash
        if isinstance(exc.__cause__, ResimulationError):
            raise exc.__cause__ from None
        raise
    if seen[0] == 0:
        raise ResimulationError("the effect record holds no clock origin (t0) before the states")
    result["finish"]()
    out = list(rows.values())
    for row in out:
        row["ok"] = bool(row["max_deviation"] <= row["tol"])
        if math.isnan(row["at_time_s"]):
            row["at_time_s"] = None
    if missing[0]:
        result["notes"].append(f"{missing[0]} recorded joint states have no re-simulated step")
    return out


@contextmanager
def bag_writer(out: str | Path, run: RecordedRun, model: DRSParams, rung: str):
    """The re-simulated run as a new bag, written as :func:`compare` goes (its ``on_state``):
    the parameters it ran with, then joint states, force, gap and acceleration at the recorded
    stamps (so ``drs-bag check`` checks it too). Nothing is left of it if the re-run fails."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rcl_interfaces.msg import ParameterEvent
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from ..conversions import command_event_msg, float_msg, time_msg
    from ..recording.mcap_recorder import McapRecorder
    from .effects import parameter_event

    names = list(run.node_parameters["joint_names"])
    tp = run.topics
    values = dict(run.node_parameters)
    values.update({f"model.{k}": float(getattr(model, k)) for k in NUMERIC_FIELDS})
    values["fidelity"] = rung  # the rung it ran on (--fidelity)
    made = not Path(out).exists()
    rec = McapRecorder(out, flush_thread=False)
    first = [True]

    def write(log: int, m, state) -> None:
        if first[0]:  # the parameters, at the first joint state's log time
            first[0] = False
            rec.register_topic(tp["parameter_events"], ParameterEvent, 1000)
            rec.write(tp["parameter_events"], parameter_event(run.node, values, log), log)
            # the node's name and the topics written, as a node's topics record gives them
            written = {k: tp[k] for k in ("joint_states", "piston_force", "flap_gap",
                                          "piston_acceleration", "parameter_events",
                                          "command_events")}  # fmt: skip
            rec.register_topic(tp["command_events"], DiagnosticArray, 100)
            record = command_event_msg(log, TOPICS, TOPICS, DiagnosticStatus.OK, "",
                                       {"node": run.node, **written})  # fmt: skip
            rec.write(tp["command_events"], record, log)
            rec.register_topic(tp["joint_states"], JointState, 10)
            for key in ("piston_force", "flap_gap", "piston_acceleration"):
                rec.register_topic(tp[key], Float64, 10)
        if state is None:
            return
        q, qd, force, gap, acc = state
        js = JointState(name=names, position=[float(x) for x in q],
                        velocity=[float(x) for x in qd],
                        effort=[float(force), math.nan, math.nan])  # fmt: skip
        js.header.stamp = time_msg(_stamp_ns(m))
        rec.write(tp["joint_states"], js, log)
        rec.write(tp["piston_force"], float_msg(force), log)
        rec.write(tp["flap_gap"], float_msg(gap), log)
        rec.write(tp["piston_acceleration"], float_msg(acc), log)

    try:
        yield write
    except BaseException:
        rec.discard()
        if made:
            shutil.rmtree(out, ignore_errors=True)
        raise
    if first[0]:  # no joint state: the parameters alone
        write(0, None, None)
    rec.finish()


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument(
        "bag",
        nargs="+",
        help="bag directory, .mcap or .db3 file recorded by drs-node; several, directories "
        "searched for bags, or globs re-run a fleet (one row per bag)",
    )
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        type=assignment_argument,
        help="change a model parameter for the re-run (repeatable), e.g. m_wing=0.5",
    )
    ap.add_argument("--params", type=parameter_file_argument,
                    help="a .toml/.yaml file of model parameters for the re-run")  # fmt: skip
    ap.add_argument(
        "--fidelity",
        choices=list(RUNGS),
        help="re-run on this rung of the fidelity ladder (default: the one recorded)",
    )
    ap.add_argument("-o", "--output", help="write the re-simulated run as a new bag directory; "
                    "with many bags, FILE.parquet: the table, one row per bag")  # fmt: skip
    ap.add_argument(
        "--tol",
        type=float,
        default=1e-9,
        help="tolerance of the joint states and the gap [m, rad, /s] (default 1e-9)",
    )
    ap.add_argument(
        "--force-tol",
        type=float,
        default=1e-6,
        help="tolerance of the piston force [N] (default 1e-6)",
    )
    ap.add_argument("--json", action="store_true", help="print the report as JSON")
    add_node_arguments(ap, TOPIC_OPTIONS)
    fleet.add_fleet_arguments(ap)


@dataclass
class ResimulationOutcome:
    """What re-running one bag gave: exit status (see the module docstring), the rows of
    :func:`compare`, the notes, the error line ('' when none), the recorded run and the model."""

    status: int
    rows: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    error: str = ""
    run: RecordedRun | None = None
    model: DRSParams | None = None


def resimulate_one(bag, args: argparse.Namespace, output: str | None = None,
                   node: BagNode | None = None) -> ResimulationOutcome:  # fmt: skip
    """Re-run one bag with the options of ``drs-bag resimulate`` (``args``), the run of
    ``node`` (default: the one ``--node`` picks), writing the re-simulated bag to ``output`` if
    given; never raises for the bag's faults."""
    tolerances = {name: (args.force_tol if unit == "N" else args.tol)
                  for name, (unit, _) in SIGNALS.items()}  # fmt: skip
    recorded = model = None
    try:
        if node is None:
            node = select_node(bag_nodes(bag), args.node, bag)
    except NodeSelectionError as exc:
        return ResimulationOutcome(EXIT_USAGE, error=f"error: {exc}")
    named = resolve_topics(node, RUN_ROLES, given_topics(args, TOPIC_OPTIONS),
                           look_ahead.channels(bag))  # fmt: skip
    try:
        recorded = read_run(bag, node, named.topics)
        model = run_params(recorded.node_parameters, args.set, args.params)
        result = resimulate(recorded, model, getattr(args, "fidelity", None))
        with ExitStack() as stack:
            on_state = None
            if output:
                on_state = stack.enter_context(
                    bag_writer(output, recorded, model, result["sim"].name)
                )
            rows = compare(recorded, result, tolerances, on_state)
    except MessageCallbackError as exc:  # our own failure on an intact message
        return ResimulationOutcome(EXIT_INTERNAL, error="internal error (not a verdict on the "
                                   f"bag): {exc}", run=recorded, model=model)  # fmt: skip
    except NothingToRerunError as exc:
        return ResimulationOutcome(EXIT_NOTHING_TO_RERUN, notes=named.notes, error=f"{exc}")
    except (BagReadError, MissingRecordError, ResimulationError) as exc:  # the bag's fault
        return ResimulationOutcome(EXIT_UNREADABLE, error=f"error: {exc}", run=recorded,
                                   model=model)  # fmt: skip
    except RecordingError as exc:  # -o OUT exists or cannot be written
        return ResimulationOutcome(EXIT_UNREADABLE, error=f"error: -o: {exc}", run=recorded,
                                   model=model)  # fmt: skip
    except DRSError as exc:  # the model refuses the re-run's parameters (or the recorded rung's)
        return ResimulationOutcome(EXIT_UNREADABLE, error="error: the model refuses the re-run "
                                   f"(the recorded parameters with --params/--set): {exc}",
                                   run=recorded, model=model)  # fmt: skip
    ok = all(r["ok"] for r in rows)
    if output:
        result["notes"].append(f"wrote the re-simulated run to {output}")
    notes = named.notes + result["notes"]
    return ResimulationOutcome(EXIT_OK if ok else EXIT_FAILED, rows, notes, "", recorded, model)


VERDICTS = {EXIT_OK: "PASS", EXIT_FAILED: "DEVIATES", EXIT_UNREADABLE: "UNREADABLE",
            EXIT_INTERNAL: "INTERNAL ERROR",
            EXIT_NOTHING_TO_RERUN: "NOTHING TO RE-RUN"}  # fmt: skip


def fleet_row(bag: str, args: argparse.Namespace) -> list[dict]:
    """Re-run one bag of a fleet (a Dask task): its rows of the table (see
    :mod:`drs_ros.bag.fleet`), one per drs node it holds (the one ``--node`` names, if given):
    verdict, exit status, error, each signal's largest deviation, counts, the notes and the
    model parameters of the re-run."""
    try:
        nodes = fleet.row_nodes(bag, args.node)
    except NodeSelectionError as exc:
        return [fleet.no_node_row(bag, exc)]
    return [_row(bag, args, resimulate_one(bag, args, node=node), node) for node in nodes]


def _row(bag: str, args: argparse.Namespace, outcome: ResimulationOutcome,
         node: BagNode | None) -> dict:  # fmt: skip
    row = fleet.base_row(bag, outcome.status, VERDICTS[outcome.status], outcome.error, node)
    for name, (unit, _) in SIGNALS.items():
        row[f"{name}_deviation_{unit.replace('/', '_')}"] = math.nan
    for r in outcome.rows:
        unit = r["unit"].replace("/", "_")
        row[f"{r['signal']}_deviation_{unit}"] = float(r["max_deviation"])
    run = outcome.run
    if run is not None:
        row.update(fleet.count_columns(run.counts, run.start_ns, run.end_ns, False))
    row["notes"] = list(outcome.notes)
    # the rung of the re-run: asked for, or the one the bag recorded
    rung = None if run is None else recorded_rung(run.node_parameters, run.records)
    row["fidelity"] = getattr(args, "fidelity", None) or rung
    row.update(fleet.param_columns(outcome.model))
    return row


def run(args: argparse.Namespace, prog: str = "drs-bag resimulate") -> int:
    if fleet.is_fleet(args):
        return fleet.run_fleet(
            fleet_row,
            args,
            prog,
            "re-simulated",
            ("messages", "stroke_deviation_m", "piston_force_deviation_N"),
        )
    outcome = resimulate_one(args.bag[0], args, args.output)
    if outcome.error:
        print(f"{prog}: {outcome.error}", file=sys.stderr)
        return outcome.status
    rows, notes, ok = outcome.rows, outcome.notes, outcome.status == 0
    if args.json:
        print(json.dumps({"bag": str(args.bag[0]), "node": outcome.run.node, "ok": ok,
                          "signals": rows,
                          "notes": notes, "changed": args.set,
                          "fidelity": args.fidelity}, indent=2,
                         default=lambda x: None))  # fmt: skip
    else:
        print(f"re-simulated {args.bag[0]}, the run of {outcome.run.node}"
              + (f" with {', '.join(args.set)}" if args.set else "")
              + (f" on the {args.fidelity} rung" if args.fidelity else ""))  # fmt: skip
        print(f"{'signal':<14} {'unit':<6} {'n':>6} {'max deviation':>14} {'at t [s]':>10} "
              f"{'tol':>8}  status")  # fmt: skip
        for r in rows:
            at = "-" if r["at_time_s"] is None else f"{r['at_time_s']:.4f}"
            print(f"{r['signal']:<14} {r['unit']:<6} {r['samples']:>6} "
                  f"{r['max_deviation']:>14.3e} {at:>10} {r['tol']:>8.1e}  "
                  f"{'ok' if r['ok'] else 'DEVIATES'}")  # fmt: skip
        for n in notes:
            print(f"note: {n}")
    return outcome.status


__all__ = [
    "ResimulationError",
    "add_arguments",
    "bag_writer",
    "compare",
    "fleet_row",
    "read_run",
    "resimulate",
    "resimulate_one",
    "run",
]
