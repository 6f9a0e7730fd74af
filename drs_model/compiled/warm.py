"""Compile every numba function of drs_model once, so that later processes load them from numba's
on-disk cache: ``python -m drs_model.compiled`` (``make`` runs it after installing; the test
suite runs :func:`warm_up` first)."""

from __future__ import annotations

import time

import numpy as np

from .. import path_range
from ..bodies import model_constants
from ..forward.fixed_step import FIXED_STEP_METHODS, FixedStepIntegrator
from ..forward.forces import ManoeuvreForce
from ..inverse import FusedInverseDynamics, path_peak_force
from ..kinematics import flap_angle_limits
from ..params import DRSParams
from ..study.crossing import crossing_times
from . import ufuncs
from .simulate import simulate_compiled


def warm_up(p: DRSParams | None = None, part: int = 0, parts: int = 1) -> float:
    """Compile (or load from numba's cache) every compiled function by a short use of each: the
    RK driver with both methods, with and without output times (the force kind is a run-time
    switch: one build serves constant, step and manoeuvre forces), the one-sample kernels, every
    fixed-step method and the gufuncs. With ``parts`` > 1 only the share ``part`` (0-based) of
    :data:`WARM_STEPS`, so that ``parts`` processes fill the cache together (``make`` runs two).
    Returns the seconds taken (the start-up cost)."""
    if not 0 <= part < parts:
        raise ValueError(f"part {part} is not in 0..{parts - 1}")
    t0 = time.perf_counter()
    p = DRSParams() if p is None else p
    for step in WARM_STEPS[part::parts]:
        step(p)
    return time.perf_counter() - t0


def _rk_driver(p: DRSParams) -> None:
    """The RK driver with both methods, with and without output times."""
    force = ManoeuvreForce(p)
    for method in ("dopri5", "dop853"):
        simulate_compiled(p, force, (0.0, 0.012), method=method, rtol=1e-6)
        simulate_compiled(p, force, (0.0, 0.002), method=method, rtol=1e-6, t_eval=[0.001, 0.002])


def _one_sample_and_arrays(p: DRSParams) -> None:
    """The inverse force, every fixed-step method, the gufuncs, a commanded path's peak, the
    study's batch of forward runs and the hydraulic rung's compiled steps."""
    inverse = FusedInverseDynamics.from_params(p)
    inverse.force(0.02, 0.1, 1.0)
    inverse.force_at(0.001)
    for method in FIXED_STEP_METHODS:
        integ = FixedStepIntegrator(p, 1e-4, method)
        integ.reset(s=0.02)
        integ.step(500.0)
    integ.form.accel(1.0, 0.0, 0.0)
    for fn in ufuncs.SIGNATURES:
        ufuncs.gufunc(fn)
    path_peak_force(p, [[0.02, 0.1, 0.0, 0.0, 0.0, 0.0]], [0.01])  # a commanded path's scan
    path_range.load_compiled()  # a commanded path's hull check
    # the study's batch of forward runs (drs study): one opening run of the nominal flap
    psi3_closed, psi3_open = flap_angle_limits(p)
    crossing_times(
        [psi3_closed],
        [psi3_open],
        np.array([model_constants(p)]),
        ([integ.s_min - 1e-9], [integ.s_max]),
        True,
        3000.0,
        0.001,
    )
    from ..fidelity.hydraulic import HydraulicRung
    from ..fidelity.hydraulic_steps import STEP_METHODS

    for method in STEP_METHODS:  # the hydraulic rung's compiled steps (at rest on the closed
        # stop: rk4 compiles the stops' switching kernel of the contact's location too)
        HydraulicRung(p, 1e-3, method=method).step()
    HydraulicRung(p, 1e-3, locate_events=True).step()  # the chart reference's switching kernel


#: What :func:`warm_up` compiles, in two shares of about equal compile time on a cold cache (each
#: compiles the kernels it inlines): ~35 s of CPU for the RK driver, ~55 s for the rest.
WARM_STEPS = (_rk_driver, _one_sample_and_arrays)
