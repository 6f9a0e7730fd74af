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

Exit status: 0 every deviation within its tolerance; 1 past a tolerance; 2 the bag cannot be
read (or its ``metadata.yaml`` is malformed), or holds no effect record (it was recorded before
drs recorded when commands took effect) or no parameters; 4 decoding a message that passed every
check of the file failed (a type that is not installed): one line ``internal error``, no verdict
on the bag.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from drs_model.errors import DRSError
from drs_model.fidelity import RUNGS, make_rung
from drs_model.fidelity.faults import RunFaults
from drs_model.overrides import assignment_overrides, from_file
from drs_model.params import NUMERIC_FIELDS, DRSParams, from_dict

from .. import commands
from ..names import ACCEPTED, CLOCK, DEFAULT_TOPICS, RESET
from .decoded import decoder
from .effects import (
    apply_fault_record,
    effect_records,
    is_fault_record,
    model_params_from,
    recorded_node_parameters,
    recorded_rung,
)
from .files import BagReadError
from .reader import MessageCallbackError, scan

#: signal -> (unit, default tolerance)
SIGNALS = {
    "stroke": ("m", 1e-9), "link_angle": ("rad", 1e-9), "flap_angle": ("rad", 1e-9),
    "stroke_rate": ("m/s", 1e-9), "link_rate": ("rad/s", 1e-9), "flap_rate": ("rad/s", 1e-9),
    "piston_force": ("N", 1e-6), "gap": ("m", 1e-9),
}  # fmt: skip


class ResimulationError(DRSError):
    """The bag cannot be re-simulated (no effect record, no parameters, a missing command)."""


@dataclass
class RecordedRun:
    """What a re-run needs from a bag, and what it is compared with."""

    node_parameters: dict
    records: list
    commands: dict = field(default_factory=dict)  # (topic, sequence) -> message
    joint_states: list = field(default_factory=list)  # (log_ns, JointState)
    forces: list = field(default_factory=list)
    gaps: list = field(default_factory=list)
    extra: dict = field(default_factory=dict)


def read_run(bag: str | Path) -> RecordedRun:
    """Verify the bag and collect the parameters, the effect record, the commands and the
    signals to compare."""
    tp = DEFAULT_TOPICS
    cmd_topics = {tp[k] for k in commands.COMMAND_TYPES}
    wanted = {tp["parameter_events"], tp["command_events"], tp["joint_states"],
              tp["piston_force"], tp["flap_gap"], *cmd_topics}  # fmt: skip
    got: dict[str, list] = {t: [] for t in wanted}
    cmds: dict = {}
    # the clock origin in force for each joint state, in the order the node wrote them (a clock
    # record is written before the states of its tick); log times alone cannot say it once the
    # node clock has jumped back
    origin: list = [None]
    state_origins: list = []
    decode = decoder()

    def keep(m) -> None:
        msg = decode(m)
        if m.topic in cmd_topics:
            cmds[(m.topic, m.sequence)] = msg
            return
        got[m.topic].append((m.log_time, msg))
        if m.topic == tp["command_events"]:
            for r in effect_records([(m.log_time, msg)]):
                if r.outcome == CLOCK:
                    origin[0] = int(r.values["t0_ns"])
        elif m.topic == tp["joint_states"]:
            state_origins.append(origin[0])

    scan(bag, keep, topics=wanted)
    params = recorded_node_parameters(got[tp["parameter_events"]])
    if params is None:
        raise ResimulationError(
            f"{bag}: the bag records no node parameters on /parameter_events: it was recorded "
            "before drs recorded what it needs to re-run a bag (see docs/ros.md, Effect record)"
        )
    if not got[tp["command_events"]]:
        raise ResimulationError(
            f"{bag}: the bag has no effect record ({tp['command_events']}): it was recorded before "
            "drs recorded when each command took effect, so it cannot be re-run exactly"
        )
    return RecordedRun(params, effect_records(got[tp["command_events"]]), cmds,
                       got[tp["joint_states"]], got[tp["piston_force"]],
                       got[tp["flap_gap"]], {"state_origins": state_origins})  # fmt: skip


def run_params(node_params: dict, sets: Sequence[str] = (), params_file: str | None = None):
    """The model of the re-run: as recorded, then a parameter file's overrides, then ``--set``."""
    model = model_params_from(node_params)
    if params_file:
        model = from_file(params_file, base=model)
    overrides = assignment_overrides(sets)
    return from_dict(overrides, model) if overrides else model


def resimulate(run: RecordedRun, model: DRSParams, fidelity: str | None = None) -> dict:
    """Re-run the recorded commands on the recorded rung (``rigid`` for a bag recorded before the
    ``fidelity`` parameter), or on ``fidelity``; returns the re-simulated samples by step index
    and notes."""
    np_ = run.node_parameters
    dt = 1.0 / float(np_["physics_rate_hz"])
    sim = make_rung(
        fidelity or recorded_rung(np_, run.records),
        model,
        dt,
        force_limit=float(np_["force_limit"]),
        integrator=str(np_["integrator"]),
        force_method=str(np_["force_method"]),
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
                s_hold = commands.hold(sim)
                if int(round(sim.t / dt)) not in reset_steps:
                    notes.append(f"at {sim.t:.6f} s the re-run's model refuses a step the "
                                 f"run took ({exc}); held at {s_hold!r} m as the node "
                                 "would")  # fmt: skip
            keep()

    keep()
    service = DEFAULT_TOPICS["drs_service"]
    for r in run.records:
        if r.outcome not in (ACCEPTED, RESET):
            continue
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
            continue
        if is_fault_record(r):  # a fault set at run time, applied at its tick as the node did
            try:
                apply_fault_record(faults, r)
            except DRSError as exc:
                notes.append(f"at {r.sim_time:.6f} s the re-run refuses {r.source} "
                             f"{r.values.get('value', '')}: {exc}")  # fmt: skip
            continue
        key = commands.SERVICE_KEY if r.source == service else r.source.rsplit("/", 1)[-1]
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
    return {"sim": sim, "states": states, "dt": dt, "notes": notes, "advance_to": advance_to}


@dataclass
class _Value:
    data: object


def _stamp_ns(msg) -> int:
    """A message's header stamp [ns]."""
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


def joint_state_steps(run: RecordedRun, dt: float) -> dict[int, int]:
    """``log_time -> physics step`` of each recorded joint state: its stamp is ``t0 +`` simulated
    time, ``t0`` being the clock origin in force when the node wrote it (a stall or a clock jump
    moves it; the origins come in write order from :func:`read_run`)."""
    origins = run.extra.get("state_origins")
    if not origins or origins[0] is None:
        raise ResimulationError("the effect record holds no clock origin (t0) before the states")
    out = {}
    for (log, m), t0 in zip(run.joint_states, origins, strict=True):
        stamp = _stamp_ns(m)
        out[log] = int(round((stamp - t0) * 1e-9 / dt))
    return out


def _deviation(recorded: float, rerun: float) -> float:
    """``|recorded - rerun|``; 0 where both are NaN (a sensor's dropout, a kinematic rung's
    force: the same sample), NaN where one only is."""
    if math.isnan(recorded) and math.isnan(rerun):
        return 0.0
    return abs(recorded - rerun)


def compare(run: RecordedRun, result: dict, tolerances: dict[str, float]) -> list[dict]:
    """Largest deviation per signal between the recorded and the re-simulated samples."""
    dt, states = result["dt"], result["states"]
    steps = joint_state_steps(run, dt)
    result["advance_to"](max(steps.values(), default=0) * dt)
    result["by_log"] = {log: states[k] for log, k in steps.items() if k in states}
    rows = {name: {"signal": name, "unit": unit, "max_deviation": 0.0, "at_time_s": math.nan,
                   "samples": 0, "tol": tolerances[name]}
            for name, (unit, _) in SIGNALS.items()}  # fmt: skip
    missing = 0

    def note(name: str, dev: float, t: float) -> None:
        row = rows[name]
        row["samples"] += 1
        if not dev <= row["max_deviation"]:  # NaN counts as the worst
            row["max_deviation"], row["at_time_s"] = dev, t

    for log, m in run.joint_states:
        k = steps[log]
        state = states.get(k)
        if state is None:
            missing += 1
            continue
        q, qd, force, _gap, _acc = state
        names = ("stroke", "link_angle", "flap_angle")
        for i, name in enumerate(names):
            note(name, _deviation(m.position[i], q[i]), k * dt)
        for i, name in enumerate(("stroke_rate", "link_rate", "flap_rate")):
            note(name, _deviation(m.velocity[i], qd[i]), k * dt)
        note("piston_force", _deviation(m.effort[0], force), k * dt)
    # the Float64 topics are published in the same tick, logged at the same node time
    for topic_msgs, name, idx in ((run.forces, "piston_force", 2), (run.gaps, "gap", 3)):
        for log, m in topic_msgs:
            k = steps.get(log)
            if k is None or k not in states:
                continue
            note(name, _deviation(m.data, states[k][idx]), k * dt)
    out = list(rows.values())
    for row in out:
        row["ok"] = bool(row["max_deviation"] <= row["tol"])
        if math.isnan(row["at_time_s"]):
            row["at_time_s"] = None
    if missing:
        result["notes"].append(f"{missing} recorded joint states have no re-simulated step")
    return out


def write_bag(out: str | Path, run: RecordedRun, result: dict, model: DRSParams) -> None:
    """The re-simulated run as a new bag: the parameters it ran with, then joint states, force,
    gap and acceleration at the recorded stamps (so ``drs-bag check`` checks it too)."""
    from rcl_interfaces.msg import ParameterEvent
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    from ..conversions import float_msg, time_msg
    from ..recording.mcap_recorder import McapRecorder
    from .effects import parameter_event

    names = list(run.node_parameters["joint_names"])
    tp = DEFAULT_TOPICS
    values = dict(run.node_parameters)
    values.update({f"model.{k}": float(getattr(model, k)) for k in NUMERIC_FIELDS})
    values["fidelity"] = result["sim"].name  # the rung it ran on (--fidelity)
    with McapRecorder(out, flush_thread=False) as rec:
        rec.register_topic(tp["parameter_events"], ParameterEvent, 1000)
        first = run.joint_states[0][0] if run.joint_states else 0
        rec.write(tp["parameter_events"], parameter_event("/drs", values, first), first)
        rec.register_topic(tp["joint_states"], JointState, 10)
        for key in ("piston_force", "flap_gap", "piston_acceleration"):
            rec.register_topic(tp[key], Float64, 10)
        for log, m in run.joint_states:
            stamp = _stamp_ns(m)
            state = result["by_log"].get(log)
            if state is None:
                continue
            q, qd, force, gap, acc = state
            js = JointState(name=names, position=[float(x) for x in q],
                            velocity=[float(x) for x in qd],
                            effort=[float(force), math.nan, math.nan])  # fmt: skip
            js.header.stamp = time_msg(stamp)
            rec.write(tp["joint_states"], js, log)
            rec.write(tp["piston_force"], float_msg(force), log)
            rec.write(tp["flap_gap"], float_msg(gap), log)
            rec.write(tp["piston_acceleration"], float_msg(acc), log)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("bag", help="bag directory or .mcap file recorded by drs-node")
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="change a model parameter for the re-run (repeatable), e.g. m_wing=0.5",
    )
    ap.add_argument("--params", help="a .toml/.yaml file of model parameters for the re-run")
    ap.add_argument(
        "--fidelity",
        choices=list(RUNGS),
        help="re-run on this rung of the fidelity ladder (default: the one recorded)",
    )
    ap.add_argument("-o", "--output", help="write the re-simulated run as a new bag directory")
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


def run(args: argparse.Namespace, prog: str = "drs-bag resimulate") -> int:
    tolerances = {name: (args.force_tol if unit == "N" else args.tol)
                  for name, (unit, _) in SIGNALS.items()}  # fmt: skip
    try:
        recorded = read_run(args.bag)
        model = run_params(recorded.node_parameters, args.set, args.params)
        result = resimulate(recorded, model, args.fidelity)
        rows = compare(recorded, result, tolerances)
        if args.output:
            write_bag(args.output, recorded, result, model)
    except MessageCallbackError as exc:  # our own failure on an intact message
        print(f"{prog}: internal error (not a verdict on the bag): {exc}", file=sys.stderr)
        return 4
    except (DRSError, BagReadError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    ok = all(r["ok"] for r in rows)
    if args.output:
        result["notes"].append(f"wrote the re-simulated run to {args.output}")
    if args.json:
        print(json.dumps({"bag": str(args.bag), "ok": ok, "signals": rows,
                          "notes": result["notes"], "changed": args.set,
                          "fidelity": args.fidelity}, indent=2,
                         default=lambda x: None))  # fmt: skip
    else:
        print(f"re-simulated {args.bag}" + (f" with {', '.join(args.set)}" if args.set else "")
              + (f" on the {args.fidelity} rung" if args.fidelity else ""))  # fmt: skip
        print(f"{'signal':<14} {'unit':<6} {'n':>6} {'max deviation':>14} {'at t [s]':>10} "
              f"{'tol':>8}  status")  # fmt: skip
        for r in rows:
            at = "-" if r["at_time_s"] is None else f"{r['at_time_s']:.4f}"
            print(f"{r['signal']:<14} {r['unit']:<6} {r['samples']:>6} "
                  f"{r['max_deviation']:>14.3e} {at:>10} {r['tol']:>8.1e}  "
                  f"{'ok' if r['ok'] else 'DEVIATES'}")  # fmt: skip
        for n in result["notes"]:
            print(f"note: {n}")
    return 0 if ok else 1


__all__ = ["ResimulationError", "add_arguments", "compare", "read_run", "resimulate", "run"]
