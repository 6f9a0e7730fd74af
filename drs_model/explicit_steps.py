r"""One step of each explicit fixed-step method, written once for any right-hand side.

Every explicit fixed step of drs runs here: the real-time integrator of formulation (a)
(compiled: the rigid rung's step under a force), the integrator's numpy formulations (plain
Python) and the hydraulic rung's RK4 (compiled). Each step is a plain function of

* ``rate(out, y, at, args)``: writes ``dy/dt`` at ``y`` into the float64 array ``out``; ``at`` is
  what the right-hand side takes at a stage's time (the piston force, the time itself, or the
  servo references) and ``args`` what it holds over the step (constants);
* ``y``: the state, a float64 array or a tuple of floats; ``h``: the step [s];
* ``start``, ``middle``, ``end``: the rate's ``at`` at ``t``, ``t + h/2`` and ``t + h``;

and returns the state after the step, a new float64 array. Under numba the step is compiled
with the compiled function that calls it (:mod:`drs_model.compiled.jit` registers these
functions), once per right-hand side, ``rate`` inlined into it (a plain function registered by
the caller: :func:`~drs_model.compiled.scalar.compiled_or_plain`'s ``inlined``): no source is
rewritten or generated, and with ``NUMBA_DISABLE_JIT=1`` or without numba a debugger steps
through it as the Python it is. A compiled caller names its method's step (a function given
from Python to a compiled function costs tens of microseconds to type at every call).

Why loops over the components into one work array, not array expressions (``y + h * k1``): a
compiled step of two states called from Python costs ~1 us, and every array numba allocates
adds ~0.05 us; with array expressions (nine arrays an RK4 step) the real-time step cost ~40 %
more than a step written by hand for two floats, with one work array ~5 %.

The methods (``h = dt``; the classic Butcher tableaux):

* ``"euler"``: explicit Euler, order 1: ``y1 = y0 + h f(y0)``;
* ``"semi-implicit-euler"``: symplectic Euler, order 1, for a state ``[x, v]`` of two halves
  with ``x' = v``: the rate first, ``v1 = v0 + h a(x0, v0)``, then ``x1 = x0 + h v1``;
* ``"rk2"``: explicit midpoint rule, order 2;
* ``"rk4"``: the classic Runge-Kutta method, order 4.

Each component is computed in one fixed order of floating-point operations, the order of the
expressions below (``0.5 * h * k`` is ``(0.5 h) k``; RK4's weights sum as
``((k1 + 2 k2) + 2 k3) + k4``), the order numpy's array expressions of the same formulas give; a
second-order system ``[x, v]`` with ``x' = v`` gets the operations of a step written for it by
hand with the position's stages taken as the rate's (RK4's ``k_x = v``).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

__all__ = [
    "FIXED_STEP_METHODS",
    "STEPS",
    "euler_step",
    "rk2_step",
    "rk4_step",
    "semi_implicit_euler_step",
]


def euler_step(rate, y, h, start, middle, end, args):
    """Explicit Euler (order 1)."""
    n = len(y)
    work = np.empty((2, n))
    k1, y_new = work[0], work[1]
    rate(k1, y, start, args)
    for i in range(n):
        y_new[i] = y[i] + h * k1[i]
    return y_new


def semi_implicit_euler_step(rate, y, h, start, middle, end, args):
    """Semi-implicit (symplectic) Euler (order 1) for ``y = [x, v]``, ``x' = v``: the rate half
    first, then the position half with the new rate."""
    n = len(y) // 2
    work = np.empty((2, len(y)))
    k1, y_new = work[0], work[1]
    rate(k1, y, start, args)
    for i in range(n, 2 * n):
        y_new[i] = y[i] + h * k1[i]
    for i in range(n):
        y_new[i] = y[i] + h * y_new[n + i]
    return y_new


def rk2_step(rate, y, h, start, middle, end, args):
    """Explicit midpoint rule (order 2)."""
    n = len(y)
    work = np.empty((3, n))
    k1, k2, y_stage = work[0], work[1], work[2]
    rate(k1, y, start, args)
    for i in range(n):
        y_stage[i] = y[i] + 0.5 * h * k1[i]
    rate(k2, y_stage, middle, args)
    for i in range(n):
        y_stage[i] = y[i] + h * k2[i]
    return y_stage


def rk4_step(rate, y, h, start, middle, end, args):
    """Classic Runge-Kutta (order 4)."""
    n = len(y)
    work = np.empty((5, n))
    k1, k2, k3, k4, y_stage = work[0], work[1], work[2], work[3], work[4]
    rate(k1, y, start, args)
    for i in range(n):
        y_stage[i] = y[i] + 0.5 * h * k1[i]
    rate(k2, y_stage, middle, args)
    for i in range(n):
        y_stage[i] = y[i] + 0.5 * h * k2[i]
    rate(k3, y_stage, middle, args)
    for i in range(n):
        y_stage[i] = y[i] + h * k3[i]
    rate(k4, y_stage, end, args)
    for i in range(n):
        y_stage[i] = y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return y_stage


#: The methods by name, and their orders.
FIXED_STEP_METHODS = MappingProxyType({"euler": 1, "semi-implicit-euler": 1, "rk2": 2, "rk4": 4})
#: The step function of each method of :data:`FIXED_STEP_METHODS`.
STEPS = MappingProxyType(
    {
        "euler": euler_step,
        "semi-implicit-euler": semi_implicit_euler_step,
        "rk2": rk2_step,
        "rk4": rk4_step,
    }
)
