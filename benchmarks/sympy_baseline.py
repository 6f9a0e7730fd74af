"""The route a user would otherwise take: sympy.physics.mechanics + lambdify + numpy/scipy.

Built independently of drs_model's equations (only the numbers of :class:`DRSParams` are shared):
the mechanism of seed 003 is modelled from scratch in ``sympy.physics.mechanics`` with
``q = [s, psi1, psi3]``, the three bodies, gravity, the piston force, the air law and the two
holonomic loop constraints, and ``LagrangesMethod`` forms

    M(q) qdd + h(q, qd) + Phi_q^T lambda = Q(q, F)        (sympy's sign: lam_coeffs = -Phi_q)

Everything is lambdified with numpy and ``cse=True``:

* ``inverse_force(q, qd, qdd)`` - the piston force [N]: the equations are linear in
  ``(F, lambda1, lambda2)``; their 3 x 3 coefficient matrix and right-hand side are lambdified and
  solved per sample (batched ``numpy.linalg.solve``).
* ``index1_accelerations(q, qd, F)`` - forward dynamics in full coordinates, index 1:
  ``[[M, Phi_q^T], [Phi_q, 0]] [qdd; lambda] = [Q - h; gamma]``.
* ``rhs(t, y, force)`` - ``y = [q, qd]`` (6 states) for ``scipy.integrate.solve_ivp``; ``force``
  is a float or a callable of t.
* ``kinematics(s, sd, sdd)`` - the loop closed numerically as a user would: vectorised Newton on
  the lambdified ``Phi`` from a guess interpolated between the seed's printed closed and open
  configurations, then ``Phi_q qd = 0`` and ``Phi_q qdd = gamma`` for the dependent rates.

``build_baseline(p)`` derives once per parameter set and process (``functools.lru_cache``; a
frozen ``DRSParams`` is hashable) and records the derivation time in ``build_time`` [s].

Import from tests with ``sys.path.insert(0, "benchmarks")`` or as ``benchmarks.sympy_baseline``.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sm
import sympy.physics.mechanics as me

from drs_model.params import DRSParams

# the seed's printed closed and open configurations (2.3.7.3): the user's Newton starting guesses
_SEED_CLOSED = (0.0001994128, -0.1706753036, 1.087075800)
_SEED_OPEN = (0.04607560011, 0.6514412053, 0.5487704485)


@dataclass(frozen=True, eq=False)
class Baseline:
    """Lambdified sympy model of the DRS mechanism (see the module docstring)."""

    params: DRSParams
    build_time: float  # [s] symbolic derivation + lambdify
    _coeffs: Callable  # (q, qd, qdd) -> flat A (3x3) and b (3) of the inverse problem
    _index1: Callable  # (q, qd, F) -> flat augmented matrix (5x5) and right-hand side (5)
    _phi: Callable  # q -> Phi (2), Phi_q (2x3)
    _gamma: Callable  # (q, qd) -> gamma (2)

    # ---- helpers ------------------------------------------------------------------------------
    @staticmethod
    def _args(*arrays):
        cols = []
        for a in arrays:
            a = np.asarray(a, dtype=float)
            cols += [a[..., k] for k in range(a.shape[-1])] if a.ndim and a.shape[-1] == 3 else [a]
        return cols

    @staticmethod
    def _stack(values, shape, lead):
        # lambdify returns scalars for constant entries: broadcast before stacking
        out = np.empty(lead + (len(values),))
        for k, v in enumerate(values):
            out[..., k] = v
        return out.reshape(lead + shape)

    # ---- public API ---------------------------------------------------------------------------
    def inverse_force(self, q, qd, qdd) -> np.ndarray:
        """Piston force [N] for ``q, qd, qdd`` of shape ``(..., 3)`` (consistent with the loop)."""
        q = np.asarray(q, dtype=float)
        lead = q.shape[:-1]
        vals = self._coeffs(*self._args(q, qd, qdd))
        a = self._stack(vals[:9], (3, 3), lead)
        b = self._stack(vals[9:], (3,), lead)
        return np.linalg.solve(a, b[..., None])[..., 0, 0]

    def index1_accelerations(self, q, qd, force, return_multipliers: bool = False):
        """``qdd`` (and ``lambda``) of the index-1 equations for piston force ``force`` [N].

        Shapes: ``q, qd`` ``(..., 3)``, ``force`` broadcastable to ``(...)``.
        """
        q = np.asarray(q, dtype=float)
        lead = np.broadcast_shapes(q.shape[:-1], np.shape(force))
        vals = self._index1(*self._args(q, qd), np.asarray(force, dtype=float))
        a = self._stack(vals[:25], (5, 5), lead)
        b = self._stack(vals[25:], (5,), lead)
        x = np.linalg.solve(a, b[..., None])[..., 0]
        return (x[..., :3], x[..., 3:]) if return_multipliers else x[..., :3]

    def rhs(self, t: float, y, force) -> np.ndarray:
        """``dy/dt`` for ``y = [q, qd]`` (shape ``(6,)`` or ``(6, k)`` as solve_ivp vectorized).

        ``force`` is a float [N] or a callable ``force(t)``.
        """
        y = np.asarray(y, dtype=float)
        f = force(t) if callable(force) else force
        q, qd = np.moveaxis(y[:3], 0, -1), np.moveaxis(y[3:], 0, -1)
        qdd = self.index1_accelerations(q, qd, f)
        return np.concatenate([y[3:], np.moveaxis(qdd, -1, 0)], axis=0)

    def constraint(self, q) -> np.ndarray:
        """``Phi(q)`` [m], shape ``(..., 2)``."""
        q = np.asarray(q, dtype=float)
        vals = self._phi(*self._args(q))
        return self._stack(vals[:2], (2,), q.shape[:-1])

    def kinematics(self, s, sd, sdd, tol: float = 1e-14, maxiter: int = 30):
        """``(q, qd, qdd)`` for stroke ``s`` [m], rate and acceleration (vectorised Newton)."""
        s, sd, sdd = (np.atleast_1d(np.asarray(x, dtype=float)) for x in (s, sd, sdd))
        c, o = np.array(_SEED_CLOSED), np.array(_SEED_OPEN)
        w = ((s - c[0]) / (o[0] - c[0]))[..., None]
        q = c + w * (o - c)
        q[..., 0] = s
        for _ in range(maxiter):
            vals = self._phi(*self._args(q))
            phi = self._stack(vals[:2], (2,), q.shape[:-1])
            jac = self._stack(vals[2:], (2, 3), q.shape[:-1])
            if np.max(np.abs(phi)) < tol:
                break
            q[..., 1:] -= np.linalg.solve(jac[..., 1:], phi[..., None])[..., 0]
        else:
            raise ArithmeticError("baseline Newton position solve did not converge")
        jac = self._stack(self._phi(*self._args(q))[2:], (2, 3), q.shape[:-1])
        qd = np.empty_like(q)
        qd[..., 0] = sd
        qd[..., 1:] = np.linalg.solve(jac[..., 1:], -jac[..., :, :1] * sd[..., None, None])[..., 0]
        gam = self._stack(self._gamma(*self._args(q, qd)), (2,), q.shape[:-1])
        qdd = np.empty_like(q)
        qdd[..., 0] = sdd
        rhs = gam - jac[..., :, 0] * sdd[..., None]
        qdd[..., 1:] = np.linalg.solve(jac[..., 1:], rhs[..., None])[..., 0]
        return q, qd, qdd


def _derive(p: DRSParams, flap_limits: tuple[float, float] | None) -> Baseline:
    t0 = time.perf_counter()
    t = me.dynamicsymbols._t
    s, psi1, psi3 = me.dynamicsymbols("s psi1 psi3")
    sd, psi1d, psi3d = me.dynamicsymbols("s psi1 psi3", 1)
    F = me.dynamicsymbols("F")
    xA, yA, xD, yD, L1, L2, L3 = sm.symbols("x_A y_A x_D y_D L1 L2 L3")
    Lw, dtip, xg, yg, g = sm.symbols("L_wing d_tip x_G3 y_G3 g")
    m1, m2, m3, I1, I2, I3 = sm.symbols("m_pist m_link m_wing Iz_pist Iz_link Iz_wing")
    Fdc, Fdo, Fnc, Fno, pc, po = sm.symbols("F_dc F_do F_nc F_no psi3_c psi3_o")

    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    # piston: RF0 at A, rod along N.y by s; G1 = RF0a (0, -4/5 L1) with RF0a at s + L1
    A = O.locatenew("A", xA * N.x + yA * N.y)
    A.set_vel(N, 0)
    P = A.locatenew("P", s * N.y)
    P.set_vel(N, sd * N.y)
    G1 = P.locatenew("G1", (L1 / 5) * N.y)
    G1.set_vel(N, sd * N.y)
    B = P.locatenew("B", L1 * N.y)
    B.set_vel(N, sd * N.y)
    # link: RF1 = RF0a . rotate(psi1), C at (0, L2)
    R1 = N.orientnew("R1", "Axis", [psi1, N.z])
    R1.set_ang_vel(N, psi1d * N.z)
    G2 = B.locatenew("G2", (L2 / 2) * R1.y)
    G2.v2pt_theory(B, N, R1)
    C = B.locatenew("C", L2 * R1.y)
    # flap: RF3 at D rotated psi3; C3 at (-L3, 0); G3 at (-L_wing + d_tip + x_G3, y_G3)
    R3 = N.orientnew("R3", "Axis", [psi3, N.z])
    R3.set_ang_vel(N, psi3d * N.z)
    D = O.locatenew("D", xD * N.x + yD * N.y)
    D.set_vel(N, 0)
    C3 = D.locatenew("C3", -L3 * R3.x)
    G3 = D.locatenew("G3", (-Lw + dtip + xg) * R3.x + yg * R3.y)
    G3.v2pt_theory(D, N, R3)

    piston = me.RigidBody("piston", G1, N, m1, (me.inertia(N, 0, 0, I1), G1))
    link = me.RigidBody("link", G2, R1, m2, (me.inertia(R1, 0, 0, I2), G2))
    flap = me.RigidBody("flap", G3, R3, m3, (me.inertia(R3, 0, 0, I3), G3))
    piston.potential_energy = m1 * g * G1.pos_from(O).dot(N.y)
    link.potential_energy = m2 * g * G2.pos_from(O).dot(N.y)
    flap.potential_energy = m3 * g * G3.pos_from(O).dot(N.y)
    lag = me.Lagrangian(N, piston, link, flap)

    u = (psi3 - po) / (pc - po)
    drag = Fdo + (Fdc - Fdo) * u
    down = Fno + (Fnc - Fno) * u
    forces = [(P, F * N.y), (G3, drag * N.x - down * N.y)]
    loop = C3.pos_from(O) - C.pos_from(O)
    phi = sm.Matrix([loop.dot(N.x), loop.dot(N.y)])

    lm = me.LagrangesMethod(lag, [s, psi1, psi3], forcelist=forces, frame=N, hol_coneqs=list(phi))
    eom = lm.form_lagranges_equations()
    lam = list(lm.lam_vec)

    psi_c, psi_o = _flap_limits(p) if flap_limits is None else flap_limits
    xg_v, yg_v = p.flap_com_local
    values = {
        xA: p.x_A,
        yA: p.y_A,
        xD: p.x_D,
        yD: p.y_D,
        L1: p.L1,
        L2: p.L2,
        L3: p.L3,
        Lw: p.L_wing,
        dtip: p.d_tip,
        xg: xg_v,
        yg: yg_v,
        g: p.g,
        m1: p.m_pist,
        m2: p.m_link,
        m3: p.m_wing,
        I1: p.Iz_pist,
        I2: p.Iz_link,
        I3: p.Iz_wing,
        Fdc: p.F_drag_closed,
        Fdo: p.F_drag_open,
        Fnc: p.F_down_closed,
        Fno: p.F_down_open,
        pc: psi_c,
        po: psi_o,
    }

    # plain symbols for lambdify
    qs = sm.symbols("q0:3")
    us = sm.symbols("u0:3")
    as_ = sm.symbols("a0:3")
    Fs, l1, l2 = sm.symbols("F lam1 lam2")
    qdd = [x.diff(t) for x in (sd, psi1d, psi3d)]
    to_plain = dict(zip(qdd, as_, strict=True))
    to_plain.update(zip((sd, psi1d, psi3d), us, strict=True))
    to_plain.update(zip((s, psi1, psi3), qs, strict=True))
    to_plain.update({F: Fs, lam[0]: l1, lam[1]: l2})

    def plain(expr):
        return sm.Matrix(expr).subs(values).subs(to_plain)

    eom_p = plain(eom)
    # inverse problem: eom linear in (F, lambda)
    unknowns = [Fs, l1, l2]
    a_inv = eom_p.jacobian(unknowns)
    b_inv = -eom_p.subs({x: 0 for x in unknowns})
    coeffs = sm.lambdify([*qs, *us, *as_], list(a_inv) + list(b_inv), "numpy", cse=True)
    # forward, index 1: rows of eom in (qdd, lambda) and the differentiated constraints
    # (from eom itself: lm.mass_matrix carries the multipliers with the opposite sign to eom's)
    acc_lam = [*as_, l1, l2]
    mm = eom_p.jacobian(acc_lam)  # [M, Phi_q^T]
    fo = -eom_p.subs({x: 0 for x in acc_lam})
    phi_p = plain(phi)
    jac_p = phi_p.jacobian(qs)
    gamma = -(jac_p * sm.Matrix(us)).jacobian(qs) * sm.Matrix(us)
    aug = mm.col_join(jac_p.row_join(sm.zeros(2, 2)))
    rhs = fo.col_join(gamma)
    index1 = sm.lambdify([*qs, *us, Fs], list(aug) + list(rhs), "numpy", cse=True)
    phis = sm.lambdify(list(qs), list(phi_p) + list(jac_p), "numpy", cse=True)
    gam = sm.lambdify([*qs, *us], list(gamma), "numpy", cse=True)
    return Baseline(p, time.perf_counter() - t0, coeffs, index1, phis, gam)


def _flap_limits(p: DRSParams) -> tuple[float, float]:
    """Closed/open flap angles of the gap rule, from the tip height (as the seed's NLPSolve)."""
    c, s = np.cos(p.gamma), np.sin(p.gamma)
    ry = s * p.x_R + c * p.y_R
    arm = p.L_wing - p.d_tip
    return (
        float(np.arcsin((p.y_D - ry - p.gap_closed) / arm)),
        float(np.arcsin((p.y_D - ry - p.gap_open) / arm)),
    )


@functools.lru_cache(maxsize=8)
def _cached(p: DRSParams, flap_limits: tuple[float, float] | None) -> Baseline:
    return _derive(p, flap_limits)


def build_baseline(
    p: DRSParams = DRSParams(),  # noqa: B008 - frozen and hashable
    flap_limits: tuple[float, float] | None = None,
) -> Baseline:
    """The lambdified sympy model for ``p``, derived once per process and parameter set.

    ``flap_limits = (psi3_closed, psi3_open)`` [rad] of the air law defaults to the gap rule's.
    """
    key = None if flap_limits is None else (float(flap_limits[0]), float(flap_limits[1]))
    return _cached(p, key)


if __name__ == "__main__":  # pragma: no cover
    bl = build_baseline()
    print(f"derivation + lambdify: {bl.build_time:.3f} s")
