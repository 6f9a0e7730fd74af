"""Kinematics the tests use as independent references and the product does not: a Newton solve
that raises, the singular configurations, the state with the flap angle independent, and the
ground velocities of named points (each built from :mod:`drs_model.kinematics`'s public parts)."""

from __future__ import annotations

import numpy as np

from drs_model import kinematics as kin
from drs_model.errors import ConvergenceError
from drs_model.params import DRSParams


def solve_position_newton(s, q_guess, p: DRSParams, tol: float = 1e-13) -> np.ndarray:
    """Like :func:`newton_position` with ``s`` independent, raising :class:`ConvergenceError`."""
    q0 = np.array(q_guess, dtype=float, copy=True)
    q0[..., kin.S] = s
    out = kin.newton_position(q0, p, "s", tol=tol)
    if not out.converged:
        raise ConvergenceError(
            f"Newton position solve failed at s={s!r} m: {out.message} "
            f"(|Phi| = {out.residual:.3g} m)"
        )
    return out.q


def singular_configurations(p: DRSParams) -> np.ndarray:
    """``q`` at each real singular stroke, shape ``(n, 3)`` (branches 1 and 2 coincide there)."""
    s = kin.singular_strokes(p)
    return kin.solve_position(s, p, branch=1) if s.size else np.zeros((0, 3))


def kinematic_state_from_flap(
    psi3, psi3d, psi3dd, p: DRSParams, branch: int = 1
) -> kin.KinematicState:
    """``(q, qd, qdd)`` with the flap angle as the independent coordinate (regular everywhere)."""
    q = kin.solve_position_from_flap_angle(psi3, p, branch)
    qd = kin.solve_velocity(q, psi3d, p, "psi3")
    qdd = kin.solve_acceleration(q, qd, psi3dd, p, "psi3")
    return kin.KinematicState(q, qd, qdd)


def point_velocities(q, qd, p: DRSParams, names=kin.POINT_NAMES) -> dict[str, np.ndarray]:
    """Ground velocities [m/s] of the named points, each ``(..., 2)``."""
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    table = kin.point_table(p)
    out = {}
    zero = np.zeros(np.broadcast_shapes(q.shape, qd.shape)[:-1] + (2,))
    vp = zero + np.stack([np.zeros_like(qd[..., kin.S]), qd[..., kin.S]], axis=-1)
    for name in names:
        body, local = table[name]
        if body is None:
            out[name] = zero.copy()
        elif body == 0:
            out[name] = vp.copy()
        elif body == 1:
            out[name] = vp + kin._cross_z(qd[..., kin.PSI1], kin._rotate(q[..., kin.PSI1], local))
        else:
            out[name] = zero + kin._cross_z(qd[..., kin.PSI3], kin._rotate(q[..., kin.PSI3], local))
    return out
