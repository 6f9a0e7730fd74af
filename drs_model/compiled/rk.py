r"""The adaptive Runge-Kutta driver of formulation (a) (``psi3``), compiled whole by numba.

Plain Python in numba's subset: the helpers are registered as callable from compiled code
(:func:`~drs_model.compiled.jit.jitable`), and the driver :func:`integrate` is compiled once per
method with its tableau bound in (:mod:`.drivers`), with numba's on-disk cache;
``NUMBA_DISABLE_JIT=1`` runs it as Python. It has no physics of its own: the stages call
:func:`drs_model.kernels.psi3_position` and :func:`~drs_model.kernels.psi3_acceleration_at`
(inlined, so that a step's checks read the stroke and ``cos psi1`` of ``y_new`` from its last
stage), the piston force is a constant per segment or
:func:`~drs_model.kernels.fused_manoeuvre_force`, and the output's ``(q, qd)`` come from
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

from ..kernels import (
    fused_manoeuvre_force,
    psi3_acceleration,
    psi3_acceleration_at,
    psi3_configuration,
    psi3_position,
)
from .jit import inlined, jitable


def _inlined(fn):
    """Register the helper ``fn`` inlined into its caller in numba's IR. The helpers of a step
    (its stages, error norm, checks and output) are: called, each passed its arrays as
    structures with their references counted, they cost ~0.2-0.3 us a step, a sixth of a run
    at rtol 1e-6 (``benchmarks/work_precision.py --floor``: 53.5 -> 44.8 us a run); the
    warm-up (``python -m drs_model.compiled``) compiles ~25 s longer."""
    return jitable(fn, "always")


# status codes of the driver
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

# the piston force of a segment
CONSTANT = 0  # one value over the segment
MANOEUVRE = 1  # the manoeuvre's inverse-dynamics force at each stage


#: :func:`~drs_model.kernels.fused_manoeuvre_force` with its callees inlined into it, as the
#: batch path builds it: through the registered kernels' calls a stage's force cost ~40 ns more.
_MANOEUVRE_FORCE = inlined(fused_manoeuvre_force)


@jitable
def _force(t, kind, value, mc, mp):
    """Piston force [N] of a segment: ``value`` (constant) or the manoeuvre's at t."""
    if kind == CONSTANT:
        return value
    return _MANOEUVRE_FORCE(t, mc, mp)


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
def _rms_norm(e0, e1):
    return math.sqrt(0.5 * (e0 * e0 + e1 * e1))


@_inlined
def _combination(K, tab_a, row, n):
    """``sum_j tab_a[row, j] K[j]`` over the first ``n`` stages: both components."""
    s0 = 0.0
    s1 = 0.0
    for j in range(n):
        s0 += K[j, 0] * tab_a[row, j]
        s1 += K[j, 1] * tab_a[row, j]
    return s0, s1


@_inlined
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


@_inlined
def _error_norm(K, ns, h, tab_e, tab_e3, sc0, sc1, is853):
    """scipy's error norms: RK45 ``RMS(h K^T E / scale)``; DOP853 the 5th-order estimate
    corrected by the 3rd-order one."""
    e0 = 0.0
    e1 = 0.0
    for j in range(ns + 1):
        e0 += K[j, 0] * tab_e[j]
        e1 += K[j, 1] * tab_e[j]
    if not is853:
        return _rms_norm(e0 * h / sc0, e1 * h / sc1)
    f0 = 0.0
    f1 = 0.0
    for j in range(ns + 1):
        f0 += K[j, 0] * tab_e3[j]
        f1 += K[j, 1] * tab_e3[j]
    e0 /= sc0
    e1 /= sc1
    f0 /= sc0
    f1 /= sc1
    n5 = e0 * e0 + e1 * e1
    n3 = f0 * f0 + f1 * f1
    if n5 == 0.0 and n3 == 0.0:
        return 0.0
    return abs(h) * n5 / math.sqrt((n5 + 0.01 * n3) * 2.0)


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


@jitable
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


@_inlined
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


@_inlined
def _try_step(K, t, b, h_abs, y0, y1, tab_a, tab_c, tab_e, tab_e3, ns, kind, value, mc, mp, kc,
              rtol, atol, max_step, is853, expo, t_fail):  # fmt: skip
    """One step from ``(t, y0, y1)`` towards ``b``: try, reject and shrink until the error norm
    is below 1. Returns ``(status, info, t_fail, t_new, h, h_abs, yn0, yn1, s_new, cos1, nfev,
    nrejected)``, ``h_abs`` the next step's size; the stages are left in ``K``."""
    nfev = 0
    nrej = 0
    status = OK
    info = 0.0
    t_new = h = yn0 = yn1 = s_new = cos1 = 0.0
    ulp_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    h_abs = min(max(h_abs, ulp_step), max_step)
    rejected = False
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
    return status, info, t_fail, t_new, h, h_abs, yn0, yn1, s_new, cos1, nfev, nrej


@_inlined
def _store_output(K, ns, n_ext, t, h, y0, y1, t_new, yn0, yn1, t_eval, has_eval, ie, t_out,
                  y_out, n_out, tab_a, tab_c, tab_dense, is853, kind, value, mc, mp,
                  kc):  # fmt: skip
    """The accepted step ``t -> t_new`` into the outputs: dense at the requested times
    ``t_eval`` (``ie`` the next one), or the step itself. Returns ``(t_out, y_out, n_out, ie,
    nfev)`` (the arrays grown if needed; DOP853's dense output costs three more stages)."""
    nfev = 0
    if has_eval:
        n_eval = t_eval.shape[0]
        if is853 and ie < n_eval and t_eval[ie] < t_new:  # three more stages
            _stages(K, ns + 1, n_ext, t, h, y0, y1, tab_a, tab_c, kind, value, mc, mp, kc)
            nfev += n_ext - ns - 1
        while ie < n_eval and t_eval[ie] <= t_new:
            if t_eval[ie] == t_new:
                y_out[0, ie], y_out[1, ie] = yn0, yn1
            else:
                y_out[0, ie], y_out[1, ie] = _dense(
                    K, ns, n_ext, (t_eval[ie] - t) / h, h, y0, y1, yn0, yn1, tab_dense, is853
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
def _start_segment(K, t, b, y0, y1, kind, value, mc, mp, kc, rtol, atol, err_order, first_step,
                   max_step, t_fail):  # fmt: skip
    """A segment's start at ``t``: its force, the first stage in ``K`` and the first step's size.
    Returns ``(status, info, t_fail, h_abs, nfev)`` (``t_fail`` as given unless it fails)."""
    fo = _force(t, kind, value, mc, mp)
    if not math.isfinite(fo):
        return NONFINITE_FORCE, fo, t, 0.0, 1
    K[0, 0] = y1
    K[0, 1] = psi3_acceleration(y0, y1, fo, kc)
    if first_step > 0.0:
        return OK, 0.0, t_fail, min(first_step, b - t), 1
    h_abs, fo = _initial_step(
        t, b, y0, y1, K[0, 1], kind, value, mc, mp, kc, rtol, atol, err_order, max_step
    )
    if not math.isfinite(fo):
        return NONFINITE_FORCE, fo, t + h_abs, h_abs, 2
    return OK, 0.0, t_fail, h_abs, 2


@_inlined
def integrate(y_start0, y_start1, t_eval, has_eval, edges, kinds, values, mc, mp, kc, tab_a,
              tab_c, tab_e, tab_e3, tab_dense, ns, n_ext, err_order, is853, rtol, atol,
              first_step, max_step, min_step, checks, max_steps):  # fmt: skip
    """The adaptive RK driver over the segments ``edges`` (see the module docstring), for the
    tableau ``tab_a ... is853`` (:func:`~.tableaux.tableau`); compiled once per method with it
    bound in (:mod:`.drivers`), inlined there.

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
    t_out, y_out, n_out = _first_output(t_eval, has_eval, edges[0], y_start0, y_start1)
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
        status, info, t_fail, h_abs, n_f = _start_segment(
            K, t, b, y0, y1, kind, value, mc, mp, kc, rtol, atol, err_order, first_step, max_step,
            t_fail,
        )
        nfev += n_f
        if status != OK:
            break
        while t < b:
            status, info, t_fail, t_new, h, h_abs, yn0, yn1, s_new, cos1, n_f, n_r = _try_step(
                K, t, b, h_abs, y0, y1, tab_a, tab_c, tab_e, tab_e3, ns, kind, value, mc, mp,
                kc, rtol, atol, max_step, is853, expo, t_fail,
            )  # fmt: skip
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
            # ---- output: dense at the requested times, or the step itself
            t_out, y_out, n_out, ie, n_f = _store_output(
                K, ns, n_ext, t, h, y0, y1, t_new, yn0, yn1, t_eval, has_eval, ie, t_out, y_out,
                n_out, tab_a, tab_c, tab_dense, is853, kind, value, mc, mp, kc,
            )  # fmt: skip
            nfev += n_f
            t = t_new
            y0 = yn0
            y1 = yn1
            K[0, 0] = K[ns, 0]  # FSAL
            K[0, 1] = K[ns, 1]
        if status != OK:
            break
    block = _output_block(t_out, y_out, n_out, kc)
    return status, nfev, nsteps, nrej, t_fail, b_fail, bd_fail, info, seg, block
