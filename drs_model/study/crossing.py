"""When does the flap reach a stroke under a constant piston force? Many samples in one compiled
call of the RK driver of :mod:`drs_model.compiled.rk`.

For each sample, :func:`crossing_times` starts the flap at rest at ``psi3_start`` [rad] and runs
:func:`drs_model.compiled.drivers.integrate_method` (formulation (a), ``psi3``: the method's
driver) under the constant force with its stroke-range check on ``[lo, hi]`` [m]: the first
accepted step that ends outside the range stops the run. If it ends past the target side, the
crossing lies in that step. The driver runs that step again from its start in steps of at most 1/64
of it, and the crossing time is where the cubic Hermite interpolant of ``psi3(t)`` through the ends
of the new crossing step (values and rates, from the driver) meets ``psi3_target``, found by
bisection. A cubic Hermite step's error is ``O(h^4)``: on the whole DOP853 step (~1 ms near the
stop) it is ~6e-9 s, on 1/64 of it far below the integration error; against scipy's event location
on another formulation the times agree to 1e-10 s (``tests/test_study_evaluate.py``). The loop over
samples is compiled as well (numba): no Python per sample.

Each sample's outcome is a code (:data:`REACHED` ... :data:`FAILED`); the driver's own status of a
failed run is kept next to it.
"""

from __future__ import annotations

import math

import numpy as np

from .. import kernels
from ..compiled import rk
from ..compiled.drivers import integrate_method
from ..compiled.jit import jit, jitable
from ..compiled.tableaux import tableau
from ..forward.formulations import Psi3Minimal

#: The run reached the target stroke; its time is the crossing time.
REACHED = 0
#: The flap moved away from the target (the force is on the wrong side of the holding force).
WRONG_WAY = 1
#: The flap had not reached the target at the end of the horizon.
NOT_WITHIN_HORIZON = 2
#: The driver failed (singular link, step collapse, ...): its status is returned with it.
FAILED = 3

OUTCOMES = {
    REACHED: "ok",
    WRONG_WAY: "moves away from the stop",
    NOT_WITHIN_HORIZON: "not within the horizon",
    FAILED: "integration failed",
}

#: What a failed run's driver status means (:mod:`drs_model.compiled.rk`).
DRIVER_FAILURES = {
    rk.STEP_COLLAPSE: "the step size collapsed",
    rk.MIN_STEP: "a step below the minimum step",
    rk.NONFINITE_STATE: "a non-finite state",
    rk.NONFINITE_FORCE: "a non-finite force",
    rk.SINGULAR: "the link turned horizontal (cos psi1 < 0.05)",
    rk.DEAD_CENTRE: "the dead centre",
    rk.TOO_MANY_STEPS: "too many steps",
}


def describe(outcome: int, status: int) -> str:
    """The text of a run's outcome (:data:`OUTCOMES`), with the driver's reason when it failed."""
    if outcome != FAILED:
        return OUTCOMES[outcome]
    return f"integration failed: {DRIVER_FAILURES.get(status, f'status {status}')}"


#: The crossing step is integrated again in steps of at most this fraction of it.
_REFINE = 64.0
#: Bisection steps on the crossing step (2^-60 of a step: far below the interpolant's error).
_BISECTIONS = 60


@jitable
def _hermite(x, h, y0, d0, y1, d1):
    """The cubic Hermite interpolant at ``x`` in [0, 1] of a step of length ``h`` [s] from
    ``(y0, d0)`` to ``(y1, d1)`` (values and time derivatives)."""
    x2 = x * x
    x3 = x2 * x
    return (
        (2.0 * x3 - 3.0 * x2 + 1.0) * y0
        + (x3 - 2.0 * x2 + x) * h * d0
        + (-2.0 * x3 + 3.0 * x2) * y1
        + (x3 - x2) * h * d1
    )


@jitable
def _set_checks(checks, lo, hi):
    """The driver's ``checks`` of a sample: its stroke range ``[lo, hi]`` [m] checked,
    ``Psi3Minimal``'s default ``min_cos_psi1``, no stop at the dead centre (formulation (a) passes
    through it)."""
    checks[0] = 0.05
    checks[1] = lo
    checks[2] = hi
    checks[3] = math.inf
    checks[4] = 1.0
    checks[5] = 0.0


@jitable
def _run(is853, y0, d0, run, kc, rtol, atol, max_step, checks, max_steps):
    """The driver from ``(psi3, psi3') = (y0, d0)`` over ``run = (no_eval, edges, kinds, values,
    mc, mp)`` (one segment under a constant force, no output times) with steps of at most
    ``max_step`` [s]. Returns ``(status, info, t_fail, psi3_fail, psi3'_fail, (t, psi3, psi3')
    at the end of the last accepted step)``."""
    no_eval, edges, kinds, values, mc, mp = run
    status, _, _, _, t_fail, b_fail, bd_fail, info, _, block = integrate_method(
        is853,
        y0,
        d0,
        no_eval,
        False,
        edges,
        kinds,
        values,
        mc,
        mp,
        kc,
        rtol,
        atol,
        0.0,
        max_step,
        1e-12,
        checks,
        max_steps,
    )
    last = block.shape[1] - 1
    return status, info, t_fail, b_fail, bd_fail, (block[0, last], block[1, last], block[2, last])


@jitable
def _hermite_crossing(target, h, y0, d0, y1, d1):
    """Where in ``[0, 1]`` the cubic Hermite interpolant of a step of ``h`` [s] from ``(y0, d0)``
    to ``(y1, d1)`` meets ``target`` (bisection, :data:`_BISECTIONS` halvings)."""
    a, b = 0.0, 1.0
    sign_a = y0 - target
    for _ in range(_BISECTIONS):
        m = 0.5 * (a + b)
        ym = _hermite(m, h, y0, d0, y1, d1) - target
        if (ym > 0.0) == (sign_a > 0.0):
            a = m
        else:
            b = m
    return 0.5 * (a + b)


@jit
def _crossings(psi3_start, psi3_target, kcs, lo, hi, towards_hi, force, horizon, is853, tols):
    """The loop of :func:`crossing_times` over the samples, compiled; ``tols = (rtol, atol,
    max_steps)``."""
    rtol, atol, max_steps = tols
    n = psi3_start.shape[0]
    times = np.full(n, np.nan)
    outcome = np.full(n, FAILED, dtype=np.int64)
    driver_status = np.zeros(n, dtype=np.int64)
    edges = np.array([0.0, horizon])
    kinds = np.zeros(1, dtype=np.int64)  # rk.CONSTANT
    mc = np.zeros(kernels.N_CONSTANTS)  # the manoeuvre's: unread under a constant force
    mp = np.ones(kernels.N_PROFILE_CONSTANTS)
    run = (np.zeros(0), edges, kinds, np.array([force]), mc, mp)
    checks = np.zeros(6)
    for i in range(n):
        _set_checks(checks, lo[i], hi[i])
        status, info, t_fail, _, _, end = _run(
            is853, psi3_start[i], 0.0, run, kcs[i], rtol, atol, math.inf, checks, max_steps
        )
        driver_status[i] = status
        if status == rk.OK:
            outcome[i] = NOT_WITHIN_HORIZON
            continue
        if status != rk.STROKE_RANGE:
            outcome[i] = FAILED
            continue
        if (info > hi[i]) != towards_hi:
            outcome[i] = WRONG_WAY
            continue
        # the crossing step again, in steps of at most 1/_REFINE of it: the interpolant's
        # error falls as h^4 (one DOP853 step near the stop spans ~1 ms, 6e-9 s of error)
        t0, y0, d0 = end  # the last accepted step before the one that crossed
        h = t_fail - t0
        edges[0], edges[1] = t0, t0 + 2.0 * h
        status, info, t_fail, b_fail, bd_fail, end = _run(
            is853, y0, d0, run, kcs[i], rtol, atol, h / _REFINE, checks, max_steps
        )
        edges[0], edges[1] = 0.0, horizon
        if status != rk.STROKE_RANGE or (info > hi[i]) != towards_hi:
            driver_status[i] = status
            outcome[i] = FAILED
            continue
        t0, y0, d0 = end
        h = t_fail - t0
        times[i] = t0 + _hermite_crossing(psi3_target[i], h, y0, d0, b_fail, bd_fail) * h
        outcome[i] = REACHED
    return times, outcome, driver_status


def crossing_times(
    psi3_start,
    psi3_target,
    constants,
    stroke_range,
    towards_hi: bool,
    force: float,
    horizon: float,
    *,
    method: str = "dop853",
    rtol: float = 1e-10,
    max_steps: int = 100_000,
):
    """First time [s] each sample reaches its target stroke from rest under a constant force.

    Parameters
    ----------
    psi3_start, psi3_target : array_like, shape (n,)
        Flap angle at rest at the start and at the target stroke [rad].
    constants : array_like, shape (n, N_CONSTANTS)
        Each sample's kernel constants (:func:`drs_model.bodies.model_constants`).
    stroke_range : (array_like, array_like), each shape (n,)
        ``(lo, hi)`` [m]: the run stops at the first step ending outside; the target is ``hi``
        when ``towards_hi`` (opening), else ``lo`` (closing).
    force : float
        Piston force [N], constant.
    horizon : float
        Longest simulated time [s].
    method, rtol, max_steps
        The driver's method (``"dopri5"``, ``"dop853"``), relative tolerance (``atol = rtol *
        [1 rad, 100 rad/s]``, as :func:`drs_model.forward.simulate`) and step budget.

    Returns
    -------
    times : ndarray, shape (n,)
        Crossing time [s], NaN where not reached.
    outcome : ndarray of int, shape (n,)
        :data:`REACHED`, :data:`WRONG_WAY`, :data:`NOT_WITHIN_HORIZON` or :data:`FAILED`.
    driver_status : ndarray of int, shape (n,)
        The status code of :mod:`drs_model.compiled.rk` for each run.
    """
    *_, is853 = tableau(method)  # an unknown method raises InputError here
    kcs = np.ascontiguousarray(constants, dtype=np.float64)
    lo, hi = (np.ascontiguousarray(x, dtype=np.float64) for x in stroke_range)
    rtol = float(rtol)
    atol = rtol * np.array(Psi3Minimal.scales, dtype=np.float64)
    return _crossings(
        np.ascontiguousarray(psi3_start, dtype=np.float64),
        np.ascontiguousarray(psi3_target, dtype=np.float64),
        kcs,
        lo,
        hi,
        bool(towards_hi),
        float(force),
        float(horizon),
        is853,
        (rtol, atol, int(max_steps)),
    )
