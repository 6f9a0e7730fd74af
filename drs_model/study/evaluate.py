"""What a study asks of each sample, for a batch of samples at once.

Per sample (a row of field values applied to the nominal design, :meth:`DRSParams.replace`):

* ``peak_force`` [N] (signed, the largest ``|F|``) and ``lowest_force`` [N] of the open-hold-close
  manoeuvre, and their times [s]: as ``drs peak`` finds them (:func:`drs_model.inverse.peak_force`,
  :func:`~drs_model.inverse.refine_extremum`): the fused inverse-dynamics force on a grid of
  ``scene.grid`` times over ``[0, T_total]``, the best grid sample (the earliest of those within
  1e-9 relative), then refined between its neighbours to 1e-12 s, here by
  :func:`scipy.optimize.elementwise.find_minimum` on every sample at once;
* ``dead_centre_margin`` [m]: the closed stroke less the dead centre (the singular stroke nearest
  the closed stroke, :attr:`DRSParams.singular_strokes`);
* ``opening_time`` / ``closing_time`` [s]: from rest at one stop to the other under the scene's
  constant force (:func:`.crossing.crossing_times`, the compiled RK driver), with the outcome in
  ``opening_status`` / ``closing_status``;
* ``gap_error_closed`` / ``gap_error_open`` [m]: the gap at the stops less the design's gap rule.

The stops and the manoeuvre's strokes are the **design's** (the nominal parameters' gap-rule
strokes): the piston runs the stroke it was built for, and a sample's tolerances change what that
stroke does (at the nominal design the gap errors are zero and the forces are ``drs peak``'s).

Only the parameters are built per sample, in Python (:func:`prepare`: :class:`DRSParams` validates
each one, and its assembly check gives a sample that does not assemble its reason; then its
constants are read); every computation after that runs on the whole batch: the force on an
``(n, grid)`` array by the numba gufunc of :func:`drs_model.kernels.fused_manoeuvre_force`, the
refinements vectorised, the forward runs in one compiled call per direction.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import elementwise as scipy_elementwise

from .. import elementwise, kernels
from ..bodies import model_constants
from ..errors import DRSError
from ..kinematics import stroke_limits
from ..params import DRSParams
from ..profile import drs_manoeuvre
from . import crossing
from .spec import Scene

#: The result columns of every sample (float64), in table order.
RESULT_COLUMNS = (
    "peak_force",
    "peak_time",
    "lowest_force",
    "lowest_time",
    "dead_centre_margin",
    "opening_time",
    "closing_time",
    "gap_error_closed",
    "gap_error_open",
)
#: Text columns: why a sample has no results (None when it has), and each forward run's outcome.
TEXT_COLUMNS = ("error", "opening_status", "closing_status")

#: Relative closeness of grid samples to the best one within which the earliest is refined (as
#: :func:`drs_model.inverse.refine_extremum`).
TWIN_RTOL = 1e-9
#: The refinement's absolute tolerance on the time [s] (as ``refine_extremum``'s Brent).
XATOL_S = 1e-12
#: A stop's stroke allowance [m]: a run that leaves its start by more, away from its target, has
#: been pushed onto the stop it started at (the force does not move it the way asked).
STOP_ALLOWANCE_M = 1e-9


class Prepared(NamedTuple):
    """The per-sample stage of :func:`evaluate`: each row's reason (None when it has
    parameters), and for the rows with parameters (``rows``, their indices) their kernel
    constants (k, N_CONSTANTS), manoeuvre constants (k, N_PROFILE_CONSTANTS) over the design's
    strokes, gap constants (k, 2), dead centre [m] (k,) and manoeuvre duration [s] (k,)."""

    errors: list
    rows: np.ndarray
    consts: np.ndarray
    profile: np.ndarray
    gap_consts: np.ndarray
    s_dead: np.ndarray
    t_total: np.ndarray


def prepare(design: DRSParams, fields, values) -> Prepared:
    """The only per-sample Python of a study: build each row's :class:`DRSParams` (its checks
    give a sample that does not assemble its reason) and read its constants."""
    s_lo, s_hi = stroke_limits(design)
    errors, good = [], []
    for row in values:
        try:
            good.append(design.replace(**dict(zip(fields, (float(v) for v in row), strict=True))))
            errors.append(None)
        except DRSError as exc:
            errors.append(f"{type(exc).__name__}: {exc}")
    # the manoeuvre depends on the sample through its three durations only
    manoeuvres: dict[tuple[float, float, float], tuple[float, ...]] = {}
    profile = []
    for p in good:
        key = (p.T_opening, p.T_still, p.T_closing)
        if key not in manoeuvres:
            manoeuvres[key] = drs_manoeuvre(p, s_lo, s_hi).constants()
        profile.append(manoeuvres[key])
    return Prepared(
        errors,
        np.array([i for i, e in enumerate(errors) if e is None], dtype=np.int64),
        np.array([model_constants(p) for p in good]).reshape(-1, kernels.N_CONSTANTS),
        np.array(profile).reshape(-1, kernels.N_PROFILE_CONSTANTS),
        np.array([p.gap_constants for p in good]).reshape(-1, 2),
        np.array([min(p.singular_strokes, key=lambda s: abs(s - s_lo)) for p in good]),
        np.array([p.T_total for p in good]),
    )


def _refine(times, values, objective):
    """The largest of ``values`` (n, grid) per row, at ``times`` (n, grid), refined between the
    neighbours of the best grid sample: ``(time [s], value)``. ``objective(t, rows)`` gives the
    value at times ``t`` of the rows ``rows`` (both (k,))."""
    n, m = values.shape
    top = values.max(axis=1)
    k = np.argmax(values >= (top - TWIN_RTOL * np.abs(top))[:, None], axis=1)
    rows = np.arange(n)
    best_t, best = times[rows, k].copy(), values[rows, k].copy()
    inner = np.flatnonzero((k > 0) & (k < m - 1))
    if inner.size:
        kk = k[inner]

        def negated(t, row):
            return -objective(t, row.astype(np.int64))

        res = scipy_elementwise.find_minimum(
            negated,
            (times[inner, kk - 1], times[inner, kk], times[inner, kk + 1]),
            args=(inner.astype(float),),
            tolerances={"xatol": XATOL_S, "xrtol": 0.0, "fatol": 0.0, "frtol": 0.0},
        )
        better = np.isfinite(res.f_x) & (-res.f_x > best[inner])
        best_t[inner[better]] = res.x[better]
        best[inner[better]] = -res.f_x[better]
    return best_t, best


def _stop_positions(consts, limits, rows, text):
    """``(ends, reach)``: at each of the design's stops (``limits``, closed and open strokes
    [m]) every sample's ``(psi3, sin psi3, h^2)``, and which samples assemble at both; the others'
    error is written into ``text``."""
    ends = {}
    for name, s in zip(("closed", "open"), limits, strict=True):
        sin1, cos1, sin3, cos3, h2 = elementwise.stroke_position(s, consts, 1.0)
        ends[name] = (np.arctan2(sin3, cos3), sin3, h2)
    reach = np.full(rows.size, True)
    for name, s in zip(("closed", "open"), limits, strict=True):
        bad = ~(ends[name][2] >= -kernels.ASSEMBLY_TOL)
        for j in np.flatnonzero(bad & reach):
            text["error"][rows[j]] = (
                f"AssemblyError: the loop cannot close at the design's {name} stroke {s!r} m"
            )
        reach &= ~bad
    return ends, reach


def _crossings(scene, consts, ends, live, limits, target, out, text) -> None:
    """The forward runs into ``out`` and ``text``: opening from the closed stop, closing from
    the open one, under the scene's forces."""
    s_lo, s_hi = limits
    psi_closed, psi_open = ends["closed"][0][live], ends["open"][0][live]
    lo, hi = np.full(live.size, s_lo), np.full(live.size, s_hi)
    for name, start, goal, stroke_range, up, f in (
        ("opening", psi_closed, psi_open, (lo - STOP_ALLOWANCE_M, hi), True, scene.opening_force),
        ("closing", psi_open, psi_closed, (lo, hi + STOP_ALLOWANCE_M), False, scene.closing_force),
    ):
        times, outcome, status = crossing.crossing_times(
            start, goal, consts, stroke_range, up, f, scene.horizon, rtol=scene.rtol
        )
        out[f"{name}_time"][target] = times
        text[f"{name}_status"][target] = [
            crossing.describe(int(o), int(s)) for o, s in zip(outcome, status, strict=True)
        ]


def evaluate(design: DRSParams, scene: Scene, fields, values) -> dict[str, np.ndarray]:
    """Evaluate the rows ``values`` (n, d) of ``fields`` on ``design``: a dict of the
    :data:`RESULT_COLUMNS` (float64, NaN where not computed) and :data:`TEXT_COLUMNS` (object
    arrays, None for no error)."""
    values = np.atleast_2d(np.asarray(values, dtype=float))
    n = values.shape[0]
    out = {name: np.full(n, np.nan) for name in RESULT_COLUMNS}
    text = {name: np.full(n, None, dtype=object) for name in TEXT_COLUMNS}
    out.update(text)
    prep = prepare(design, fields, values)
    text["error"][:] = prep.errors
    rows = prep.rows
    if rows.size == 0:
        return out
    consts, profile, gap_consts = prep.consts, prep.profile, prep.gap_consts
    s_dead, t_total = prep.s_dead, prep.t_total
    s_lo, s_hi = stroke_limits(design)

    ends, reach = _stop_positions(consts, (s_lo, s_hi), rows, text)

    # ---- the manoeuvre's force on the grid
    grid = np.linspace(0.0, t_total, scene.grid, axis=1)
    force = elementwise.fused_manoeuvre_force(grid, consts[:, None, :], profile[:, None, :])
    finite = np.all(np.isfinite(force), axis=1)
    for j in np.flatnonzero(reach & ~finite):
        t_bad = grid[j][~np.isfinite(force[j])][0]
        text["error"][rows[j]] = (
            f"AssemblyError: the manoeuvre's force is not finite at t = {t_bad!r} s (the loop "
            "cannot close, or the dead centre lies on the design's stroke)"
        )
    reach &= finite
    live = np.flatnonzero(reach)
    if live.size == 0:
        return out
    consts, profile, force, grid = consts[live], profile[live], force[live], grid[live]
    target = rows[live]

    def force_at(t, r):
        return elementwise.fused_manoeuvre_force(t, consts[r], profile[r])

    peak_t, _ = _refine(grid, np.abs(force), lambda t, r: np.abs(force_at(t, r)))
    out["peak_time"][target] = peak_t
    out["peak_force"][target] = force_at(peak_t, np.arange(live.size))
    low_t, low = _refine(grid, -force, lambda t, r: -force_at(t, r))
    out["lowest_time"][target] = low_t
    out["lowest_force"][target] = -low
    out["dead_centre_margin"][target] = s_lo - s_dead[live]
    gap0, tip = gap_consts[live, 0], gap_consts[live, 1]
    out["gap_error_closed"][target] = (
        kernels.flap_gap(ends["closed"][1][live], gap0, tip) - design.gap_closed
    )
    out["gap_error_open"][target] = (
        kernels.flap_gap(ends["open"][1][live], gap0, tip) - design.gap_open
    )

    _crossings(scene, consts, ends, live, (s_lo, s_hi), target, out, text)
    return out
