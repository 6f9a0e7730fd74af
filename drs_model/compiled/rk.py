r"""The adaptive Runge-Kutta driver of formulation (a) (``psi3``), compiled whole by numba.

Plain Python in numba's subset: the helpers are registered as callable from compiled code
(:func:`~drs_model.compiled.jit.jitable`), and the driver :func:`integrate` is compiled once per
method with its tableau bound in (:mod:`.drivers`), with numba's on-disk cache;
``NUMBA_DISABLE_JIT=1`` runs it as Python. It has no physics of its own: a step (its stages, the
piston force, the error norm and the step-size control) is :mod:`.rk_step`'s; here are the
segments, the checks of an accepted step and the output, whose ``(q, qd)`` come from
:func:`~drs_model.kernels.psi3_configuration`.

An explicit embedded Runge-Kutta pair with scipy's step-size control: ``"dopri5"`` (Dormand-Prince
5(4), scipy's ``RK45``) or ``"dop853"`` (Hairer's DOP853, scipy's ``DOP853``), tableaux from
:mod:`.tableaux`. Error norm ``RMS(err / (atol + max(|y|, |y_new|) rtol))``, new step ``h *
min(10, max(0.2, 0.9 * norm^(-1/(p+1))))`` (no growth right after a rejection), scipy's
initial-step heuristic (Hairer, Norsett & Wanner II.4) at the start of every segment. Output by
dense output at the requested times (scipy's continuous extensions: the quartic of RK45, the
degree-7 interpolant of DOP853, which costs 3 extra evaluations on each step that holds an output
time), or at every accepted step if no times are given.

A failure comes back as a status code (scipy's ``(success, message)`` pattern), which
:mod:`.simulate` raises as a typed error.
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import psi3_acceleration, psi3_configuration
from .jit import jitable, jitable_inlined
from .rk_step import (
    CONSTANT,
    DEAD_CENTRE,
    MANOEUVRE,
    MIN_STEP,
    NONFINITE_FORCE,
    NONFINITE_STATE,
    OK,
    SINGULAR,
    STEP_COLLAPSE,
    STROKE_RANGE,
    TOO_MANY_STEPS,
    initial_step,
    segment_force,
    stages,
    try_step,
)

#: The driver's status codes and force kinds, defined with the step (:mod:`.rk_step`).
__all__ = [
    "CONSTANT",
    "DEAD_CENTRE",
    "MANOEUVRE",
    "MIN_STEP",
    "NONFINITE_FORCE",
    "NONFINITE_STATE",
    "OK",
    "SINGULAR",
    "STEP_COLLAPSE",
    "STROKE_RANGE",
    "TOO_MANY_STEPS",
    "integrate",
]


@jitable
def _output_block(t_out, y_out, n, kc):
    """The run's output as one exact-size block ``(11, n)``: rows ``t``, ``[psi3, psi3']``,
    ``q`` and ``qd`` (``(s, psi1, psi3)`` and their rates, closed form) of the first ``n``
    outputs, and two rows of zeros (the constraint residuals of minimal coordinates). One array
    crosses back to Python (each returned array costs a boxing of its own, and a view of it less
    than a new array)."""
    out = np.empty((11, n))
    for i in range(n):
        b, bd = y_out[0, i], y_out[1, i]
        s, psi1, u0, u1 = psi3_configuration(b, kc)
        out[0, i], out[1, i], out[2, i] = t_out[i], b, bd
        out[3, i], out[4, i], out[5, i] = s, psi1, b
        out[6, i], out[7, i], out[8, i] = u0 * bd, u1 * bd, bd
        out[9, i] = out[10, i] = 0.0
    return out


@jitable
def _grow(t_out, y_out):
    n = t_out.shape[0]
    t_new = np.empty(2 * n)
    y_new = np.empty((2, 2 * n))
    for i in range(n):  # element loops: a slice assignment compiles numba's string formatting
        t_new[i] = t_out[i]
        y_new[0, i] = y_out[0, i]
        y_new[1, i] = y_out[1, i]
    return t_new, y_new


@jitable
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


@jitable_inlined
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


@jitable_inlined
def _store_output(K, step, t_eval, has_eval, output, tableau, force, kc):
    """The accepted step ``step = (t, h, y0, y1, t_new, yn0, yn1)`` into the outputs
    ``(t_out, y_out, n_out, ie)``: dense at the requested times ``t_eval`` (``ie`` the next one),
    or the step itself. Returns ``(t_out, y_out, n_out, ie, nfev)`` (the arrays grown if needed;
    DOP853's dense output costs three more stages)."""
    t, h, y0, y1, t_new, yn0, yn1 = step
    t_out, y_out, n_out, ie = output
    tab_a, tab_c, _, _, tab_dense, ns, n_ext, _, is853 = tableau
    nfev = 0
    if has_eval:
        n_eval = t_eval.shape[0]
        if is853 and ie < n_eval and t_eval[ie] < t_new:  # three more stages
            stages(K, ns + 1, n_ext, t, h, y0, y1, tab_a, tab_c, force, kc)
            nfev += n_ext - ns - 1
        while ie < n_eval and t_eval[ie] <= t_new:
            if t_eval[ie] == t_new:
                y_out[0, ie], y_out[1, ie] = yn0, yn1
            else:
                x = (t_eval[ie] - t) / h
                y_out[0, ie], y_out[1, ie] = _dense(
                    K, ns, n_ext, x, h, y0, y1, yn0, yn1, tab_dense, is853
                )
            ie += 1
        return t_out, y_out, ie, ie, nfev
    if n_out == t_out.shape[0]:
        t_out, y_out = _grow(t_out, y_out)
    t_out[n_out] = t_new
    y_out[0, n_out], y_out[1, n_out] = yn0, yn1
    return t_out, y_out, n_out + 1, ie, nfev


@jitable
def _first_output(t_eval, has_eval, t0, y_start0, y_start1):
    """``(t_out, y_out, n_out)``: the output arrays, for the requested times ``t_eval`` or, to
    grow, for every step from the start state."""
    if has_eval:
        return t_eval.copy(), np.empty((2, t_eval.shape[0])), 0
    t_out = np.empty(256)
    y_out = np.empty((2, 256))
    t_out[0] = t0
    y_out[0, 0] = y_start0
    y_out[1, 0] = y_start1
    return t_out, y_out, 1


@jitable
def _start_segment(K, t, b, y0, y1, force, kc, control, err_order, t_fail):
    """A segment's start at ``t``: its force, the first stage in ``K`` and the first step's size.
    Returns ``(status, info, t_fail, h_abs, nfev)`` (``t_fail`` as given unless it fails)."""
    rtol, atol, first_step, max_step, _, _, _ = control
    kind, value, mc, mp = force
    fo = segment_force(t, kind, value, mc, mp)
    if not math.isfinite(fo):
        return NONFINITE_FORCE, fo, t, 0.0, 1
    K[0, 0] = y1
    K[0, 1] = psi3_acceleration(y0, y1, fo, kc)
    if first_step > 0.0:
        return OK, 0.0, t_fail, min(first_step, b - t), 1
    h_abs, fo = initial_step(t, b, y0, y1, K[0, 1], force, kc, rtol, atol, err_order, max_step)
    if not math.isfinite(fo):
        return NONFINITE_FORCE, fo, t + h_abs, h_abs, 2
    return OK, 0.0, t_fail, h_abs, 2


@jitable_inlined
def integrate(y_start0, y_start1, t_eval, has_eval, segments, tableau, control):
    """The adaptive RK driver from ``(psi3, psi3')`` = ``(y_start0, y_start1)`` over the
    segments ``(edges, kinds, values, mc, mp, kc)`` (see the module docstring), for the
    ``tableau`` of :func:`~.tableaux.tableau`, under ``control = (rtol, atol, first_step,
    max_step, min_step, checks, max_steps)``; compiled once per method with its tableau bound in
    (:mod:`.drivers`), inlined there.

    ``tab_a`` (n_ext, n_ext) holds the stages' coefficients with the weights B in row ``ns``
    (``y_new`` is "stage" ``ns`` at ``c = 1``, FSAL) and the dense-output stages of DOP853 in
    the rows after it. Returns ``(status, nfev, nsteps, nrejected, t_fail, psi3_fail,
    psi3'_fail, info, segment, block)``: ``info`` is the offending step size, force, cos psi1,
    psi3 or stroke of a failure, ``block`` the :func:`_output_block` of the outputs (one call
    from Python, one array back).
    """
    edges, kinds, values, mc, mp, kc = segments
    ns, n_ext, err_order = tableau[5], tableau[6], tableau[7]
    rtol, atol, _, max_step, min_step, checks, max_steps = control
    expo = -1.0 / (err_order + 1.0)
    K = np.zeros((n_ext, 3))  # psi3', psi3'', piston force per stage
    b_fail = bd_fail = 0.0
    t_out, y_out, n_out = _first_output(t_eval, has_eval, edges[0], y_start0, y_start1)
    ie = nfev = nsteps = nrej = 0
    status = OK
    info = 0.0
    y0, y1 = y_start0, y_start1
    t = t_fail = edges[0]
    n_seg = edges.shape[0] - 1
    seg = 0
    for seg in range(n_seg):
        b = edges[seg + 1]
        force = (kinds[seg], values[seg], mc, mp)
        t = edges[seg]
        status, info, t_fail, h_abs, n_f = _start_segment(
            K, t, b, y0, y1, force, kc, control, err_order, t_fail
        )
        nfev += n_f
        while status == OK and t < b:
            status, info, t_fail, t_new, h, h_abs, yn0, yn1, s_new, cos1, n_f, n_r = try_step(
                K, t, b, h_abs, y0, y1, tableau, force, kc, rtol, atol, max_step, expo, t_fail
            )
            nfev += n_f
            nrej += n_r
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
            step = (t, h, y0, y1, t_new, yn0, yn1)
            t_out, y_out, n_out, ie, n_f = _store_output(
                K, step, t_eval, has_eval, (t_out, y_out, n_out, ie), tableau, force, kc
            )
            nfev += n_f
            t, y0, y1 = t_new, yn0, yn1
            K[0, 0] = K[ns, 0]  # FSAL
            K[0, 1] = K[ns, 1]
        if status != OK:
            break
    block = _output_block(t_out, y_out, n_out, kc)
    return status, nfev, nsteps, nrej, t_fail, b_fail, bd_fail, info, seg, block
