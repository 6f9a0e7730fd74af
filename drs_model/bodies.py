r"""Bodies, mass properties and applied forces of the DRS mechanism (seed 003, "Dynamics").

Three rigid bodies in the full coordinates ``q = [s, psi1, psi3]``:

* piston: mass ``m_pist`` at G1 (RF0a (0, -4/5 L1), i.e. L1/5 above P), translates along y,
  ``Iz_pist``;
* link: mass ``m_link`` at G2 (mid-link), angle psi1, ``Iz_link`` about G2;
* flap wing: mass ``m_wing`` at G3 (mean of the flap outline points, the seed's ``getCoM``), turning
  about the fixed pivot D with angle psi3, ``Iz_wing`` about G3.

With ``J_G`` the Jacobian of a centre of mass and ``e_k`` the unit vector of a body's angle:

.. math::

    M(q) = \sum_b m_b J_{G_b}^T J_{G_b} + I_b e_{k_b} e_{k_b}^T, \qquad
    h(q, \dot q) = \sum_b m_b J_{G_b}^T \dot J_{G_b} \dot q

so that the equations of motion read ``M qdd + h = Q(q, F) + Phi_q^T lambda``. Only the link has a
velocity term (the flap turns about a fixed point and the piston translates): ``h = -m_link J_G2^T
psi1'^2 r_G2`` with ``r_G2 = G2 - B``.

Applied forces ``Q``: gravity ``(0, -m g)`` at each centre of mass; the piston force ``F`` along
y of RF0 at P (generalised force ``F e_s``); the air force ``(F_drag, -F_down)`` at G3, each
linear in psi3 between its closed and open values (the seed's ``air_forces_law``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import kernels
from .constraints import PSI1, PSI3, S
from .kinematics import flap_angle_limits, point_jacobian, point_positions, point_table
from .params import DRSParams


class Body(NamedTuple):
    name: str
    com: str  # point name of the centre of mass
    mass: float  # kg
    inertia: float  # kg m^2 about the centre of mass
    angle: int | None  # index of its angle in q, None if it does not rotate


def bodies(p: DRSParams) -> tuple[Body, Body, Body]:
    """The piston, the link and the flap wing of ``p``."""
    return (
        Body("piston", "G1", p.m_pist, p.Iz_pist, None),
        Body("link", "G2", p.m_link, p.Iz_link, PSI1),
        Body("flap", "G3", p.m_wing, p.Iz_wing, PSI3),
    )


def model_constants(
    p: DRSParams, flap_limits: tuple[float, float] | None = None
) -> tuple[float, ...]:
    """The constants vector of the kernels of :mod:`drs_model.kernels` (indexed ``XA`` ...
    ``YB`` there): geometry, mass properties and the air law of ``p``.

    ``flap_limits = (psi3_closed, psi3_open)`` [rad] of the air law defaults to our exact
    gap-rule angles.
    """
    psi_c, psi_o = flap_angle_limits(p) if flap_limits is None else flap_limits
    xg, yg = p.flap_com_local
    gx, gy = p.d_tip - p.L_wing + xg, yg  # G3 in RF3 (at D)
    points = point_table(p)  # G1 and B in the piston frame (at P)
    dpsi = psi_c - psi_o
    out = (
        *p.loop_constants,
        gx,
        gy,
        p.m_pist,
        p.m_link,
        p.m_wing,
        p.Iz_link,
        p.Iz_wing,
        p.g,
        p.F_drag_open,
        (p.F_drag_closed - p.F_drag_open) / dpsi,
        p.F_down_open,
        (p.F_down_closed - p.F_down_open) / dpsi,
        psi_o,
        p.m_link * p.L2**2 / 4.0 + p.Iz_link,
        p.m_wing * (gx * gx + gy * gy) + p.Iz_wing,
        points["G1"][1][1],
        points["B"][1][1],
    )
    return tuple(float(x) for x in out)


def _com_offset(q: np.ndarray, p: DRSParams, body: Body) -> np.ndarray:
    """Centre of mass relative to the body's rotation centre (B or D) [m], ``(..., 2)``."""
    _, local = point_table(p)[body.com]
    angle = q[..., body.angle]
    return np.stack(kernels.rotate(np.cos(angle), np.sin(angle), *local), axis=-1)


def mass_matrix(q, p: DRSParams) -> np.ndarray:
    """Mass matrix ``M(q)`` [kg, kg m, kg m^2], shape ``(..., 3, 3)`` (symmetric, constant in s
    and psi3)."""
    q = np.asarray(q, dtype=float)
    m = np.zeros(q.shape[:-1] + (3, 3))
    for b in bodies(p):
        jac = point_jacobian(b.com, q, p)
        m += b.mass * np.einsum("...ki,...kj->...ij", jac, jac)
        if b.angle is not None:
            m[..., b.angle, b.angle] += b.inertia
    return m


def velocity_forces(q, qd, p: DRSParams) -> np.ndarray:
    """Quadratic velocity terms ``h(q, qd) = sum m J^T Jdot qd`` [N, N m], shape ``(..., 3)``."""
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    h = np.zeros(np.broadcast_shapes(q.shape, qd.shape))
    for b in bodies(p):
        if b.angle is None:
            continue
        r = _com_offset(q, p, b)
        jac = point_jacobian(b.com, q, p)
        acc_bias = -(qd[..., b.angle] ** 2)[..., None] * r  # centripetal acceleration of the CoM
        h += b.mass * np.einsum("...ki,...k->...i", jac, acc_bias)
    return h


def air_forces(psi3, p: DRSParams, flap_limits: tuple[float, float] | None = None):
    """Drag and downforce [N] at flap angle(s) psi3 [rad], linear in psi3 (seed's law).

    ``flap_limits = (psi3_closed, psi3_open)`` defaults to our exact gap-rule angles; pass the
    seed's printed ones to reproduce its numbers. Outside the range the law extrapolates, as the
    seed's does.
    """
    return kernels.air_load(np.asarray(psi3, dtype=float), model_constants(p, flap_limits))


def applied_forces(
    q, piston_force, p: DRSParams, flap_limits: tuple[float, float] | None = None
) -> np.ndarray:
    """Generalised applied forces ``Q`` [N, N m] of gravity, piston force [N] and air,
    shape ``(..., 3)``."""
    q = np.asarray(q, dtype=float)
    f = np.asarray(piston_force, dtype=float)
    shape = np.broadcast_shapes(q.shape[:-1], f.shape) + (3,)
    out = np.zeros(shape)
    for b in bodies(p):
        jac = point_jacobian(b.com, q, p)
        out += -b.mass * p.g * jac[..., 1, :]
    drag, down = air_forces(q[..., PSI3], p, flap_limits)
    jac3 = point_jacobian("G3", q, p)
    out += jac3[..., 0, :] * drag[..., None] - jac3[..., 1, :] * down[..., None]
    out[..., S] += f
    return out


def kinetic_energy(q, qd, p: DRSParams) -> np.ndarray:
    """Kinetic energy [J]."""
    qd = np.asarray(qd, dtype=float)
    return 0.5 * np.einsum("...i,...ij,...j->...", qd, mass_matrix(q, p), qd)


def potential_energy(q, p: DRSParams) -> np.ndarray:
    """Gravitational potential energy [J] (zero at y = 0)."""
    pts = point_positions(q, p, ("G1", "G2", "G3"))
    return p.g * sum(b.mass * pts[b.com][..., 1] for b in bodies(p))
