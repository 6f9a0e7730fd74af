"""What a bag says about its own run: the parameters it ran with, and when each command took
effect (the effect record ``~/command_events``; docs/ros.md, "Effect record").

The node records, once at start, a ``rcl_interfaces/ParameterEvent`` on ``/parameter_events``
listing every node parameter, the ``model.*`` and ``hydraulic.*`` ones at the values the model
ran with (the values the node serves). This module
turns such records back into values; it holds no state.
"""

from __future__ import annotations

import ast
from collections.abc import Sequence
from dataclasses import dataclass

from drs_model.fidelity.faults import FAULTS, RunFaults
from drs_model.params import NUMERIC_FIELDS, DRSParams, from_dict
from drs_ros.errors import DRSRosError
from drs_ros.names import FAULT_PREFIX, FIDELITY

#: rcl_interfaces/ParameterType values -> the ParameterValue field holding the value.
_VALUE_FIELDS = {
    1: "bool_value",
    2: "integer_value",
    3: "double_value",
    4: "string_value",
    5: "byte_array_value",
    6: "bool_array_value",
    7: "integer_array_value",
    8: "double_array_value",
    9: "string_array_value",
}


def parameter_values(event) -> dict[str, object]:
    """``name -> value`` of the new parameters of one ParameterEvent message."""
    out = {}
    for param in event.new_parameters:
        field = _VALUE_FIELDS.get(param.value.type)
        if field is not None:
            value = getattr(param.value, field)
            out[param.name] = list(value) if field.endswith("array_value") else value
    return out


def parameter_event(node: str, values: dict[str, object], stamp_ns: int):
    """A ParameterEvent listing ``values`` as new parameters (the inverse of
    :func:`parameter_values` for bool, int, float, str and lists of str or float)."""
    from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterValue

    from drs_ros.conversions import time_msg

    params = []
    for name, value in values.items():
        if isinstance(value, bool):
            pv = ParameterValue(type=1, bool_value=value)
        elif isinstance(value, int):
            pv = ParameterValue(type=2, integer_value=value)
        elif isinstance(value, float):
            pv = ParameterValue(type=3, double_value=value)
        elif isinstance(value, str):
            pv = ParameterValue(type=4, string_value=value)
        elif all(isinstance(v, str) for v in value):
            pv = ParameterValue(type=9, string_array_value=list(value))
        else:
            pv = ParameterValue(type=8, double_array_value=[float(v) for v in value])
        params.append(Parameter(name=name, value=pv))
    return ParameterEvent(stamp=time_msg(stamp_ns), node=node, new_parameters=params)


def _start_event(messages: Sequence, node: str | None):
    """The first ParameterEvent of ``(log_ns, event)`` pairs that lists new parameters, of
    ``node`` (None: of any node)."""
    for _log_ns, event in messages:
        if node in (None, event.node) and event.new_parameters:
            return event
    return None


def recorded_node_parameters(
    messages: Sequence, node: str | None = None
) -> dict[str, object] | None:
    """The parameters ``node`` (a fully qualified name; None: the first node that recorded any)
    recorded at start (``(log_ns, ParameterEvent)`` pairs), or None. Which nodes a bag holds:
    :func:`drs_ros.bag.read.nodes.bag_nodes`."""
    event = _start_event(messages, node)
    return None if event is None else parameter_values(event)


def model_params_from(values: dict[str, object]) -> DRSParams:
    """DRSParams from recorded ``model.<field>`` values, every one passed to ``from_dict`` as
    recorded: a value equal to the seed's is the run's all the same (a run with ``m_wing = 3``
    and ``Iz_wing = 0.0096``, the seed's value, had that inertia, not the ``m_wing L_wing^2 / 3
    = 0.0144`` a missing ``Iz_wing`` would derive). The outlines (drawing only, never recorded)
    stay the seed's."""
    model = {k.removeprefix("model."): v for k, v in values.items() if k.startswith("model.")}
    # every recorded value as recorded; a name DRSParams no longer has is skipped: older bags
    # hold wing_span and rho_steel, which the planar model never used
    known = {k: v for k, v in model.items() if k in NUMERIC_FIELDS}
    return from_dict(known) if known else DRSParams()


def hydraulic_params_from(values: dict[str, object] | None):
    """HydraulicParams from recorded ``hydraulic.<field>`` values, each as recorded (the valve's
    port ratio recorded as the area ratio keeps following the bore and rod:
    :func:`~drs_model.fidelity.hydraulic_params.hydraulic_from_dict`); a bag recorded before
    the node recorded them (none) gives HydraulicParams' defaults."""
    from drs_model.fidelity.hydraulic_params import HYDRAULIC_FIELDS, hydraulic_from_dict

    recorded = {
        k.removeprefix("hydraulic."): v
        for k, v in (values or {}).items()
        if k.startswith("hydraulic.")
    }
    return hydraulic_from_dict({k: v for k, v in recorded.items() if k in HYDRAULIC_FIELDS})


@dataclass(frozen=True)
class EffectRecord:
    """One record of ``~/command_events``: ``source`` (a command topic, the service, ``clock``
    or ``reset``), ``outcome``, the simulated time [s] and step it speaks of, and its values."""

    source: str
    outcome: str
    sim_time: float
    values: dict[str, str]
    log_time: int


def effect_records(messages: Sequence) -> list[EffectRecord]:
    """Parse ``(log_ns, DiagnosticArray)`` pairs of ``~/command_events``, in record order."""
    out = []
    for log_ns, msg in messages:
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            out.append(
                EffectRecord(
                    status.name,
                    values.get("outcome", ""),
                    float(values.get("sim_time", "nan")),
                    values,
                    log_ns,
                )
            )
    return out


class MissingRecordError(DRSRosError):
    """The effect record lacks a record the run's parameters say it must hold."""


def recorded_rung(node_parameters: dict, records: Sequence[EffectRecord]) -> str:
    """The rung a run ran on: its ``fidelity`` parameter (``rigid`` for a bag recorded before
    it), or, for ``auto``, the rung its ``fidelity`` record says it chose."""
    fidelity = str(node_parameters.get("fidelity", "rigid"))
    if fidelity != "auto":
        return fidelity
    chosen = [r.values["rung"] for r in records if r.source == FIDELITY]
    if not chosen:
        raise MissingRecordError(
            "fidelity auto, but the effect record holds no 'fidelity' record of the rung "
            "chosen: the run never stepped"
        )
    return chosen[0]


def is_fault_record(record: EffectRecord) -> bool:
    """Whether ``record`` is a fault set at run time (source ``fault.<name>``)."""
    name = record.source.removeprefix(FAULT_PREFIX)
    return record.source.startswith(FAULT_PREFIX) and name in FAULTS


def fault_of(record: EffectRecord) -> tuple[str, object]:
    """The fault a record of one (:func:`is_fault_record`) speaks of and its value: the name in
    :data:`~drs_model.fidelity.faults.FAULTS` and the record's ``repr`` of the value (a bool, an
    int or a float, which ``repr`` gives back exactly)."""
    return record.source.removeprefix(FAULT_PREFIX), ast.literal_eval(record.values["value"])


def apply_fault_record(faults: RunFaults, record: EffectRecord) -> None:
    """Apply the fault an accepted record says took effect, to ``faults`` (of the re-run's
    rung, at the record's simulated instant, where the caller has brought it)."""
    faults.apply(*fault_of(record))


__all__ = [
    "FAULT_PREFIX",
    "EffectRecord",
    "MissingRecordError",
    "apply_fault_record",
    "fault_of",
    "is_fault_record",
    "recorded_rung",
    "effect_records",
    "hydraulic_params_from",
    "model_params_from",
    "parameter_event",
    "parameter_values",
    "recorded_node_parameters",
]
