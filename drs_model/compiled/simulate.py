r"""Forward dynamics of formulation (a) (``psi3``) with the compiled RK driver (:mod:`.rk`):
validation, the plan of a run, and its failures as typed errors.

Importing this module imports numba (:mod:`.jit`); :func:`drs_model.forward.simulate` imports it
for the methods ``"dopri5-numba"`` and ``"dop853-numba"`` only, so without numba those raise
:class:`~drs_model.errors.NumbaUnavailableError` (an ``ImportError``) and everything else works.

One run is one call of the method's driver (:data:`.drivers.DRIVERS`). What it computes, compiled:

* the psi3 acceleration: :func:`drs_model.kernels.psi3_acceleration` (constants: the
  formulation's ``consts`` as a float64 array);
* the piston force: a constant per segment (:class:`~drs_model.forward.ConstantForce`,
  :class:`~drs_model.forward.StepForce`), or the manoeuvre's inverse-dynamics force
  (:class:`~drs_model.forward.ManoeuvreForce`): :func:`drs_model.kernels.fused_manoeuvre_force`
  (constants in :func:`manoeuvre_constants`), evaluated once for a segment where the manoeuvre
  rests (:func:`~drs_model.kernels.profile_held`: the same value to the bit);
* ``(q, qd)`` from ``[psi3, psi3']`` in closed form (:func:`drs_model.kernels.psi3_configuration`).

The span is cut at the force's breakpoints (0, 10, 40, 50 ms for the manoeuvre) and every segment
restarts the integrator, as :func:`drs_model.forward.simulate` does, so no stage straddles a
kink. Numerical failures come back from the driver as a status code; this module raises the typed
errors of the pure-Python path:

=================  ======================================================================
status             error
=================  ======================================================================
step collapse      :class:`~drs_model.errors.IntegrationError` ("step size collapsed")
non-finite state   :class:`~drs_model.errors.IntegrationError`
non-finite force   :class:`~drs_model.errors.IntegrationError` ("piston force is not finite")
cos psi1 small     :class:`~drs_model.errors.SingularConfigurationError` (as ``Psi3Minimal``)
dead centre        :class:`~drs_model.errors.SingularConfigurationError` (``stop_at_dead_centre``)
stroke range       :class:`~drs_model.errors.StrokeRangeError` (``stroke_range``)
too many steps     :class:`~drs_model.errors.IntegrationError` (``max_steps``)
=================  ======================================================================
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .. import elementwise, kernels
from ..errors import InputError, IntegrationError, SingularConfigurationError, StrokeRangeError
from ..forward.arguments import output_times, relative_tolerance, time_span
from ..forward.forces import ConstantForce, ManoeuvreForce, StepForce, as_force
from ..forward.formulations import Psi3Minimal, manoeuvre_initial_state
from ..forward.solution import Solution
from ..kinematics import dead_centre, solve_position
from ..params import DRSParams
from . import rk
from .drivers import DRIVERS

__all__ = [
    "manoeuvre_constants",
    "psi3_constants",
    "psi3_formulation",
    "run_formulation",
    "simulate_compiled",
]


# ---- constants ----------------------------------------------------------------------------------
@lru_cache(maxsize=64)
def psi3_constants(form: Psi3Minimal) -> np.ndarray:
    """The formulation's kernel constants (:func:`drs_model.bodies.model_constants`) as float64
    (cached per formulation; read-only to the driver)."""
    return np.array(form.consts, dtype=np.float64)


@lru_cache(maxsize=64)
def manoeuvre_constants(force: ManoeuvreForce) -> tuple[np.ndarray, np.ndarray]:
    """``(mc, mp)``: the force's kernel constants and its manoeuvre's profile constants
    (:meth:`drs_model.profile.Manoeuvre.constants`), as float64 arrays (cached per force)."""
    inv = force.inverse
    return np.array(inv.consts, dtype=np.float64), np.array(inv.profile, dtype=np.float64)


@lru_cache(maxsize=64)
def _default_form(p: DRSParams, flap_limits, min_cos_psi1: float) -> Psi3Minimal:
    return Psi3Minimal(p, flap_limits, min_cos_psi1)


def psi3_formulation(
    p: DRSParams, flap_limits: tuple[float, float] | None = None, min_cos_psi1: float = 0.05
) -> Psi3Minimal:
    """A :class:`~drs_model.forward.Psi3Minimal` for ``p``, cached (building one costs ~60 us,
    as much as a whole compiled run)."""
    if not isinstance(p, DRSParams):
        raise InputError(f"p must be DRSParams, got {type(p).__name__}")
    try:
        return _default_form(p, flap_limits, float(min_cos_psi1))
    except TypeError:  # unhashable flap_limits (a list)
        return Psi3Minimal(p, flap_limits, float(min_cos_psi1))


@lru_cache(maxsize=256)
def _checks(form: Psi3Minimal, lo: float, hi: float, check_range: bool, stop: bool) -> np.ndarray:
    """The driver's ``checks``: ``[min_cos_psi1, lo, hi, psi3 of the dead centre, check the stroke
    range, stop at the dead centre]`` (cached: the driver only reads it)."""
    psi3_dead = _dead_centre_psi3(form.p) if stop else math.inf
    return np.array([form.min_cos_psi1, lo, hi, psi3_dead, float(check_range), float(stop)])


@lru_cache(maxsize=64)
def _rest_state(p: DRSParams) -> tuple[float, float]:
    q0, qd0 = manoeuvre_initial_state(p)
    y = _default_form(p, None, 0.05).initial_state(q0, qd0)
    return float(y[0]), float(y[1])


@lru_cache(maxsize=64)
def _dead_centre_psi3(p: DRSParams) -> float:
    return float(solve_position(dead_centre(p), p)[2])


# ---- the wrapper --------------------------------------------------------------------------------
def _segments(fobj, t0: float, t1: float, extra=()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(edges, kinds, values)`` of the segments of ``[t0, t1]`` (cached: the driver only reads
    them)."""
    return _segments_of(fobj, float(t0), float(t1), tuple(float(b) for b in extra) if extra else ())


@lru_cache(maxsize=64)
def _segments_of(fobj, t0: float, t1: float, extra: tuple[float, ...]):
    cuts = sorted({float(b) for b in (*fobj.breakpoints, *extra) if t0 < b < t1})
    edges = np.array([t0, *cuts, t1], dtype=np.float64)
    n = edges.size - 1
    kinds = np.full(n, rk.CONSTANT, dtype=np.int64)
    values = np.zeros(n, dtype=np.float64)
    if isinstance(fobj, ManoeuvreForce):
        # where the manoeuvre rests the force is one value: no kernel call per stage
        mc, mp = manoeuvre_constants(fobj)
        for i in range(n):
            if kernels.profile_held(edges[i], edges[i + 1], mp):
                mid = np.array([0.5 * (edges[i] + edges[i + 1])])
                values[i] = elementwise.fused_manoeuvre_force(mid, mc, mp)[0]  # compiled
            else:
                kinds[i] = rk.MANOEUVRE
    elif isinstance(fobj, ConstantForce):
        values[:] = fobj.value
    elif isinstance(fobj, StepForce):
        mid = 0.5 * (edges[:-1] + edges[1:])
        values[:] = np.where(mid < fobj.t_step, fobj.before, fobj.after)
    else:
        raise InputError(
            "the compiled methods take a constant force, a StepForce or a ManoeuvreForce, got "
            f"{type(fobj).__name__}; use a scipy method ('DOP853', 'LSODA', ...) for a callable"
        )
    return edges, kinds, values


_NO_MANOEUVRE = (np.zeros(kernels.N_CONSTANTS), np.ones(kernels.N_PROFILE_CONSTANTS))
_NO_OUTPUT_TIMES = np.zeros(0)  # read-only to the driver
_EPS = float(np.finfo(float).eps)


@lru_cache(maxsize=256)
def _plan(
    form,
    fobj,
    method,
    t0,
    t1,
    rtol,
    atol,
    first_step,
    max_step,
    min_step,
    breakpoints,
    stroke_range,
    stop_at_dead_centre,
    max_steps,
):
    """``(the method's driver, its arguments after the start state and the output times, the
    segments as (start, end) pairs [s])``, validated. Cached: they depend on these (hashable)
    inputs only, and the driver only reads them."""
    time_span((t0, t1))
    rtol = max(relative_tolerance(rtol), 100 * _EPS)  # scipy's floor
    if atol is None:
        atol_arr = rtol * np.array(form.scales, dtype=np.float64)
    else:
        atol_arr = np.array(atol, dtype=np.float64)
        if not (np.all(np.isfinite(atol_arr)) and np.all(atol_arr >= 0.0)):
            raise InputError(f"atol must be finite and >= 0, got {atol!r}")
    fs = 0.0 if first_step is None else float(first_step)
    if first_step is not None and not (fs > 0.0 and math.isfinite(fs)):
        raise InputError(f"first_step must be a finite number > 0 s, got {first_step!r}")
    if not max_step > 0.0:
        raise InputError(f"max_step must be > 0 s, got {max_step!r}")
    if int(max_steps) < 1:
        raise InputError(f"max_steps must be >= 1, got {max_steps!r}")
    edges, kinds, values = _segments(fobj, t0, t1, breakpoints)
    mc, mp = manoeuvre_constants(fobj) if isinstance(fobj, ManoeuvreForce) else _NO_MANOEUVRE
    if stroke_range is None:
        lo, hi = -math.inf, math.inf
    else:
        lo, hi = (float(v) for v in stroke_range)
        if not lo < hi:
            raise InputError(
                f"stroke_range must be (lo, hi) with lo < hi [m], got {stroke_range!r}"
            )
    checks = _checks(form, lo, hi, stroke_range is not None, bool(stop_at_dead_centre))
    driver = _driver(method)
    driver_args = (
        edges,
        kinds,
        values,
        mc,
        mp,
        psi3_constants(form),
        rtol,
        atol_arr,
        fs,
        float(max_step),
        float(min_step),
        checks,
        int(max_steps),
    )
    edge_list = edges.tolist()
    return driver, driver_args, tuple(zip(edge_list[:-1], edge_list[1:], strict=True))


def _driver(method: str):
    """The compiled driver of ``method`` (:data:`.drivers.DRIVERS`)."""
    try:
        return DRIVERS[method]
    except (KeyError, TypeError):
        methods = " or ".join(repr(m) for m in DRIVERS)
        raise InputError(f"method must be {methods}, got {method!r}") from None


#: What each failure status of the driver raises: ``(error type, message)``, the message a
#: template of the run's ``head``, ``label``, ``where``, ``state``, ``t`` [s], ``y`` (psi3 [rad],
#: psi3' [rad/s]), ``info`` (the status's value), ``checks``, ``s_dead`` [m], ``min_step`` [s]
#: and ``max_steps``.
_FAILURES = {
    rk.STEP_COLLAPSE: (
        IntegrationError,
        "{head}: step size collapsed to {info:.3g} s (10 ulp of t) {where}, {state}: "
        "the error control rejects every step (a stage outside the assembly range?)",
    ),
    rk.MIN_STEP: (
        IntegrationError,
        "{head}: step size collapsed to {info:.3g} s < min_step = {min_step:g} s {where}",
    ),
    rk.NONFINITE_STATE: (IntegrationError, "{head}: non-finite state {where}: {state}"),
    rk.NONFINITE_FORCE: (
        IntegrationError,
        "{head}: piston force is not finite at t = {t!r} s: {info!r} N (the manoeuvre's "
        "loop cannot close there?)",
    ),
    rk.SINGULAR: (
        SingularConfigurationError,
        "psi3 formulation ({label}): at psi3 = {y[0]:.9g} rad (t = {t:.9g} s) cos psi1 = "
        "{info:.3g} < min_cos_psi1 = {checks[0]:g}: the link is nearly horizontal and psi3 "
        "cannot stay the independent coordinate",
    ),
    rk.DEAD_CENTRE: (
        SingularConfigurationError,
        "{head}: step to t = {t:.9g} s crosses the dead centre: psi3 = {y[0]:.9g} rad >= "
        "{checks[3]:.9g} rad (s_dead = {s_dead:.9g} m)",
    ),
    rk.STROKE_RANGE: (
        StrokeRangeError,
        "{head}: stroke s = {info:.9g} m at t = {t:.9g} s leaves the stroke range "
        "[{checks[1]:.9g}, {checks[2]:.9g}] m ({state})",
    ),
    rk.TOO_MANY_STEPS: (
        IntegrationError,
        "{head}: more than max_steps = {max_steps} steps {where}",
    ),
}


def _raise(status, label, t, y, info, seg, plan, p):
    """Raise the typed error of the driver's failure ``status`` (:data:`_FAILURES`) at ``t`` [s]
    in segment ``seg`` of the run of ``plan`` (:func:`_plan`'s driver arguments)."""
    edges, min_step, checks, max_steps = plan[0], plan[-3], plan[-2], plan[-1]
    error, message = _FAILURES.get(
        status, (IntegrationError, "{head}: unknown status {status} {where}")
    )
    raise error(
        message.format(
            head=f"{label} on formulation 'psi3'",
            label=label,
            where=f"at t = {t:.9g} s (segment [{edges[seg]:.6g}, {edges[seg + 1]:.6g}] s)",
            state=f"psi3 = {y[0]:.9g} rad, psi3' = {y[1]:.9g} rad/s",
            status=status,
            t=t,
            y=y,
            info=info,
            checks=checks,
            s_dead=dead_centre(p) if status == rk.DEAD_CENTRE else math.nan,
            min_step=min_step,
            max_steps=max_steps,
        )
    )


def simulate_compiled(
    p: DRSParams,
    force,
    t_span: tuple[float, float],
    *,
    method: str = "dop853",
    flap_limits: tuple[float, float] | None = None,
    min_cos_psi1: float = 0.05,
    **options,
):
    """Forward dynamics of formulation (a) (``psi3``) with a compiled adaptive RK method.

    Parameters
    ----------
    p : DRSParams
    force : float or force object
        A constant [N], a :class:`~drs_model.forward.StepForce` or a
        :class:`~drs_model.forward.ManoeuvreForce` (a general callable of t is refused: use a
        scipy method).
    t_span : (float, float)
        Start and end times [s].
    method : {"dopri5", "dop853"}
        Dormand-Prince 5(4) or DOP853 (the tableaux and step control of scipy's RK45 / DOP853).
    flap_limits, min_cos_psi1
        Options of :class:`~drs_model.forward.Psi3Minimal`.
    **options
        The run's options, those of :func:`run_formulation` (with the same defaults):
    rtol, atol : float or array_like
        Tolerances; ``atol`` defaults to ``rtol * [1 rad, 100 rad/s]`` (as ``simulate``).
    t_eval : array_like, shape (n,), optional
        Sorted output times [s] (dense output); default: every accepted step.
    first_step, max_step, min_step : float
        As in :func:`drs_model.forward.simulate` [s].
    initial, y0
        ``(q0, qd0)`` (consistent full coordinates) or ``[psi3, psi3']``; default: at rest at
        the closed stroke.
    breakpoints : tuple of float
        Extra restart times [s].
    stroke_range : (float, float), optional
        A step ending with the stroke outside ``[lo, hi]`` [m] raises
        :class:`~drs_model.errors.StrokeRangeError` (default: no check, as ``simulate``).
    stop_at_dead_centre : bool
        A step ending at ``psi3 >= psi3(s_dead)`` raises
        :class:`~drs_model.errors.SingularConfigurationError` (default False: formulation (a)
        passes through the dead centre).
    max_steps : int
        Accepted steps allowed over the whole span.

    Returns
    -------
    Solution
        ``method`` is ``"dopri5-numba"`` or ``"dop853-numba"``; ``nrejected`` counts the
        rejected steps.

    Raises
    ------
    NumbaUnavailableError
        numba is not installed.
    InputError, IntegrationError, SingularConfigurationError, StrokeRangeError
        See the module docstring.
    """
    form = psi3_formulation(p, flap_limits, min_cos_psi1)
    return run_formulation(form, force, t_span, method=method, **options)


def run_formulation(
    form,
    force,
    t_span,
    *,
    method: str,
    initial=None,
    y0=None,
    label: str | None = None,
    rtol: float = 1e-8,
    atol=None,
    t_eval=None,
    first_step: float | None = None,
    max_step: float = math.inf,
    min_step: float = 1e-12,
    breakpoints: tuple[float, ...] = (),
    stroke_range: tuple[float, float] | None = None,
    stop_at_dead_centre: bool = False,
    max_steps: int = 1_000_000,
):
    """:func:`simulate_compiled` on a formulation instance (the hook of ``simulate``): validate,
    run the compiled driver, raise its failure as a typed error or return the
    :class:`~drs_model.forward.solution.Solution`."""
    _check_formulation(form)
    fobj = as_force(force)
    t0, t1 = float(t_span[0]), float(t_span[1])  # checked in the cached plan
    b0, bd0 = _start_state(form, t0, initial, y0)
    if atol is not None:  # hashable, for the plan's cache
        atol = tuple(np.broadcast_to(np.asarray(atol, dtype=np.float64), (2,)).tolist())
    driver, plan, segments = _plan(
        form,
        fobj,
        method,
        t0,
        t1,
        rtol,
        atol,
        first_step,
        max_step,
        min_step,
        tuple(breakpoints),
        None if stroke_range is None else tuple(stroke_range),
        bool(stop_at_dead_centre),
        max_steps,
    )
    if t_eval is None:
        te, has_eval = _NO_OUTPUT_TIMES, False
    else:
        te = output_times(t_eval, (t0, t1))
        has_eval = True
    status, nfev, nsteps, nrej, t_fail, b_fail, bd_fail, info, seg, block = driver(
        b0, bd0, te, has_eval, *plan
    )
    label = label or f"{method}-numba"
    if status != rk.OK:
        _raise(status, label, t_fail, (b_fail, bd_fail), info, seg, plan, form.p)
    return _solution(form.name, label, block, nfev, nsteps, nrej, segments)


def _solution(formulation, label, block, nfev, nsteps, nrejected, segments) -> Solution:
    """The run's :class:`~drs_model.forward.solution.Solution`: views into the one block the
    driver returned (q, qd: (n, 3), Fortran order; the residuals of minimal coordinates: its
    rows of zeros)."""
    return Solution(
        formulation,
        label,
        block[0],
        block[1:3],
        block[3:6].T,
        block[6:9].T,
        block[9],
        block[10],
        nfev,
        0,
        0,
        nsteps,
        list(segments),
        nrejected,
    )


def _check_formulation(form) -> None:
    """Refuse a formulation the compiled methods do not integrate (only ``psi3``'s)."""
    if not isinstance(form, Psi3Minimal):
        if isinstance(form, str):
            raise InputError("run_formulation takes a formulation instance")
        raise InputError(
            f"the compiled methods integrate formulation 'psi3' only, got {form.name!r}; use a "
            f"scipy method for the others"
        )


def _start_state(form: Psi3Minimal, t0: float, initial, y0) -> tuple[float, float]:
    """``(psi3 [rad], psi3' [rad/s])`` at ``t0``: ``y0`` (checked), from ``initial = (q0, qd0)``,
    or at rest at the closed stroke."""
    if y0 is not None:
        y = np.asarray(y0, dtype=float).reshape(2)
        form.check(t0, y)
    elif initial is not None:
        y = form.initial_state(*initial)
    else:
        y = _rest_state(form.p)
    return float(y[0]), float(y[1])
