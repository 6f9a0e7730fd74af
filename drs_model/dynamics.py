"""The inverse dynamics moved to :mod:`drs_model.inverse`; this module keeps the old import path.

Nothing is defined here: every name is :mod:`drs_model.inverse`'s own object.
"""

from .inverse import (  # noqa: F401
    INVERSE_METHODS,
    NE_EQUATIONS,
    NE_UNKNOWNS,
    REACTION_NAMES,
    Extremum,
    FusedInverseDynamics,
    InverseDynamicsResult,
    InverseMethod,
    PeakForce,
    force_ratio,
    get_method,
    inverse_dynamics,
    manoeuvre_force,
    manoeuvre_state,
    newton_euler_system,
    peak_force,
    refine_extremum,
    static_force_ratio,
)
