"""The node's command intake: a part of :class:`drs_ros.node.adapter.DRSNode` that owns the
commands received and not yet applied.

Commands are latest-wins: a subscription callback only decodes the bytes that arrived, does the
state-free part of the command's work (a trajectory's plan) and keeps the newest command per
topic; the next tick applies it before stepping (:meth:`CommandIntake.apply_pending`), so no
queued, stale setpoint is ever executed. A ``~/drs`` service call acts at once
(:meth:`CommandIntake.on_drs`; under the deadline loop just after a tick due within 1 ms:
:mod:`.tick_gate`). Every command is recorded as its exact CDR bytes as it arrives;
what became of it goes into the effect record.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import Float64

from .. import commands
from ..names import ACCEPTED, REFUSED, SUPERSEDED
from ..recording import cdr_received, msgdefs
from .effect_record import EffectRecord, PendingCommand, refusal_reason
from .float64_cdr import read_float64
from .trajectory_cdr import read_joint_trajectory

#: The command topics (``~/<key>``) and their message classes, as commands.COMMAND_TYPES names them.
COMMANDS = {key: msgdefs.message_class(name) for key, name in commands.COMMAND_TYPES.items()}


def command_decoders() -> dict:
    """Command key -> ``decode(data) -> (message, exact CDR bytes)``. A command is taken if it
    decodes and is as long as its exact CDR (plus transport padding), and recorded as that exact
    CDR, which every reader of the bag decodes; a trajectory is read in place (rclpy's decoder
    would hold the GIL for ~100 ms on 10,000 points, a stall of the real-time tick), and so is a
    Float64 (~2 us against ~13)."""
    decode = {
        key: functools.partial(cdr_received.decode_exact, msg_class=cls)
        for key, cls in COMMANDS.items()
    }
    decode.update({key: read_float64 for key, cls in COMMANDS.items() if cls is Float64})
    decode["trajectory_cmd"] = lambda data: (v := read_joint_trajectory(data), v.exact)
    return decode


class CommandIntake:
    """The commands of one configured node, from their bytes to the actuator.

    Parameters
    ----------
    topics : dict
        Command key -> resolved topic (the recording's key).
    service_name : str
        The resolved ``~/drs`` service (the source of its records).
    piston_joint : str
        The piston joint's name (a trajectory's or a JointState's).
    effects : EffectRecord
        Where each command's fate is counted and recorded.
    actuator : callable
        ``actuator()``: the actuator the node runs now.
    lock : threading.Lock
        The node's lock, held by the tick: the callbacks take it to touch the pending commands.
    now_ns, state_stamp_ns, record : callable
        The node clock [ns]; the stamp [ns] of the actuator's state, which the next tick
        applies a command to (None before the first tick after an activation);
        ``record(topic, data, now_ns)``, the bytes into the bag.
    """

    def __init__(
        self,
        topics: dict[str, str],
        service_name: str,
        piston_joint: str,
        effects: EffectRecord,
        actuator: Callable[[], object],
        lock,
        now_ns: Callable[[], int],
        state_stamp_ns: Callable[[], int | None],
        record: Callable,
    ) -> None:
        self.topics, self.service_name, self.piston_joint = topics, service_name, piston_joint
        self._effects, self._actuator, self._lock = effects, actuator, lock
        self._now_ns, self._record = now_ns, record
        self._state_stamp_ns = state_stamp_ns
        self._decode = command_decoders()
        self._pending: dict[str, PendingCommand] = {}

    @property
    def waiting(self) -> bool:
        """A command waits for the next physics step."""
        return bool(self._pending)

    def clear(self) -> None:
        """Forget the commands not yet applied (a node deactivated: they never act)."""
        self._pending.clear()

    def receive(self, key: str, data: bytes) -> None:
        """A raw command arrived (executor thread): decode it and do the state-free part of its
        work here, outside the lock the real-time tick takes (a 10,000-point trajectory is
        planned in ~4 ms), then record it and keep it as the newest of its topic. Its log time
        is taken under the lock: no tick logged after it applies an older command of its topic."""
        topic, fx = self.topics[key], self._effects
        try:
            msg, exact = self._decode[key](data)
        except Exception as exc:  # noqa: BLE001 - any bytes from any participant: refused, kept
            with self._lock:
                fx.received += 1
                fx.refuse_malformed(topic, COMMANDS[key], data, exc, self._now_ns())
            return
        # a stamped trajectory's times are read against the stamp of the state the next tick
        # applies it to, not the node clock: the tick applies it before its steps, at a state
        # up to a publish period (and a late tick's lateness) older, and it would arrive that
        # much early. Read without the lock, before the plan: a tick that comes in between
        # applies it one tick later (it arrives a tick late, never early).
        planned_ns = self._state_stamp_ns()
        if planned_ns is None:  # no tick since the activation: its origin will be the clock
            planned_ns = self._now_ns()
        try:
            prepared = commands.prepare(self._actuator(), key, msg, self.piston_joint, planned_ns)
            refusal = None
        except Exception as exc:  # noqa: BLE001 - what a command carries never stops the node
            prepared, refusal = None, exc
        with self._lock:
            now = self._now_ns()
            fx.received += 1
            # only bytes that decode go on the typed topic: the bag stays readable by all readers
            # recorded as its exact CDR: the bytes that arrived, any alignment padding zeroed
            cmd = PendingCommand(
                key, topic, msg, self._record(topic, exact, now), now, prepared, planned_ns
            )
            if refusal is not None:
                fx.refuse_command(cmd, refusal, now)
                return
            older = self._pending.get(key)
            if older is not None:  # counted and recorded (one record per step) when it comes
                cmd.superseded = older.superseded
                cmd.superseded.append(older.sequence)
            self._pending[key] = cmd

    def apply_pending(self, now_ns: int) -> None:
        """Apply the newest command of each topic at the present physics step, oldest first."""
        pending = sorted(self._pending.values(), key=lambda c: c.received_ns)
        self._pending.clear()
        fx, sim = self._effects, self._actuator()
        for cmd in pending:
            if cmd.superseded:
                n = len(cmd.superseded)
                fx.superseded += n
                reason = f"{n} {cmd.key} replaced by a newer one before the next physics step"
                fx.troubles.add(now_ns, SUPERSEDED, reason)
                known = [q for q in cmd.superseded if q is not None]
                fx.event(
                    cmd.topic,
                    SUPERSEDED,
                    DiagnosticStatus.STALE,
                    reason,
                    None,
                    {
                        "count": n,
                        "sequences": f"{known[0]}..{known[-1]}" if known else "",
                    },
                    now_ns,
                )
            try:
                commands.apply(sim, cmd.key, cmd.msg, self.piston_joint, cmd.prepared)
            except Exception as exc:  # noqa: BLE001 - what a command carries never stops the node
                fx.refuse_command(cmd, exc, now_ns)
                continue
            fx.accepted += 1
            values = {"value": repr(commands.describe(cmd.key, cmd.msg))}
            if commands.reads_stamp(cmd.key, cmd.msg):  # a re-run starts it where the node did
                values["planned_ns"] = str(cmd.planned_ns)
            fx.event(cmd.topic, ACCEPTED, DiagnosticStatus.OK, "", cmd, values, now_ns)

    def before_drs(self, request) -> None:
        """A ``~/drs`` call's move evaluated before the node's lock (executor thread): its force
        check's path peak is then kept by the actuator, and :meth:`on_drs`, under the lock,
        finds it (a flap at rest: always; a moving one, unless a step came between), so the
        tick does not wait for it (~20 us compiled, ~0.3 ms before). Changes nothing else."""
        try:
            self._actuator().drs_duration(bool(request.data))
        except Exception:  # noqa: BLE001 - the call itself, under the lock, says what is wrong
            pass

    def on_drs(self, request, response, now_ns: int):
        """A ``~/drs`` call (under the node's lock): it takes effect at once, the simulation
        being between two physics steps, after the commands that arrived before it."""
        self.apply_pending(now_ns)  # commands that arrived earlier act first, as they would have
        fx = self._effects
        value = commands.describe(commands.SERVICE_KEY, request)
        try:
            seg = commands.apply(self._actuator(), commands.SERVICE_KEY, request, self.piston_joint)
        except Exception as exc:  # noqa: BLE001 - what a request carries never stops the node
            response.success = False
            response.message = fx.refuse("drs", value, refusal_reason(exc), now_ns)
            fx.event(
                self.service_name,
                REFUSED,
                DiagnosticStatus.WARN,
                response.message,
                None,
                {"value": repr(value)},
                now_ns,
            )
            return response
        fx.accepted += 1
        response.success = True
        response.message = (
            f"{'opening' if value else 'closing'} to {seg.end_stroke:.6g} m in {seg.duration:g} s"
        )
        fx.event(
            self.service_name,
            ACCEPTED,
            DiagnosticStatus.OK,
            "",
            None,
            {"value": repr(value)},
            now_ns,
        )
        return response


__all__ = ["COMMANDS", "CommandIntake", "command_decoders"]
