"""The fixed-step integrator of the forward dynamics: the real-time loop.

:class:`FixedStepIntegrator`: one call of :meth:`~FixedStepIntegrator.step` advances by ``dt``
under a piston force held over the step (or a callable of t). Each method's step is
:mod:`drs_model.explicit_steps`'s (:data:`~drs_model.explicit_steps.FIXED_STEP_METHODS`: explicit
and semi-implicit Euler, RK2, RK4). For formulation (a) it runs on :func:`psi3_rate` (the psi3
kernel :func:`drs_model.kernels.psi3_acceleration`), one function per method
(:data:`PSI3_STEPS`) compiled whole by numba when it is installed
(:func:`drs_model.compiled.scalar.bind`: one call of ~1 us per step; the plain Python step takes
tens of microseconds); any other formulation runs it on its numpy right-hand side. A step that
would leave the stroke range (or cross the dead centre, or produce a non-finite state) is refused
with a typed error and the state is kept.
"""

from __future__ import annotations

import math
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from ..compiled.scalar import bind
from ..errors import InputError, IntegrationError, SingularConfigurationError, StrokeRangeError
from ..explicit_steps import (
    FIXED_STEP_METHODS,
    STEPS,
    euler_step,
    rk2_step,
    rk4_step,
    semi_implicit_euler_step,
)
from ..kernels import flap_gap, psi3_acceleration
from ..kinematics import (
    dead_centre,
    solve_position,
    solve_position_from_flap_angle,
    stroke_limits,
    velocity_ratio,
)
from ..params import DRSParams
from .forces import as_force
from .formulations import Formulation, Psi3Minimal, get_formulation

__all__ = ["FIXED_STEP_METHODS", "FixedStepIntegrator", "StepState"]


# ---- one step of formulation (a): y = [psi3, psi3'], a(psi3, psi3', F) = psi3'' ------------------
def psi3_rate(out, y, force, c):
    """Formulation (a)'s ``dy/dt = [psi3', psi3'']`` [rad/s, rad/s^2] at ``y = [psi3, psi3']``
    [rad, rad/s] under the piston force [N] (``c``: the kernel constants), into ``out``."""
    b, bd = float(y[0]), float(y[1])  # plain Python: floats, ~3x faster than numpy's scalars
    out[0] = bd
    out[1] = psi3_acceleration(b, bd, force, c)


def _psi3_by(step, b, bd, f0, f1, f2, h, c):
    """``(psi3, psi3')`` [rad, rad/s] after one step of ``h`` [s] by ``step`` (a step of
    :mod:`drs_model.explicit_steps`) from ``(b, bd)`` under the piston force ``f0``, ``f1``,
    ``f2`` [N] at the step's start, middle and end."""
    y = step(psi3_rate, (b, bd), h, f0, f1, f2, c)
    return float(y[0]), float(y[1])


# one compiled function per method (numba types a function given from Python far more slowly)
def psi3_euler_step(b, bd, f0, f1, f2, h, c):
    """Explicit Euler on formulation (a) (:func:`_psi3_by`)."""
    return _psi3_by(euler_step, b, bd, f0, f1, f2, h, c)


def psi3_semi_implicit_euler_step(b, bd, f0, f1, f2, h, c):
    """Semi-implicit Euler on formulation (a) (:func:`_psi3_by`)."""
    return _psi3_by(semi_implicit_euler_step, b, bd, f0, f1, f2, h, c)


def psi3_rk2_step(b, bd, f0, f1, f2, h, c):
    """The explicit midpoint rule on formulation (a) (:func:`_psi3_by`)."""
    return _psi3_by(rk2_step, b, bd, f0, f1, f2, h, c)


def psi3_rk4_step(b, bd, f0, f1, f2, h, c):
    """Classic Runge-Kutta on formulation (a) (:func:`_psi3_by`)."""
    return _psi3_by(rk4_step, b, bd, f0, f1, f2, h, c)


#: One step of formulation (a) per method of :data:`FIXED_STEP_METHODS`.
PSI3_STEPS = MappingProxyType(
    {
        "euler": psi3_euler_step,
        "semi-implicit-euler": psi3_semi_implicit_euler_step,
        "rk2": psi3_rk2_step,
        "rk4": psi3_rk4_step,
    }
)


def _rate_at_time(out, y, t, fun):
    """A formulation's right-hand side ``fun(t, y)``, into ``out``."""
    out[:] = fun(t, y)


class StepState(NamedTuple):
    """State after a fixed step: time [s], coordinates [m, rad, rad], rates [m/s, rad/s, rad/s],
    flap gap [m]."""

    t: float
    s: float
    psi1: float
    psi3: float
    s_dot: float
    psi1_dot: float
    psi3_dot: float
    gap: float


class FixedStepIntegrator:
    """Fixed-step integration of the forward dynamics for a real-time loop.

    Parameters
    ----------
    p : DRSParams
    dt : float
        Step [s] (e.g. 1e-3 or 1e-4).
    method : str
        One of :data:`FIXED_STEP_METHODS` (``"rk4"`` by default).
    formulation : str or Formulation
        ``"psi3"`` (default) runs the scalar kernel; any other formulation its numpy right-hand
        side (projected after each step if it projects).
    stroke_margin : float
        Admissible stroke range ``[s_min - stroke_margin, s_max + stroke_margin]`` [m]; must be
        smaller than the distance from the closed stroke to the dead centre.
    flap_limits : (float, float), optional
        Air-force law's flap angles (default: the gap-rule angles).

    Notes
    -----
    :meth:`step` refuses (raises, keeping the state) a step that ends outside the stroke range
    (:class:`StrokeRangeError`), crosses the dead centre (:class:`SingularConfigurationError`) or
    is not finite (:class:`IntegrationError`).
    """

    def __init__(
        self,
        p: DRSParams,
        dt: float,
        method: str = "rk4",
        formulation="psi3",
        stroke_margin: float = 1e-4,
        flap_limits: tuple[float, float] | None = None,
        **formulation_options,
    ) -> None:
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
            raise InputError(f"dt must be a finite number > 0 s, got {dt!r}")
        if method not in FIXED_STEP_METHODS:
            raise InputError(f"method must be one of {sorted(FIXED_STEP_METHODS)}, got {method!r}")
        self.p = p
        self.dt = float(dt)
        self.method = method
        self.form = (
            formulation
            if isinstance(formulation, Formulation)
            else get_formulation(formulation, p, flap_limits=flap_limits, **formulation_options)
        )
        self.s_min, self.s_max = stroke_limits(p)
        self.s_dead = dead_centre(p)
        gap_to_dead = self.s_min - self.s_dead
        if not (math.isfinite(stroke_margin) and 0.0 <= stroke_margin < gap_to_dead):
            raise InputError(
                f"stroke_margin must be in [0, {gap_to_dead:.6g}) m (the closed stroke's distance "
                f"to the dead centre), got {stroke_margin!r}"
            )
        self.stroke_margin = float(stroke_margin)
        self.lo, self.hi = self.s_min - stroke_margin, self.s_max + stroke_margin
        self.psi3_dead = float(solve_position(self.s_dead, p)[2])
        self._fast = isinstance(self.form, Psi3Minimal)
        self._psi3_step = (
            bind(PSI3_STEPS[method], self.form.consts, inlined=(psi3_rate, _psi3_by))
            if self._fast
            else None
        )
        self._gap = p.gap_constants
        self.steps = 0
        self.reset()
        if self._fast:
            # compile (or load from numba's cache) what a step calls now, not at the first step:
            # in a real-time loop that would stall it (~20 ms from the cache, seconds without)
            b, bd = self._y
            self._psi3_step(b, bd, 0.0, 0.0, 0.0, self.dt)
            self.form.accel(b, bd, 0.0)

    # ---- state ---------------------------------------------------------------------------------
    def reset(
        self,
        s: float | None = None,
        s_dot: float = 0.0,
        *,
        psi3: float | None = None,
        psi3_dot: float | None = None,
        t: float = 0.0,
    ) -> StepState:
        """Put the mechanism at stroke ``s`` [m] (default ``s_min``) with rate ``s_dot`` [m/s], or
        at flap angle ``psi3`` [rad] with rate ``psi3_dot`` [rad/s]; time ``t`` [s]."""
        if s is not None and psi3 is not None:
            raise InputError("give either s or psi3, not both")
        for name, v in (
            ("s", s),
            ("s_dot", s_dot),
            ("psi3", psi3),
            ("psi3_dot", psi3_dot),
            ("t", t),
        ):
            if v is not None and not math.isfinite(v):
                raise InputError(f"{name} must be finite, got {v!r}")
        if psi3 is not None:
            q = solve_position_from_flap_angle(psi3, self.p)
            qd = velocity_ratio(q, self.p, "psi3") * (0.0 if psi3_dot is None else psi3_dot)
        else:
            s = self.s_min if s is None else float(s)
            q = solve_position(s, self.p)
            qd = velocity_ratio(q, self.p, "s") * s_dot
        if not self.lo <= q[0] <= self.hi:
            raise StrokeRangeError(
                f"stroke {q[0]!r} m is outside [s_min, s_max] = [{self.s_min:.9g}, "
                f"{self.s_max:.9g}] m (margin {self.stroke_margin:g} m)"
            )
        self._y = self.form.initial_state(q, qd)
        self._t = float(t)
        self.steps = 0
        self._state = self._make_state(self._t, self._y)
        return self._state

    @property
    def t(self) -> float:
        """Current time [s]."""
        return self._t

    @property
    def state(self) -> StepState:
        """Current state."""
        return self._state

    @property
    def y(self) -> np.ndarray:
        """Current state in the formulation's coordinates, shape ``(n_state,)``."""
        return np.array(self._y, dtype=float)

    def _make_state(self, t: float, y) -> StepState:
        if self._fast:
            b, bd = y
            s, a, u0, u1 = self.form.config(b)
            return StepState(t, s, a, b, u0 * bd, u1 * bd, bd, flap_gap(math.sin(b), *self._gap))
        q, qd = self.form.to_q_qd(np.asarray(y, dtype=float).reshape(-1, 1))
        q, qd = q[0], qd[0]
        gap = flap_gap(math.sin(q[2]), *self._gap)
        return StepState(t, q[0], q[1], q[2], qd[0], qd[1], qd[2], gap)

    # ---- stepping ------------------------------------------------------------------------------
    def step(self, force) -> StepState:
        """Advance by ``dt`` under ``force`` [N] (a number held over the step, or a callable of
        t). Returns the new state; raises and keeps the old state if the step is refused."""
        if self._fast:
            y = self._step_fast(force)
        else:
            y = self._step_generic(force)
        t_new = self._t + self.dt
        state = self._validate(t_new, y)
        self._y, self._t, self._state = y, t_new, state
        self.steps += 1
        return state

    def _validate(self, t_new: float, y) -> StepState:
        for v in y:
            if not math.isfinite(v):
                raise IntegrationError(
                    f"fixed step {self.method} (dt = {self.dt:g} s) diverged at t = {t_new:.9g} s: "
                    f"non-finite state {list(y)}; reduce dt"
                )
        if not self._fast:
            self.form.check(t_new, np.asarray(y))
        state = self._make_state(t_new, y)
        if state.psi3 >= self.psi3_dead:
            raise SingularConfigurationError(
                f"step to t = {t_new:.9g} s refused: psi3 = {state.psi3:.9g} rad crosses the dead "
                f"centre (psi3 = {self.psi3_dead:.9g} rad, s = {self.s_dead:.9g} m); "
                f"state kept at t = {self._t:.9g} s"
            )
        if not self.lo <= state.s <= self.hi:
            raise StrokeRangeError(
                f"step to t = {t_new:.9g} s refused: stroke s = {state.s:.9g} m leaves "
                f"[s_min, s_max] = [{self.s_min:.9g}, {self.s_max:.9g}] m (margin "
                f"{self.stroke_margin:g} m; dead centre at {self.s_dead:.9g} m); "
                f"state kept at t = {self._t:.9g} s"
            )
        return state

    def _step_fast(self, force):
        h, t = self.dt, self._t
        b, bd = self._y
        if callable(force):
            piece = force.segment(t, t + h) if hasattr(force, "segment") else force
            f0, f1, f2 = piece(t), piece(t + 0.5 * h), piece(t + h)
            for f in (f0, f1, f2):
                if not math.isfinite(f):
                    raise IntegrationError(f"piston force is not finite near t = {t!r} s: {f!r} N")
        else:
            f0 = f1 = f2 = float(force)
            if not math.isfinite(f0):
                raise IntegrationError(f"piston force is not finite at t = {t!r} s: {force!r} N")
        try:
            return self._psi3_step(b, bd, f0, f1, f2, h)
        except (OverflowError, ZeroDivisionError, ValueError) as exc:  # the plain Python step
            raise IntegrationError(
                f"fixed step {self.method} (dt = {h:g} s) diverged at t = {t + h:.9g} s: {exc}; "
                "reduce dt"
            ) from exc

    def _step_generic(self, force):
        fobj = as_force(force)
        h, t = self.dt, self._t
        fun = self.form.fun(fobj.segment(t, t + h))
        y = np.asarray(self._y, dtype=float)
        m = self.method
        try:
            with np.errstate(all="raise"):
                y_new = STEPS[m](_rate_at_time, y, h, t, t + 0.5 * h, t + h, fun)
        except (FloatingPointError, OverflowError, ZeroDivisionError, ValueError) as exc:
            raise IntegrationError(
                f"fixed step {m} (dt = {h:g} s) diverged at t = {t + h:.9g} s: {exc}; reduce dt"
            ) from exc
        if self.form.project is not None and np.all(np.isfinite(y_new)):
            y_new = self.form.project(y_new)
        return tuple(float(v) for v in y_new)

    # ---- a search inside one step (ActuatorSim finds where a stop is reached) ------------------
    def step_by(self, force, h: float) -> StepState:
        """Advance by ``h`` [s] (``0 < h <= dt``) instead of ``dt``: the same method and the same
        checks as :meth:`step`, which it is (raises and keeps the state alike)."""
        h = float(h)
        if not (math.isfinite(h) and 0.0 < h <= self.dt):
            raise InputError(f"h must be a finite number in (0, dt = {self.dt:g}] s, got {h!r}")
        dt, self.dt = self.dt, h
        try:
            return self.step(force)
        finally:
            self.dt = dt

    def restore(self, t: float, y) -> StepState:
        """Put the integrator at time ``t`` [s] in state ``y`` (the formulation's coordinates,
        as :attr:`y` gives them), exactly and without :meth:`reset`'s constraint checks (which
        cost ~0.4 ms): to go back to a state it held (:attr:`state` gives ``psi3`` and
        ``psi3_dot``, the ``"psi3"`` formulation's ``y``). Raises :class:`InputError` for a
        non-finite value."""
        y = tuple(float(v) for v in y)
        if not (math.isfinite(t) and all(math.isfinite(v) for v in y)):
            raise InputError(f"t and y must be finite, got t = {t!r}, y = {list(y)}")
        state = self._make_state(float(t), y)
        self._y, self._t, self._state = y, float(t), state
        return state
