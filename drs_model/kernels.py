r"""The scalar closed forms of the DRS model, each written once, as ordinary Python.

Every kernel is a plain function of floats (``math``, ``if``, ``return``) in the subset of Python
that numba compiles, so the same function serves every path:

* Python calls it as it is (what you step through in a debugger);
* :mod:`drs_model.compiled` compiles it with numba (``njit(cache=True)``): for one sample at a
  time (the real-time fixed step, one inverse-dynamics force) and inside the compiled RK driver;
* on numpy arrays, the kernels that are arithmetic alone (:func:`rotate`, :func:`quintic`,
  :func:`flap_gap`, :func:`air_load`, :func:`loop_residual`, :func:`loop_gamma` ...) take arrays
  as they are; those with a branch or a ``math`` function run element by element through
  :mod:`drs_model.elementwise` (numba gufuncs, or :func:`numpy.vectorize` without numba).

Without numba (it is the optional extra ``fast``), everything runs as plain Python: the same
values, more slowly (docs/forward.md, "Without numba").

A kernel never raises: where the loop cannot close or the mechanism is at the dead centre it returns
NaN (or the quantity that says so, such as ``h2`` below), and its caller raises the typed error.

Constants ``c`` (a tuple, or a float64 array for the compiled paths) are indexed by the names
below; the first six (``XA .. L3``, :attr:`DRSParams.loop_constants
<drs_model.params.DRSParams.loop_constants>`) are all the position kernels need, the rest
(:func:`drs_model.bodies.model_constants`) the dynamics.

Position with ``s`` independent: ``C`` lies on the circle of radius ``L2`` about ``B = (x_A, y_A +
L1 + s)`` and on the circle of radius ``L3`` about ``D``. With ``d = D - B``, ``rho = |d|``,
``a = (rho^2 + L2^2 - L3^2) / (2 rho)`` and ``h^2 = L2^2 - a^2``:
``C = B + (a d + h k x d) / rho`` (branch 1: ``h > 0``). ``h^2 < 0``: the loop cannot close.

Position with ``psi3`` independent: ``sin psi1 = (x_A - x_D + L3 cos psi3) / L2`` (branch 1:
``cos psi1 > 0``), ``s = y_D - y_A - L1 - L3 sin psi3 - L2 cos psi1``.

Rates: ``Phi_q qd = 0`` and ``Phi_q qdd = gamma`` solved for the two dependent coordinates by
Cramer's rule (determinant ``-L2 L3 cos(psi1 - psi3)`` with ``s`` independent).
"""

from __future__ import annotations

import math

#: Below this normalised singularity measure ``|cos(psi1 - psi3)|`` a stroke is the dead centre.
SINGULAR_TOL = 1e-9
#: Normalised ``h^2 / L2^2`` below which the loop does not close (rounding allowance).
ASSEMBLY_TOL = 1e-12

# indices of the constants vector
XA, YB0, XD, YD, L2, L3 = 0, 1, 2, 3, 4, 5  # x_A, y_A + L1, x_D, y_D, L2, L3 [m]
GX, GY = 6, 7  # G3 in the flap frame RF3 [m]
M1, M2, M3, I2, I3, G = 8, 9, 10, 11, 12, 13  # masses [kg], inertias [kg m^2], gravity [m/s^2]
DRAG_OPEN, DRAG_SLOPE, DOWN_OPEN, DOWN_SLOPE, PSI3_OPEN = 14, 15, 16, 17, 18  # air law [N, N/rad]
M11, M22 = 19, 20  # m_link L2^2/4 + Iz_link, m_wing |r_G3|^2 + Iz_wing [kg m^2]
YG1, YB = 21, 22  # G1 and B above P in the piston frame [m]
N_CONSTANTS = 23
#: Number of the manoeuvre's constants ``k`` (:meth:`drs_model.profile.Manoeuvre.constants`).
N_PROFILE_CONSTANTS = 18


# ---- elementary ---------------------------------------------------------------------------------
def rotate(c, s, x, y):
    """``(x, y)`` turned by the angle of cosine ``c`` and sine ``s``."""
    return c * x - s * y, s * x + c * y


#: Cephes' ``atan`` (S. L. Moshier, Cephes Math Library, atan.c): ``atan(x) = x + x z P(z) /
#: Q(z)``, ``z = x^2``, on ``|x| <= 0.66`` after reduction; ``Q`` is monic. Peak relative error
#: 1.9e-16 on [-10, 10] (Cephes' own figure).
_ATAN_P = (
    -8.750608600031904122785e-1,
    -1.615753718733365076637e1,
    -7.500855792314704667340e1,
    -1.228866684490136173410e2,
    -6.485021904942025371773e1,
)
_ATAN_Q = (
    2.485846490142306297962e1,
    1.650270098316988542046e2,
    4.328810604912902668951e2,
    4.853903996359136964868e2,
    1.945506571482613964425e2,
)
_TAN_3PI_8 = 2.41421356237309504880
_PI_2_LOW = 6.123233995736765886130e-17  # pi/2 - float(pi/2): the bits pi/2 loses as a float


def arctangent(y, x):
    """The angle [rad] of the point ``(x, y)``: :func:`math.atan2`'s, within 1 ulp of it.

    Why not ``math.atan2``: compiled, libm's call was 15-28 ns of the ~70 ns of
    :func:`fused_force` on a sample; for ``x > 0`` (the flap's half plane) this is Cephes'
    rational ``atan`` of ``y / x``, ~7.5 ns cheaper (a moving sample 66.4 -> 59 ns,
    docs/dynamics.md), and ``math.atan2`` elsewhere (NaN and the left half plane included). A
    signed zero keeps its sign.
    """
    if not x > 0.0:
        return math.atan2(y, x)
    t = y / x
    if t == 0.0 or t != t:  # a signed zero, or NaN (a NaN y, inf / inf)
        return math.atan2(y, x)
    negative = t < 0.0
    if negative:
        t = -t
    if t > _TAN_3PI_8:  # atan t = pi/2 - atan(1/t)
        base, low, t = 0.5 * math.pi, _PI_2_LOW, -1.0 / t
    elif t > 0.66:  # atan t = pi/4 + atan((t - 1) / (t + 1))
        base, low, t = 0.25 * math.pi, 0.5 * _PI_2_LOW, (t - 1.0) / (t + 1.0)
    else:
        base, low = 0.0, 0.0
    z = t * t
    p = (((_ATAN_P[0] * z + _ATAN_P[1]) * z + _ATAN_P[2]) * z + _ATAN_P[3]) * z + _ATAN_P[4]
    q = ((((z + _ATAN_Q[0]) * z + _ATAN_Q[1]) * z + _ATAN_Q[2]) * z + _ATAN_Q[3]) * z + _ATAN_Q[4]
    angle = base + ((t * (z * p / q) + t) + low)
    return -angle if negative else angle


def quintic(tau, k, i):
    """``(s, s', s'')`` of ``sum k[i + j] tau^j`` (``j = 0..5``) at local time ``tau`` [s]."""
    c0, c1, c2, c3, c4, c5 = k[i], k[i + 1], k[i + 2], k[i + 3], k[i + 4], k[i + 5]
    s = c0 + tau * (c1 + tau * (c2 + tau * (c3 + tau * (c4 + tau * c5))))
    v = c1 + tau * (2.0 * c2 + tau * (3.0 * c3 + tau * (4.0 * c4 + tau * 5.0 * c5)))
    a = 2.0 * c2 + tau * (6.0 * c3 + tau * (12.0 * c4 + tau * 20.0 * c5))
    return s, v, a


def manoeuvre_profile(t, k):
    """``(s, s', s'')`` [m, m/s, m/s^2] of the open-hold-close manoeuvre at time ``t`` [s].

    ``k = (t0_open, T_open, 6 coefficients, t0_close, T_close, 6 coefficients, s_min, s_max)``
    (:meth:`drs_model.profile.Manoeuvre.constants`). Each move's quintic runs strictly inside its
    segment, ``0 < t - t0 < T``; at its ends and outside the moves the rod rests, exactly at
    ``s_min`` (before the opening, after the closing) or ``s_max`` (the hold).
    """
    tau = t - k[0]
    if tau <= 0.0:
        return k[16], 0.0, 0.0
    if tau < k[1]:
        return quintic(tau, k, 2)
    tau = t - k[8]
    if tau <= 0.0:
        return k[17], 0.0, 0.0
    if tau < k[9]:
        return quintic(tau, k, 10)
    return k[16], 0.0, 0.0


def profile_held(a, b, k):
    """Whether :func:`manoeuvre_profile` ``k`` rests over the whole of ``[a, b]`` [s] (before the
    opening, in the hold, after the closing), so that ``(s, s', s'')`` and any force of them are
    one value there, to the bit. Exact: a floating-point difference ``t - t0`` is monotonic in
    ``t``, so the branch :func:`manoeuvre_profile` takes at ``a`` and at ``b`` is taken in between.
    Planning, not a kernel: it is not compiled."""
    if b - k[0] <= 0.0:
        return True  # before the opening
    if a - k[0] < k[1]:
        return False  # some of [a, b] in the opening
    return b - k[8] <= 0.0 or a - k[8] >= k[9]  # the hold, or after the closing


def flap_gap(sin_psi3, gap0, tip_arm):
    """Gap ``T_y - R_y`` [m] at ``sin psi3``, with ``gap0 = y_D - R_y`` and ``tip_arm = |DT|``."""
    return gap0 - tip_arm * sin_psi3


def flap_sine_for_gap(gap, gap0, tip_arm):
    """``sin psi3`` of the gap [m] (the inverse of :func:`flap_gap`; ``|.| > 1``: unreachable)."""
    return (gap0 - gap) / tip_arm


def air_load(psi3, c):
    """Drag and downforce [N] at flap angle ``psi3`` [rad], linear between closed and open."""
    d = psi3 - c[PSI3_OPEN]
    return c[DRAG_OPEN] + c[DRAG_SLOPE] * d, c[DOWN_OPEN] + c[DOWN_SLOPE] * d


# ---- loop closure ------------------------------------------------------------------------------
def loop_residual(s, sin1, cos1, sin3, cos3, c):
    """``Phi(q) = r_C3 - r_C`` [m] from ``s`` and the sines and cosines of psi1, psi3."""
    return (
        c[L2] * sin1 - c[L3] * cos3 - c[XA] + c[XD],
        -c[L2] * cos1 - c[L3] * sin3 - c[YB0] - s + c[YD],
    )


def loop_velocity(sd, sin1, cos1, sin3, cos3, w1, w3, c):
    """``Phi_q qd`` [m/s] for rates ``sd`` [m/s], ``w1``, ``w3`` [rad/s]."""
    return (
        c[L2] * cos1 * w1 + c[L3] * sin3 * w3,
        -sd + c[L2] * sin1 * w1 - c[L3] * cos3 * w3,
    )


def loop_gamma(sin1, cos1, sin3, cos3, w1, w3, c):
    """``gamma`` [m/s^2] of ``Phi_q qdd = gamma`` at angular rates ``w1``, ``w3`` [rad/s]."""
    l2, l3 = c[L2], c[L3]
    return (
        l2 * sin1 * w1 * w1 - l3 * cos3 * w3 * w3,
        -l2 * cos1 * w1 * w1 - l3 * sin3 * w3 * w3,
    )


def stroke_position(s, c, sign):
    """``(sin psi1, cos psi1, sin psi3, cos psi3, h2)`` at stroke ``s`` [m].

    ``sign = 1`` is assembly branch 1, ``-1`` branch 2; ``h2 = h^2 / L2^2`` (module docstring) is
    negative where the loop cannot close (the position is then that of ``h = 0``).
    """
    xa, xd, yd, l2, l3 = c[XA], c[XD], c[YD], c[L2], c[L3]
    by = c[YB0] + s
    dx, dy = xd - xa, yd - by
    rho2 = dx * dx + dy * dy
    inv_rho = 1.0 / math.sqrt(rho2)
    a = 0.5 * (rho2 + l2 * l2 - l3 * l3) * inv_rho
    h2 = l2 * l2 - a * a
    h = sign * math.sqrt(max(h2, 0.0)) * inv_rho
    a = a * inv_rho
    cx = xa + a * dx - h * dy
    cy = by + a * dy + h * dx
    # one division per length instead of one per result (a division costs several products)
    inv_l2, inv_l3 = 1.0 / l2, 1.0 / l3
    return (
        (xa - cx) * inv_l2,
        (cy - by) * inv_l2,
        (yd - cy) * inv_l3,
        (xd - cx) * inv_l3,
        h2 * inv_l2 * inv_l2,
    )


def stroke_rates(sin1, cos1, sin3, cos3, sd, sdd, c):
    """``(dpsi1/ds, dpsi3/ds, psi1'', psi3'')`` with ``s`` independent, at stroke rate ``sd``
    [m/s] and acceleration ``sdd`` [m/s^2]; NaN at the dead centre (``|cos(psi1 - psi3)| <
    SINGULAR_TOL``). The angular rates are ``dpsi/ds * sd``."""
    l2, l3 = c[L2], c[L3]
    det = -l2 * l3 * (cos1 * cos3 + sin1 * sin3)
    if not abs(det) >= SINGULAR_TOL * l2 * l3:  # the dead centre (or NaN)
        return math.nan, math.nan, math.nan, math.nan
    inv_det = 1.0 / det  # Cramer's rule's four quotients share it
    tau1, tau3 = -l3 * sin3 * inv_det, l2 * cos1 * inv_det
    w1, w3 = tau1 * sd, tau3 * sd
    # J_D [psi1'', psi3''] = gamma - J_s s'' with J_D = [[L2 c1, L3 s3], [L2 s1, -L3 c3]]
    r0, r1 = loop_gamma(sin1, cos1, sin3, cos3, w1, w3, c)
    r1 = r1 + sdd
    return (
        tau1,
        tau3,
        (-l3 * cos3 * r0 - l3 * sin3 * r1) * inv_det,
        (-l2 * sin1 * r0 + l2 * cos1 * r1) * inv_det,
    )


def flap_position(sin3, cos3, c, sign):
    """``(s, sin psi1, cos psi1, cos^2 psi1)`` at the flap angle of sine ``sin3`` and cosine
    ``cos3``; ``sign = 1`` is branch 1 (``cos psi1 > 0``). ``cos^2 psi1 < 0``: no assembly."""
    l2, l3 = c[L2], c[L3]
    sin1 = (c[XA] - c[XD] + l3 * cos3) / l2
    cos1_sq = 1.0 - sin1 * sin1
    cos1 = sign * math.sqrt(min(max(cos1_sq, 0.0), 1.0))
    return c[YD] - c[YB0] - l3 * sin3 - l2 * cos1, sin1, cos1, cos1_sq


def flap_rates(sin1, cos1, sin3, cos3, c):
    """``(u_s, u_psi1, w_s, w_psi1)``: ``u = dq/dpsi3`` and ``w = du/dpsi3`` with psi3
    independent (``qd = u psi3'``, ``qdd = u psi3'' + w psi3'^2``); NaN where ``cos psi1 = 0``."""
    l2, l3 = c[L2], c[L3]
    if cos1 == 0.0:
        return math.nan, math.nan, math.nan, math.nan
    l2c1 = l2 * cos1
    u1 = -l3 * sin3 / l2c1
    w1 = (l2 * sin1 * u1 * u1 - l3 * cos3) / l2c1
    return (
        l2 * sin1 * u1 - l3 * cos3,
        u1,
        l2 * sin1 * w1 + l2 * cos1 * u1 * u1 + l3 * sin3,
        w1,
    )


# ---- dynamics ---------------------------------------------------------------------------------
def generalised_forces(sin1, sin3, cos3, psi3, c):
    """``Q0`` [N, N m, N m]: the generalised forces of gravity and air (no piston force) on
    ``(s, psi1, psi3)``."""
    m2, g = c[M2], c[G]
    rx, ry = rotate(cos3, sin3, c[GX], c[GY])
    drag, down = air_load(psi3, c)
    return (
        -(c[M1] + m2) * g,
        m2 * g * 0.5 * c[L2] * sin1,
        -(c[M3] * g + down) * rx - drag * ry,
    )


def projected_dynamics(sin1, cos1, sin3, cos3, psi3, u0, u1, u2, w0, w1, w2, c):
    r"""``(u.M.u, u.M.w + u.h(q, u), u.Q0)`` for a direction ``u = dq/dx`` and ``w = du/dx``.

    The equations of motion projected on ``u`` (virtual work: ``u^T Phi_q^T = 0``) read
    ``(u.M.u) x'' + (u.M.w + u.h(q, u)) x'^2 = u.Q0 + u_s F`` (``Q0``: gravity and air, no piston
    force). ``M`` is block diagonal: ``[[m1 + m2, -m2 L2/2 sin psi1], [., M11]]`` on ``(s, psi1)``
    and ``M22`` on psi3; ``h = (-m2 L2/2 cos psi1 psi1'^2, 0, 0)``.
    """
    m2, hl2 = c[M2], 0.5 * c[L2]
    m12 = c[M1] + m2
    m01 = -m2 * hl2 * sin1
    umu = m12 * u0 * u0 + 2.0 * m01 * u0 * u1 + c[M11] * u1 * u1 + c[M22] * u2 * u2
    umw = m12 * u0 * w0 + m01 * (u0 * w1 + u1 * w0) + c[M11] * u1 * w1 + c[M22] * u2 * w2
    uh = -u0 * m2 * hl2 * cos1 * u1 * u1
    q0, q1, q2 = generalised_forces(sin1, sin3, cos3, psi3, c)
    return umu, umw + uh, u0 * q0 + u1 * q1 + u2 * q2


def com_offsets(sin1, cos1, sin3, cos3, c):
    """``(G2 - B, G3 - D)`` [m] as ``(r2x, r2y, r3x, r3y)``: the link's centre of mass halfway
    along it, ``(L2/2)(-sin psi1, cos psi1)``, and the flap's ``R(psi3) (gx, gy)``."""
    r3x, r3y = rotate(cos3, sin3, c[GX], c[GY])
    return -0.5 * c[L2] * sin1, 0.5 * c[L2] * cos1, r3x, r3y


def turning_acceleration(rx, ry, w, alpha):
    """Acceleration [m/s^2] of a point at ``(rx, ry)`` [m] from the centre of a body turning at
    ``w`` [rad/s] and ``alpha`` [rad/s^2], relative to that centre: ``alpha k x r - w^2 r``."""
    return -alpha * ry - w * w * rx, alpha * rx - w * w * ry


def dalembert_loads(sin1, cos1, sin3, cos3, psi3, w1, w3, sdd, a1, a3, c):
    """``K_b = m_b (a_Gb - g) - F_air,b`` [N] (``g = (0, -g)``; the air force at G3 of flap
    angle ``psi3`` [rad]): what the joint and piston forces on each body must supply, as
    ``(K1y, K2x, K2y, K3x, K3y)`` (``K1x = 0``: the piston moves along y).

    ``w1``, ``w3`` [rad/s] and ``a1``, ``a3`` [rad/s^2] are the rates of psi1 and psi3, ``sdd``
    [m/s^2] the rod's acceleration. Arithmetic alone: takes floats or numpy arrays.
    """
    g = c[G]
    r2x, r2y, r3x, r3y = com_offsets(sin1, cos1, sin3, cos3, c)
    a2x, a2y = turning_acceleration(r2x, r2y, w1, a1)  # G2 turns about B, which moves with the rod
    a3x, a3y = turning_acceleration(r3x, r3y, w3, a3)  # G3 turns about the fixed pivot D
    drag, down = air_load(psi3, c)
    return (
        c[M1] * (sdd + g),
        c[M2] * a2x,
        c[M2] * (sdd + a2y + g),
        c[M3] * a3x - drag,
        c[M3] * (a3y + g) + down,
    )


def newton_euler_reactions(s, sin1, cos1, sin3, cos3, psi3, w1, w3, sdd, a1, a3, c):
    """Per-body Newton-Euler in closed form: ``(Np, Tp, rj1x, rj1y, rj2x, rj2y, rj3x, rj3y, F)``
    [N, N m, N ...] at stroke ``s`` [m], the sines and cosines of psi1 and psi3 and ``psi3``
    [rad], with the rates of :func:`dalembert_loads` (equations and signs:
    :mod:`drs_model.inverse.formulations`). Arithmetic alone: takes floats or numpy arrays;
    inf or NaN at the dead centre (the caller refuses it first).

    Link and flap Newton give ``rj1 = rj2 - K2`` and ``rj3 = rj2 + K3``; their Euler equations
    about the centres of mass, ``(C - B) x rj2 = I2 psi1'' + r2 x K2`` and
    ``(D - C) x rj2 = I3 psi3'' + r3 x K3``, are 2 x 2 in ``rj2`` (Cramer's rule); then the piston
    gives ``Np``, ``F`` and ``Tp``. The pin-C reaction acts at the link's C, as in the seed.
    """
    k1y, k2x, k2y, k3x, k3y = dalembert_loads(sin1, cos1, sin3, cos3, psi3, w1, w3, sdd, a1, a3, c)
    r2x, r2y, r3x, r3y = com_offsets(sin1, cos1, sin3, cos3, c)
    ex, ey = -c[L2] * sin1, c[L2] * cos1  # C - B
    fx, fy = c[XD] - c[XA] - ex, c[YD] - c[YB0] - s - ey  # D - C
    m1 = c[I2] * a1 + (r2x * k2y - r2y * k2x)
    m3 = c[I3] * a3 + (r3x * k3y - r3y * k3x)
    det = ex * fy - ey * fx
    rj2x = (m1 * fx - ex * m3) / det
    rj2y = (m1 * fy - ey * m3) / det
    rj1x, rj1y = rj2x - k2x, rj2y - k2y
    rj3x, rj3y = rj2x + k3x, rj2y + k3y
    np_ = -rj1x  # K1x = 0
    force = k1y - rj1y
    # Euler of the piston about G1 (it does not turn): Tp + (P - G1) x (Np, F) + (B - G1) x rj1 = 0
    tp = -c[YG1] * np_ + (c[YB] - c[YG1]) * rj1x
    return np_, tp, rj1x, rj1y, rj2x, rj2y, rj3x, rj3y, force


def psi3_position(psi3, c):
    """``(sin psi3, cos psi3, s, sin psi1, cos psi1, cos^2 psi1)`` at ``psi3`` [rad] on
    branch 1 (:func:`flap_position`); ``cos^2 psi1 <= 0``: no assembly."""
    sin3, cos3 = math.sin(psi3), math.cos(psi3)
    s, sin1, cos1, cos1_sq = flap_position(sin3, cos3, c, 1.0)
    return sin3, cos3, s, sin1, cos1, cos1_sq


def psi3_acceleration_at(psi3, psi3d, force, sin3, cos3, sin1, cos1, c):
    """:func:`psi3_acceleration` at a position already solved by :func:`psi3_position` (the
    compiled driver keeps that position for its step checks); NaN where ``cos psi1 = 0``."""
    u0, u1, w0, w1 = flap_rates(sin1, cos1, sin3, cos3, c)
    umu, quad, uq0 = projected_dynamics(sin1, cos1, sin3, cos3, psi3, u0, u1, 1.0, w0, w1, 0.0, c)
    return (uq0 + u0 * force - psi3d * psi3d * quad) / umu


def psi3_acceleration(psi3, psi3d, force, c):
    r"""Formulation (a): ``psi3''`` [rad/s^2] at ``psi3`` [rad], ``psi3' = psi3d`` [rad/s] under
    the piston force [N]; NaN where the loop cannot close (a trial stage the error control
    rejects).

    .. math::  \ddot\psi_3 = \frac{u^T Q - \dot\psi_3^2\,(u^T M w + u^T h(q, u))}{u^T M u}
    """
    sin3, cos3, _, sin1, cos1, cos1_sq = psi3_position(psi3, c)
    if not cos1_sq > 0.0:  # no assembly (or NaN)
        return math.nan
    return psi3_acceleration_at(psi3, psi3d, force, sin3, cos3, sin1, cos1, c)


def psi3_configuration(psi3, c):
    """``(s, psi1, u_s, u_psi1)`` at ``psi3`` [rad] on branch 1: the dependent coordinates
    [m, rad] and their rates per unit psi3 rate."""
    sin3, cos3, s, sin1, cos1, _ = psi3_position(psi3, c)
    u0, u1, _, _ = flap_rates(sin1, cos1, sin3, cos3, c)
    return s, math.asin(min(max(sin1, -1.0), 1.0)), u0, u1


def fused_force(s, sd, sdd, c):
    r"""Piston force [N] for stroke ``s`` [m], rate ``sd`` [m/s], acceleration ``sdd`` [m/s^2]:
    closed-form kinematics (branch 1) and d'Alembert's principle along ``u = dq/ds``. NaN where
    the loop cannot close or at the dead centre.

    .. math::

        F = m_1 (\ddot s + g) + \sum_{b = 2, 3} \left[ m_b (a_{G_b} - g) \cdot \frac{dG_b}{ds}
            + I_b \ddot\psi_b \frac{d\psi_b}{ds} \right] - F_{air} \cdot \frac{dG_3}{ds}

    (the d'Alembert loads of :func:`dalembert_loads` along ``dG/ds``).
    """
    s1, c1, s3, c3, h2 = stroke_position(s, c, 1.0)
    if not h2 >= -ASSEMBLY_TOL:  # the loop cannot close (or NaN)
        return math.nan
    tau1, tau3, a1, a3 = stroke_rates(s1, c1, s3, c3, sd, sdd, c)
    w1, w3 = tau1 * sd, tau3 * sd
    r2x, r2y, r3x, r3y = com_offsets(s1, c1, s3, c3, c)
    k1y, k2x, k2y, k3x, k3y = dalembert_loads(
        s1, c1, s3, c3, arctangent(s3, c3), w1, w3, sdd, a1, a3, c
    )
    # dG/ds: G1 moves with the rod, G2 = B + r2 and G3 = D + r3 turn with psi1 and psi3
    v2x, v2y = -tau1 * r2y, 1.0 + tau1 * r2x
    v3x, v3y = -tau3 * r3y, tau3 * r3x
    return (
        k1y
        + (k2x * v2x + k2y * v2y)
        + c[I2] * a1 * tau1
        + (k3x * v3x + k3y * v3y)
        + c[I3] * a3 * tau3
    )


def fused_manoeuvre_force(t, c, k):
    """:func:`fused_force` [N] along the manoeuvre ``k`` (:func:`manoeuvre_profile`) at time ``t``
    [s]: the piston force that makes the mechanism follow it."""
    s, sd, sdd = manoeuvre_profile(t, k)
    return fused_force(s, sd, sdd, c)


#: Every kernel: :mod:`drs_model.compiled` makes each callable from compiled code.
KERNELS = (
    arctangent,
    rotate,
    quintic,
    manoeuvre_profile,
    flap_gap,
    flap_sine_for_gap,
    air_load,
    loop_residual,
    loop_velocity,
    loop_gamma,
    stroke_position,
    stroke_rates,
    flap_position,
    flap_rates,
    generalised_forces,
    projected_dynamics,
    com_offsets,
    turning_acceleration,
    dalembert_loads,
    newton_euler_reactions,
    psi3_position,
    psi3_acceleration_at,
    psi3_acceleration,
    psi3_configuration,
    fused_force,
    fused_manoeuvre_force,
)
