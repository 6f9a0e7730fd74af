"""Inverse dynamics along the seed's open-hold-close manoeuvre: the kinematic state, the piston
force by any formulation, its peak and its ratio to the air load."""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from ..bodies import air_forces
from ..constraints import PSI3, S
from ..errors import InputError
from ..kinematics import KinematicState, kinematic_state, solve_position
from ..params import DRSParams
from ..profile import drs_manoeuvre
from .formulations import Fused, InverseMethod, get_method, inverse_dynamics
from .fused import FusedInverseDynamics


def manoeuvre_state(
    t, p: DRSParams, s_limits: tuple[float, float] | None = None
) -> tuple[np.ndarray, KinematicState]:
    """Stroke profile -> full kinematic state along the open-hold-close manoeuvre.

    Parameters
    ----------
    t : array_like, shape (N,) or scalar
        Times [s] (outside ``[0, T_total]`` the rod rests at ``s_min``).
    p : DRSParams
    s_limits : (float, float), optional
        ``(s_min, s_max)`` [m]; default our exact gap-rule strokes.

    Returns
    -------
    t : ndarray, shape (N,) or ()
    state : KinematicState
        Arrays of shape ``t.shape + (3,)``.
    """
    t = np.asarray(t, dtype=float)
    if not np.all(np.isfinite(t)):
        raise InputError(f"time must be finite, got {float(t[~np.isfinite(t)].ravel()[0])!r}")
    man = drs_manoeuvre(p, *(s_limits if s_limits is not None else (None, None)))
    s, sd, sdd = man.evaluate(t)
    return t, kinematic_state(s, sd, sdd, p)


def manoeuvre_force(
    t,
    p: DRSParams,
    method: str | InverseMethod = "fused",
    s_limits: tuple[float, float] | None = None,
    flap_limits: tuple[float, float] | None = None,
) -> np.ndarray:
    """Piston force [N] along the seed's open-hold-close manoeuvre at times ``t`` [s].

    Profile -> kinematics -> force, shape of ``t``. ``"fused"`` (the default) runs the fused
    closed form on the profile directly (:meth:`FusedInverseDynamics.force_at_times`: the fast
    path); the other methods go through :func:`~drs_model.kinematics.kinematic_state` and
    :func:`inverse_dynamics`. All agree to ~1e-12 relative. For one sample at a time use
    :meth:`FusedInverseDynamics.force_at`.

    Raises
    ------
    InputError
        Unknown method or non-finite time.
    """
    formulation = get_method(method)
    if formulation.name == Fused.name:
        return _fused(p, flap_limits, s_limits).force_at_times(t)
    _, state = manoeuvre_state(t, p, s_limits)
    return formulation(state, p, flap_limits).piston_force


def _fused(p: DRSParams, flap_limits, s_limits) -> FusedInverseDynamics:
    """The fused inverse dynamics of ``p`` and the limits, built once per set of them (the
    manoeuvre's planning alone takes ~150 us, as long as 2,500 samples of the force); limits
    given as lists (unhashable) are built for the call."""
    try:
        return _fused_built(p, flap_limits, s_limits)
    except TypeError:  # unhashable limits (a bad value raises again, from the build itself)
        return FusedInverseDynamics.from_params(p, flap_limits, s_limits)


@functools.lru_cache(maxsize=32)
def _fused_built(p: DRSParams, flap_limits, s_limits) -> FusedInverseDynamics:
    return FusedInverseDynamics.from_params(p, flap_limits, s_limits)


def air_load_magnitude(
    psi3, p: DRSParams, flap_limits: tuple[float, float] | None = None
) -> np.ndarray:
    """``|(F_drag, -F_down)|`` [N] at flap angle(s) psi3 [rad]."""
    drag, down = air_forces(psi3, p, flap_limits)
    return np.hypot(drag, down)


def force_ratio(
    t,
    p: DRSParams,
    method: str | InverseMethod = "virtual-work",
    s_limits: tuple[float, float] | None = None,
    flap_limits: tuple[float, float] | None = None,
) -> np.ndarray:
    """Piston force per air-load magnitude, ``F / |F_air|`` [-], along the manoeuvre at ``t``."""
    _, state = manoeuvre_state(t, p, s_limits)
    force = inverse_dynamics(state, p, method, flap_limits).piston_force
    return force / air_load_magnitude(state.q[..., PSI3], p, flap_limits)


def static_force_ratio(
    s, p: DRSParams, flap_limits: tuple[float, float] | None = None
) -> np.ndarray:
    """Quasi-static ``F / |F_air|`` [-] at stroke(s) ``s`` [m] (zero rates: the seed's static
    virtual work): the transmission of the air load to the piston along the stroke."""
    q = solve_position(s, p)
    z = np.zeros_like(q)
    force = inverse_dynamics((q, z, z), p, "virtual-work", flap_limits).piston_force
    return force / air_load_magnitude(q[..., PSI3], p, flap_limits)


class PeakForce(NamedTuple):
    """Largest ``|F|`` along the manoeuvre: the signed force [N], its time [s], stroke [m] and flap
    angle [rad]."""

    force: float
    time: float
    stroke: float
    psi3: float


class Extremum(NamedTuple):
    """A refined extremum: where it is (``x``, a time [s] or a stroke [m]) and its value."""

    x: float
    value: float


def refine_extremum(fun, grid, kind: str = "max") -> Extremum:
    """The largest (``kind="max"``) or smallest (``"min"``) value of ``fun`` over ``grid``,
    refined by bounded Brent between the neighbours of the best sample (``xatol`` 1e-12).

    ``fun`` maps an array of ``x`` to an array of values; of samples within 1e-9 relative of the
    best (a symmetric manoeuvre has twin extrema) the earliest is refined.
    """
    if kind not in ("max", "min"):
        raise InputError(f"kind must be 'max' or 'min', got {kind!r}")
    sign = 1.0 if kind == "max" else -1.0
    grid = np.asarray(grid, dtype=float)
    values = sign * np.asarray(fun(grid), dtype=float)
    top = float(np.max(values))
    k = int(np.flatnonzero(values >= top - 1e-9 * abs(top))[0])
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    best_x, best = float(grid[k]), float(values[k])
    if hi > lo:
        from scipy.optimize import minimize_scalar  # lazy: 0.4 s of import for one refinement

        def negated(x: float) -> float:
            return -sign * float(fun(np.array([x]))[0])

        res = minimize_scalar(negated, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
        if -res.fun > best:
            best_x, best = float(res.x), float(-res.fun)
    return Extremum(best_x, sign * best)


def peak_force(
    p: DRSParams,
    method: str | InverseMethod = "fused",
    n: int = 5001,
    s_limits: tuple[float, float] | None = None,
    flap_limits: tuple[float, float] | None = None,
) -> PeakForce:
    """The peak ``|F|`` along the manoeuvre: a grid of ``n`` samples, refined by bounded Brent
    (:func:`refine_extremum`; of twin peaks, the earlier).

    Raises
    ------
    InputError
        ``n < 3``.
    """
    if int(n) < 3:
        raise InputError(f"n must be >= 3 samples, got {n!r}")
    t = np.linspace(0.0, p.T_total, int(n))
    best = refine_extremum(
        lambda tt: np.abs(manoeuvre_force(tt, p, method, s_limits, flap_limits)), t, "max"
    )
    _, state = manoeuvre_state(np.array([best.x]), p, s_limits)
    f = float(inverse_dynamics(state, p, method, flap_limits).piston_force[0])
    return PeakForce(f, best.x, float(state.q[0, S]), float(state.q[0, PSI3]))
