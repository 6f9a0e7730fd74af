r"""One step of the adaptive Runge-Kutta driver (:mod:`.rk`): the stages of an embedded pair,
scipy's error norm, step-size control and initial step, and the piston force of a stage.

Plain Python in numba's subset, registered as callable from compiled code
(:func:`~drs_model.compiled.jit.jitable`, the step's helpers inlined into the driver). The stages
call :func:`drs_model.kernels.psi3_position` and :func:`~drs_model.kernels.psi3_acceleration_at`
(so that a step's checks read the stroke and ``cos psi1`` of ``y_new`` from its last stage); the
piston force is a constant per segment or :func:`~drs_model.kernels.fused_manoeuvre_force`.

The arguments come grouped as the driver holds them: ``tableau`` is
``(tab_a, tab_c, tab_e, tab_e3, tab_dense, ns, n_ext, err_order, is853)``
(:func:`~.tableaux.tableau`), ``force`` a segment's piston force ``(kind, value, mc, mp)``
(:data:`CONSTANT` ``value`` [N] or the :data:`MANOEUVRE` of the coefficients ``mc``, ``mp``),
``kc`` the formulation's constants (:func:`~.simulate.psi3_constants`).
"""

from __future__ import annotations

import math

import numpy as np

from ..kernels import (
    fused_manoeuvre_force,
    psi3_acceleration,
    psi3_acceleration_at,
    psi3_position,
)
from .jit import inlined, jitable, jitable_inlined

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
def segment_force(t, kind, value, mc, mp):
    """Piston force [N] of a segment: ``value`` (constant) or the manoeuvre's at t."""
    if kind == CONSTANT:
        return value
    return _MANOEUVRE_FORCE(t, mc, mp)


@jitable
def rms_norm(e0, e1):
    """Root mean square of the two components."""
    return math.sqrt(0.5 * (e0 * e0 + e1 * e1))


@jitable_inlined
def combination(K, tab_a, row, n):
    """``sum_j tab_a[row, j] K[j]`` over the first ``n`` stages: both components."""
    s0 = 0.0
    s1 = 0.0
    for j in range(n):
        s0 += K[j, 0] * tab_a[row, j]
        s1 += K[j, 1] * tab_a[row, j]
    return s0, s1


@jitable_inlined
def stages(K, s_from, s_to, t, h, y0, y1, tab_a, tab_c, force, kc):
    """Stages ``s_from <= s < s_to`` (``s_from >= 1``) of an explicit RK step into the rows of
    ``K`` (columns: psi3', psi3'', piston force). The forces depend on the stage times only: all
    are evaluated first, free of the stages' chain of dependencies; a stage at the same time as
    the one before (``c = 1`` twice: the last stage and y_new) reuses its force. Returns
    ``(-1, 0.0, s, cos psi1)`` with the stroke [m] and ``cos psi1`` of the last stage (that of
    ``y_new`` for the stages of a step: its checks need no position of their own), or ``(the
    stage whose piston force is not finite, that force, NaN, NaN)``."""
    kind, value, mc, mp = force
    for s in range(s_from, s_to):
        if tab_c[s] == tab_c[s - 1]:
            K[s, 2] = K[s - 1, 2]
        else:
            K[s, 2] = segment_force(t + tab_c[s] * h, kind, value, mc, mp)
    for s in range(s_from, s_to):
        if not math.isfinite(K[s, 2]):
            return s, K[s, 2], math.nan, math.nan
    stroke = cos1 = math.nan
    for s in range(s_from, s_to):
        s0, s1 = combination(K, tab_a, s, s)
        ys0 = y0 + s0 * h
        ys1 = y1 + s1 * h
        K[s, 0] = ys1
        # psi3_acceleration in its two halves (NaN where the loop cannot close, as there)
        sb, cb, stroke, sa, cos1, _ = psi3_position(ys0, kc)
        K[s, 1] = psi3_acceleration_at(ys0, ys1, K[s, 2], sb, cb, sa, cos1, kc)
    return -1, 0.0, stroke, cos1


@jitable_inlined
def error_norm(K, ns, h, tab_e, tab_e3, sc0, sc1, is853):
    """scipy's error norms: RK45 ``RMS(h K^T E / scale)``; DOP853 the 5th-order estimate
    corrected by the 3rd-order one."""
    e0 = 0.0
    e1 = 0.0
    for j in range(ns + 1):
        e0 += K[j, 0] * tab_e[j]
        e1 += K[j, 1] * tab_e[j]
    if not is853:
        return rms_norm(e0 * h / sc0, e1 * h / sc1)
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
def initial_step(t, b, y0, y1, f1, force, kc, rtol, atol, err_order, max_step):
    """scipy's ``select_initial_step`` (Hairer, Norsett & Wanner II.4). Returns ``(h, force at
    the probe)``; the force is NaN-checked by the caller."""
    kind, value, mc, mp = force
    f0 = y1
    sc0 = atol[0] + abs(y0) * rtol
    sc1 = atol[1] + abs(y1) * rtol
    d0 = rms_norm(y0 / sc0, y1 / sc1)
    d1 = rms_norm(f0 / sc0, f1 / sc1)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, b - t)
    z0 = y0 + h0 * f0
    z1 = y1 + h0 * f1
    fo = segment_force(t + h0, kind, value, mc, mp)
    if not math.isfinite(fo):
        return h0, fo
    g1 = psi3_acceleration(z0, z1, fo, kc)
    d2 = rms_norm((z1 - f0) / sc0, (g1 - f1) / sc1) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    elif d2 != d2:
        h1 = h0  # a NaN trial stage (no assembly): the error control shrinks the step
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (err_order + 1.0))
    return min(100.0 * h0, h1, b - t, max_step), fo


@jitable_inlined
def step_factor(err, expo, rejected):
    """scipy's factor of the next step's size after a step of error norm ``err`` (< 1: accepted,
    no growth right after a rejection; >= 1 or NaN: rejected, NaN being a stage outside the
    assembly range)."""
    if err < 1.0:
        factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err**expo)
        if rejected:
            factor = min(1.0, factor)
        return factor
    if err != err:
        return MIN_FACTOR
    return max(MIN_FACTOR, SAFETY * err**expo)


@jitable_inlined
def try_step(K, t, b, h_abs, y0, y1, tableau, force, kc, rtol, atol, max_step, expo, t_fail):
    """One step from ``(t, y0, y1)`` towards ``b``: try, reject and shrink until the error norm
    is below 1. Returns ``(status, info, t_fail, t_new, h, h_abs, yn0, yn1, s_new, cos1, nfev,
    nrejected)``, ``h_abs`` the next step's size; the stages are left in ``K``."""
    tab_a, tab_c, tab_e, tab_e3, _, ns, _, _, is853 = tableau
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
        bad, fo, s_new, cos1 = stages(K, 1, ns + 1, t, h, y0, y1, tab_a, tab_c, force, kc)
        if bad >= 0:
            nfev += bad
            status, info, t_fail = NONFINITE_FORCE, fo, t + tab_c[bad] * h
            break
        nfev += ns
        s0, s1 = combination(K, tab_a, ns, ns)
        yn0 = y0 + s0 * h
        yn1 = y1 + s1 * h
        sc0 = atol[0] + max(abs(y0), abs(yn0)) * rtol
        sc1 = atol[1] + max(abs(y1), abs(yn1)) * rtol
        err = error_norm(K, ns, h, tab_e, tab_e3, sc0, sc1, is853)
        h_abs *= step_factor(err, expo, rejected)
        if err < 1.0:
            break
        rejected = True
        nrej += 1
    return status, info, t_fail, t_new, h, h_abs, yn0, yn1, s_new, cos1, nfev, nrej
