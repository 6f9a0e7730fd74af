"""The node's faults as run-time parameters ``fault.<name>`` (the faults of
:data:`drs_model.fidelity.faults.FAULTS`), the only parameters that may change while it runs.

A change is checked when it is set (a bad value, or a fault the rung cannot model, is refused
with the reason in the ``SetParametersResult`` and in the effect record; the node goes on),
recorded on ``/parameter_events`` (rclpy publishes it; the node's bag gets the same change), and
applied at the next tick, before the physics steps: its effect record (``~/command_events``,
source ``fault.<name>``) gives the simulated instant, from which ``drs-bag resimulate`` applies it
again. Values given at start (``-p fault.x:=...``) act at the first tick the same way.

:class:`NodeFaults` is a part of :class:`drs_ros.node.adapter.DRSNode`, constructed with the
node it watches; it owns the actuator's faults.
"""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticStatus
from rcl_interfaces.msg import ParameterDescriptor, ParameterEvent, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from drs_model.errors import DRSError
from drs_model.fidelity.faults import FAULT_RANGES, FAULTS, RunFaults, describe_range

from ..conversions import time_msg
from ..names import ACCEPTED, FAULT_PREFIX, REFUSED
from ..rclpy_private import parameter_overrides


def fault_parameter_names() -> list[str]:
    """``fault.<name>`` for every fault, in :data:`FAULTS` order."""
    return [FAULT_PREFIX + name for name in FAULTS]


def declare_fault_parameters(node: Node) -> None:
    """Declare the ``fault.*`` parameters (writable, healthy by default). An integer given for a
    float one is taken as that float, as for the node's other parameters."""
    overrides = parameter_overrides(node)
    for name, (healthy, description) in FAULTS.items():
        full = FAULT_PREFIX + name
        given = overrides.get(full)
        if isinstance(healthy, float) and given is not None:
            if given.type_ == Parameter.Type.INTEGER:
                overrides[full] = Parameter(full, Parameter.Type.DOUBLE, float(given.value))
        if name in FAULT_RANGES:  # not as a descriptor range: rclpy would refuse an outlier
            description += f"; range {describe_range(name)}"  # before the effect record sees it
        node.declare_parameter(
            full,
            healthy,
            ParameterDescriptor(description=f"fault (run time, docs/fidelity.md): {description}"),
        )


class NodeFaults:
    """The fault parameters of one node: a part of :class:`drs_ros.node.adapter.DRSNode` that
    owns the actuator's :class:`~drs_model.fidelity.faults.RunFaults` (``faults``) and the
    faults set but not yet applied.

    Parameters
    ----------
    node : rclpy.node.Node
        Whose ``fault.*`` parameters these are (read, and watched for changes).
    lock : threading.Lock
        The node's lock, held by the tick.
    now_ns : callable
        The node clock [ns].
    configured : callable
        ``configured()``: the node is configured (a fault is refused before).
    """

    def __init__(self, node: Node, lock, now_ns, configured) -> None:
        self._node, self._lock, self._now_ns, self._configured = node, lock, now_ns, configured
        self.faults: RunFaults | None = None
        self._pending: list[tuple[str, object]] = []
        self._effects = self._record = self._recording = None
        self._watching = False

    def start(self, sim, effects, record, recording) -> None:
        """At configure: the faults of the new actuator ``sim``, and the values given at start
        pending for the first tick. ``effects``: the effect record; ``record(topic, msg,
        now_ns)``: into the bag; ``recording()``: a bag is recorded."""
        self._effects, self._record, self._recording = effects, record, recording
        self.faults = RunFaults(sim)
        gp = self._node.get_parameter
        healthy = {FAULT_PREFIX + name: value for name, (value, _text) in FAULTS.items()}
        self._pending = [
            (name, gp(name).value)
            for name in fault_parameter_names()
            if gp(name).value != healthy[name]
        ]
        if not self._watching:  # once, though configured again
            self._watching = True
            self._node.add_on_set_parameters_callback(self._on_set_faults)
            self._node.add_post_set_parameters_callback(self._record_parameter_change)

    def new_actuator(self, sim) -> None:
        """The node runs another actuator (before its first step): none applied yet."""
        self.faults = RunFaults(sim)

    @property
    def waiting(self) -> bool:
        """A fault waits for the next tick."""
        return bool(self._pending)

    def _on_set_faults(self, params: list[Parameter]) -> SetParametersResult:
        """Check every fault of a ``set_parameters`` call; all are taken or none (the first
        refusal's reason)."""
        checked = []
        if not self._configured() and any(p.name.startswith(FAULT_PREFIX) for p in params):
            return SetParametersResult(
                successful=False, reason="faults are set on a configured node only"
            )
        with self._lock:
            now = self._now_ns()
            for p in params:
                if not p.name.startswith(FAULT_PREFIX):
                    continue  # the others are read-only: rclpy refuses them itself
                name = p.name.removeprefix(FAULT_PREFIX)
                try:
                    value = self.faults.check(name, p.value)
                except DRSError as exc:
                    reason = self._effects.refuse(p.name, p.value, str(exc), now)
                    self._effects.event(
                        p.name,
                        REFUSED,
                        DiagnosticStatus.WARN,
                        reason,
                        None,
                        {"value": repr(p.value)},
                        now,
                    )
                    return SetParametersResult(successful=False, reason=reason)
                checked.append((p.name, value))
            order = list(fault_parameter_names())
            self._pending.extend(sorted(checked, key=lambda nv: order.index(nv[0])))
        return SetParametersResult(successful=True)

    def _record_parameter_change(self, params: list[Parameter]) -> None:
        """The change rclpy publishes on /parameter_events, in the node's bag as well."""
        if self._recording is None or not self._recording():
            return
        with self._lock:
            now = self._now_ns()
            event = ParameterEvent(
                stamp=time_msg(now),
                node=self._node.get_fully_qualified_name(),
                changed_parameters=[p.to_parameter_msg() for p in params],
            )
            self._record("/parameter_events", event, now)

    def apply_pending(self, now_ns: int) -> None:
        """Apply the faults set since the last tick, in the order set (a ramp set with a supply
        loss in one call comes first: :data:`FAULTS` order within a call)."""
        pending, self._pending = self._pending, []
        fx = self._effects
        for full, value in pending:
            name = full.removeprefix(FAULT_PREFIX)
            try:
                self.faults.apply(name, value)
            except DRSError as exc:  # checked when set: only a rung changed since would refuse
                reason = fx.refuse(full, value, str(exc), now_ns)
                fx.event(
                    full,
                    REFUSED,
                    DiagnosticStatus.WARN,
                    reason,
                    None,
                    {"value": repr(value)},
                    now_ns,
                )
                continue
            fx.troubles.add(now_ns, "fault", f"{full} = {value!r}")
            fx.event(full, ACCEPTED, DiagnosticStatus.OK, "", None, {"value": repr(value)}, now_ns)

    def text(self) -> str:
        """The faults in force, for diagnostics ('none' when healthy)."""
        active = self.faults.active()
        return ", ".join(f"{k}={v!r}" for k, v in active.items()) or "none"


__all__ = ["NodeFaults", "declare_fault_parameters", "fault_parameter_names"]
