"""The scalar kernels of the full-coordinate formulations (c) and (d) of
:mod:`drs_model.forward.formulations`: the KKT system solved by the Schur complement, and the
M-metric projection onto the constraints."""

from __future__ import annotations

import math
from collections.abc import Callable

from .. import kernels
from ..kernels import generalised_forces, loop_gamma, loop_residual, loop_velocity


def make_full_kernel(c: tuple[float, ...]) -> tuple[Callable, Callable]:
    """Scalar kernels of the full-coordinate formulations for the constants ``c``
    (:func:`drs_model.bodies.model_constants`).

    Returns ``accel(y, F, alpha, beta) -> (sdd, psi1dd, psi3dd)`` solving the KKT system of (c)
    by the Schur complement, and ``project(y, tol, maxiter) -> y`` (formulation (d)).
    """
    k = kernels
    L2, L3, m_l, hl2, M11, M22 = c[k.L2], c[k.L3], c[k.M2], 0.5 * c[k.L2], c[k.M11], c[k.M22]
    m_ps = c[k.M1] + m_l
    sin, cos = math.sin, math.cos

    def _schur(sa, ca, sb, cb):
        # M^-1 for the (s, psi1) block and psi3
        m01 = -m_l * hl2 * sa
        det2 = m_ps * M11 - m01 * m01
        i00, i01, i11, i22 = M11 / det2, -m01 / det2, m_ps / det2, 1.0 / M22
        # J rows: r1 = [0, L2 ca, L3 sb], r2 = [-1, L2 sa, -L3 cb]; X = M^-1 J^T (columns)
        x10, x11, x12 = i01 * L2 * ca, i11 * L2 * ca, i22 * L3 * sb
        x20, x21, x22 = -i00 + i01 * L2 * sa, -i01 + i11 * L2 * sa, -i22 * L3 * cb
        a11 = L2 * ca * x11 + L3 * sb * x12
        a12 = L2 * ca * x21 + L3 * sb * x22
        a22 = -x20 + L2 * sa * x21 - L3 * cb * x22
        return (i00, i01, i11, i22), (x10, x11, x12, x20, x21, x22), (a11, a12, a22)

    def accel(y, force: float, alpha: float, beta: float):
        s, a, b, sd, ad, bd = y
        sa, ca, sb, cb = sin(a), cos(a), sin(b), cos(b)
        (i00, i01, i11, i22), (x10, x11, x12, x20, x21, x22), (a11, a12, a22) = _schur(
            sa, ca, sb, cb
        )
        f0, f1, f2 = generalised_forces(sa, sb, cb, b, c)
        f0 += force + m_l * hl2 * ca * ad * ad  # Q - h
        z0, z1, z2 = i00 * f0 + i01 * f1, i01 * f0 + i11 * f1, i22 * f2  # M^-1 (Q - h)
        gam1, gam2 = loop_gamma(sa, ca, sb, cb, ad, bd, c)
        if alpha != 0.0 or beta != 0.0:
            pd1, pd2 = loop_velocity(sd, sa, ca, sb, cb, ad, bd, c)
            p1, p2 = loop_residual(s, sa, ca, sb, cb, c)
            gam1 -= 2.0 * alpha * pd1 + beta * beta * p1
            gam2 -= 2.0 * alpha * pd2 + beta * beta * p2
        # (Phi_q M^-1 Phi_q^T) lambda = Phi_q M^-1 (Q - h) - gamma, then qdd = M^-1 (Q - h - Phi_q^T
        # lambda): lambda is the multiplier of M qdd + h + Phi_q^T lambda = Q
        r1 = (L2 * ca * z1 + L3 * sb * z2) - gam1
        r2 = (-z0 + L2 * sa * z1 - L3 * cb * z2) - gam2
        det = a11 * a22 - a12 * a12
        lam1 = (a22 * r1 - a12 * r2) / det
        lam2 = (a11 * r2 - a12 * r1) / det
        return (
            z0 - x10 * lam1 - x20 * lam2,
            z1 - x11 * lam1 - x21 * lam2,
            z2 - x12 * lam1 - x22 * lam2,
        )

    def _correction(sa, ca, sb, cb, v1, v2):
        """``M^-1 Phi_q^T (Phi_q M^-1 Phi_q^T)^-1 v``: the M-metric projection's step."""
        _, (x10, x11, x12, x20, x21, x22), (a11, a12, a22) = _schur(sa, ca, sb, cb)
        det = a11 * a22 - a12 * a12
        l1 = (a22 * v1 - a12 * v2) / det
        l2 = (a11 * v2 - a12 * v1) / det
        return x10 * l1 + x20 * l2, x11 * l1 + x21 * l2, x12 * l1 + x22 * l2

    def project(y, tol: float = 1e-15, maxiter: int = 6):
        s, a, b, sd, ad, bd = (float(v) for v in y)
        for _ in range(maxiter):
            sa, ca, sb, cb = sin(a), cos(a), sin(b), cos(b)
            p1, p2 = loop_residual(s, sa, ca, sb, cb, c)
            d0, d1, d2 = _correction(sa, ca, sb, cb, p1, p2)
            s, a, b = s - d0, a - d1, b - d2
            if max(abs(p1), abs(p2)) <= tol:
                break
        sa, ca, sb, cb = sin(a), cos(a), sin(b), cos(b)
        d0, d1, d2 = _correction(sa, ca, sb, cb, *loop_velocity(sd, sa, ca, sb, cb, ad, bd, c))
        return s, a, b, sd - d0, ad - d1, bd - d2

    return accel, project
