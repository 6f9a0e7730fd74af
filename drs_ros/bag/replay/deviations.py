"""The recorded signals against the re-run's (:func:`compare`): the largest deviation per signal
(:data:`SIGNALS`), the recorded samples streamed from the bag.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from drs_ros.bag.read.decoded import decoder
from drs_ros.bag.read.effects import effect_records
from drs_ros.bag.read.reader import scan
from drs_ros.bag.read.recorded import MessageCallbackError
from drs_ros.bag.read.recorded_run import RecordedRun, ResimulationError
from drs_ros.bag.replay.rerun import STATE_WINDOW
from drs_ros.names import CLOCK
from drs_ros.timestamps import nearest_step, ns_of, seconds_from_ns

#: signal -> (unit, default tolerance)
SIGNALS = {
    "stroke": ("m", 1e-9),
    "link_angle": ("rad", 1e-9),
    "flap_angle": ("rad", 1e-9),
    "stroke_rate": ("m/s", 1e-9),
    "link_rate": ("rad/s", 1e-9),
    "flap_rate": ("rad/s", 1e-9),
    "piston_force": ("N", 1e-6),
    "gap": ("m", 1e-9),
}


def _deviation(recorded: float, simulated: float) -> float:
    """``|recorded - simulated|``; 0 where both are NaN (a sensor's dropout, a kinematic rung's
    force: the same sample), NaN where one only is."""
    if math.isnan(recorded) and math.isnan(simulated):
        return 0.0
    return abs(recorded - simulated)


class _LargestDeviations:
    """The largest deviation of each signal of :data:`SIGNALS` so far, the simulated time of
    its first occurrence [s] and the samples compared; NaN counts as the worst."""

    def __init__(self, tolerances: dict[str, float]):
        self.rows = {
            name: {
                "signal": name,
                "unit": unit,
                "max_deviation": 0.0,
                "at_time_s": math.nan,
                "samples": 0,
                "tol": tolerances[name],
            }
            for name, (unit, _) in SIGNALS.items()
        }

    def note(self, name: str, dev: float, t: float) -> None:
        row = self.rows[name]
        row["samples"] += 1
        if not dev <= row["max_deviation"]:  # NaN counts as the worst
            row["max_deviation"], row["at_time_s"] = dev, t

    def note_joint_state(self, msg, state: tuple, t: float) -> None:
        """A recorded JointState against the re-simulated ``state`` of its step at ``t`` [s]."""
        q, qd, force, _gap, _acc = state
        for i, name in enumerate(("stroke", "link_angle", "flap_angle")):
            self.note(name, _deviation(msg.position[i], q[i]), t)
        for i, name in enumerate(("stroke_rate", "link_rate", "flap_rate")):
            self.note(name, _deviation(msg.velocity[i], qd[i]), t)
        self.note("piston_force", _deviation(msg.effort[0], force), t)

    def report(self) -> list[dict]:
        """The rows, each with ``ok`` (within its tolerance) and ``at_time_s`` None where no
        sample deviated."""
        out = list(self.rows.values())
        for row in out:
            row["ok"] = bool(row["max_deviation"] <= row["tol"])
            if math.isnan(row["at_time_s"]):
                row["at_time_s"] = None
        return out


def compare(
    run: RecordedRun, rerun: dict, tolerances: dict[str, float], on_state: Callable | None = None
) -> list[dict]:
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
    dt, state_at = rerun["dt"], rerun["state_at"]
    largest = _LargestDeviations(tolerances)
    missing = [0]
    origin: list = [None]
    seen = [0]
    recent: dict[int, int] = {}  # log time -> step of the latest joint states
    decode = decoder()

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
            k = nearest_step(seconds_from_ns(ns_of(msg.header.stamp) - origin[0]), dt)
            recent[m.log_time] = k
            if len(recent) > STATE_WINDOW:
                del recent[next(iter(recent))]
            state = state_at(k)
            if on_state is not None:
                on_state(m.log_time, msg, state)
            if state is None:
                missing[0] += 1
                return
            largest.note_joint_state(msg, state, k * dt)
            return
        # the Float64 topics are published in the same tick, logged at the same node time
        name, idx = scalar[m.topic]
        k = recent.get(m.log_time)
        state = None if k is None else state_at(k)
        if state is not None:
            largest.note(name, _deviation(msg.data, state[idx]), k * dt)

    topics = {tp["command_events"], tp["joint_states"], *scalar}
    try:
        scan(run.bag, take, exact=False, topics=topics)
    except MessageCallbackError as exc:  # the re-run's own refusal: a verdict, not a crash
        if isinstance(exc.__cause__, ResimulationError):
            raise exc.__cause__ from None
        raise
    if seen[0] == 0:
        raise ResimulationError("the effect record holds no clock origin (t0) before the states")
    rerun["finish"]()
    out = largest.report()
    if missing[0]:
        rerun["notes"].append(f"{missing[0]} recorded joint states have no re-simulated step")
    return out


__all__ = ["SIGNALS", "compare"]
