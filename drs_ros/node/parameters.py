"""The node's parameters: the table of its own, the ``model.*`` ones of :class:`DRSParams` and the
``hydraulic.*`` ones of :class:`HydraulicParams`, their declaration (read-only, with ranges; a
misspelt name is refused), the model's parameters they give, and every value the node runs with
(what a re-run needs, recorded at start).

The ``model.*`` and ``hydraulic.*`` parameters are declared once the model is built (at
configure), at the values it runs: a derived inertia, ``model_params_file``'s values and the
valve's port ratio are served as the model has them, read-only, and what the bag records is
what ``ros2 param get`` gives.
"""

from __future__ import annotations

import difflib
import math
import os
from dataclasses import dataclass

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from drs_model.errors import ParameterError
from drs_model.fidelity import RUNGS
from drs_model.fidelity.faults import FAULT_RANGES, FAULTS, describe_range
from drs_model.fidelity.hydraulic_params import HYDRAULIC_FIELDS, HydraulicParams, field_range
from drs_model.overrides import apply_overrides, file_overrides, split_overrides
from drs_model.params import FORCE_LIMIT_DEFAULT_N, NUMERIC_FIELDS, DRSParams

from ..errors import DRSRosError
from ..model_parameters import MODEL_PARAMETERS, served_value
from ..names import DEFAULT_JOINT_NAMES
from ..rclpy_private import parameter_overrides
from ..stack.layer import STACK_PARAMETERS
from .tick_schedule import FIFO_PRIORITY_RANGE, TICK_CPU_RANGE, TICK_SCHEDULING, cpu_refusal

#: How the node is driven (the ``executor`` parameter, read by ``main``):
#: ``deadline``: the main thread ticks at absolute deadlines of the wall clock and rclpy's
#: EventsExecutor in a second thread serves subscriptions, the service and diagnostics
#: (under ``use_sim_time`` the ticks follow ``/clock`` through a timer, as ``single`` does);
#: ``single``: one SingleThreadedExecutor runs everything, the tick being an rclpy timer.
#: rclpy's EventsExecutor is not offered for the whole node: with the Jazzy wheels its ``spin``
#: ignored SIGINT and SIGTERM (docs/ros.md, "Rate").
EXECUTORS = ("deadline", "single")

#: The rungs of the fidelity ladder the node runs (drs_model.fidelity.RUNGS), and ``auto``: the
#: lowest rung that meets the tolerances for what the subscribers ask (drs_model.fidelity.auto).
FIDELITIES = (*RUNGS, "auto")

#: The node's own parameters: (name, default, description, valid range or choices). All read-only.
NODE_PARAMETERS = (
    ("physics_rate_hz", 1000.0, "fixed physics step rate [Hz]", (100.0, 20000.0)),
    (
        "publish_rate_hz",
        250.0,
        "joint-state publish rate [Hz], at most physics_rate_hz",
        (1.0, 2000.0),
    ),
    ("joint_names", DEFAULT_JOINT_NAMES, "JointState names: piston, link, flap", None),
    ("integrator", "rk4", "fixed-step method of force mode", None),
    (
        "force_method",
        "fused",
        "inverse-dynamics formulation: fused (the fused closed form), newton-euler, lagrange, "
        "virtual-work (d'Alembert along dq/dpsi3)",
        None,
    ),
    (
        "fidelity",
        "rigid",
        "model rung: kinematic, quasi-static, rigid, hydraulic or auto (docs/fidelity.md)",
        FIDELITIES,
    ),
    (
        "fidelity_tolerance",
        5e-4,
        "auto: largest gap error [m] against the hydraulic rung",
        (1e-9, 1.0),
    ),
    (
        "fidelity_force_tolerance",
        2000.0,
        "auto: largest piston force error [N] against the hydraulic rung",
        (1e-3, 1e6),
    ),
    (
        "fidelity_auto_discovery_s",
        1.0,
        "auto: time [s] after activation the node waits for subscribers before it chooses",
        (0.0, 60.0),
    ),
    (
        "force_limit",
        FORCE_LIMIT_DEFAULT_N,
        "largest accepted |piston force| [N]: of a force command and, with limit_moves, of a "
        "move's inverse-dynamics peak",
        (1.0, 1.0e6),
    ),
    (
        "limit_moves",
        True,
        "refuse a trajectory or goal whose inverse-dynamics peak force "
        "exceeds force_limit, naming both; a stroke or DRS command takes longer instead",
        None,
    ),
    (
        "max_catch_up_steps",
        200,
        "physics steps per tick before the simulation drops time",
        (1, 100000),
    ),
    (
        "frame_id",
        "drs_base",
        "frame of ~/markers: the seed's ground frame (x rearwards, y up)",
        None,
    ),
    (
        "markers_rate_hz",
        30.0,
        "~/markers (and rerun drawing) rate [Hz], computed only when used",
        (0.1, 1000.0),
    ),
    (
        "diagnostics_window",
        5.0,
        "diagnostics report the troubles of the last this many s [s]",
        (0.1, 3600.0),
    ),
    (
        "executor",
        "deadline",
        "deadline (ticks on absolute deadlines, executor thread for the rest) or single",
        EXECUTORS,
    ),
    (
        "tick_scheduling",
        "fifo",
        "the deadline loop's tick thread under SCHED_FIFO when the "
        "process may have it (else SCHED_OTHER, saying why) or other (SCHED_OTHER)",
        TICK_SCHEDULING,
    ),
    ("tick_fifo_priority", 10, "SCHED_FIFO priority of the tick thread", FIFO_PRIORITY_RANGE),
    (
        "tick_cpu",
        -1,
        "the one CPU the deadline loop's tick thread is kept on (-1: any the process may use)",
        TICK_CPU_RANGE,
    ),
    (
        "bag_path",
        "",
        "MCAP bag directory ('' = no bag; --managed: the n-th later "
        "configure's is this name with _n appended)",
        None,
    ),
    (
        "rrd_path",
        "",
        "rerun .rrd file ('' = none; --managed: the n-th later configure's is NAME_n.rrd)",
        None,
    ),
    (
        "rerun_connect",
        "",
        "stream to a running rerun viewer on loopback, e.g. "
        "rerun+http://127.0.0.1:9876/proxy ('' = none)",
        None,
    ),
    ("flush_period", 0.5, "MCAP flush period [s]", (0.01, 10.0)),
    ("model_params_file", "", "TOML/YAML file of DRSParams overrides", None),
) + STACK_PARAMETERS


class StartupError(DRSRosError):
    """The node refuses to start: a parameter or a recording path is wrong (the reason says)."""


def declare_parameters(node: Node) -> frozenset[str]:
    """Declare every parameter of :data:`NODE_PARAMETERS` (read-only, with their ranges);
    returns the names given to the node (``-p`` or ``--params-file``), the ``model.*`` and
    ``hydraulic.*`` ones among them (declared at configure: :func:`serve_model_parameters`).

    Raises :class:`StartupError` for a name given that the node does not know (with the closest
    known one), and for a string outside its choices. An integer given for a float parameter is
    taken as that float."""
    known = [name for name, *_ in NODE_PARAMETERS]
    known += MODEL_PARAMETERS
    # and the ones rclpy declares itself
    known += [name for name in node.get_parameters_by_prefix("") if name not in known]
    # rclpy keeps the --ros-args / parameter_overrides values here before they are declared:
    # the only place a misspelt name (never declared, silently ignored) can be seen
    overrides = parameter_overrides(node)
    given_names = frozenset(overrides)
    for name in overrides:
        if name not in known and not name.startswith("qos_overrides."):
            close = difflib.get_close_matches(name, known, n=1, cutoff=0.5)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise StartupError(f"unknown parameter {name!r}{hint} (known: {', '.join(known)})")
    for name in MODEL_PARAMETERS:  # -p model.m_wing:=3 means 3.0
        given = overrides.get(name)
        if given is not None and given.type_ == Parameter.Type.INTEGER:
            overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(given.value))
    for name, default, description, valid in NODE_PARAMETERS:
        desc = ParameterDescriptor(description=description, read_only=True)
        if isinstance(default, float):
            given = overrides.get(name)
            if given is not None and given.type_ == Parameter.Type.INTEGER:
                # -p rate:=500 means 500.0: an integer is a valid double
                overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(given.value))
            if isinstance(valid, tuple):
                desc.floating_point_range = [
                    FloatingPointRange(from_value=valid[0], to_value=valid[1], step=0.0)
                ]
        elif isinstance(valid, tuple) and isinstance(default, int):
            desc.integer_range = [IntegerRange(from_value=valid[0], to_value=valid[1], step=1)]
        elif isinstance(valid, tuple):
            desc.additional_constraints = f"one of {', '.join(valid)}"
        node.declare_parameter(name, list(default) if isinstance(default, tuple) else default, desc)
        if isinstance(valid, tuple) and isinstance(default, str):
            value = node.get_parameter(name).value
            if value not in valid:
                raise StartupError(f"{name} must be one of {list(valid)}, got {value!r}")
    return given_names


def _given_values(node: Node, given_names: frozenset[str]) -> dict[str, object]:
    """The ``model.*`` and ``hydraulic.*`` values given to the node, by parameter name."""
    overrides = parameter_overrides(node)
    return {
        name: overrides[name].value
        for name in MODEL_PARAMETERS
        if name in given_names and name in overrides
    }


def _file_values(path: str) -> dict[str, object]:
    """``model_params_file``'s values by node parameter name (``model.m_wing``, ...)."""
    try:
        model, hydraulic = split_overrides(file_overrides(path))
    except ParameterError as exc:
        raise StartupError(f"model_params_file {path!r}: {exc}") from exc
    return {
        **{f"model.{k}": v for k, v in model.items()},
        **{f"hydraulic.{k}": v for k, v in hydraulic.items()},
    }


def model_params(node: Node, given_names: frozenset[str]) -> tuple[DRSParams, HydraulicParams]:
    """The model's parameters: the seed's and HydraulicParams' defaults, then
    ``model_params_file``'s, then every ``model.*`` and ``hydraulic.*`` parameter given to the
    node (``-p`` or a ROS ``--params-file``), whatever its value.

    Raises :class:`StartupError` naming the node parameter the model refuses (the file, or the
    values given) and the model's reason, and for a value given both to the node and in
    ``model_params_file`` that differ (one would silently shadow the other)."""
    path = node.get_parameter("model_params_file").value
    given = _given_values(node, given_names)
    from_file = _file_values(path) if path else {}
    shadowed = [
        f"{name}:={given[name]!r} shadows model_params_file {path!r}'s "
        f"{name.split('.', 1)[1]} = {from_file[name]!r}"
        for name in given
        if name in from_file and given[name] != from_file[name]
    ]
    if shadowed:
        raise StartupError(f"{'; '.join(shadowed)}: give each value in one place")
    try:
        base = apply_overrides(from_file)
    except ParameterError as exc:
        raise StartupError(f"model_params_file {path!r}: {exc}") from exc
    try:
        return apply_overrides(given, *base) if given else base
    except ParameterError as exc:
        named = ", ".join(f"{k}:={v!r}" for k, v in given.items())
        raise StartupError(f"the model refuses {named}: {exc}") from exc


def _descriptor(name: str) -> ParameterDescriptor:
    owner, field = name.split(".", 1)
    if owner == "model":
        return ParameterDescriptor(
            description=f"DRSParams.{field} (SI), as the model runs it", read_only=True
        )
    desc = ParameterDescriptor(
        description=f"HydraulicParams.{field} (SI), as the model runs it", read_only=True
    )
    desc.additional_constraints = field_range(field)
    return desc


def serve_model_parameters(node: Node, params: DRSParams, hydraulic: HydraulicParams) -> None:
    """Declare every ``model.*`` and ``hydraulic.*`` parameter at the value the model runs
    (read-only). A managed node configured again serves them already: its values cannot change
    (read-only), so a model that now differs (``model_params_file`` edited in between) is
    refused with :class:`StartupError`."""
    changed = []
    for name in MODEL_PARAMETERS:
        value = served_value(name, params, hydraulic)
        if node.has_parameter(name):
            if node.get_parameter(name).value != value:
                changed.append(f"{name} {node.get_parameter(name).value!r} -> {value!r}")
            continue
        node.declare_parameter(name, value, _descriptor(name), ignore_override=True)
    if changed:
        raise StartupError(
            f"the model's parameters changed since the node was first configured "
            f"({', '.join(changed)}): they are read-only; start a new node"
        )


@dataclass(frozen=True)
class TickSettings:
    """The node's rates and names, checked together (:func:`tick_settings`)."""

    physics_hz: float
    publish_hz: float
    markers_rate_hz: float
    #: Physics steps one tick may catch up; the excess is dropped (a stall).
    max_catch_up: int
    frame_id: str
    #: piston, link, flap
    joint_names: tuple[str, str, str]
    fidelity: str

    @property
    def physics_dt(self) -> float:
        """The physics step [s]."""
        return 1.0 / self.physics_hz

    @property
    def publish_period(self) -> float:
        """The tick's period [s]."""
        return 1.0 / self.publish_hz

    @property
    def markers_period(self) -> float:
        """Least simulated time [s] between two ``~/markers`` messages."""
        return 1.0 / self.markers_rate_hz


def tick_settings(node: Node) -> TickSettings:
    """The rates and names of the declared parameters, or the reason they cannot run together:
    :class:`StartupError` for a publish rate above the physics rate or a catch-up too short for
    one late tick, ``ParameterException`` for joint names that are not three."""
    gp = node.get_parameter
    physics_hz, publish_hz = gp("physics_rate_hz").value, gp("publish_rate_hz").value
    if publish_hz > physics_hz:
        raise StartupError(
            f"publish_rate_hz {publish_hz:g} exceeds physics_rate_hz {physics_hz:g}: the node "
            "cannot publish new states faster than it computes them; lower publish_rate_hz "
            "or raise physics_rate_hz"
        )
    joint_names = list(gp("joint_names").value)
    if len(joint_names) != 3:
        raise ParameterException(
            f"joint_names must hold 3 names (piston, link, flap), got {joint_names}",
            ["joint_names"],
        )
    tick_cpu = gp("tick_cpu").value
    refusal = cpu_refusal(tick_cpu) if tick_cpu >= 0 else None
    if refusal is not None:
        raise StartupError(
            f"tick_cpu {tick_cpu} refused by the system ({refusal}; the CPUs are 0.."
            f"{(os.cpu_count() or 1) - 1}): give one a thread may run on, or -1 for any"
        )
    max_catch_up = int(gp("max_catch_up_steps").value)
    # a tick late by one period must still catch up, or every tick would drop steps
    needed = math.ceil(2.0 * physics_hz / publish_hz)
    if max_catch_up < needed:
        raise StartupError(
            f"max_catch_up_steps {max_catch_up} is below the {needed} physics steps of "
            f"two publish periods ({physics_hz:g} Hz physics, {publish_hz:g} Hz publish): "
            f"every late tick would drop simulated time; give max_catch_up_steps >= {needed} "
            "or publish faster"
        )
    return TickSettings(
        physics_hz,
        publish_hz,
        gp("markers_rate_hz").value,
        max_catch_up,
        gp("frame_id").value,
        tuple(joint_names),
        gp("fidelity").value,
    )


def effective_parameters(node: Node) -> list[Parameter]:
    """Every node parameter as served, the ``model.*`` and ``hydraulic.*`` ones at the values
    the model runs with (:func:`serve_model_parameters`): what a re-run needs."""
    # "": every declared parameter
    return [node.get_parameter(name) for name in sorted(node.get_parameters_by_prefix(""))]


def _valid_text(valid) -> str:
    """A parameter's valid range or choices, as ``usage_text`` prints them."""
    if valid is None:
        return ""
    if isinstance(valid[0], str):
        return f"; one of {', '.join(valid)}"
    return f"; [{valid[0]:g}, {valid[1]:g}]"


def usage_text() -> str:
    """What ``drs-node --help`` prints: how to start the node, and every parameter it takes
    with its default, its valid range and what it means (the tables it declares them from)."""
    lines = [
        "usage: drs-node [--managed] [--ros-args -p NAME:=VALUE ... --params-file FILE]",
        "",
        "The DRS actuator's ROS 2 node (docs/ros.md). --managed: a lifecycle node.",
        "",
        "parameters (read-only once started):",
    ]
    for name, default, description, valid in NODE_PARAMETERS:
        shown = list(default) if isinstance(default, tuple) else default
        lines.append(f"  {name} (default {shown!r}{_valid_text(valid)}): {description}")
    lines.append(
        "  model.<field> (default: the seed's value): a DRSParams field, SI units; one of "
        + ", ".join(NUMERIC_FIELDS)
    )
    lines.append(
        "  hydraulic.<field> (default: HydraulicParams'): the hydraulic rung's, SI units; "
        + ", ".join(f"{n} ({field_range(n)})" for n in HYDRAULIC_FIELDS)
    )
    lines.append(
        "  model_params_file may set both; a value given there and as a parameter that "
        "differ refuse to start. Served once configured, as the model runs them."
    )
    lines += ["", "fault parameters (may change while the node runs; healthy by default):"]
    for name, (healthy, description) in FAULTS.items():
        valid = f"; {describe_range(name)}" if name in FAULT_RANGES else ""
        lines.append(f"  fault.{name} (default {healthy!r}{valid}): {description}")
    return "\n".join(lines)


__all__ = [
    "EXECUTORS",
    "FIDELITIES",
    "MODEL_PARAMETERS",
    "NODE_PARAMETERS",
    "StartupError",
    "TickSettings",
    "declare_parameters",
    "effective_parameters",
    "model_params",
    "serve_model_parameters",
    "tick_settings",
    "usage_text",
]
