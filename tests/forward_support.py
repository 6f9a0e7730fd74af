"""Forward-dynamics references for the tests: the right-hand sides of the formulations from the
numpy library functions (slow), against which the scalar kernels are checked."""

from __future__ import annotations

import numpy as np

from drs_model.bodies import applied_forces, mass_matrix, velocity_forces
from drs_model.constraints import constraint, constraint_gamma, constraint_jacobian
from drs_model.forward.formulations import Formulation, FullCoordinates, Psi3Minimal, StrokeMinimal
from drs_model.kinematics import (
    solve_acceleration,
    solve_position,
    solve_position_from_flap_angle,
    velocity_ratio,
)


def reference_rhs(formulation: Formulation, t: float, y: np.ndarray, force: float) -> np.ndarray:
    """The right-hand side of ``formulation`` from the numpy library functions (slow, for tests).

    (a)/(b): ``x'' = u.(Q - M w x'^2 - h(q, u) x'^2)/(u.M.u)`` with ``u`` from
    :func:`velocity_ratio` and ``w`` from :func:`solve_acceleration`; (c)/(d): the 5 x 5 KKT system
    with :func:`mass_matrix`, :func:`velocity_forces`, :func:`applied_forces`,
    :func:`constraint_jacobian`, :func:`constraint_gamma`.
    """
    p, fl = formulation.p, formulation.flap_limits
    y = np.asarray(y, dtype=float)
    if isinstance(formulation, (Psi3Minimal, StrokeMinimal)):
        ind = "psi3" if isinstance(formulation, Psi3Minimal) else "s"
        q = solve_position_from_flap_angle(y[0], p) if ind == "psi3" else solve_position(y[0], p)
        u = velocity_ratio(q, p, ind)
        w = solve_acceleration(q, u, 0.0, p, ind)
        m = mass_matrix(q, p)
        qq = applied_forces(q, force, p, fl)
        num = u @ qq - y[1] ** 2 * (u @ m @ w + u @ velocity_forces(q, u, p))
        return np.array([y[1], num / (u @ m @ u)])
    q, qd = y[:3], y[3:]
    m = mass_matrix(q, p)
    jac = constraint_jacobian(q, p)
    gam = constraint_gamma(q, qd, p)
    if isinstance(formulation, FullCoordinates) and (formulation.alpha or formulation.beta):
        gam = gam - 2 * formulation.alpha * (jac @ qd) - formulation.beta**2 * constraint(q, p)
    kkt = np.zeros((5, 5))
    kkt[:3, :3], kkt[:3, 3:], kkt[3:, :3] = m, jac.T, jac
    rhs = np.concatenate([applied_forces(q, force, p, fl) - velocity_forces(q, qd, p), gam])
    sol = np.linalg.solve(kkt, rhs)
    return np.concatenate([qd, sol[:3]])
