"""drs_model: kinematics and dynamics of the DRS flap actuator (pure numpy/scipy, no ROS)."""

from .errors import (
    AssemblyError,
    ConstraintDriftError,
    ConvergenceError,
    DRSError,
    InputError,
    IntegrationError,
    ParameterError,
    SingularConfigurationError,
    StrokeRangeError,
)
from .params import SEED_LITERAL_IZ_WING, DRSParams, from_dict, from_file

__all__ = [
    "AssemblyError",
    "ConstraintDriftError",
    "ConvergenceError",
    "DRSError",
    "DRSParams",
    "InputError",
    "IntegrationError",
    "ParameterError",
    "SEED_LITERAL_IZ_WING",
    "SingularConfigurationError",
    "StrokeRangeError",
    "from_dict",
    "from_file",
]
