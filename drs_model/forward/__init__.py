"""Forward dynamics: the motion of the mechanism under a given piston force.

Modules: ``forces`` (constant, step, function and manoeuvre forces), ``formulations`` (psi3, s,
index-1, Baumgarte, projection), ``solve`` (:func:`simulate`: scipy and compiled methods behind
one call), ``solution`` (its result) and ``fixed_step`` (the real-time
:class:`FixedStepIntegrator`). The compiled RK methods live in :mod:`drs_model.compiled` (optional
numba). This module re-exports the public names.
"""

from .fixed_step import FIXED_STEP_METHODS, FixedStepIntegrator, StepState
from .forces import ConstantForce, ForceLike, FunctionForce, ManoeuvreForce, StepForce, as_force
from .formulations import (
    FORMULATIONS,
    Formulation,
    FullCoordinates,
    Projected,
    Psi3Minimal,
    StrokeMinimal,
    get_formulation,
    manoeuvre_initial_state,
)
from .solution import Solution
from .solve import COMPILED_METHODS, SCIPY_METHODS, default_atol, simulate

__all__ = [
    "COMPILED_METHODS",
    "FIXED_STEP_METHODS",
    "FORMULATIONS",
    "SCIPY_METHODS",
    "ConstantForce",
    "FixedStepIntegrator",
    "ForceLike",
    "Formulation",
    "FullCoordinates",
    "FunctionForce",
    "ManoeuvreForce",
    "Projected",
    "Psi3Minimal",
    "Solution",
    "StepForce",
    "StepState",
    "StrokeMinimal",
    "as_force",
    "default_atol",
    "get_formulation",
    "manoeuvre_initial_state",
    "simulate",
]
