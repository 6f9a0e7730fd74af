"""A recorded run judged against the model that ran it: the rung and the faults the bag recorded
(:class:`~drs_ros.bag.read.recorded_run.RecordedRun`), judged with the rung's own equations
(:mod:`drs_model.fidelity.recorded`). Part of ``drs-bag check`` (docs/bags.md, "What check
judges").

:class:`RunChecker` hands every joint state to :class:`~drs_ros.bag.check.model_checks.ModelChecker`
(constraints, gap, and the piston force of the logged motion where the rung has inertia), with
the stroke a faulty sensor published replaced by the true one (from the flap angle, which the
sensor faults leave alone), and judges each tick (the messages the node wrote at one log time,
after the tick's records) by its rung:

* every rung: ``~/piston_force`` is the joint state's effort;
* ``kinematic``: no piston force (NaN or absent);
* ``quasi-static``: the force is the statics at the stroke (at rest on an end stop it is not);
* ``rigid``: the inverse dynamics of the logged motion (:class:`ModelChecker`);
* ``hydraulic``: the force is the rod force of the recorded chamber pressures with the friction
  in force; plus the stops' contact force it is the inverse dynamics of the logged motion; the
  supply pressure is the one the faults set; a stuck spool stays where it stuck.

And by the recorded faults: a sensor fault's stroke against the faulty sensor replayed (its seed
gives the same noise), a supply loss on ``rigid`` and ``quasi-static`` as a zero force until the
next command.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from drs_model.errors import DRSError
from drs_model.fidelity.hydraulic_params import hydraulic_from_dict
from drs_model.fidelity.recorded import HydraulicRecord, SensorReplay, StaticForce, TrueStroke
from drs_model.kinematics import stroke_limits
from drs_ros.bag.check.model_checks import FORCE_CHECK, CheckResult, ModelChecker, _Worst, joint_row
from drs_ros.bag.read.effects import EffectRecord, fault_of, hydraulic_params_from, is_fault_record
from drs_ros.bag.read.recorded_run import RecordedRun
from drs_ros.names import ACCEPTED, RESET
from drs_ros.timestamps import ns_of

#: Topics read per tick besides the joint states: key of the topic -> how its value is read.
TICK_TOPICS = {
    "piston_force": "data",
    "pressure_piston_side": "fluid_pressure",
    "pressure_rod_side": "fluid_pressure",
    "supply_pressure": "fluid_pressure",
    "valve_spool": "data",
}
#: Ticks held at most while their joint state is awaited (the node writes a tick's messages
#: together, so a bag in its order holds one or two).
MAX_PENDING_TICKS = 1024
#: The rungs whose piston force the inverse dynamics of the logged motion gives.
DYNAMIC_RUNGS = ("rigid", "hydraulic")


def _dev(recorded: float, model: float) -> float:
    """``|recorded - model|``; 0 where both are NaN (the same missing value), inf where one is."""
    if math.isnan(recorded) and math.isnan(model):
        return 0.0
    d = abs(recorded - model)
    return math.inf if math.isnan(d) else d


class RunChecker:
    """The checks of one run: feed it every message of :attr:`topics` in the bag's order
    (:meth:`add`), then ask for :meth:`results`. ``model`` checks the joint states (its force
    model, the user's or the inverse dynamics, is used on the rungs with inertia);
    ``pressure_tol`` [Pa] is the tolerance of the hydraulic pressure checks; ``node`` the fully
    qualified name whose parameters and records are read."""

    def __init__(
        self,
        model: ModelChecker,
        *,
        pressure_tol: float = 1.0,
        node: str = "/drs",
        hydraulic_overrides: dict | None = None,
    ):
        self.model, self.p = model, model.p
        # HydraulicParams values set over the recorded ones (a --params file's hydraulic names)
        self.hydraulic_overrides = dict(hydraulic_overrides or {})
        self.run = RecordedRun(node)
        self.tp = model.tp
        self.pressure_tol = pressure_tol
        self.rung: str | None = None
        self.rung_error = ""
        self._forces = model.force_model, model.force_note
        self._resolved = False
        self._sensor: SensorReplay | None = None
        self._hydraulic: HydraulicRecord | None = None
        self._static: StaticForce | None = None
        self._true = TrueStroke(self.p)
        self._s_min, self._s_max = stroke_limits(self.p)
        self._tick_key = {self.tp[k]: k for k in TICK_TOPICS}
        self._ticks: dict[int, dict] = {}
        self._zero_force = False  # a supply loss on a rung that models it as a zero force
        self._stuck = False
        self._stuck_spool: float | None = None
        self.worst = {
            k: _Worst()
            for k in (
                "sensor",
                "force_topic",
                "kinematic",
                "statics",
                "zero_force",
                "rod",
                "supply",
                "spool",
            )
        }
        self.on_stop = self.missing_pressures = 0
        self.bad_faults: list[str] = []  # accepted fault records the model refuses

    @property
    def topics(self) -> set[str]:
        """The topics the checks read."""
        tp = self.tp
        return {*self.model.topics, *self._tick_key, tp["parameter_events"], tp["command_events"]}

    # ---- the stream ---------------------------------------------------------------------------
    def add(self, topic: str, log_ns: int, msg) -> None:
        """One decoded message, in the bag's order (other topics are ignored)."""
        tp = self.tp
        if topic == tp["parameter_events"]:
            self.run.take_parameters(msg)
        elif topic == tp["command_events"]:
            self._flush()
            for r in self.run.take_effects(log_ns, msg):
                self._act(r)
        elif topic == tp["joint_states"]:
            self._joint_state(log_ns, msg)
        elif topic in self._tick_key:
            key = self._tick_key[topic]
            self._ticks.setdefault(log_ns, {})[key] = float(getattr(msg, TICK_TOPICS[key]))
            if len(self._ticks) > MAX_PENDING_TICKS:  # samples without joint states: bounded
                self._tick(self._ticks.pop(min(self._ticks)))
        else:
            self.model.add(topic, log_ns, msg)

    def _hydraulic_params(self):
        """The HydraulicParams the node recorded (``hydraulic.*``; the defaults where none),
        with :attr:`hydraulic_overrides` set over them."""
        base = hydraulic_params_from(self.run.node_parameters)
        return hydraulic_from_dict(self.hydraulic_overrides, base=base)

    def _resolve(self) -> None:
        """The rung, once (its records precede the first state and the first fault)."""
        if self._resolved:
            return
        self._resolved = True
        try:
            self.rung = self.run.rung()
        except DRSError as exc:
            self.rung_error = str(exc)
        dt, rung = self.run.dt, self.rung
        self._sensor = SensorReplay(rung or "rigid", dt)
        if rung == "hydraulic":
            self._hydraulic = HydraulicRecord(self.p, dt, self._hydraulic_params())
        elif rung == "quasi-static":
            self._static = StaticForce(self.p, dt)
        force_model, note = self._forces
        if rung not in DYNAMIC_RUNGS:
            self.model.force_model = None
        elif rung == "hydraulic" and force_model is not None:
            self.model.force_model = self._less_stops(force_model)
            self.model.force_note = f"{note} less the end stops' contact force"

    def _less_stops(self, force_model: Callable) -> Callable:
        """The rod force the hydraulic rung publishes: the force of the logged motion less the
        compliant end stops' contact force (the cylinder does not give it)."""
        hyd = self._hydraulic

        def rod_force(q, qd, qdd, p):
            total = np.asarray(force_model(q, qd, qdd, p), dtype=float).reshape(-1)
            stops = [hyd.stop_force(s, sd) for s, sd in zip(q[:, 0], qd[:, 0], strict=True)]
            return total - np.asarray(stops, dtype=float)

        return rod_force

    def _act(self, r: EffectRecord) -> None:
        """Follow an effect record: a fault, or a command (which ends a supply loss's zero
        force on the rungs that model it so)."""
        if r.outcome not in (ACCEPTED, RESET):
            return
        if not is_fault_record(r):
            self._zero_force = False
            return
        self._resolve()
        try:
            name, value = fault_of(r)
            if name.startswith("sensor."):
                self._sensor.set(name, value)
                return
            if self._hydraulic is not None:
                self._hydraulic.set(name, value, r.sim_time)
        except (DRSError, ValueError, SyntaxError) as exc:  # a record the model cannot take
            self.bad_faults.append(f"{r.source} = {r.values.get('value')!r}: {exc}")
            return
        if name == "supply_loss" and value and self.rung in ("rigid", "quasi-static"):
            self._zero_force = True
        elif name == "stuck_valve":
            self._stuck, self._stuck_spool = bool(value), None

    def _joint_state(self, log_ns: int, msg) -> None:
        self._resolve()
        self._flush(before=log_ns)
        row = joint_row(log_ns, msg, self.model.joint_names)
        if row is None:
            self.model.add_row(None)
            return
        t, log, q, qd, effort = row
        stamp = ns_of(msg.header.stamp)
        t_sim = self.run.sim_time(stamp)
        if not math.isnan(t_sim):
            s_true = self._true(q[2]) if math.isfinite(q[2]) else math.nan
            published = self._sensor.reading(t_sim, s_true)
            if not self._sensor.healthy:  # judged against the faulty sensor, then set aside
                self.worst["sensor"].add([_dev(q[0], published)], [t])
                q = [s_true, q[1], q[2]]
        self.model.add_row((t, log, q, qd, effort))
        self._ticks.setdefault(log_ns, {})["js"] = (t, q, qd, effort, t_sim)

    def _flush(self, before: int | None = None) -> None:
        """Judge the ticks logged before ``before`` (all of them by default)."""
        for log_ns in sorted(self._ticks):
            if before is not None and log_ns >= before:
                break
            self._tick(self._ticks.pop(log_ns))

    # ---- one tick -----------------------------------------------------------------------------
    def _tick(self, tick: dict) -> None:
        js = tick.get("js")
        if js is None:
            return  # scalars without a joint state: nothing to pair them with
        t, q, qd, effort, t_sim = js
        w = self.worst
        if "piston_force" in tick:
            w["force_topic"].add([_dev(tick["piston_force"], effort)], [t])
        if self.rung == "kinematic":
            forces = [effort, tick.get("piston_force", math.nan)]
            w["kinematic"].add(
                [max((abs(f) for f in forces if not math.isnan(f)), default=0.0)], [t]
            )
        elif self.rung == "quasi-static":
            self._statics(t, q, qd, effort)
        elif self.rung == "hydraulic":
            self._hydraulics(tick, t, qd, effort, t_sim)
        if self._zero_force:
            w["zero_force"].add([_dev(effort, 0.0)], [t])

    def _statics(self, t, q, qd, effort) -> None:
        s = q[0]
        if not (math.isfinite(s) and math.isfinite(effort)):
            self.worst["statics"].add([math.inf], [t])
            return
        at_rest = all(v == 0.0 for v in qd)
        if at_rest and (abs(s - self._s_min) < 1e-12 or abs(s - self._s_max) < 1e-12):
            self.on_stop += 1  # the stop carries the difference between force and statics
            return
        self.worst["statics"].add([abs(effort - self._static(s))], [t])

    def _hydraulics(self, tick: dict, t, qd, effort, t_sim) -> None:
        w, hyd = self.worst, self._hydraulic
        pa, pb = tick.get("pressure_piston_side"), tick.get("pressure_rod_side")
        if pa is None or pb is None:
            self.missing_pressures += 1
        else:
            w["rod"].add([_dev(effort, hyd.rod_force(pa, pb, qd[0]))], [t])
        if "supply_pressure" in tick and not math.isnan(t_sim):
            w["supply"].add([_dev(tick["supply_pressure"], hyd.supply_pressure(t_sim))], [t])
        spool = tick.get("valve_spool")
        if self._stuck and spool is not None:
            if self._stuck_spool is None:
                self._stuck_spool = spool
            w["spool"].add([_dev(spool, self._stuck_spool)], [t])

    # ---- the report ---------------------------------------------------------------------------
    def results(self) -> list[CheckResult]:
        """Every check's result: the joint-state checks, then the rung's and the faults'."""
        self._resolve()
        self._flush()
        out = [
            r for r in self.model.results() if self.rung in DYNAMIC_RUNGS or r.name != FORCE_CHECK
        ]
        return out + self._rung_results()

    def _rung_results(self) -> list[CheckResult]:
        tp, w, ftol = self.tp, self.worst, self.model.force_tol
        js, force = tp["joint_states"], tp["piston_force"]
        out = [
            w["force_topic"].result(
                "piston force topic vs joint effort",
                force,
                "N",
                0.0,
                "the same value published twice",
            )
        ]
        if self.rung is None:
            out.append(
                CheckResult(
                    "rung of the run",
                    tp["command_events"],
                    "-",
                    0,
                    math.inf,
                    math.nan,
                    0.0,
                    "FAIL",
                    self.rung_error,
                )
            )
        elif self.rung == "kinematic":
            res = w["kinematic"].result("no piston force (kinematic rung)", js, "N", 0.0)
            note = (
                "the kinematic rung models no force: every force sample is NaN or absent"
                if res.status == "ok"
                else "the kinematic rung models no force, yet the bag holds force values"
            )
            out.append(replace(res, note=note))
        elif self.rung == "quasi-static":
            out.append(
                w["statics"].result(
                    "piston force vs statics",
                    js,
                    "N",
                    ftol,
                    f"{self.on_stop} samples resting on an end stop left out",
                )
            )
        elif self.rung == "hydraulic":
            out += self._hydraulic_results()
        out += self._fault_results()
        return out

    def _hydraulic_results(self) -> list[CheckResult]:
        tp, w, ptol = self.tp, self.worst, self.pressure_tol
        note = (
            f"{self.missing_pressures} joint states without both pressures"
            if self.missing_pressures
            else "p_A A_A - p_B A_B - friction"
        )
        return [
            w["rod"].result(
                "piston force vs chamber pressures",
                tp["pressure_piston_side"],
                "N",
                self.model.force_tol,
                note,
            ),
            w["supply"].result(
                "supply pressure vs faults",
                tp["supply_pressure"],
                "Pa",
                ptol,
                "the supply, its loss and ramps as recorded",
            ),
        ]

    def _fault_results(self) -> list[CheckResult]:
        tp, w = self.tp, self.worst
        out = []
        if self.bad_faults:
            out.append(
                CheckResult(
                    "recorded faults",
                    tp["command_events"],
                    "count",
                    len(self.bad_faults),
                    float(len(self.bad_faults)),
                    math.nan,
                    0.0,
                    "FAIL",
                    "; ".join(self.bad_faults),
                )
            )
        if w["sensor"].samples:
            out.append(
                w["sensor"].result(
                    "stroke vs faulty sensor model",
                    tp["joint_states"],
                    "m",
                    self.model.tol,
                    "the sensor faults replayed (seeded noise, dropouts, bias, frozen); the true "
                    "stroke, from the flap angle, is what the other checks use",
                )
            )
        if w["zero_force"].samples:
            out.append(
                w["zero_force"].result(
                    "piston force under supply loss",
                    tp["joint_states"],
                    "N",
                    self.model.force_tol,
                    f"the {self.rung} rung: zero until the next command",
                )
            )
        if w["spool"].samples:
            out.append(
                w["spool"].result(
                    "stuck spool holds", tp["valve_spool"], "-", 0.0, "the spool where it stuck"
                )
            )
        return out


def fault_report(run: RecordedRun) -> list[dict]:
    """The recorded faults' spans, JSON-ready: fault, value, from and to in simulated time [s]
    and log time [ns] (``to`` None: to the end of the recording)."""
    return [
        {
            "fault": s.fault,
            "value": s.value,
            "sim_from_s": s.sim_from_s,
            "sim_to_s": s.sim_to_s,
            "log_from_ns": s.log_from_ns,
            "log_to_ns": s.log_to_ns,
        }
        for s in run.spans
    ]


__all__ = ["RunChecker", "TICK_TOPICS", "fault_report"]
