r"""The compiled RK driver of formulation (a) (``psi3``): numba, no physics of its own.

Optional: needs numba (``pip install drs[fast]``). Importing this module does not import numba;
the first call of :func:`simulate_compiled` (or :func:`load`) does, and compiles the kernels (or
loads them from numba's on-disk cache, ``cache=True``). Without numba that call raises
:class:`NumbaUnavailableError` (an ``ImportError``).

What runs compiled, in one call per simulation:

* the psi3 acceleration: :func:`drs_model.kernels.psi3_acceleration` itself, compiled, and in
  the stages its two halves :func:`~drs_model.kernels.psi3_position` and
  :func:`~drs_model.kernels.psi3_acceleration_at` (inlined), so that a step's checks read the
  stroke and ``cos psi1`` of ``y_new`` from its last stage (constants: the formulation's
  ``consts`` as a float64 array);
* the piston force: a constant per segment (:class:`~drs_model.forward.ConstantForce`,
  :class:`~drs_model.forward.StepForce`), or the manoeuvre's inverse-dynamics force
  (:class:`~drs_model.forward.ManoeuvreForce`): :func:`drs_model.kernels.manoeuvre_force` itself,
  compiled (constants in :func:`manoeuvre_constants`), evaluated once for a segment where the
  manoeuvre holds still (:func:`~drs_model.kernels.profile_held`: the same value to the bit);
* an explicit embedded Runge-Kutta driver, ``"dopri5"`` (Dormand-Prince 5(4), scipy's ``RK45``)
  or ``"dop853"`` (Hairer's DOP853, scipy's ``DOP853``), with scipy's step-size control:
  error norm ``RMS(err / (atol + max(|y|, |y_new|) rtol))``, new step ``h * min(10, max(0.2,
  0.9 * norm^(-1/(p+1))))`` (no growth right after a rejection), scipy's initial-step
  heuristic (Hairer, Norsett & Wanner II.4) at the start of every segment. The tableaux are read
  from scipy's public solver classes (``RK45.A``, ``DOP853.E5`` ...), one source of truth;
* output by **dense output** at the requested times (scipy's continuous extensions: the quartic
  of RK45, the degree-7 interpolant of DOP853, which costs 3 extra evaluations on each step that
  holds an output time), or at every accepted step if no times are given;
* ``(q, qd)`` from ``[psi3, psi3']`` in closed form (:func:`drs_model.kernels.psi3_configuration`,
  compiled).

The span is cut at the force's breakpoints (0, 10, 40, 50 ms for the manoeuvre) and every segment
restarts the integrator, as :func:`drs_model.forward.simulate` does, so no stage straddles a
kink. Numerical failures come back from the compiled code as a status code (scipy's
``(success, message)`` pattern); the wrapper raises the typed errors of the pure-Python path:

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
import time
from functools import lru_cache

import numpy as np

from .. import kernels
from ..errors import (
    DRSError,
    InputError,
    IntegrationError,
    SingularConfigurationError,
    StrokeRangeError,
)
from ..kernels import (
    manoeuvre_force,
    psi3_acceleration,
    psi3_acceleration_at,
    psi3_configuration,
    psi3_position,
)
from ..kinematics import dead_centre, solve_position
from ..params import DRSParams
from .forces import ConstantForce, ManoeuvreForce, StepForce, as_force
from .formulations import Psi3Minimal, manoeuvre_initial_state
from .solution import Solution

__all__ = [
    "COMPILED_METHODS",
    "NumbaUnavailableError",
    "available",
    "load",
    "manoeuvre_constants",
    "psi3_constants",
    "psi3_formulation",
    "run_formulation",
    "simulate_compiled",
    "warm_up",
]

#: Names of the compiled methods in :func:`drs_model.forward.simulate` -> driver name.
COMPILED_METHODS = {"dopri5-numba": "dopri5", "dop853-numba": "dop853"}

# status codes of the compiled driver
OK = 0
STEP_COLLAPSE = 1  # h below scipy's 10 ulp(t) after rejections
MIN_STEP = 2  # an accepted step shorter than min_step (not the last of a segment)
NONFINITE_STATE = 3
NONFINITE_FORCE = 4
SINGULAR = 5  # cos psi1 < min_cos_psi1
DEAD_CENTRE = 6
STROKE_RANGE = 7
TOO_MANY_STEPS = 8

# scipy's step-size control (scipy/integrate/_ivp/rk.py)
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0

# force kinds per segment
_CONSTANT = 0
_MANOEUVRE = 1


class NumbaUnavailableError(DRSError, ImportError):
    """The compiled methods need numba, which is not installed (``pip install drs[fast]``)."""


# ---- the driver (plain Python in numba's subset; njit-ed by load()) ------------------------------
def _force(t, kind, value, mc, mp):
    """Piston force [N] of a segment: ``value`` (constant) or the manoeuvre's at t."""
    if kind == 0:
        return value
    return manoeuvre_force(t, mc, mp)


def _manoeuvre_forces(t, mc, mp):
    """The compiled :func:`~drs_model.kernels.manoeuvre_force` at each time of ``t`` (1-D) [N]
    (for tests and benchmarks)."""
    out = np.empty(t.shape[0])
    for i in range(t.shape[0]):
        out[i] = manoeuvre_force(t[i], mc, mp)
    return out


def _psi3_accels(b, bd, f, kc):
    """The compiled :func:`~drs_model.kernels.psi3_acceleration` element-wise over 1-D arrays
    (for tests)."""
    out = np.empty(b.shape[0])
    for i in range(b.shape[0]):
        out[i] = psi3_acceleration(b[i], bd[i], f[i], kc)
    return out


def _output_block(t_out, y_out, n, kc):
    """The run's output as one exact-size block ``(9, n)``: rows ``t``, ``[psi3, psi3']``, ``q``
    and ``qd`` (``(s, psi1, psi3)`` and their rates, closed form) of the first ``n`` outputs. One
    array crosses back to Python (each returned array costs a boxing of its own)."""
    out = np.empty((9, n))
    for i in range(n):
        b, bd = y_out[0, i], y_out[1, i]
        s, psi1, u0, u1 = psi3_configuration(b, kc)
        out[0, i], out[1, i], out[2, i] = t_out[i], b, bd
        out[3, i], out[4, i], out[5, i] = s, psi1, b
        out[6, i], out[7, i], out[8, i] = u0 * bd, u1 * bd, bd
    return out


def _grow(t_out, y_out):
    n = t_out.shape[0]
    t_new = np.empty(2 * n)
    y_new = np.empty((2, 2 * n))
    for i in range(n):  # element loops: a slice assignment compiles numba's string formatting
        t_new[i] = t_out[i]
        y_new[0, i] = y_out[0, i]
        y_new[1, i] = y_out[1, i]
    return t_new, y_new


def _rms_norm(e0, e1):
    return math.sqrt(0.5 * (e0 * e0 + e1 * e1))


def _combination(K, tab_a, row, n):
    """``sum_j tab_a[row, j] K[j]`` over the first ``n`` stages: both components."""
    s0 = 0.0
    s1 = 0.0
    for j in range(n):
        s0 += K[j, 0] * tab_a[row, j]
        s1 += K[j, 1] * tab_a[row, j]
    return s0, s1


def _stages(K, s_from, s_to, t, h, y0, y1, tab_a, tab_c, kind, value, mc, mp, kc):
    """Stages ``s_from <= s < s_to`` (``s_from >= 1``) of an explicit RK step into the rows of
    ``K`` (columns: psi3', psi3'', piston force). The forces depend on the stage times only: all
    are evaluated first, free of the stages' chain of dependencies; a stage at the same time as
    the one before (``c = 1`` twice: the last stage and y_new) reuses its force. Returns
    ``(-1, 0.0, s, cos psi1)`` with the stroke [m] and ``cos psi1`` of the last stage (that of
    ``y_new`` for the stages of a step: its checks need no position of their own), or ``(the
    stage whose piston force is not finite, that force, NaN, NaN)``."""
    for s in range(s_from, s_to):
        if tab_c[s] == tab_c[s - 1]:
            K[s, 2] = K[s - 1, 2]
        else:
            K[s, 2] = _force(t + tab_c[s] * h, kind, value, mc, mp)
    for s in range(s_from, s_to):
        if not math.isfinite(K[s, 2]):
            return s, K[s, 2], math.nan, math.nan
    stroke = cos1 = math.nan
    for s in range(s_from, s_to):
        s0, s1 = _combination(K, tab_a, s, s)
        ys0 = y0 + s0 * h
        ys1 = y1 + s1 * h
        K[s, 0] = ys1
        # psi3_acceleration in its two halves (NaN where the loop cannot close, as there)
        sb, cb, stroke, sa, cos1, _ = psi3_position(ys0, kc)
        K[s, 1] = psi3_acceleration_at(ys0, ys1, K[s, 2], sb, cb, sa, cos1, kc)
    return -1, 0.0, stroke, cos1


def _error_norm(K, ns, h, tab_e, tab_e3, sc0, sc1, is853):
    """scipy's error norms: RK45 ``RMS(h K^T E / scale)``; DOP853 the 5th-order estimate
    corrected by the 3rd-order one."""
    e0 = 0.0
    e1 = 0.0
    f0 = 0.0
    f1 = 0.0
    for j in range(ns + 1):
        e0 += K[j, 0] * tab_e[j]
        e1 += K[j, 1] * tab_e[j]
        f0 += K[j, 0] * tab_e3[j]
        f1 += K[j, 1] * tab_e3[j]
    if not is853:
        return _rms_norm(e0 * h / sc0, e1 * h / sc1)
    e0 /= sc0
    e1 /= sc1
    f0 /= sc0
    f1 /= sc1
    n5 = e0 * e0 + e1 * e1
    n3 = f0 * f0 + f1 * f1
    if n5 == 0.0 and n3 == 0.0:
        return 0.0
    return abs(h) * n5 / math.sqrt((n5 + 0.01 * n3) * 2.0)


def _dense(K, ns, n_ext, x, h, y0, y1, yn0, yn1, tab_dense, is853):
    """The continuous extension at ``t + x h`` (scipy's RkDenseOutput / Dop853DenseOutput)."""
    r0 = 0.0
    r1 = 0.0
    if not is853:  # y_old + h (K^T P) [x, x^2, x^3, x^4]
        xp = 1.0
        for m in range(tab_dense.shape[1]):
            xp *= x
            q0 = 0.0
            q1 = 0.0
            for j in range(ns + 1):
                q0 += K[j, 0] * tab_dense[j, m]
                q1 += K[j, 1] * tab_dense[j, m]
            r0 += q0 * xp
            r1 += q1 * xp
        return y0 + h * r0, y1 + h * r1
    dy0 = yn0 - y0
    dy1 = yn1 - y1
    # F = [dy, h f_old - dy, 2 dy - h (f_new + f_old), h D K], Horner from F[6] down
    for i in range(6, -1, -1):
        if i == 0:
            c0, c1 = dy0, dy1
        elif i == 1:
            c0, c1 = h * K[0, 0] - dy0, h * K[0, 1] - dy1
        elif i == 2:
            c0 = 2.0 * dy0 - h * (K[ns, 0] + K[0, 0])
            c1 = 2.0 * dy1 - h * (K[ns, 1] + K[0, 1])
        else:
            c0 = 0.0
            c1 = 0.0
            for j in range(n_ext):
                c0 += tab_dense[i - 3, j] * K[j, 0]
                c1 += tab_dense[i - 3, j] * K[j, 1]
            c0 *= h
            c1 *= h
        r0 += c0
        r1 += c1
        if (6 - i) % 2 == 0:
            r0 *= x
            r1 *= x
        else:
            r0 *= 1.0 - x
            r1 *= 1.0 - x
    return y0 + r0, y1 + r1


def _initial_step(t, b, y0, y1, f1, kind, value, mc, mp, kc, rtol, atol, err_order, max_step):
    """scipy's ``select_initial_step`` (Hairer, Norsett & Wanner II.4). Returns ``(h, force at
    the probe)``; the force is NaN-checked by the caller."""
    f0 = y1
    sc0 = atol[0] + abs(y0) * rtol
    sc1 = atol[1] + abs(y1) * rtol
    d0 = _rms_norm(y0 / sc0, y1 / sc1)
    d1 = _rms_norm(f0 / sc0, f1 / sc1)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, b - t)
    z0 = y0 + h0 * f0
    z1 = y1 + h0 * f1
    fo = _force(t + h0, kind, value, mc, mp)
    if not math.isfinite(fo):
        return h0, fo
    g1 = psi3_acceleration(z0, z1, fo, kc)
    d2 = _rms_norm((z1 - f0) / sc0, (g1 - f1) / sc1) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    elif d2 != d2:
        h1 = h0  # a NaN trial stage (no assembly): the error control shrinks the step
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (err_order + 1.0))
    return min(100.0 * h0, h1, b - t, max_step), fo


def _check_step(t_new, b, h, yn0, yn1, s_new, cos1, min_step, checks):
    """The checks after an accepted step (the Guarded solver's and Psi3Minimal.check, plus the
    optional dead centre and stroke range) on ``y_new``, its stroke ``s_new`` [m] and ``cos1``
    (``cos psi1``). Returns ``(status, info)``."""
    if h < min_step and t_new != b:
        return MIN_STEP, h
    if not (math.isfinite(yn0) and math.isfinite(yn1)):
        return NONFINITE_STATE, 0.0
    if not cos1 >= checks[0]:
        return SINGULAR, cos1
    if checks[5] != 0.0 and yn0 >= checks[3]:
        return DEAD_CENTRE, yn0
    if checks[4] != 0.0:
        if not (checks[1] <= s_new <= checks[2]):
            return STROKE_RANGE, s_new
    return OK, 0.0


def _integrate(
    y_start0,
    y_start1,
    t_eval,
    has_eval,
    edges,
    kinds,
    values,
    mc,
    mp,
    kc,
    tab_a,
    tab_c,
    tab_e,
    tab_e3,
    tab_dense,
    ns,
    n_ext,
    err_order,
    is853,
    rtol,
    atol,
    first_step,
    max_step,
    min_step,
    checks,
    max_steps,
):
    """The adaptive RK driver over the segments ``edges`` (see the module docstring).

    ``tab_a`` (n_ext, n_ext) holds the stages' coefficients with the weights B in row ``ns``
    (``y_new`` is "stage" ``ns`` at ``c = 1``, FSAL) and the dense-output stages of DOP853 in
    the rows after it. Returns ``(status, nfev, nsteps, nrejected, t_fail, psi3_fail,
    psi3'_fail, info, segment, block)``: ``info`` is the offending step size, force, cos psi1,
    psi3 or stroke of a failure, ``block`` the :func:`_output_block` of the outputs (one call
    from Python, one array back).
    """
    expo = -1.0 / (err_order + 1.0)
    K = np.zeros((n_ext, 3))  # psi3', psi3'', piston force per stage
    b_fail = bd_fail = 0.0
    n_eval = t_eval.shape[0]
    if has_eval:
        t_out = t_eval.copy()
        y_out = np.empty((2, n_eval))
        n_out = 0
    else:
        t_out = np.empty(256)
        y_out = np.empty((2, 256))
        t_out[0] = edges[0]
        y_out[0, 0] = y_start0
        y_out[1, 0] = y_start1
        n_out = 1
    ie = 0
    nfev = 0
    nsteps = 0
    nrej = 0
    status = OK
    info = 0.0
    y0 = y_start0
    y1 = y_start1
    t = edges[0]
    t_fail = t
    n_seg = edges.shape[0] - 1
    seg = 0
    for seg in range(n_seg):
        b = edges[seg + 1]
        kind, value = kinds[seg], values[seg]
        t = edges[seg]
        fo = _force(t, kind, value, mc, mp)
        nfev += 1
        if not math.isfinite(fo):
            status, info, t_fail = NONFINITE_FORCE, fo, t
            break
        K[0, 0] = y1
        K[0, 1] = psi3_acceleration(y0, y1, fo, kc)
        if first_step > 0.0:
            h_abs = min(first_step, b - t)
        else:
            h_abs, fo = _initial_step(
                t, b, y0, y1, K[0, 1], kind, value, mc, mp, kc, rtol, atol, err_order, max_step
            )
            nfev += 1
            if not math.isfinite(fo):
                status, info, t_fail = NONFINITE_FORCE, fo, t + h_abs
                break
        while t < b:
            ulp_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
            h_abs = min(max(h_abs, ulp_step), max_step)
            rejected = False
            # ---- one step: try, reject and shrink until the error norm is below 1
            while True:
                if h_abs < ulp_step:
                    status, info, t_fail = STEP_COLLAPSE, h_abs, t
                    break
                t_new = min(t + h_abs, b)
                h = t_new - t
                h_abs = abs(h)
                bad, fo, s_new, cos1 = _stages(
                    K, 1, ns + 1, t, h, y0, y1, tab_a, tab_c, kind, value, mc, mp, kc
                )
                if bad >= 0:
                    nfev += bad
                    status, info, t_fail = NONFINITE_FORCE, fo, t + tab_c[bad] * h
                    break
                nfev += ns
                s0, s1 = _combination(K, tab_a, ns, ns)
                yn0 = y0 + s0 * h
                yn1 = y1 + s1 * h
                sc0 = atol[0] + max(abs(y0), abs(yn0)) * rtol
                sc1 = atol[1] + max(abs(y1), abs(yn1)) * rtol
                err = _error_norm(K, ns, h, tab_e, tab_e3, sc0, sc1, is853)
                if err < 1.0:
                    factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err**expo)
                    if rejected:
                        factor = min(1.0, factor)
                    h_abs *= factor
                    break
                if err != err:  # NaN: a stage outside the assembly range
                    h_abs *= MIN_FACTOR
                else:
                    h_abs *= max(MIN_FACTOR, SAFETY * err**expo)
                rejected = True
                nrej += 1
            if status != OK:
                b_fail, bd_fail = y0, y1
                break
            nsteps += 1
            status, info = _check_step(t_new, b, h, yn0, yn1, s_new, cos1, min_step, checks)
            if status == OK and nsteps >= max_steps and not (seg == n_seg - 1 and t_new == b):
                status = TOO_MANY_STEPS
            if status != OK:
                b_fail, bd_fail, t_fail = yn0, yn1, t_new
                break
            # ---- output: dense at the requested times, or the step itself
            if has_eval:
                if is853 and ie < n_eval and t_eval[ie] < t_new:  # three more stages
                    _stages(K, ns + 1, n_ext, t, h, y0, y1, tab_a, tab_c, kind, value, mc, mp, kc)
                    nfev += n_ext - ns - 1
                while ie < n_eval and t_eval[ie] <= t_new:
                    if t_eval[ie] == t_new:
                        y_out[0, ie], y_out[1, ie] = yn0, yn1
                    else:
                        y_out[0, ie], y_out[1, ie] = _dense(
                            K,
                            ns,
                            n_ext,
                            (t_eval[ie] - t) / h,
                            h,
                            y0,
                            y1,
                            yn0,
                            yn1,
                            tab_dense,
                            is853,
                        )
                    ie += 1
                n_out = ie
            else:
                if n_out == t_out.shape[0]:
                    t_out, y_out = _grow(t_out, y_out)
                t_out[n_out] = t_new
                y_out[0, n_out], y_out[1, n_out] = yn0, yn1
                n_out += 1
            t = t_new
            y0 = yn0
            y1 = yn1
            K[0, 0] = K[ns, 0]  # FSAL
            K[0, 1] = K[ns, 1]
        if status != OK:
            break
    block = _output_block(t_out, y_out, n_out, kc)
    return status, nfev, nsteps, nrej, t_fail, b_fail, bd_fail, info, seg, block


#: The driver's own functions, callees first; the kernels of :mod:`drs_model.kernels` are compiled
#: before them.
_DRIVER = (
    "_force",
    "_manoeuvre_forces",
    "_psi3_accels",
    "_output_block",
    "_grow",
    "_rms_norm",
    "_combination",
    "_stages",
    "_error_norm",
    "_dense",
    "_initial_step",
    "_check_step",
    "_integrate",
)
_LOADED = False


def available() -> bool:
    """Whether numba can be imported (without importing it twice)."""
    if _LOADED:
        return True
    import importlib.util

    return importlib.util.find_spec("numba") is not None


def load() -> float:
    """Import numba and wrap the kernels in ``njit(cache=True)`` (once). Returns the seconds this
    call took (0 after the first). Compilation itself happens at the first call of each kernel
    (or is loaded from numba's cache); :func:`warm_up` triggers it.

    Raises
    ------
    NumbaUnavailableError
        numba is not installed.
    """
    # The one module-level binding in drs_model: numba resolves calls between jitted functions
    # through their globals, so the driver's names are rebound here once (a closure factory would
    # lose numba's on-disk cache). It only ever goes from the Python functions to their jitted
    # wrappers.
    global _LOADED
    if _LOADED:
        return 0.0
    t0 = time.perf_counter()
    try:
        import numba
    except ImportError as exc:
        raise NumbaUnavailableError(
            "the compiled methods ('dopri5-numba', 'dop853-numba') need numba, which is not "
            "installed: pip install 'drs[fast]' (or pip install 'numba>=0.60'); the scipy "
            "methods ('RK45', 'DOP853', 'LSODA', ...) work without it"
        ) from exc
    # numpy's error model: a division by zero gives inf/NaN (which the driver treats as a rejected
    # stage) instead of a ZeroDivisionError check on every division
    from numba.extending import register_jitable

    jit = numba.njit(cache=True, error_model="numpy")
    # the kernels' own code objects, with globals in which every kernel is registered with numba:
    # each compiles into the driver function that calls it (no dispatcher of its own)
    namespace = kernels.rebind(kernels.KERNELS, dict(vars(kernels)))
    for name in kernels.KERNELS:
        # the two halves of psi3_acceleration are inlined (numba IR): split, they cost as much
        # as whole, and the driver keeps the position of y_new for free
        inline = "always" if name in ("psi3_position", "psi3_acceleration_at") else "never"
        namespace[name] = register_jitable(error_model="numpy", inline=inline)(namespace[name])
    g = globals()
    for name in (
        "manoeuvre_force",
        "psi3_acceleration",
        "psi3_acceleration_at",
        "psi3_configuration",
        "psi3_position",
    ):
        g[name] = namespace[name]
    for name in _DRIVER:  # callees first: a function resolves the others when it compiles
        g[name] = jit(g[name])
    _LOADED = True
    return time.perf_counter() - t0


def warm_up(p: DRSParams | None = None) -> float:
    """Load and compile (or load from numba's cache) every kernel by short runs of both methods,
    with and without output times (the force kind is a run-time switch: one compilation serves
    constant, step and manoeuvre forces); returns the seconds taken (the start-up cost)."""
    t0 = time.perf_counter()
    load()
    p = DRSParams() if p is None else p
    force = ManoeuvreForce(p)
    for method in ("dopri5", "dop853"):
        simulate_compiled(p, force, (0.0, 0.012), method=method, rtol=1e-6)
        simulate_compiled(p, force, (0.0, 0.002), method=method, rtol=1e-6, t_eval=[0.001, 0.002])
    t = np.array([0.001])
    _manoeuvre_forces(t, *manoeuvre_constants(force))
    _psi3_accels(t, t, t, psi3_constants(Psi3Minimal(p)))
    return time.perf_counter() - t0


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


@lru_cache(maxsize=2)
def _tableau(method: str):
    """The method's arrays, read from scipy's public solver classes (one source of truth):
    ``A`` (n_ext, n_ext) with the weights B in row ``ns`` (FSAL: ``y_new`` is the stage at
    ``c = 1``) and DOP853's dense-output stages below it, ``C`` (n_ext,), the error weights ``E``
    (RK45) or ``E5`` and ``E3`` (DOP853), the dense-output matrix ``P`` (RK45, (7, 4)) or ``D``
    (DOP853, (4, 16)); then ``ns``, ``n_ext``, the error estimator's order, is-DOP853."""
    from scipy.integrate import DOP853, RK45

    if method == "dopri5":
        ns, n_ext = RK45.n_stages, RK45.n_stages + 1
        a = np.zeros((n_ext, n_ext))
        a[:ns, : RK45.A.shape[1]] = RK45.A
        a[ns, :ns] = RK45.B
        c = np.zeros(n_ext)
        c[:ns], c[ns] = RK45.C, 1.0
        e, e3, dense = RK45.E, np.zeros(n_ext), RK45.P
        order = RK45.error_estimator_order
    elif method == "dop853":
        ns = DOP853.n_stages
        n_ext = ns + 1 + DOP853.A_EXTRA.shape[0]
        a = np.zeros((n_ext, n_ext))
        a[:ns, :ns] = DOP853.A
        a[ns, :ns] = DOP853.B
        a[ns + 1 :, : DOP853.A_EXTRA.shape[1]] = DOP853.A_EXTRA
        c = np.zeros(n_ext)
        c[:ns], c[ns], c[ns + 1 :] = DOP853.C, 1.0, DOP853.C_EXTRA
        e, e3, dense = DOP853.E5, DOP853.E3, DOP853.D
        order = DOP853.error_estimator_order
    else:
        raise InputError(f"method must be 'dopri5' or 'dop853', got {method!r}")
    arrays = tuple(np.ascontiguousarray(x, dtype=np.float64) for x in (a, c, e, e3, dense))
    return (*arrays, int(ns), int(n_ext), float(order), method == "dop853")


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
    kinds = np.zeros(n, dtype=np.int64)
    values = np.zeros(n, dtype=np.float64)
    if isinstance(fobj, ManoeuvreForce):
        # where the manoeuvre is held still the force is one value: no kernel call per stage
        mc, mp = manoeuvre_constants(fobj)
        for i in range(n):
            if kernels.profile_held(edges[i], edges[i + 1], mp):
                mid = np.array([0.5 * (edges[i] + edges[i + 1])])
                values[i] = _manoeuvre_forces(mid, mc, mp)[0]  # compiled: the driver's own
            else:
                kinds[i] = _MANOEUVRE
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


_NO_MANOEUVRE = (np.zeros(kernels.N_CONSTANTS), np.ones(17))
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
    """``(driver arguments after the start state and the output times, the segments as (start,
    end) pairs [s])``, validated. Cached: they depend on these (hashable) inputs only, and the
    driver only reads them."""
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span must be finite with t_end > t_start, got {(t0, t1)!r}")
    if not (rtol > 0.0 and math.isfinite(rtol)):
        raise InputError(f"rtol must be a finite number > 0, got {rtol!r}")
    rtol = max(float(rtol), 100 * _EPS)  # scipy's floor
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
    a, c, e, e3, dense, ns, n_ext, order, is853 = _tableau(method)
    driver_args = (
        edges,
        kinds,
        values,
        mc,
        mp,
        psi3_constants(form),
        a,
        c,
        e,
        e3,
        dense,
        ns,
        n_ext,
        order,
        is853,
        rtol,
        atol_arr,
        fs,
        float(max_step),
        float(min_step),
        checks,
        int(max_steps),
    )
    edge_list = edges.tolist()
    return driver_args, tuple(zip(edge_list[:-1], edge_list[1:], strict=True))


def _raise(status, label, t, y, info, seg, edges, checks, p, max_steps, min_step):
    where = f"at t = {t:.9g} s (segment [{edges[seg]:.6g}, {edges[seg + 1]:.6g}] s)"
    state = f"psi3 = {y[0]:.9g} rad, psi3' = {y[1]:.9g} rad/s"
    head = f"{label} on formulation 'psi3'"
    if status == STEP_COLLAPSE:
        raise IntegrationError(
            f"{head}: step size collapsed to {info:.3g} s (10 ulp of t) {where}, {state}: "
            f"the error control rejects every step (a stage outside the assembly range?)"
        )
    if status == MIN_STEP:
        raise IntegrationError(
            f"{head}: step size collapsed to {info:.3g} s < min_step = {min_step:g} s {where}"
        )
    if status == NONFINITE_STATE:
        raise IntegrationError(f"{head}: non-finite state {where}: {state}")
    if status == NONFINITE_FORCE:
        raise IntegrationError(
            f"{head}: piston force is not finite at t = {t!r} s: {info!r} N (the manoeuvre's "
            f"loop cannot close there?)"
        )
    if status == SINGULAR:
        raise SingularConfigurationError(
            f"psi3 formulation ({label}): at psi3 = {y[0]:.9g} rad (t = {t:.9g} s) cos psi1 = "
            f"{info:.3g} < min_cos_psi1 = {checks[0]:g}: the link is nearly horizontal and psi3 "
            f"cannot stay the independent coordinate"
        )
    if status == DEAD_CENTRE:
        raise SingularConfigurationError(
            f"{head}: step to t = {t:.9g} s crosses the dead centre: psi3 = {y[0]:.9g} rad >= "
            f"{checks[3]:.9g} rad (s_dead = {dead_centre(p):.9g} m)"
        )
    if status == STROKE_RANGE:
        raise StrokeRangeError(
            f"{head}: stroke s = {info:.9g} m at t = {t:.9g} s leaves the stroke range "
            f"[{checks[1]:.9g}, {checks[2]:.9g}] m ({state})"
        )
    if status == TOO_MANY_STEPS:
        raise IntegrationError(f"{head}: more than max_steps = {max_steps} steps {where}")
    raise IntegrationError(f"{head}: unknown status {status} {where}")  # pragma: no cover


def simulate_compiled(
    p: DRSParams,
    force,
    t_span: tuple[float, float],
    *,
    method: str = "dop853",
    rtol: float = 1e-8,
    atol=None,
    t_eval=None,
    first_step: float | None = None,
    max_step: float = math.inf,
    min_step: float = 1e-12,
    initial: tuple | None = None,
    y0=None,
    breakpoints: tuple[float, ...] = (),
    flap_limits: tuple[float, float] | None = None,
    min_cos_psi1: float = 0.05,
    stroke_range: tuple[float, float] | None = None,
    stop_at_dead_centre: bool = False,
    max_steps: int = 1_000_000,
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
    flap_limits, min_cos_psi1
        Options of :class:`~drs_model.forward.Psi3Minimal`.
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
    return run_formulation(
        form,
        force,
        t_span,
        method=method,
        rtol=rtol,
        atol=atol,
        t_eval=t_eval,
        first_step=first_step,
        max_step=max_step,
        min_step=min_step,
        initial=initial,
        y0=y0,
        breakpoints=breakpoints,
        stroke_range=stroke_range,
        stop_at_dead_centre=stop_at_dead_centre,
        max_steps=max_steps,
    )


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
    if not isinstance(form, Psi3Minimal):
        if isinstance(form, str):
            raise InputError("run_formulation takes a formulation instance")
        raise InputError(
            f"the compiled methods integrate formulation 'psi3' only, got {form.name!r}; use a "
            f"scipy method for the others"
        )
    if not _LOADED:
        load()
    fobj = as_force(force)
    t0, t1 = float(t_span[0]), float(t_span[1])
    if y0 is not None:
        y = np.asarray(y0, dtype=float).reshape(2)
        form.check(t0, y)
    elif initial is not None:
        y = form.initial_state(*initial)
    else:
        y = _rest_state(form.p)
    if atol is not None:  # hashable, for the plan's cache
        atol = tuple(np.broadcast_to(np.asarray(atol, dtype=np.float64), (2,)).tolist())
    plan, segments = _plan(
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
        te = np.ascontiguousarray(t_eval, dtype=np.float64)
        if te.ndim != 1 or np.any(te < t0) or np.any(te > t1):
            raise InputError(f"t_eval must be 1-D within t_span {t_span!r}")
        if np.any(np.diff(te) < 0.0):
            raise InputError("t_eval must be sorted in increasing order")
        has_eval = True
    status, nfev, nsteps, nrej, t_fail, b_fail, bd_fail, info, seg, block = _integrate(
        float(y[0]), float(y[1]), te, has_eval, *plan
    )
    label = label or f"{method}-numba"
    if status != OK:
        edges, min_step, checks, max_steps = plan[0], plan[-3], plan[-2], plan[-1]
        _raise(status, label, t_fail, (b_fail, bd_fail), info, seg, edges, checks, form.p,
               max_steps, min_step)  # fmt: skip
    n_out = block.shape[1]
    # views into the one block the driver returned (q, qd: (n, 3), Fortran order)
    return Solution(
        form.name,
        label,
        block[0],
        block[1:3],
        block[3:6].T,
        block[6:9].T,
        np.zeros(n_out),
        np.zeros(n_out),
        nfev,
        0,
        0,
        nsteps,
        list(segments),
        nrej,
    )
