"""Inverse dynamics of the DRS actuator: the piston force (and joint reactions) for a given motion.

Modules: ``formulations`` (the result type, one interface and the registry
:data:`INVERSE_METHODS` of the four formulations: Newton-Euler with every joint reaction,
Lagrange with multipliers, virtual work, the fused closed form; the equations are in its
docstring), ``fused`` (:class:`FusedInverseDynamics`, the fused closed form for one sample at a
time and on arrays) and ``manoeuvre`` (along the open-hold-close manoeuvre: the state, the force,
its peak, its ratio to the air load). This module re-exports their public names.
"""

from .formulations import (
    INVERSE_METHODS,
    NE_UNKNOWNS,
    REACTION_NAMES,
    Fused,
    InverseDynamicsResult,
    InverseMethod,
    Lagrange,
    NewtonEuler,
    VirtualWork,
    get_method,
    inverse_dynamics,
    newton_euler_system,
)
from .fused import FusedInverseDynamics
from .manoeuvre import (
    Extremum,
    PeakForce,
    air_load_magnitude,
    force_ratio,
    manoeuvre_force,
    manoeuvre_state,
    peak_force,
    refine_extremum,
    static_force_ratio,
)
from .path_peak import PATH_FORCE_SAMPLES, PathPeak, path_peak_force

__all__ = [
    "PATH_FORCE_SAMPLES",
    "PathPeak",
    "path_peak_force",
    "INVERSE_METHODS",
    "NE_UNKNOWNS",
    "REACTION_NAMES",
    "Extremum",
    "Fused",
    "FusedInverseDynamics",
    "InverseDynamicsResult",
    "InverseMethod",
    "Lagrange",
    "NewtonEuler",
    "PeakForce",
    "VirtualWork",
    "air_load_magnitude",
    "force_ratio",
    "get_method",
    "inverse_dynamics",
    "manoeuvre_force",
    "manoeuvre_state",
    "newton_euler_system",
    "peak_force",
    "refine_extremum",
    "static_force_ratio",
]
