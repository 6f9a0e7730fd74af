"""The node's effect record and diagnostics.

The effect record (``~/command_events``, docs/ros.md "Effect record") says what became of every
command (accepted, refused or superseded, at which simulated instant) and of the node's own
doings (a clock origin, a physics reset): with the recorded commands and parameters, a bag
re-runs deterministically. Diagnostics (``/diagnostics``, ~1 Hz) report the cumulative counters
and the troubles of the last few seconds (:class:`TroubleWindow`), so they recover once a trouble
is over.

:class:`EffectRecord` is a part of :class:`drs_ros.node.adapter.DRSNode`, constructed with the
publisher, the recorder's hook and the actuator's instant it needs; it holds the counters.
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib

from diagnostic_msgs.msg import DiagnosticStatus

from drs_model.errors import DRSError

from .. import commands
from ..conversions import command_event_status
from ..errors import DRSRosError
from ..log_throttle import LogThrottle
from ..names import CLOCK, REFUSED
from ..recording.cdr_received import without_source_location
from ..recording.diagnostic_cdr import diagnostic_array_cdr
from ..timestamps import ns_from_seconds, seconds_from_ns
from .tick_schedule import LatenessHistogram

#: Bytes of a malformed command kept (hex) in its effect record, for forensics.
MALFORMED_BYTES_KEPT = 4096


@dataclasses.dataclass
class PendingCommand:
    """A command received and recorded, waiting for the next physics step (newest wins)."""

    key: str
    topic: str
    msg: object  # the decoded message (only messages that decode are ever pending)
    sequence: int | None
    received_ns: int
    prepared: object = None  # commands.prepare's result (a trajectory's plan)
    #: the node time [ns] its times were read against (a trajectory with a ``header.stamp``)
    planned_ns: int | None = None
    #: sequence numbers of the older commands of the topic this one replaced before a step
    superseded: list = dataclasses.field(default_factory=list)


def refusal_reason(exc: Exception) -> str:
    """Why a command was refused: the model's own words, or the exception's type and text."""
    return str(exc) if isinstance(exc, (DRSError, DRSRosError)) else f"{type(exc).__name__}: {exc}"


def error_text(exc: Exception) -> str:
    """An exception's type and text, without the C++ source location rmw appends."""
    return f"{type(exc).__name__}: {without_source_location(str(exc))}"


class TroubleWindow:
    """Troubles (refusals, missed deadlines, superseded commands...) of the last ``window_s``
    seconds of node time, for diagnostics that recover once the trouble is over."""

    def __init__(self, window_s: float) -> None:
        self.window_ns = ns_from_seconds(window_s)
        self._events: collections.deque[tuple[int, str, str]] = collections.deque()

    def add(self, now_ns: int, kind: str, reason: str) -> None:
        self._events.append((now_ns, kind, reason))

    def recent(self, now_ns: int) -> dict[str, tuple[int, str]]:
        """kind -> (count in the window, last reason)."""
        while self._events and now_ns - self._events[0][0] > self.window_ns:
            self._events.popleft()
        out: dict[str, tuple[int, str]] = {}
        for _t, kind, reason in self._events:
            out[kind] = (out.get(kind, (0, ""))[0] + 1, reason)
        return out


class EffectRecord:
    """The effect record and the counters of one configured node: a part of
    :class:`drs_ros.node.adapter.DRSNode`, constructed with what it needs.

    Parameters
    ----------
    publisher : rclpy.publisher.Publisher
        ``~/command_events`` (diagnostic_msgs/DiagnosticArray).
    record : callable
        ``record(topic, data, now_ns)``: the bytes into the bag (the sequence number, or None).
    instant : callable
        ``instant() -> (sim_time [s], steps, t0_ns or None)``: the actuator's simulated instant
        and the clock origin (None before the first tick), which stamp each record.
    logger
        The node's logger (a refusal is logged at WARN, at most once a second).
    window_s : float
        Diagnostics report the troubles of the last this many seconds [s].
    """

    def __init__(self, publisher, record, instant, logger, window_s: float) -> None:
        self._publisher, self._topic = publisher, publisher.topic_name
        self._record, self._instant = record, instant
        self._logger = logger
        # a refusal is logged at most once a second, decided before rclpy is asked (rclpy's
        # throttle costs ~0.16 ms a call, up to 0.75 ms on a flooded tick: drs_ros.log_throttle)
        self._log_refusal = LogThrottle(logger.warning)
        # diagnostics (cumulative) and the window of recent troubles, from zero
        self.refused = 0
        self.accepted = 0
        self.superseded = 0
        self.received = 0
        self.last_refusal = ""
        self.refusals: collections.deque[str] = collections.deque(maxlen=100)
        self.missed_deadlines = 0
        self.dropped_steps = 0
        self.ticks = 0
        self.troubles = TroubleWindow(window_s)
        self.clock_jumps = 0
        #: CPU time [s] of the ticks: stepping the model, publishing, recording.
        self.cpu = {"model": 0.0, "publish": 0.0, "record": 0.0}
        #: The tick thread's scheduling policy (set by the deadline loop) and its lateness.
        self.tick_policy = "rclpy timer (executor thread)"
        self.lateness = LatenessHistogram()

    def refuse_malformed(
        self, topic: str, msg_type, data: bytes, exc: Exception, now_ns: int
    ) -> None:
        """Bytes that are no ``msg_type``: refused with the reason; the bytes themselves go into
        the effect record (hex, for forensics), never onto the typed topic."""
        type_name = f"{msg_type.__module__.split('.')[0]}/msg/{msg_type.__name__}"
        reason = self.refuse(
            topic, f"<{len(data)} bytes>", f"not a valid {type_name} ({error_text(exc)})", now_ns
        )
        self.event(
            topic,
            REFUSED,
            DiagnosticStatus.WARN,
            reason,
            None,
            {
                "value": f"<{len(data)} bytes>",
                "malformed": "true",
                "size": len(data),
                "sha256": hashlib.sha256(data).hexdigest(),
                "bytes_hex": data[:MALFORMED_BYTES_KEPT].hex(),
            },
            now_ns,
        )

    def refuse_command(self, cmd: PendingCommand, exc: Exception, now_ns: int) -> None:
        """A command its actuator refuses: counted, logged and recorded with the reason."""
        value = commands.describe(cmd.key, cmd.msg)
        reason = self.refuse(cmd.key, value, refusal_reason(exc), now_ns)
        self.event(
            cmd.topic, REFUSED, DiagnosticStatus.WARN, reason, cmd, {"value": repr(value)}, now_ns
        )

    def refuse(self, what: str, value, reason: str, now_ns: int) -> str:
        """Count and log a refusal of ``value`` (``what`` it was for); returns its text."""
        self.refused += 1
        self.last_refusal = f"{what} {value!r} refused: {reason}"
        self.refusals.append(self.last_refusal)
        self.troubles.add(now_ns, REFUSED, self.last_refusal)
        self._log_refusal(self.last_refusal)
        return self.last_refusal

    def event(
        self,
        source: str,
        outcome: str,
        level: bytes,
        reason: str,
        cmd: PendingCommand | None,
        values: dict,
        now_ns: int,
    ) -> None:
        """One record of the effect log: what happened, at which simulated instant. ``now_ns``
        is the node time of the tick or callback it happens in (its log time in the bag). Packed
        once, straight into CDR (no rclpy message on the tick): the bytes published and recorded
        are the same. Published while someone subscribes; recorded always."""
        sim_t, steps, t0_ns = self._instant()
        record = {"sim_time": repr(sim_t), "step": steps}
        if cmd is not None:
            record["sequence"] = "" if cmd.sequence is None else cmd.sequence
            record["received_ns"] = cmd.received_ns
        record.update(values)
        stamp = now_ns if t0_ns is None else t0_ns + ns_from_seconds(sim_t)
        status = command_event_status(source, outcome, level, reason, record)
        data = diagnostic_array_cdr(stamp, [status])
        # DDS keeps nothing of a volatile topic for a later subscriber: with none matched now,
        # publishing would deliver to no one and costs ~25 us; asking costs ~1 us
        if self._publisher.get_subscription_count():
            self._publisher.publish(data)
        self._record(self._topic, data, now_ns)

    def clock_origin(
        self, now_ns: int, level: bytes = DiagnosticStatus.OK, reason: str = "", **values
    ) -> None:
        """A ``clock`` record: the clock origin ``t0_ns`` now in force (at the first tick, after
        dropped steps, after a clock jump), with ``values`` after it."""
        t0_ns = self._instant()[2]
        self.event(CLOCK, CLOCK, level, reason, None, {"t0_ns": t0_ns, **values}, now_ns)

    def counter_values(self) -> dict[str, object]:
        """The cumulative counters, as diagnostics report them."""
        return {
            "received_commands": self.received,
            "accepted_commands": self.accepted,
            "refused_commands": self.refused,
            "superseded_commands": self.superseded,
            "last_refusal": self.last_refusal or "none",
        }

    def level(self, now_ns: int, failures: list[str], mode: str) -> tuple[bytes, str]:
        """OK, WARN or ERROR with the reason: ERROR for ``failures`` (the recordings stopped),
        WARN for the troubles of the recent window only, else OK in actuator ``mode``."""
        if failures:
            return DiagnosticStatus.ERROR, "; ".join(failures)
        recent = self.troubles.recent(now_ns)
        if not recent:
            return DiagnosticStatus.OK, f"mode {mode}"
        window = seconds_from_ns(self.troubles.window_ns)
        parts = [
            f"{n} {kind.replace('_', ' ')} (last: {reason})"
            for kind, (n, reason) in sorted(recent.items())
        ]
        return DiagnosticStatus.WARN, f"in the last {window:g} s: " + "; ".join(parts)


def diagnostics_values(
    st, effects: EffectRecord, faults: str, callback_errors: int, recordings: dict[str, str]
) -> dict[str, object]:
    """What diagnostics report, by name: the actuator's state ``st``, the counters of
    ``effects``, the ``faults`` in force, the callbacks that failed, the ``recordings``' status
    and the CPU time spent."""
    return {
        "mode": st.mode,
        "sim_time_s": f"{st.t:.6f}",
        "stroke_m": f"{st.q[0]:.9g}",
        "gap_m": f"{st.gap:.9g}",
        "piston_force_N": f"{st.piston_force:.6g}",
        "at_stop": st.at_stop or "none",
        "dead_centre_distance_m": f"{st.dead_centre_distance:.6g}",
        "transmission_cos": f"{st.transmission:.4f}",
        **effects.counter_values(),
        "faults": faults,
        "missed_deadlines": effects.missed_deadlines,
        "dropped_steps": effects.dropped_steps,
        "clock_jumps": effects.clock_jumps,
        "callback_errors": callback_errors,
        "ticks": effects.ticks,
        "tick_policy": effects.tick_policy,
        **effects.lateness.values(),
        **recordings,
        **{f"cpu_{part}_s": f"{spent:.3f}" for part, spent in effects.cpu.items()},
    }


__all__ = [
    "MALFORMED_BYTES_KEPT",
    "EffectRecord",
    "PendingCommand",
    "TroubleWindow",
    "error_text",
    "refusal_reason",
    "diagnostics_values",
]
