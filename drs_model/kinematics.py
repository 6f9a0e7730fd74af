r"""Position, velocity and acceleration analysis of the DRS loop (seed 003, "Kinematics").

Closed-form position solution (both assembly branches)
-----------------------------------------------------
With ``s`` independent, C lies on the circle of radius L2 about B = (x_A, y_A + s + L1) and on the
circle of radius L3 about D. With ``d = D - B``, ``rho = |d|``, ``phi_d = atan2(d_y, d_x)``:

.. math::  \cos(\psi_3 - \phi_d) = \frac{\rho^2 + L_3^2 - L_2^2}{2 L_3 \rho}

so ``psi3 = phi_d -+ acos(.)``; branch 1 (the seed's ``kin_sols[1]``) takes the minus sign. Then
``psi1 = atan2(B_x - C_x, C_y - B_y)``. No real solution exists when ``|.| > 1``; the two branches
meet where B, C, D are aligned (``rho = L2 + L3``): the singular strokes
``s = y_D - y_A - L1 -+ sqrt((L2 + L3)^2 - (x_D - x_A)^2)``.

With ``psi3`` independent (the seed's ``psi3_kin_sol``): ``sin psi1 = (x_A - x_D + L3 cos psi3)/L2``
(branch 1: ``cos psi1 > 0``) and ``s = y_D - y_A - L1 - L3 sin psi3 - L2 cos psi1``. This
parametrisation is regular over the whole stroke (``cos psi1`` stays near 1).

The gap (seed: ``comp_Y(PT) - comp_Y(PR)``) depends on psi3 only:
``gap = y_D - (L_wing - d_tip) sin psi3 - R_y``, so ``stroke_for_gap`` is closed form through psi3.

Velocities and accelerations: ``Phi_q qd = 0`` and ``Phi_q qdd = gamma`` solved for the dependent
coordinates; points by rigid-body kinematics of the three bodies.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import elementwise, kernels
from .constraints import (
    PSI1,
    PSI3,
    S,
    constraint,
    constraint_gamma,
    constraint_jacobian,
    jacobian_blocks,
    partition,
    singularity_measure,
)
from .errors import (
    AssemblyError,
    InputError,
    SingularConfigurationError,
    StrokeRangeError,
)
from .kernels import ASSEMBLY_TOL, SINGULAR_TOL, flap_rates, stroke_position, stroke_rates
from .params import DRSParams, check_geometry  # noqa: F401 - check_geometry: public here too

BRANCHES = (1, 2)


class KinematicState(NamedTuple):
    """Coordinates and their first two time derivatives, each of shape ``(..., 3)``."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def _finite(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        bad = float(arr[~np.isfinite(arr)].ravel()[0])
        raise InputError(f"{name} must be finite, got {bad!r}")
    return arr


def _branch(branch: int) -> int:
    if branch not in BRANCHES:
        raise InputError(f"branch must be 1 or 2, got {branch!r}")
    return branch


# ---- position -----------------------------------------------------------------------------------
def solve_position(s, p: DRSParams, branch: int = 1) -> np.ndarray:
    """Closed-form ``q = [s, psi1, psi3]`` for stroke(s) ``s`` [m], shape ``(..., 3)``.

    Raises :class:`AssemblyError` where the loop cannot close (beyond a singular stroke).
    """
    s = _finite("stroke", s)
    sign = 1.0 if _branch(branch) == 1 else -1.0
    sin1, cos1, sin3, cos3, h2 = elementwise.stroke_position(s, p.loop_constants, sign)
    if np.any(h2 < -ASSEMBLY_TOL):
        sing = singular_strokes(p)
        lo, hi = sing[[0, -1]] if sing.size else (np.nan, np.nan)
        bad = float(np.broadcast_to(s, h2.shape)[h2 < -ASSEMBLY_TOL].ravel()[0])
        raise AssemblyError(
            f"the loop cannot close at stroke {bad!r} m: assembly needs {lo:.6g} <= s <= {hi:.6g} m"
        )
    return np.stack(np.broadcast_arrays(s, np.arctan2(sin1, cos1), np.arctan2(sin3, cos3)), -1)


def solve_position_from_flap_angle(psi3, p: DRSParams, branch: int = 1) -> np.ndarray:
    """Closed-form ``q`` for flap angle(s) ``psi3`` [rad] (the seed's ``psi3_kin_sol``).

    Branch 1 has ``cos psi1 > 0`` (the seed's assembly). Shape ``(..., 3)``.
    """
    psi3 = _finite("flap angle", psi3)
    sign = 1.0 if _branch(branch) == 1 else -1.0
    s, sin1, _, cos1_sq = elementwise.flap_position(
        np.sin(psi3), np.cos(psi3), p.loop_constants, sign
    )
    if np.any(cos1_sq < -ASSEMBLY_TOL):
        bad = float(psi3[cos1_sq < -ASSEMBLY_TOL].ravel()[0])
        raise AssemblyError(f"the loop cannot close at flap angle {bad!r} rad: |sin psi1| > 1")
    psi1 = np.arcsin(np.clip(sin1, -1.0, 1.0))
    if sign < 0.0:
        psi1 = math.pi - psi1
    return np.stack(np.broadcast_arrays(s, psi1, psi3), axis=-1)


@dataclass(frozen=True)
class NewtonResult:
    """Outcome of :func:`newton_position` (scipy-like: the solution and a status, no exception)."""

    q: np.ndarray
    converged: bool
    iterations: int
    residual: float  # max |Phi| [m]
    message: str


def newton_position(
    q0,
    p: DRSParams,
    independent: str = "s",
    tol: float = 1e-13,
    maxiter: int = 50,
) -> NewtonResult:
    """Newton-Raphson on ``Phi(q) = 0`` for the dependent coordinates, the independent one fixed.

    ``q0`` (shape ``(..., 3)``) holds the independent value and the initial guess of the others.
    Converges to the branch nearest the guess. Returns the status instead of raising.
    """
    q = _finite("q0", q0).astype(float, copy=True)
    _, dep = partition(independent)
    dep = list(dep)
    res = np.inf
    for it in range(1, maxiter + 1):
        phi = constraint(q, p)
        res = float(np.max(np.abs(phi))) if phi.size else 0.0
        if res <= tol:
            return NewtonResult(q, True, it - 1, res, "converged")
        jd = constraint_jacobian(q, p)[..., dep]
        det = np.linalg.det(jd)
        if np.any(np.abs(det) < 1e-300):
            return NewtonResult(q, False, it, res, "singular dependent Jacobian")
        q[..., dep] -= np.linalg.solve(jd, phi[..., None])[..., 0]
        if not np.all(np.isfinite(q)):
            return NewtonResult(q, False, it, res, "diverged (non-finite iterate)")
    phi = constraint(q, p)
    res = float(np.max(np.abs(phi))) if phi.size else 0.0
    ok = res <= tol
    return NewtonResult(q, ok, maxiter, res, "converged" if ok else "maximum iterations reached")


# ---- singular configurations --------------------------------------------------------------------
def singular_strokes(p: DRSParams) -> np.ndarray:
    """Real strokes [m] where B, C, D align (the s-parametrisation is singular), sorted."""
    return np.array(p.singular_strokes)


def dead_centre(p: DRSParams) -> float:
    """The singular stroke nearest the closed position [m] (about -1.55 mm for the seed)."""
    s_min, _ = stroke_limits(p)
    sing = singular_strokes(p)
    return float(sing[np.argmin(np.abs(sing - s_min))])


def distance_to_singularity(s, p: DRSParams) -> np.ndarray:
    """Stroke distance [m] to the nearest singular stroke."""
    s = _finite("stroke", s)
    sing = singular_strokes(p)
    if sing.size == 0:
        return np.full_like(s, np.inf)
    return np.min(np.abs(s[..., None] - sing), axis=-1)


# ---- velocity and acceleration ------------------------------------------------------------------
def _check_regular(q: np.ndarray, p: DRSParams, independent: str) -> None:
    meas = singularity_measure(q, p, independent)
    if np.any(meas < SINGULAR_TOL):
        bad = np.asarray(q)[meas < SINGULAR_TOL].reshape(-1, 3)[0]
        raise SingularConfigurationError(
            f"{independent!r} cannot be the independent coordinate at q = {bad.tolist()}: the "
            f"dependent Jacobian is singular (measure {float(np.min(meas)):.3g} < {SINGULAR_TOL:g})"
        )


def velocity_ratio(q, p: DRSParams, independent: str = "s", check: bool = True) -> np.ndarray:
    """``dq/dq_I`` (1 at the independent index), shape ``(..., 3)``.

    For ``independent="s"`` the entries 1 and 2 are the seed's ``tau`` (dpsi1/ds, dpsi3/ds [rad/m]).
    """
    q = np.asarray(q, dtype=float)
    i, dep = partition(independent)
    if check:
        _check_regular(q, p, independent)
    ji, jd = jacobian_blocks(q, p, independent)
    tau = -np.linalg.solve(jd, ji)[..., 0]
    out = np.empty(q.shape)
    out[..., i] = 1.0
    out[..., list(dep)] = tau
    return out


def solve_velocity(q, qd_independent, p: DRSParams, independent: str = "s") -> np.ndarray:
    """Full ``qd`` [m/s, rad/s] from the independent rate, shape ``(..., 3)``."""
    qd_i = _finite("independent velocity", qd_independent)
    return velocity_ratio(q, p, independent) * qd_i[..., None]


def solve_acceleration(q, qd, qdd_independent, p: DRSParams, independent: str = "s") -> np.ndarray:
    """Full ``qdd`` from ``Phi_q qdd = gamma`` and the independent acceleration, ``(..., 3)``."""
    q = np.asarray(q, dtype=float)
    qdd_i = _finite("independent acceleration", qdd_independent)
    i, dep = partition(independent)
    _check_regular(q, p, independent)
    ji, jd = jacobian_blocks(q, p, independent)
    rhs = constraint_gamma(q, qd, p) - ji[..., 0] * qdd_i[..., None]
    out = np.empty(np.broadcast_shapes(q.shape, qdd_i.shape + (3,)))
    out[..., i] = qdd_i
    out[..., list(dep)] = np.linalg.solve(jd, rhs[..., None])[..., 0]
    return out


def kinematic_state(s, sd, sdd, p: DRSParams, branch: int = 1) -> KinematicState:
    """``(q, qd, qdd)`` for stroke, stroke rate and stroke acceleration (vectorised)."""
    q = solve_position(s, p, branch)
    qd = solve_velocity(q, sd, p, "s")
    qdd = solve_acceleration(q, qd, sdd, p, "s")
    return KinematicState(q, qd, qdd)


# ---- points -------------------------------------------------------------------------------------
#: Named points: body (0 piston, 1 link, 2 flap, None ground) and a function of p giving the local
#: coordinates in the body frame (piston frame at P, link frame RF1 at B, flap frame RF3 at D).
def point_table(p: DRSParams) -> dict[str, tuple[int | None, tuple[float, float]]]:
    """Named points and where they sit: ``name -> (body, local (x, y) [m])``.

    Bodies: 0 piston (frame at P, not rotating), 1 link (RF1 at B, angle psi1), 2 flap (RF3 at D,
    angle psi3), None ground (ground coordinates).
    """
    xg, yg = p.flap_com_local
    off = p.d_tip - p.L_wing
    return {
        "A": (None, (p.x_A, p.y_A)),
        "D": (None, (p.x_D, p.y_D)),
        "R": (None, p.reference_point),
        "P": (0, (0.0, 0.0)),
        "G1": (0, (0.0, p.L1 / 5.0)),  # seed: RF0a (0, -4/5 L1)
        "B": (0, (0.0, p.L1)),
        "G2": (1, (0.0, p.L2 / 2.0)),
        "C": (1, (0.0, p.L2)),
        "C3": (2, (-p.L3, 0.0)),
        "T": (2, (off, 0.0)),
        "G3": (2, (off + xg, yg)),
    }


POINT_NAMES = ("A", "D", "R", "P", "G1", "B", "G2", "C", "C3", "T", "G3")


def _rotate(angle: np.ndarray, local: tuple[float, float]) -> np.ndarray:
    return np.stack(kernels.rotate(np.cos(angle), np.sin(angle), *local), axis=-1)


def _cross_z(w: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``w k x r`` for planar r of shape (..., 2)."""
    return np.stack([-w * r[..., 1], w * r[..., 0]], axis=-1)


def _body_origin(q: np.ndarray, body: int, p: DRSParams) -> np.ndarray:
    s = q[..., S]
    origin = np.empty(s.shape + (2,))
    if body == 2:
        origin[...] = (p.x_D, p.y_D)
        return origin
    origin[..., 0] = p.x_A
    origin[..., 1] = p.y_A + s + (p.L1 if body == 1 else 0.0)
    return origin


def _body_points(q: np.ndarray, body: int | None, local: np.ndarray, p: DRSParams) -> np.ndarray:
    """Ground positions [m], shape ``(..., k, 2)``, of the points at ``local`` (k, 2) in the frame
    of ``body`` (:func:`point_table`'s numbering; None: the ground) at configuration(s) ``q``."""
    # filled with np.empty and assignments: np.stack and np.broadcast_to cost several times more
    # than the arithmetic on a few points
    out = np.empty(q.shape[:-1] + local.shape)
    if body is None:
        out[...] = local
        return out
    if body == 0:  # the piston translates only
        out[...] = local
    else:
        angle = q[..., PSI1 if body == 1 else PSI3, None]
        out[..., 0], out[..., 1] = kernels.rotate(np.cos(angle), np.sin(angle), *local.T)
    out += _body_origin(q, body, p)[..., None, :]
    return out


def point_positions(q, p: DRSParams, names=POINT_NAMES) -> dict[str, np.ndarray]:
    """Ground positions [m] of the named points, each of shape ``(..., 2)``.

    The points of one body are placed together (:func:`_body_points`): its origin and its turn
    are computed once, so that one configuration (the node draws one every marker tick) costs a
    few small numpy operations per body rather than per point."""
    q = np.asarray(q, dtype=float)
    table = point_table(p)
    bodies: dict[int | None, list[str]] = {}
    for name in names:
        bodies.setdefault(table[name][0], []).append(name)
    out = {}
    for body, members in bodies.items():
        ground = _body_points(q, body, np.array([table[name][1] for name in members]), p)
        out.update((name, ground[..., k, :]) for k, name in enumerate(members))
    return out


def point_accelerations(q, qd, qdd, p: DRSParams, names=POINT_NAMES) -> dict[str, np.ndarray]:
    """Ground accelerations [m/s^2] of the named points, each ``(..., 2)``."""
    q, qd, qdd = (np.asarray(x, dtype=float) for x in (q, qd, qdd))
    table = point_table(p)
    out = {}
    zero = np.zeros(np.broadcast_shapes(q.shape, qd.shape, qdd.shape)[:-1] + (2,))
    ap = zero + np.stack([np.zeros_like(qdd[..., S]), qdd[..., S]], axis=-1)
    for name in names:
        body, local = table[name]
        if body is None:
            out[name] = zero.copy()
            continue
        if body == 0:
            out[name] = ap.copy()
            continue
        k = PSI1 if body == 1 else PSI3
        r = _rotate(q[..., k], local)
        rel = _cross_z(qdd[..., k], r) - (qd[..., k] ** 2)[..., None] * r
        out[name] = (ap if body == 1 else zero) + rel
    return out


def point_jacobian(name: str, q, p: DRSParams) -> np.ndarray:
    """``d r_point / dq``, shape ``(..., 2, 3)`` (so that ``v = J qd``)."""
    q = np.asarray(q, dtype=float)
    body, local = point_table(p)[name]
    jac = np.zeros(q.shape[:-1] + (2, 3))
    if body is None:
        return jac
    if body in (0, 1):
        jac[..., 1, S] = 1.0
    if body in (1, 2):
        k = PSI1 if body == 1 else PSI3
        r = _rotate(q[..., k], local)
        jac[..., 0, k] = -r[..., 1]
        jac[..., 1, k] = r[..., 0]
    return jac


def flap_outline(q, p: DRSParams) -> np.ndarray:
    """Flap-wing outline in ground [m], shape ``(..., n, 2)``."""
    return _body_points(np.asarray(q, dtype=float), 2, _flap_outline_local(p), p)


@functools.lru_cache(maxsize=8)
def _flap_outline_local(p: DRSParams) -> np.ndarray:
    """The flap outline (n, 2) [m] in the flap frame RF3 (at D; the outline's own frame is
    ``L_wing - d_tip`` further, as T), read-only: made once per parameter set, not per drawing."""
    local = np.asarray(p.flap_outline) + np.array([p.d_tip - p.L_wing, 0.0])
    local.flags.writeable = False
    return local


def main_wing_outline(p: DRSParams) -> np.ndarray:
    """Main-wing outline in ground [m], shape ``(n, 2)`` (fixed)."""
    local = np.asarray(p.main_wing_outline)
    x, y = kernels.rotate(math.cos(p.gamma), math.sin(p.gamma), local[:, 0], local[:, 1])
    return np.stack([p.d_wing + x, y], axis=-1)


# ---- gap, limits, workspace ---------------------------------------------------------------------
def gap_from_flap_angle(psi3, p: DRSParams) -> np.ndarray:
    """Gap ``T_y - R_y`` [m] for flap angle(s) psi3 [rad]."""
    return kernels.flap_gap(np.sin(np.asarray(psi3, dtype=float)), *p.gap_constants)


def gap(q, p: DRSParams) -> np.ndarray:
    """Gap ``comp_Y(PT) - comp_Y(PR)`` [m] of configuration(s) q."""
    return gap_from_flap_angle(np.asarray(q, dtype=float)[..., PSI3], p)


def flap_angle_for_gap(gap_m, p: DRSParams) -> np.ndarray:
    """Flap angle psi3 [rad] (in (-pi/2, pi/2)) giving the gap [m]; closed form."""
    g = _finite("gap", gap_m)
    gap0, tip = p.gap_constants
    sin3 = kernels.flap_sine_for_gap(g, gap0, tip)
    if np.any(np.abs(sin3) > 1.0):
        bad = float(g[np.abs(sin3) > 1.0].ravel()[0])
        raise StrokeRangeError(
            f"gap {bad!r} m is unreachable: the flap tip spans {gap0 - tip:.6g}..{gap0 + tip:.6g} m"
        )
    return np.arcsin(sin3)


def stroke_for_gap(gap_m, p: DRSParams) -> np.ndarray:
    """Stroke s [m] giving the gap [m], through psi3 in closed form (branch 1)."""
    return solve_position_from_flap_angle(flap_angle_for_gap(gap_m, p), p)[..., S]


def stroke_limits(p: DRSParams) -> tuple[float, float]:
    """``(s_min, s_max)`` [m]: strokes of the closed (gap_closed) and open (gap_open) flap."""
    s = stroke_for_gap(np.array([p.gap_closed, p.gap_open]), p)
    return float(s[0]), float(s[1])


def flap_angle_limits(p: DRSParams) -> tuple[float, float]:
    """``(psi3_closed, psi3_open)`` [rad]; the closed flap has the larger angle."""
    a = flap_angle_for_gap(np.array([p.gap_closed, p.gap_open]), p)
    return float(a[0]), float(a[1])


def check_stroke(s, p: DRSParams, tol: float = 1e-12) -> np.ndarray:
    """Return ``s`` as an array if every value lies in ``[s_min, s_max]`` (within tol)."""
    s = _finite("stroke", s)
    lo, hi = stroke_limits(p)
    bad = (s < lo - tol) | (s > hi + tol)
    if np.any(bad):
        raise StrokeRangeError(
            f"stroke {float(s[bad].ravel()[0])!r} m is outside "
            f"[s_min, s_max] = [{lo:.9g}, {hi:.9g}] m"
        )
    return s


def workspace_traces(p: DRSParams, n: int = 50) -> dict[str, np.ndarray]:
    """Traces of B and C [m] over the working stroke (the seed's ``space_B``/``space_C``)."""
    lo, hi = stroke_limits(p)
    q = solve_position(np.linspace(lo, hi, n), p)
    pts = point_positions(q, p, ("B", "C"))
    return {"s": q[:, S], "B": pts["B"], "C": pts["C"]}


# ---- scalar fast paths (math only; for per-step use in a real-time loop) -------------------------
def kinematic_state_scalar(
    s: float, sd: float, sdd: float, p: DRSParams
) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]:
    """:func:`kinematic_state` for one sample on branch 1 with ``math`` only (no numpy overhead).

    Returns ``(q, qd, qdd)`` as tuples. Raises like the vectorised version.
    """
    if not (math.isfinite(s) and math.isfinite(sd) and math.isfinite(sdd)):
        raise InputError(f"stroke, rate and acceleration must be finite, got {(s, sd, sdd)!r}")
    c = p.loop_constants
    sin1, cos1, sin3, cos3, h2 = stroke_position(s, c, 1.0)
    if h2 < -ASSEMBLY_TOL:
        solve_position(s, p)  # raises the AssemblyError with the admissible range
    psi1, psi3 = math.atan2(sin1, cos1), math.atan2(sin3, cos3)
    tau1, tau3, a1, a3 = stroke_rates(sin1, cos1, sin3, cos3, sd, sdd, c)
    if math.isnan(tau1):
        _check_regular(np.array([s, psi1, psi3]), p, "s")
    return (s, psi1, psi3), (sd, tau1 * sd, tau3 * sd), (sdd, a1, a3)


def accelerations_from_flap_scalar(
    q, qd, psi3dd: float, p: DRSParams
) -> tuple[float, float, float]:
    """``qdd`` for one sample given the flap acceleration [rad/s^2] (``psi3`` independent):
    ``qdd = u psi3'' + w psi3'^2`` with ``u = dq/dpsi3``, ``w = du/dpsi3`` at ``q``."""
    _, psi1, psi3 = q
    w3 = qd[2]
    u0, u1, w0, w1 = flap_rates(
        math.sin(psi1), math.cos(psi1), math.sin(psi3), math.cos(psi3), p.loop_constants
    )
    return (u0 * psi3dd + w0 * w3 * w3, u1 * psi3dd + w1 * w3 * w3, psi3dd)
