"""Exception types of drs_model.

Every public failure raises a subclass of :class:`DRSError`, so a caller can catch the whole family
(as mcap roots its errors in ``McapError``). Messages name the bad value and the valid range.
"""

from __future__ import annotations


class DRSError(Exception):
    """Root of every error raised by drs_model."""


class ParameterError(DRSError, ValueError):
    """A model parameter is invalid (non-positive length, NaN, unknown name, unreachable
    geometry)."""


class InputError(DRSError, ValueError):
    """An argument of a function is invalid (NaN, wrong shape, non-positive duration...)."""


class StrokeRangeError(InputError):
    """A stroke (or gap, or flap angle) lies outside the admissible range."""


class ForceLimitError(InputError):
    """A commanded move whose inverse-dynamics peak piston force exceeds the actuator's limit."""


class AssemblyError(DRSError, ValueError):
    """The loop cannot be closed: no real position solution exists for this input."""


class DegenerateGeometryError(AssemblyError):
    """The pin reaches the pivot (zero length between them) or the pivot lies inside the wheel
    (:mod:`drs_model.coriolis`)."""


class SingularConfigurationError(DRSError, ArithmeticError):
    """The chosen independent coordinate is singular here (det of the dependent Jacobian ~ 0)."""


class ConvergenceError(DRSError, ArithmeticError):
    """An iterative solver (Newton, root finder, integrator) did not converge."""


class IntegrationError(DRSError, ArithmeticError):
    """Forward dynamics failed: step size collapsed, NaN, or the constraint residual grew past a
    bound."""


class ConstraintDriftError(IntegrationError):
    """The constraint residual of a forward-dynamics solution grew past the allowed bound."""


class NumbaUnavailableError(DRSError, ImportError):
    """The compiled paths need numba, which is not installed (``pip install 'drs[fast]'``)."""


class DaskUnavailableError(DRSError, ImportError):
    """Many runs at once need dask.distributed, which is not installed (``pip install
    'drs[fleet]'``)."""


class SchedulerUnreachableError(DRSError, ConnectionError):
    """No Dask scheduler answered at the address given."""


class StudySpecError(InputError):
    """A study specification (``drs study SPEC.toml``) is invalid: an unknown table, key,
    parameter or distribution, or a bad value; the message names it and the valid ones."""


class StiffStepError(IntegrationError):
    """An explicit step of a stiff model (the hydraulic rung's oil column) is longer than its
    stability limit: refused before it is taken, with the step, the limit and the frequency that
    sets it in the message, instead of a silent blow-up."""


class TooStiffError(StiffStepError):
    """A state (or a fault, a parameter) is too stiff for the physics step: the sub-steps its
    stability needs exceed the rung's cap (``max_substeps``). Refused before any sub-step is
    taken, with the rate, the sub-steps needed and the cap in the message: no value makes one
    physics step unbounded."""


class UnsupportedCommandError(DRSError, ValueError):
    """A fidelity rung cannot represent this command (a force on the kinematic rung, which has no
    forces): the message names the rung and the rungs that can."""
