r"""Integrators of the forward dynamics: a scipy-driven adaptive driver and a fixed-step loop.

:func:`simulate` integrates any :class:`~drs_model.forward.Formulation` with
:func:`scipy.integrate.solve_ivp` (``method`` in RK45, DOP853, Radau, BDF, LSODA). The scipy
solver class is wrapped in a subclass (solve_ivp accepts an ``OdeSolver`` subclass) whose
``_step_impl`` runs, after every accepted step:

* the formulation's projection, if any (formulation (d)); the solver's cached derivative (RK,
  Radau) or its newest difference (BDF) is updated so the next step starts from the projected state;
* the checks that turn a bad state into a typed error: a non-finite state
  (:class:`~drs_model.errors.IntegrationError`), a step shorter than ``min_step`` (step-size
  collapse, IntegrationError), the dead centre of the s formulation
  (:class:`~drs_model.errors.SingularConfigurationError`), a constraint residual past the bound
  (:class:`~drs_model.errors.ConstraintDriftError`).

The time span is cut at the force's ``breakpoints`` (jerk jumps of the manoeuvre at 0, 10, 40,
50 ms, the time of a step force) and each segment is integrated with the smooth piece of the force
valid there, so that no step straddles a kink: an error-controlled method otherwise spends many
rejected steps locating it, and a fixed-order method loses its order.

:class:`FixedStepIntegrator` is the real-time loop: one call of :meth:`~FixedStepIntegrator.step`
advances by ``dt`` under a piston force held over the step (or a callable of t). For formulation
(a) it runs a scalar ``math`` kernel (about 4 right-hand sides of ~1.5 us each per RK4 step); any
other formulation runs through its numpy right-hand side. A step that would leave the stroke range
(or cross the dead centre, or produce a non-finite state) is refused with a typed error and the
state is kept.

Fixed-step methods (Butcher tableaux; ``h = dt``):

* ``"euler"`` (explicit, order 1), ``"semi-implicit-euler"`` (symplectic, order 1:
  ``v += h a(x, v); x += h v``), ``"rk2"`` (explicit midpoint, order 2), ``"rk4"`` (classic,
  order 4).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, OdeSolver, Radau, solve_ivp

from .compiled import COMPILED_METHODS
from .constraints import S
from .errors import (
    InputError,
    IntegrationError,
    SingularConfigurationError,
    StrokeRangeError,
)
from .forward import (
    Formulation,
    Psi3Minimal,
    as_force,
    get_formulation,
    manoeuvre_initial_state,
)
from .kinematics import dead_centre, solve_position, stroke_limits
from .params import DRSParams

__all__ = [
    "COMPILED_METHODS",
    "FIXED_STEP_METHODS",
    "METHODS",
    "FixedStepIntegrator",
    "Solution",
    "StepState",
    "simulate",
]

#: Adaptive methods: name -> scipy OdeSolver class.
METHODS: dict[str, type[OdeSolver]] = {
    "RK45": RK45,
    "DOP853": DOP853,
    "Radau": Radau,
    "BDF": BDF,
    "LSODA": LSODA,
}
#: Fixed-step methods and their orders.
FIXED_STEP_METHODS: dict[str, int] = {"euler": 1, "semi-implicit-euler": 1, "rk2": 2, "rk4": 4}

#: Typical magnitude of each state component [SI] per formulation: atol defaults to rtol * this.
_SCALES = {
    2: None,  # minimal coordinates: set from the coordinate names below
    6: np.array([0.05, 1.0, 1.0, 10.0, 100.0, 100.0]),
}
_MINIMAL_SCALES = {"psi3": np.array([1.0, 100.0]), "s": np.array([0.05, 10.0])}


def default_atol(formulation: Formulation, rtol: float) -> np.ndarray:
    """``rtol`` times the typical magnitude of each state component (shape ``(n_state,)``)."""
    if formulation.n_state == 6:
        return rtol * _SCALES[6]
    return rtol * _MINIMAL_SCALES.get(formulation.coordinates[0], np.ones(formulation.n_state))


@dataclass
class Solution:
    """Result of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Output times [s].
    y : ndarray, shape (n_state, n)
        The formulation's states.
    q, qd : ndarray, shape (n, 3)
        Configurations [m, rad, rad] and velocities [m/s, rad/s] (mapped back).
    residual, velocity_residual : ndarray, shape (n,)
        ``max |Phi|`` [m] and ``max |Phi_q qd|`` [m/s] (zero for minimal coordinates).
    nfev, njev, nlu, nsteps : int
        Right-hand-side and Jacobian evaluations, LU decompositions, accepted steps.
    segments : list of (float, float)
        The integration segments [s] (restarts at the force's breakpoints).
    nrejected : int
        Rejected steps (counted by the compiled methods only; 0 for the scipy methods).
    """

    formulation: str
    method: str
    t: np.ndarray
    y: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    residual: np.ndarray
    velocity_residual: np.ndarray
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    nsteps: int = 0
    segments: list[tuple[float, float]] = field(default_factory=list)
    nrejected: int = 0

    @property
    def s(self) -> np.ndarray:
        """Stroke [m], shape (n,)."""
        return self.q[:, S]

    @property
    def psi3(self) -> np.ndarray:
        """Flap angle [rad], shape (n,)."""
        return self.q[:, 2]


def _guarded_solver(
    base: type[OdeSolver], formulation: Formulation, min_step: float, stats: dict
) -> type[OdeSolver]:
    """A subclass of ``base`` that projects and checks after each accepted step."""
    project = formulation.project
    check = formulation.check
    if project is not None and base is LSODA:
        raise InputError(
            "LSODA keeps its state inside Fortran and cannot be projected; use RK45, DOP853, "
            "Radau or BDF with the projection formulation"
        )
    is_bdf = issubclass(base, BDF)
    has_f = issubclass(base, (RK45, DOP853, Radau))

    class Guarded(base):  # type: ignore[misc, valid-type]
        def _step_impl(self):
            t_prev = self.t
            ok, message = super()._step_impl()
            if not ok:
                return ok, message
            stats["nsteps"] += 1
            h = abs(self.t - t_prev)
            if h < min_step and self.t != self.t_bound:
                raise IntegrationError(
                    f"{base.__name__} on formulation {formulation.name!r}: step size collapsed "
                    f"to {h:.3g} s < min_step = {min_step:g} s at t = {self.t:.9g} s"
                )
            if project is not None:
                y = project(self.y)
                self.y = y
                if is_bdf:
                    self.D[0] = y
                elif has_f:
                    self.f = self.fun(self.t, y)
            check(self.t, self.y)
            return ok, message

    Guarded.__name__ = Guarded.__qualname__ = f"Guarded{base.__name__}"
    return Guarded


def simulate(
    formulation,
    force,
    t_span: tuple[float, float],
    y0=None,
    *,
    params: DRSParams | None = None,
    initial: tuple | None = None,
    method: str = "DOP853",
    rtol: float = 1e-8,
    atol=None,
    max_step: float = math.inf,
    first_step: float | None = None,
    t_eval=None,
    min_step: float = 1e-12,
    breakpoints: tuple[float, ...] = (),
    **formulation_options,
) -> Solution:
    """Integrate the forward dynamics under the piston force ``force``.

    Parameters
    ----------
    formulation : str or Formulation
        A name of :data:`drs_model.forward.FORMULATIONS` (``"psi3"``, ``"s"``, ``"index1"``,
        ``"baumgarte"``, ``"projection"``; needs ``params``) or an instance.
    force : float, callable or force object
        Piston force [N]: a constant, a callable of t [s], a :class:`~drs_model.forward.StepForce`
        or :class:`~drs_model.forward.ManoeuvreForce`.
    t_span : (float, float)
        Start and end times [s].
    y0 : array_like, shape (n_state,), optional
        Initial state in the formulation's coordinates. Alternatively ``initial = (q0, qd0)``
        (consistent full coordinates). Default: at rest at the closed stroke ``s_min``.
    method : str
        ``"RK45"``, ``"DOP853"``, ``"Radau"``, ``"BDF"`` or ``"LSODA"`` (scipy), or a compiled
        method of :data:`COMPILED_METHODS`, ``"dopri5-numba"`` or ``"dop853-numba"`` (formulation
        ``"psi3"`` only, a constant, step or manoeuvre force; needs numba: ``pip install
        drs[fast]``; see :mod:`drs_model.compiled`, which also takes the options
        ``stroke_range``, ``stop_at_dead_centre`` and ``max_steps``).
    rtol, atol : float or array_like
        Tolerances as in solve_ivp; ``atol`` defaults to ``rtol`` times each component's typical
        magnitude (0.05 m, 1 rad, 10 m/s, 100 rad/s).
    max_step, first_step : float
        As in solve_ivp [s].
    t_eval : array_like, optional
        Output times [s]; default: every accepted step.
    min_step : float
        A step shorter than this [s] (other than the last one of a segment) raises
        :class:`IntegrationError`.
    breakpoints : tuple of float
        Extra restart times [s], in addition to the force's own.
    **formulation_options
        Passed to the formulation's constructor (e.g. ``alpha``, ``beta``, ``drift_bound``,
        ``dead_centre_margin``).

    Returns
    -------
    Solution

    Raises
    ------
    IntegrationError
        Non-finite state or force, step-size collapse, solver failure.
    ConstraintDriftError
        The constraint residual of a full-coordinate formulation exceeded its bound.
    SingularConfigurationError
        The s formulation approached the dead centre.
    """
    if isinstance(method, str) and method in COMPILED_METHODS:
        return _simulate_compiled(
            formulation, force, t_span, y0, params, initial, method, rtol, atol, max_step,
            first_step, t_eval, min_step, breakpoints, formulation_options,
        )  # fmt: skip
    if isinstance(formulation, Formulation):
        form = get_formulation(formulation, formulation.p, **formulation_options)
    else:
        if params is None:
            raise InputError("params is required with a formulation name")
        form = get_formulation(formulation, params, **formulation_options)
    p = form.p
    try:
        base = METHODS[method]
    except (KeyError, TypeError):
        raise InputError(
            f"method must be one of {sorted(METHODS) + sorted(COMPILED_METHODS)}, got {method!r}"
        ) from None
    t0, t1 = (float(v) for v in t_span)
    if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
        raise InputError(f"t_span must be finite with t_end > t_start, got {t_span!r}")
    if not (rtol > 0.0 and math.isfinite(rtol)):
        raise InputError(f"rtol must be a finite number > 0, got {rtol!r}")
    fobj = as_force(force)
    if y0 is None:
        q0, qd0 = manoeuvre_initial_state(p) if initial is None else initial
        y = form.initial_state(q0, qd0)
    else:
        y = np.asarray(y0, dtype=float).reshape(form.n_state)
        form.check(t0, y)
    atol = default_atol(form, rtol) if atol is None else atol
    cuts = sorted({float(b) for b in (*fobj.breakpoints, *breakpoints) if t0 < b < t1})
    edges = [t0, *cuts, t1]
    te = None if t_eval is None else np.asarray(t_eval, dtype=float)
    if te is not None and (te.ndim != 1 or np.any(te < t0) or np.any(te > t1)):
        raise InputError(f"t_eval must be 1-D within t_span {t_span!r}")
    stats = {"nsteps": 0}
    solver = _guarded_solver(base, form, float(min_step), stats)
    ts, ys = [], []
    nfev = njev = nlu = 0
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        want = None
        if te is not None:
            want = te[(te >= a if k == 0 else te > a) & (te <= b)]
            # b is always evaluated: the next segment restarts from it
            seg_eval = np.append(want[want < b], b)
        else:
            seg_eval = None
        fun = form.fun(fobj.segment(a, b))
        sol = solve_ivp(
            fun,
            (a, b),
            y,
            method=solver,
            t_eval=seg_eval,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            first_step=first_step,
        )
        nfev += sol.nfev
        njev += sol.njev
        nlu += sol.nlu
        if sol.status != 0 or sol.t.size == 0 or sol.t[-1] != b:
            t_fail = sol.t[-1] if sol.t.size else a
            if sol.t.size:  # the formulation may know why (e.g. the dead centre of 's')
                form.check(t_fail, sol.y[:, -1])
            raise IntegrationError(
                f"{method} on formulation {form.name!r} failed at t = {t_fail:.9g} s "
                f"(segment [{a:.6g}, {b:.6g}] s): {sol.message}"
            )
        if te is None:
            keep = slice(None) if k == 0 else slice(1, None)
            ts.append(sol.t[keep])
            ys.append(sol.y[:, keep])
        else:
            n_keep = sol.t.size if (want.size and want[-1] == b) else sol.t.size - 1
            ts.append(sol.t[:n_keep])
            ys.append(sol.y[:, :n_keep])
        # restart from the end of the segment (projected if the formulation projects)
        y = sol.y[:, -1].copy()
        if form.project is not None:
            y = form.project(y)
    t_out = np.concatenate(ts)
    y_out = np.concatenate(ys, axis=1) if ys else np.zeros((form.n_state, 0))
    q, qd = form.to_q_qd(y_out)
    res, vres = form.residual(y_out)
    return Solution(
        form.name,
        method,
        t_out,
        y_out,
        q,
        qd,
        res,
        vres,
        nfev,
        njev,
        nlu,
        stats["nsteps"],
        list(zip(edges[:-1], edges[1:], strict=True)),
    )


_COMPILED_OPTIONS = ("stroke_range", "stop_at_dead_centre", "max_steps")


def _simulate_compiled(
    formulation, force, t_span, y0, params, initial, method, rtol, atol, max_step, first_step,
    t_eval, min_step, breakpoints, options,
) -> Solution:  # fmt: skip
    """``simulate`` with a compiled method: formulation (a) in :mod:`drs_model.compiled`."""
    from . import compiled

    extra = {k: options.pop(k) for k in _COMPILED_OPTIONS if k in options}
    name = formulation.name if isinstance(formulation, Formulation) else formulation
    if name != "psi3":
        raise InputError(
            f"method {method!r} integrates formulation 'psi3' only, got {name!r}; use a scipy "
            f"method ({', '.join(sorted(METHODS))}) for the others"
        )
    if isinstance(formulation, Formulation):
        form = get_formulation(formulation, formulation.p, **options)
    else:
        if params is None:
            raise InputError("params is required with a formulation name")
        form = compiled.psi3_formulation(params, **options)
    return compiled.run_formulation(
        form, force, t_span, method=COMPILED_METHODS[method], initial=initial, y0=y0,
        label=method, rtol=rtol, atol=atol, t_eval=t_eval, first_step=first_step,
        max_step=max_step, min_step=min_step, breakpoints=breakpoints, **extra,
    )  # fmt: skip


# ---- fixed-step real-time integrator -----------------------------------------------------------
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
        self._gap0 = p.y_D - p.reference_point[1]
        self._tip = p.tip_arm
        self.steps = 0
        self.reset()

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
        from .kinematics import solve_position_from_flap_angle, velocity_ratio

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
            return StepState(t, s, a, b, u0 * bd, u1 * bd, bd, self._gap0 - self._tip * math.sin(b))
        q, qd = self.form.to_q_qd(np.asarray(y, dtype=float).reshape(-1, 1))
        q, qd = q[0], qd[0]
        return StepState(
            t, q[0], q[1], q[2], qd[0], qd[1], qd[2], self._gap0 - self._tip * math.sin(q[2])
        )

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
        acc, h, t = self.form.accel, self.dt, self._t
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
        m = self.method
        try:
            if m == "rk4":
                hh = 0.5 * h
                k1 = acc(b, bd, f0)
                v2 = bd + hh * k1
                k2 = acc(b + hh * bd, v2, f1)
                v3 = bd + hh * k2
                k3 = acc(b + hh * v2, v3, f1)
                v4 = bd + h * k3
                k4 = acc(b + h * v3, v4, f2)
                return (
                    b + h / 6.0 * (bd + 2.0 * v2 + 2.0 * v3 + v4),
                    bd + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4),
                )
            if m == "rk2":
                k1 = acc(b, bd, f0)
                v2 = bd + 0.5 * h * k1
                return b + h * v2, bd + h * acc(b + 0.5 * h * bd, v2, f1)
            if m == "euler":
                return b + h * bd, bd + h * acc(b, bd, f0)
            v = bd + h * acc(b, bd, f0)  # semi-implicit Euler
            return b + h * v, v
        except (OverflowError, ZeroDivisionError, IntegrationError) as exc:
            raise IntegrationError(
                f"fixed step {m} (dt = {h:g} s) diverged at t = {t + h:.9g} s: {exc}; reduce dt"
            ) from exc

    def _step_generic(self, force):
        fobj = as_force(force)
        h, t = self.dt, self._t
        fun = self.form.fun(fobj.segment(t, t + h))
        y = np.asarray(self._y, dtype=float)
        m = self.method
        try:
            with np.errstate(all="raise"):
                if m == "rk4":
                    k1 = fun(t, y)
                    k2 = fun(t + 0.5 * h, y + 0.5 * h * k1)
                    k3 = fun(t + 0.5 * h, y + 0.5 * h * k2)
                    k4 = fun(t + h, y + h * k3)
                    y_new = y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
                elif m == "rk2":
                    k1 = fun(t, y)
                    y_new = y + h * fun(t + 0.5 * h, y + 0.5 * h * k1)
                elif m == "euler":
                    y_new = y + h * fun(t, y)
                else:
                    n = y.size // 2
                    v = y[n:] + h * fun(t, y)[n:]
                    y_new = np.concatenate([y[:n] + h * v, v])
        except (FloatingPointError, OverflowError, ZeroDivisionError, ValueError) as exc:
            raise IntegrationError(
                f"fixed step {m} (dt = {h:g} s) diverged at t = {t + h:.9g} s: {exc}; reduce dt"
            ) from exc
        if self.form.project is not None and np.all(np.isfinite(y_new)):
            y_new = self.form.project(y_new)
        return tuple(float(v) for v in y_new)

    def run(self, forces) -> list[StepState]:
        """Step once per force in ``forces``; returns the states (convenience for tests)."""
        return [self.step(f) for f in forces]


def fixed_step_trajectory(
    integ: FixedStepIntegrator, force: Callable[[float], float], n_steps: int
) -> np.ndarray:
    """``[t, s, psi3]`` after each of ``n_steps`` steps under ``force(t)``, shape ``(n, 3)``."""
    out = np.empty((n_steps, 3))
    for i in range(n_steps):
        st = integ.step(force)
        out[i] = st.t, st.s, st.psi3
    return out
