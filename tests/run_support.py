"""Runs recorded as the node records them, without DDS: bags whose truth is known, for the fits'
tests and benchmarks (a test fixture, not a product: no command line uses it).

:func:`record_run` steps a rung of :mod:`drs_model.fidelity` the way the node's tick does (one
physics step per tick, the commands and faults applied at the tick's start, then the step, then
what the node publishes) and writes what the node's bag holds: the node parameters on
``/parameter_events`` (the fault parameters at their values), the effect record
(``~/command_events``: the clock origin, each command and fault where it took effect), the
commands on their topics, the joint states (the stroke as the possibly faulty sensor reports
it), the force, gap and acceleration, and on the hydraulic rung the chamber, supply pressures
and spool. It uses the node's own pieces (:mod:`drs_ros.commands`,
:class:`~drs_model.fidelity.faults.RunFaults`, :mod:`drs_ros.conversions`), and
``drs-bag resimulate`` re-runs such a bag to the bit (tested), which is what says it is a bag
the node would have written.

Truth: the model parameters recorded, HydraulicParams' defaults, and the faults (a leak to
the outside adds to ``leak_to_outside``, a jam to ``coulomb_friction`` and
``breakaway_friction``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from long_bag_support import T0_NS

from drs_model.fidelity import HydraulicParams, make_rung
from drs_model.fidelity.faults import FAULTS, RunFaults
from drs_model.params import DRSParams
from drs_ros import commands as cmds
from drs_ros.model_parameters import served_values
from drs_ros.names import ACCEPTED, CLOCK, DEFAULT_JOINT_NAMES, DEFAULT_TOPICS


@dataclass(frozen=True)
class Command:
    """A command taking effect at the physics step ``step``: ``key`` ``"drs"`` (the service;
    ``value`` open or close), ``"stroke_cmd"``, ``"force_cmd"`` (a float) or
    ``"trajectory_cmd"`` (``value``: a FollowJointTrajectory goal's ``trajectory`` mapping, as
    ``drs excite -o`` writes it and ``drs-bag from-goal`` reads it), or ``"fault"`` (``value``:
    ``(name, value)`` of :data:`~drs_model.fidelity.faults.FAULTS`, set as the node sets its
    ``fault.*`` parameters while it runs)."""

    step: int
    key: str
    value: object


def seed_commands(
    params: DRSParams, physics_rate_hz: float = 1000.0, hold_s: float | None = None
) -> tuple[Command, ...]:
    """The seed's manoeuvre as the node takes it through its service: open at step 1, close
    when the opening and the hold are over."""
    hold = params.T_still if hold_s is None else hold_s
    close = 1 + int(round((params.T_opening + hold) * physics_rate_hz))
    return (Command(1, "drs", True), Command(close, "drs", False))


def _node_parameters(params, fidelity, physics_rate_hz, faults, joint_names, hydraulic) -> dict:
    values = {
        "physics_rate_hz": float(physics_rate_hz),
        "publish_rate_hz": float(physics_rate_hz),
        "force_limit": 2.0e4,
        "integrator": "rk4",
        "force_method": "fused",
        "fidelity": fidelity,
        "joint_names": list(joint_names),
    }
    values.update(served_values(params, hydraulic))  # model.* and hydraulic.*, as served
    for name, (healthy, _) in FAULTS.items():
        values[f"fault.{name}"] = faults.get(name, healthy)
    return values


def _register(rec, hydraulic: bool) -> None:
    from diagnostic_msgs.msg import DiagnosticArray
    from rcl_interfaces.msg import ParameterEvent
    from sensor_msgs.msg import FluidPressure, JointState
    from std_msgs.msg import Float64
    from trajectory_msgs.msg import JointTrajectory

    tp = DEFAULT_TOPICS
    rec.register_topic(tp["parameter_events"], ParameterEvent, 1000)
    rec.register_topic(tp["command_events"], DiagnosticArray, 100)
    for key in ("stroke_cmd", "force_cmd"):
        rec.register_topic(tp[key], Float64, 10)
    rec.register_topic(tp["trajectory_cmd"], JointTrajectory, 10)
    rec.register_topic(tp["joint_states"], JointState, 10)
    for key in ("piston_force", "flap_gap", "piston_acceleration"):
        rec.register_topic(tp[key], Float64, 10)
    if hydraulic:
        for role in ("pressure_piston_side", "pressure_rod_side", "supply_pressure"):
            rec.register_topic(tp[role], FluidPressure, 10)
        rec.register_topic(tp["valve_spool"], Float64, 10)


class _Writer:
    """The node's recording side for one run: events stamped at simulated instants, states."""

    def __init__(self, rec, sim, faults, names, t0_ns: int, frame_id: str = "drs_base") -> None:
        self.rec, self.sim, self.faults, self.names = rec, sim, faults, list(names)
        self.t0, self.frame_id = t0_ns, frame_id

    def stamp(self) -> int:
        return self.t0 + int(round(self.sim.t * 1e9))

    def event(self, now: int, source: str, outcome: str, values: dict) -> None:
        from diagnostic_msgs.msg import DiagnosticStatus

        from drs_ros.conversions import command_event_msg

        record = {"sim_time": repr(self.sim.t), "step": self.sim.steps, **values}
        msg = command_event_msg(self.stamp(), source, outcome, DiagnosticStatus.OK, "", record)
        self.rec.write(DEFAULT_TOPICS["command_events"], msg, now)

    def command(self, now: int, c: Command) -> None:
        from std_msgs.msg import Float64

        tp = DEFAULT_TOPICS
        if c.key == "fault":  # a fault parameter set while the node runs
            name, value = c.value
            self.faults.apply(name, value)
            self.event(now, f"fault.{name}", ACCEPTED, {"value": repr(value)})
            return
        if c.key == "drs":
            cmds.apply(self.sim, cmds.SERVICE_KEY, _Data(bool(c.value)), self.names[0])
            self.event(now, tp["drs_service"], ACCEPTED, {"value": repr(bool(c.value))})
            return
        if c.key == "trajectory_cmd":
            from drs_ros.bag.from_goal import check_trajectory, trajectory_message

            check_trajectory(c.value)
            msg = trajectory_message(c.value)
        else:
            msg = Float64(data=float(c.value))
        received = now - 500_000
        seq = self.rec.write(tp[c.key], msg, received)
        cmds.apply(self.sim, c.key, msg, self.names[0])
        self.event(
            now,
            tp[c.key],
            ACCEPTED,
            {"sequence": seq, "received_ns": received, "value": repr(cmds.describe(c.key, msg))},
        )

    def publish(self, now: int, hydraulic: bool) -> None:
        from message_support import joint_state_msg
        from sensor_msgs.msg import FluidPressure
        from std_msgs.msg import Header

        from drs_ros.conversions import float_msg, time_msg

        tp, st, stamp = DEFAULT_TOPICS, self.sim.state, self.stamp()
        js = joint_state_msg(st, self.names, stamp)
        js.position[0] = self.faults.published_stroke(st.t, float(st.q[0]))
        self.rec.write(tp["joint_states"], js, now)
        for key, value in (
            ("piston_force", st.piston_force),
            ("flap_gap", st.gap),
            ("piston_acceleration", st.qdd[0]),
        ):
            self.rec.write(tp[key], float_msg(float(value)), now)
        if hydraulic:
            header = Header(stamp=time_msg(stamp), frame_id=self.frame_id)
            for role, value in (
                ("pressure_piston_side", st.pressure_a),
                ("pressure_rod_side", st.pressure_b),
                ("supply_pressure", st.supply_pressure),
            ):
                self.rec.write(tp[role], FluidPressure(header=header, fluid_pressure=value), now)
            spool = math.nan if st.spool is None else st.spool
            self.rec.write(tp["valve_spool"], float_msg(float(spool)), now)


@dataclass(frozen=True)
class _Data:
    data: object


def record_run(
    bag_dir: str | Path,
    steps: int,
    commands: Sequence[Command] = (),
    *,
    fidelity: str = "rigid",
    params: DRSParams | None = None,
    faults: dict | None = None,
    physics_rate_hz: float = 1000.0,
    t0_ns: int = T0_NS,
    joint_names: Sequence[str] = DEFAULT_JOINT_NAMES,
    hydraulic_params: HydraulicParams | None = None,
) -> Path:
    """Record ``steps`` physics steps of a run (module docstring) into the new bag directory
    ``bag_dir``: ``commands`` act at their steps, ``faults`` (``name -> value`` of
    :data:`~drs_model.fidelity.faults.FAULTS`) from the first tick, at the node time ``t0_ns``
    onwards, one tick per physics step; ``hydraulic_params``: the hydraulic rung's (default:
    HydraulicParams' defaults). Returns the bag directory."""
    from drs_ros.bag.read.effects import parameter_event
    from drs_ros.recording.mcap_recorder import McapRecorder

    params = DRSParams() if params is None else params
    faults = dict(faults or {})
    dt = 1.0 / physics_rate_hz
    hp = HydraulicParams() if hydraulic_params is None else hydraulic_params
    sim = make_rung(fidelity, params, dt, **({"hydraulic": hp} if fidelity == "hydraulic" else {}))
    run_faults = RunFaults(sim)
    hydraulic = fidelity == "hydraulic"
    by_step: dict[int, list[Command]] = {}
    for c in commands:
        by_step.setdefault(int(c.step), []).append(c)
    with McapRecorder(bag_dir, flush_thread=False) as rec:
        _register(rec, hydraulic)
        values = _node_parameters(params, fidelity, physics_rate_hz, faults, joint_names, hp)
        rec.write(DEFAULT_TOPICS["parameter_events"], parameter_event("/drs", values, t0_ns), t0_ns)
        w = _Writer(rec, sim, run_faults, joint_names, t0_ns)
        w.event(t0_ns, CLOCK, CLOCK, {"t0_ns": t0_ns})
        for name in FAULTS:  # the faults given at start, in FAULTS order, at the first tick
            if name in faults and faults[name] != FAULTS[name][0]:
                run_faults.apply(name, faults[name])
                w.event(t0_ns, f"fault.{name}", ACCEPTED, {"value": repr(faults[name])})
        w.publish(t0_ns, hydraulic)
        for k in range(1, steps + 1):
            now = t0_ns + int(round(k * dt * 1e9))
            for c in by_step.get(k, ()):  # arrived before this tick: act before its step
                w.command(now, c)
            sim.step()
            w.publish(now, hydraulic)
    return Path(bag_dir)


__all__ = ["T0_NS", "Command", "record_run", "seed_commands"]
