"""drs_model: kinematics and dynamics of the DRS flap actuator (pure numpy/scipy, no ROS).

Modules: ``params`` (DRSParams), ``overrides`` (parameters from --set items and files), ``kernels``
(each scalar closed form, once, as plain Python), ``elementwise`` (the kernels on arrays),
``constraints`` (Phi, Jacobians, gamma), ``kinematics`` (positions, velocities, accelerations, gap,
limits), ``profile`` (quintic manoeuvre), ``bodies`` (mass matrix, forces), ``inverse`` (inverse
dynamics, four formulations: Newton-Euler, Lagrange, virtual work and the fused closed form),
``forward`` (forward dynamics: forces, formulations, the scipy and fixed-step drivers),
``compiled`` (numba's builds of the kernels and the compiled RK driver; optional), ``motion`` (the
commanded stroke path and clock), ``commanded`` (the interface every actuator shares), ``actuator``
(the fixed-step rigid actuator), ``fidelity`` (the ladder of rungs the node runs), ``coriolis``
(rotating-frame kinematics of seed 000), ``plotting`` (figures), ``cluster`` (the Dask client for
many runs at once).
"""

import importlib
from types import MappingProxyType

from .errors import (
    AssemblyError,
    ConstraintDriftError,
    ConvergenceError,
    DaskUnavailableError,
    DRSError,
    InputError,
    IntegrationError,
    NumbaUnavailableError,
    ParameterError,
    SchedulerUnreachableError,
    SingularConfigurationError,
    StrokeRangeError,
)

#: Names re-exported lazily (PEP 562): the model's modules pull in numpy (~0.1 s) and
#: scipy.integrate/optimize (~0.5 s), which a quick ``drs limits`` or a kinematics-only user
#: should not pay for, and which a console script imports only after it took SIGINT and SIGTERM
#: (:mod:`drs_model.cli.start_signals`).
_LAZY = MappingProxyType(
    {
        **{
            name: ("kinematics", name)
            for name in (
                "KinematicState",
                "flap_angle_limits",
                "gap",
                "kinematic_state",
                "solve_position",
                "solve_position_from_flap_angle",
                "stroke_for_gap",
                "stroke_limits",
                "velocity_ratio",
            )
        },
        "from_file": ("overrides", "from_file"),
        "SEED_LITERAL_IZ_WING": ("params", "SEED_LITERAL_IZ_WING"),
        "DRSParams": ("params", "DRSParams"),
        "from_dict": ("params", "from_dict"),
        **{
            name: ("profile", name)
            for name in ("Manoeuvre", "QuinticSegment", "drs_manoeuvre", "quintic_move")
        },
        "ActuatorSim": ("actuator", "ActuatorSim"),
        "ActuatorState": ("actuator", "ActuatorState"),
        "DegenerateGeometryError": ("coriolis", "DegenerateGeometryError"),
        "collar_kinematics": ("coriolis", "collar_kinematics"),
        "slotted_link_closed_form": ("coriolis", "slotted_link_closed_form"),
        "INVERSE_METHODS": ("inverse", "INVERSE_METHODS"),
        "FusedInverseDynamics": ("inverse", "FusedInverseDynamics"),
        "inverse_dynamics": ("inverse", "inverse_dynamics"),
        "manoeuvre_force": ("inverse", "manoeuvre_force"),
        "peak_force": ("inverse", "peak_force"),
        "FORMULATIONS": ("forward", "FORMULATIONS"),
        "ConstantForce": ("forward", "ConstantForce"),
        "ManoeuvreForce": ("forward", "ManoeuvreForce"),
        "StepForce": ("forward", "StepForce"),
        "FixedStepIntegrator": ("forward", "FixedStepIntegrator"),
        "simulate": ("forward", "simulate"),
    }
)


def __getattr__(name: str):
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'drs_model' has no attribute {name!r}") from None
    return getattr(importlib.import_module(f".{module}", __name__), attr)


__all__ = [
    "FORMULATIONS",
    "INVERSE_METHODS",
    "SEED_LITERAL_IZ_WING",
    "ActuatorSim",
    "ActuatorState",
    "AssemblyError",
    "ConstantForce",
    "ConstraintDriftError",
    "ConvergenceError",
    "DRSError",
    "DRSParams",
    "DaskUnavailableError",
    "DegenerateGeometryError",
    "FixedStepIntegrator",
    "FusedInverseDynamics",
    "InputError",
    "IntegrationError",
    "KinematicState",
    "Manoeuvre",
    "ManoeuvreForce",
    "NumbaUnavailableError",
    "ParameterError",
    "QuinticSegment",
    "SchedulerUnreachableError",
    "SingularConfigurationError",
    "StepForce",
    "StrokeRangeError",
    "collar_kinematics",
    "drs_manoeuvre",
    "flap_angle_limits",
    "from_dict",
    "from_file",
    "gap",
    "inverse_dynamics",
    "kinematic_state",
    "manoeuvre_force",
    "peak_force",
    "quintic_move",
    "simulate",
    "slotted_link_closed_form",
    "solve_position",
    "solve_position_from_flap_angle",
    "stroke_for_gap",
    "stroke_limits",
    "velocity_ratio",
]
