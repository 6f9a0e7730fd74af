"""What a bag says about the run it recorded, followed as it streams past: the node's parameters
(its first ``/parameter_events`` message), the rung it ran on (its ``fidelity`` parameter, or
``auto``'s choice in the effect record), its physics step, its clock origin (``clock`` records),
the simulated time of each published state, and the faults set at run time with their spans
(``fault.<name>`` records of ``~/command_events``).

:class:`RunRecord` holds no messages: a few numbers and one span per fault set. What the check
makes of it: :mod:`drs_ros.bag.run_checks`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from drs_model.fidelity.faults import FAULTS

from ..names import ACCEPTED, CLOCK, FIDELITY, REFUSED, RESET
from ..timestamps import seconds_from_ns
from .effects import (
    EffectRecord,
    MissingRecordError,
    effect_records,
    fault_of,
    is_fault_record,
    parameter_values,
    recorded_rung,
)

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


__all__ = ["DEFAULT_DT", "FaultSpan", "MissingRecordError", "RunRecord"]
