"""Identification: the actuator's parameters from what a run measured (``drs-bag fit``).

* :mod:`.parameters`: what can be fitted (DRSParams' inertial and air-load fields, every
  HydraulicParams field), units, sizes, bounds, the motion that determines each;
* :mod:`.record`: a run's measured signals as arrays;
* :mod:`.regressor`: the rigid force as ``Y(s, s', s'') theta``, from the model's inverse dynamics;
* :mod:`.continuity`, :mod:`.friction`: the chambers' continuity and the rod's force balance as
  regressions;
* :mod:`.least_squares`: weighted least squares with the estimates' covariance;
* :mod:`.identifiability`: rank, condition number, what cannot be separated;
* :mod:`.equation_error`: stage 1, the regressions of a rung;
* :mod:`.output_error`: stage 2, the recorded commands re-simulated and the signals fitted;
* :mod:`.intervals`: Jacobian and profile-likelihood intervals;
* :mod:`.results`: estimates, fitted signals, stages;
* :mod:`.driver`: the fit, stage by stage (``drs-bag fit``);
* :mod:`.excitation`: D-optimal excitation design (``drs excite``);
* :mod:`.trend`: a parameter over a season, drift and threshold crossing (``drs-bag trend``).

docs/identify.md describes the whole.
"""

from .driver import FIT_RUNGS, fit
from .equation_error import equation_error
from .excitation import Excitation, design_excitation
from .identifiability import Identifiability, assess
from .parameters import RIGID_PARAMETERS, FitParameter, fit_parameter, hydraulic_field_names
from .record import Record
from .regressor import rigid_regressor
from .results import Estimate, FitResult, FittedSignal, StageFit
from .trend import Trend

__all__ = [
    "FIT_RUNGS",
    "RIGID_PARAMETERS",
    "Estimate",
    "Excitation",
    "FitParameter",
    "FitResult",
    "FittedSignal",
    "Identifiability",
    "Record",
    "StageFit",
    "Trend",
    "assess",
    "design_excitation",
    "equation_error",
    "fit",
    "fit_parameter",
    "hydraulic_field_names",
    "rigid_regressor",
]
