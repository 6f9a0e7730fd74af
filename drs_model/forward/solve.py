r"""Forward simulation: :func:`simulate` integrates any formulation of
:mod:`drs_model.forward.formulations` under a piston force of :mod:`drs_model.forward.forces`.

``method`` is a scipy solver (:data:`SCIPY_METHODS`: RK45, DOP853, Radau, BDF, LSODA), driven by
:func:`scipy.integrate.solve_ivp`, or a compiled one (:data:`COMPILED_METHODS`: ``dopri5-numba``,
``dop853-numba``; formulation ``"psi3"`` only), driven by :mod:`drs_model.compiled.simulate`
(imported for these methods only: it needs numba). Both return a
:class:`~drs_model.forward.solution.Solution`.

The scipy solver class is wrapped in a subclass (solve_ivp accepts an ``OdeSolver`` subclass)
whose ``_step_impl`` runs, after every accepted step:

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
"""

from __future__ import annotations

import math
from functools import cache
from types import MappingProxyType

import numpy as np
from scipy.integrate import BDF, DOP853, LSODA, RK45, OdeSolver, Radau, solve_ivp

from ..errors import InputError, IntegrationError
from ..params import DRSParams
from .arguments import output_times, relative_tolerance, time_span
from .forces import as_force
from .formulations import Formulation, check_options, get_formulation, manoeuvre_initial_state
from .solution import Solution

__all__ = ["COMPILED_METHODS", "SCIPY_METHODS", "default_atol", "simulate"]

#: Adaptive scipy methods: name -> OdeSolver class.
SCIPY_METHODS = MappingProxyType(
    {"RK45": RK45, "DOP853": DOP853, "Radau": Radau, "BDF": BDF, "LSODA": LSODA}
)
#: Compiled methods (formulation "psi3"): name -> method of
#: :func:`drs_model.compiled.simulate.simulate_compiled`.
COMPILED_METHODS = MappingProxyType({"dopri5-numba": "dopri5", "dop853-numba": "dop853"})


def default_atol(formulation: Formulation, rtol: float) -> np.ndarray:
    """``rtol`` times the typical magnitude of each state component (shape ``(n_state,)``)."""
    return rtol * np.asarray(formulation.scales, dtype=float)


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
        A name of :data:`~drs_model.forward.formulations.FORMULATIONS` (``"psi3"``, ``"s"``,
        ``"index1"``, ``"baumgarte"``, ``"projection"``; needs ``params``) or an instance.
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
        drs[fast]``; see :mod:`drs_model.compiled.simulate`, which also takes the options
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
    steps = dict(rtol=rtol, atol=atol, max_step=max_step, first_step=first_step, min_step=min_step)
    run = (force, t_span, (y0, initial), t_eval, breakpoints, steps)
    if isinstance(method, str) and method in COMPILED_METHODS:
        return _simulate_compiled(formulation, params, method, formulation_options, *run)
    form, base = _scipy_formulation(formulation, params, method, formulation_options)
    return _simulate_scipy(form, base, method, *run)


def _scipy_formulation(formulation, params, method, options: dict):
    """``(formulation, scipy solver class)`` for ``simulate`` with a scipy method."""
    if isinstance(formulation, Formulation):
        form = get_formulation(formulation, formulation.p, **options)
    else:
        if params is None:
            raise InputError("params is required with a formulation name")
        form = get_formulation(formulation, params, **options)
    try:
        return form, SCIPY_METHODS[method]
    except (KeyError, TypeError):
        raise InputError(
            f"method must be one of {sorted(SCIPY_METHODS) + sorted(COMPILED_METHODS)}, "
            f"got {method!r}"
        ) from None


def _simulate_scipy(form, base, method, force, t_span, start, t_eval, breakpoints, steps):
    """``simulate`` with the scipy solver class ``base`` (guarded): one ``solve_ivp`` per
    segment between the force's breakpoints (and ``breakpoints``), each restarting from the end
    of the last (projected if the formulation projects); ``start = (y0, initial)``;
    ``steps``: the tolerances and step bounds."""
    t0, t1 = time_span(t_span)
    rtol, atol = steps["rtol"], steps["atol"]
    relative_tolerance(rtol)
    fobj = as_force(force)
    y = _initial_state(form, t0, *start)
    atol = default_atol(form, rtol) if atol is None else atol
    cuts = sorted({float(b) for b in (*fobj.breakpoints, *breakpoints) if t0 < b < t1})
    edges = [t0, *cuts, t1]
    te = None if t_eval is None else output_times(t_eval, (t0, t1))
    stats = {"nsteps": 0}
    options = {
        "method": _guarded_solver(base, form, float(steps["min_step"]), stats),
        "rtol": rtol,
        "atol": atol,
        "max_step": steps["max_step"],
        "first_step": steps["first_step"],
    }
    ts, ys = [], []
    counts = [0, 0, 0]  # nfev, njev, nlu
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        sol, keep = _segment(form, fobj, (a, b), y, te, k == 0, options, method)
        counts = [n + m for n, m in zip(counts, (sol.nfev, sol.njev, sol.nlu), strict=True)]
        ts.append(sol.t[keep])
        ys.append(sol.y[:, keep])
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
        *counts,
        stats["nsteps"],
        list(zip(edges[:-1], edges[1:], strict=True)),
    )


def _initial_state(form, t0: float, y0, initial):
    """The formulation's initial state: ``y0`` (checked), else from ``initial = (q0, qd0)``,
    else at rest at the manoeuvre's closed stroke."""
    if y0 is None:
        q0, qd0 = manoeuvre_initial_state(form.p) if initial is None else initial
        return form.initial_state(q0, qd0)
    y = np.asarray(y0, dtype=float).reshape(form.n_state)
    form.check(t0, y)
    return y


def _segment(form, fobj, span, y, te, first: bool, options: dict, method):
    """``(sol, keep)``: ``solve_ivp`` over ``span = (a, b)`` from ``y`` and the slice of its
    samples to keep (the output times in the segment; every step without ``te``, the first
    sample only in the first segment). A failed segment raises :class:`IntegrationError` (or
    the formulation's own error, e.g. the dead centre of ``s``)."""
    a, b = span
    want = seg_eval = None
    if te is not None:
        want = te[(te >= a if first else te > a) & (te <= b)]
        # b is always evaluated: the next segment restarts from it
        seg_eval = np.append(want[want < b], b)
    sol = solve_ivp(form.fun(fobj.segment(a, b)), (a, b), y, t_eval=seg_eval, **options)
    if sol.status != 0 or sol.t.size == 0 or sol.t[-1] != b:
        t_fail = sol.t[-1] if sol.t.size else a
        if sol.t.size:  # the formulation may know why (e.g. the dead centre of 's')
            form.check(t_fail, sol.y[:, -1])
        raise IntegrationError(
            f"{method} on formulation {form.name!r} failed at t = {t_fail:.9g} s "
            f"(segment [{a:.6g}, {b:.6g}] s): {sol.message}"
        )
    if te is None:
        return sol, slice(None) if first else slice(1, None)
    n_keep = sol.t.size if (want.size and want[-1] == b) else sol.t.size - 1
    return sol, slice(0, n_keep)


_COMPILED_OPTIONS = ("stroke_range", "stop_at_dead_centre", "max_steps")


@cache
def _compiled_driver():
    """:mod:`drs_model.compiled.simulate`, imported at the first compiled run (it imports numba;
    without numba this raises :class:`~drs_model.errors.NumbaUnavailableError`). Cached: an
    import statement costs ~1-2 us, a few % of a compiled run."""
    from ..compiled import simulate

    return simulate


def _simulate_compiled(
    formulation, params, method, options, force, t_span, start, t_eval, breakpoints, steps
):
    """``simulate`` with a compiled method: formulation (a) run by
    :func:`drs_model.compiled.simulate.run_formulation`; ``start = (y0, initial)``, ``steps``
    the tolerances and step bounds, ``options`` the formulation's and the driver's own."""
    form, extra = _compiled_formulation(formulation, params, method, options)
    y0, initial = start
    return _compiled_driver().run_formulation(
        form,
        force,
        t_span,
        method=COMPILED_METHODS[method],
        initial=initial,
        y0=y0,
        label=method,
        t_eval=t_eval,
        breakpoints=breakpoints,
        **steps,
        **extra,
    )


def _compiled_formulation(formulation, params, method: str, options: dict):
    """``(formulation (a), the compiled driver's own options)`` for ``simulate`` with a compiled
    method (:mod:`drs_model.compiled.simulate`); ``options`` are the formulation options, those of
    the driver included."""
    extra = {k: options.pop(k) for k in _COMPILED_OPTIONS if k in options} if options else {}
    name = formulation.name if isinstance(formulation, Formulation) else formulation
    if name != "psi3":
        raise InputError(
            f"method {method!r} integrates formulation 'psi3' only, got {name!r}; use a scipy "
            f"method ({', '.join(sorted(SCIPY_METHODS))}) for the others"
        )
    if isinstance(formulation, Formulation):
        form = get_formulation(formulation, formulation.p, **options)
    else:
        if params is None:
            raise InputError("params is required with a formulation name")
        if options:
            check_options("psi3", options)
        form = _compiled_driver().psi3_formulation(params, **options)
    return form, extra
