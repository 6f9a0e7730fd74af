r"""Fixed steps of the hydraulic rung: explicit RK4 and two linearly implicit (Rosenbrock) methods,
each one plain function of floats and small numpy arrays (numba compiles them as they are).

The rung is stiff: the oil column rings at ``w_h = sqrt(beta A^2 (1/V_A + 1/V_B) / m_eff)``
(several thousand rad/s with the defaults, more with stiffer oil or smaller chambers). An
explicit method is stable only while ``h w`` stays inside its stability region: RK4 reaches
2.83 on the imaginary axis and 2.79 on the negative real one, so a step is refused
(:class:`~drs_model.errors.StiffStepError`) when ``h`` times
:func:`~drs_model.fidelity.hydraulic_kernels.stiffest_rate` exceeds :data:`RK4_LIMIT`.

The Rosenbrock methods solve with ``W = I - gamma h J`` (``J``: the Jacobian of the right-hand
side by forward differences) and are L-stable, so any step is stable; the step then sets only the
accuracy:

* ``"linearly-implicit-euler"``: ``W k = f(y0)``, ``y1 = y0 + h k`` (order 1, ``gamma = 1``);
* ``"ros2"`` (Verwer et al. 1999, SIAM J. Sci. Comput. 20:1456): ``gamma = 1 + 1/sqrt(2)``,
  ``W k1 = f(y0)``, ``W k2 = f(y0 + h k1) - 2 k1``, ``y1 = y0 + h (3 k1 + k2) / 2`` (order 2).

The RK4 step is :func:`drs_model.explicit_steps.rk4_step` on :func:`stage_rate`. Each step
function takes the state ``y`` (5 floats, :mod:`~drs_model.fidelity.hydraulic_kernels`),
the servo references at the start, middle and end of the step (``s0, v0, sm, vm, s1, v1``), the
force reference, the supply pressure at the start and end, the spool-held flag, the step ``h``
and the constants, and returns the new state as a float64 array of 5.
"""

from __future__ import annotations

import math

import numpy as np

from .. import explicit_steps
from ..errors import InputError, StiffStepError, TooStiffError
from . import hydraulic_kernels
from .hydraulic_kernels import hydraulic_derivatives

#: Largest ``h * stiffest_rate`` an RK4 step may take (its stability interval is 2.79 on the
#: negative real axis and 2.83 on the imaginary one; the margin covers the estimate's error).
RK4_LIMIT = 2.5

#: Relative perturbation of the forward-difference Jacobian.
JACOBIAN_EPS = 1e-7


#: Relative slack of :func:`substep_count`: a step's length is ``t1 - t0`` of two clock readings,
#: which rounds up to ~1e-12 of a 10 us step late in a run (a 1e-6 s sub-step of a 1e-5 s step
#: is then 10.000000000002 of them).
COUNT_SLACK = 1e-9


def substep_count(needed: float) -> float:
    """The whole number of sub-steps that covers ``needed`` (a ratio of step lengths, rounded
    in the clock's arithmetic) to within :data:`COUNT_SLACK`, at least 1; NaN or inf as given
    (refused by the cap's comparison)."""
    if not math.isfinite(needed):
        return needed
    return max(1, math.ceil(needed * (1.0 - COUNT_SLACK)))


#: The shortest sub-step [s] the rung takes by default at a ``stability_fraction`` of 1
#: (``max_substeps = ceil(dt / MIN_SUBSTEP)``, 1000 at 1 kHz): a state whose stability needs
#: shorter ones (a stiffest rate above ``RK4_LIMIT / MIN_SUBSTEP`` = 2.5e6 1/s, 170 times the oil
#: column's at the closed stop) is refused with :class:`~drs_model.errors.TooStiffError`, so that
#: no state makes a step unbounded.
MIN_SUBSTEP = 1e-6

#: A fault (or a start) is refused when its stiffest probed state needs more than
#: ``1 / STIFFNESS_MARGIN`` of the cap: the state's own swings (a chamber pressure near supply or
#: return stiffens the valve's edges 5-fold) then stay within it.
STIFFNESS_MARGIN = 2.0


#: Default longest sub-step [s] of the implicit methods: set by accuracy alone (they are stable
#: at any step); at 0.1 ms ``ros2`` keeps the stroke within 3e-5 m of the tight reference on the
#: open-hold-close scene (docs/fidelity.md).
DEFAULT_IMPLICIT_SUBSTEP = 1e-4

#: RK4's own sub-step is set by the stiffest rate at its start; a state can stiffen within it (a
#: chamber filling towards the supply or draining towards the return, where a metering edge's
#: slope grows as its drop falls; the air of a chamber whose cavity closed, compressed from the
#: vapour pressure). The rung checks the rate at each sub-step's end and, above what the
#: sub-step's length allows, takes that sub-step again, with the rest of the step, at this
#: multiple of the rate met (so that a state that goes on stiffening is not taken again at every
#: sub-step) ...
RETAKE_HEADROOM = 1.25
#: ... and the next step starts from at least this fraction of the rate a step was taken at.
RATE_MEMORY = 0.9


def checked_options(method, substep, stability_fraction, max_substeps, locate_events):
    """Refuse (:class:`~drs_model.errors.InputError`, naming the value and its range) a
    sub-stepping option of :class:`~drs_model.fidelity.hydraulic.HydraulicRung` out of range;
    returns ``locate_events`` as the rung keeps it (``"contacts"``, ``True`` or ``False``)."""
    if method not in STEP_METHODS:
        raise InputError(f"method must be one of {sorted(STEP_METHODS)}, got {method!r}")
    if substep is not None and not (math.isfinite(substep) and substep > 0.0):
        raise InputError(f"substep must be a finite number > 0 s, got {substep!r}")
    if not (math.isfinite(stability_fraction) and 0.0 < stability_fraction <= 1.0):
        raise InputError(f"stability_fraction must be in (0, 1], got {stability_fraction!r}")
    if max_substeps is not None and (
        isinstance(max_substeps, bool) or not isinstance(max_substeps, int) or max_substeps < 1
    ):
        raise InputError(f"max_substeps must be an int >= 1 or None, got {max_substeps!r}")
    if locate_events not in (True, False, "contacts"):
        raise InputError(f"locate_events must be True, False or 'contacts', got {locate_events!r}")
    return "contacts" if locate_events == "contacts" else bool(locate_events)


def substeps_within_margin(rate, dt, fraction, substep, cap, method) -> int:
    """The sub-steps of ``method`` a physics step of ``dt`` [s] needs at the stiffest rate
    ``rate`` [1/s] (the longest ``substep`` [s] given, else ``fraction`` of RK4's stable one).
    Raises :class:`~drs_model.errors.TooStiffError` when that is above
    ``cap / STIFFNESS_MARGIN``: the rung's check of a fault or a start."""
    longest = fraction * RK4_LIMIT / rate
    needed = dt / (longest if substep is None else substep)
    if not needed * STIFFNESS_MARGIN <= cap:
        raise TooStiffError(
            f"too stiff for a physics step of {dt:.3g} s: its stiffest rate {rate:.4g} "
            f"1/s needs {needed:.4g} {method} sub-steps per step, above "
            f"1/{STIFFNESS_MARGIN:g} of the cap of {cap} (max_substeps); "
            "a shorter physics step (a higher rate) needs fewer"
        )
    return max(1, math.ceil(needed * (1 - 1e-12)))


def substeps_needed(rate, t0, t1, used, cap, method, substep, fraction, guard, dt) -> int:
    """The sub-steps of ``method`` from ``t0`` to ``t1`` [s] at the stiffest rate ``rate``
    [1/s], ``used`` sub-steps of the physics step (``dt`` [s]) already taken: the longest
    ``substep`` [s] given, else ``fraction`` of RK4's stable one or
    :data:`DEFAULT_IMPLICIT_SUBSTEP`. Raises :class:`~drs_model.errors.StiffStepError` for an
    RK4 ``substep`` above the stability limit (with ``guard``) and
    :class:`~drs_model.errors.TooStiffError` for a count above what is left of the ``cap``."""
    if STEP_METHODS[method][1]:
        limit = RK4_LIMIT / rate
        if guard and substep is not None and substep > limit:
            raise StiffStepError(
                f"an explicit {method} sub-step of {substep:.3g} s exceeds the stability limit "
                f"{limit:.3g} s of the stiffest mode ({rate:.4g} rad/s, h * rate must stay <= "
                f"{RK4_LIMIT}): use substep <= {limit:.3g} s or an implicit method ('ros2', "
                "'linearly-implicit-euler')"
            )
        longest = fraction * limit if substep is None else substep
    else:
        longest = DEFAULT_IMPLICIT_SUBSTEP if substep is None else substep
    needed = (t1 - t0) / longest if longest > 0.0 else math.inf
    n = substep_count(needed)
    if not n <= cap - used:  # NaN too: a rate that is no number is refused
        raise TooStiffError(
            f"the hydraulic state at t = {t0:.6g} s is too stiff for a physics step of "
            f"{dt:.3g} s: its stiffest rate {rate:.4g} 1/s needs {needed:.4g} {method} "
            f"sub-steps, above the cap of {cap} (max_substeps)"
            + (f" less the {used} taken" if used else "")
        )
    return n


def state_rate(y, mode, s_ref, v_ref, f_ref, ps, held, c, h):
    """``dy/dt`` as a float64 array of 5 (:func:`~.hydraulic_kernels.hydraulic_derivatives`)."""
    out = np.empty(5)
    stage_rate(out, y, (s_ref, v_ref, ps), (mode, f_ref, held, c, h))
    return out


def stage_rate(out, y, refs, args):
    """``dy/dt`` into ``out`` in the form the steps of :mod:`drs_model.explicit_steps` call:
    ``refs = (s_ref, v_ref, ps)``, the references at the stage's time [m, m/s, Pa], and
    ``args = (mode, f_ref, held, c, h)``, what the step holds."""
    s_ref, v_ref, ps = refs
    mode, f_ref, held, c, h = args
    d = hydraulic_derivatives(
        y[0], y[1], y[2], y[3], y[4], mode, s_ref, v_ref, f_ref, ps, held, c, h
    )
    for i in range(5):
        out[i] = d[i]


def rk4_step(y, mode, s0, v0, sm, vm, s1, v1, f_ref, ps0, ps1, held, dt, c, h):
    """One classic Runge-Kutta step of ``dt`` [s] (explicit, order 4:
    :func:`drs_model.explicit_steps.rk4_step`), the supply pressure at the middle the mean of the
    ends'."""
    psm = 0.5 * (ps0 + ps1)
    start, middle, end = (s0, v0, ps0), (sm, vm, psm), (s1, v1, ps1)
    return explicit_steps.rk4_step(stage_rate, y, dt, start, middle, end, (mode, f_ref, held, c, h))


def jacobian(y, f0, mode, s_ref, v_ref, f_ref, ps, held, c, h):
    """``df/dy`` (5 x 5) by forward differences around ``y`` (``f0 = f(y)``)."""
    jac = np.empty((5, 5))
    for j in range(5):
        dy = JACOBIAN_EPS * max(abs(y[j]), 1.0 if j != 2 and j != 3 else 1e5)
        yp = y.copy()
        yp[j] += dy
        fp = state_rate(yp, mode, s_ref, v_ref, f_ref, ps, held, c, h)
        for i in range(5):
            jac[i, j] = (fp[i] - f0[i]) / dy
    return jac


def linearly_implicit_euler_step(y, mode, s0, v0, sm, vm, s1, v1, f_ref, ps0, ps1, held, dt, c, h):
    """One linearly implicit Euler step (Rosenbrock, order 1, L-stable); the references at the
    step's end, where the implicit step evaluates its stiff part."""
    f0 = state_rate(y, mode, s1, v1, f_ref, ps1, held, c, h)
    w = np.eye(5) - dt * jacobian(y, f0, mode, s1, v1, f_ref, ps1, held, c, h)
    return y + dt * np.linalg.solve(w, f0)


ROS2_GAMMA = 1.0 + 1.0 / np.sqrt(2.0)


def ros2_step(y, mode, s0, v0, sm, vm, s1, v1, f_ref, ps0, ps1, held, dt, c, h):
    """One ROS2 step (Rosenbrock, order 2, L-stable; module docstring)."""
    f0 = state_rate(y, mode, s0, v0, f_ref, ps0, held, c, h)
    w = np.eye(5) - ROS2_GAMMA * dt * jacobian(y, f0, mode, s0, v0, f_ref, ps0, held, c, h)
    k1 = np.linalg.solve(w, f0)
    f1 = state_rate(y + dt * k1, mode, s1, v1, f_ref, ps1, held, c, h)
    k2 = np.linalg.solve(w, f1 - 2.0 * k1)
    return y + dt * (1.5 * k1 + 0.5 * k2)


#: The fixed-step methods of the hydraulic rung: name -> (step function, explicit, order).
STEP_METHODS = {
    "rk4": (rk4_step, True, 4),
    "linearly-implicit-euler": (linearly_implicit_euler_step, False, 1),
    "ros2": (ros2_step, False, 2),
}

#: Every kernel of this module (registered with numba where a compiled step calls it).
KERNELS = (state_rate, stage_rate, rk4_step, jacobian, linearly_implicit_euler_step, ros2_step)
#: What a compiled kernel of the hydraulic rung may call: every function of its two modules
#: (:func:`drs_model.compiled.scalar.compiled_or_plain` registers them with numba).
CALLEES = hydraulic_kernels.KERNELS + KERNELS
