r"""Forward dynamics: formulations of the equations of motion under a given piston force.

The constrained equations of motion (see :mod:`drs_model.bodies`) in ``q = [s, psi1, psi3]`` are

.. math::

    M(q) \ddot q + h(q, \dot q) = Q(q, F) + \Phi_q^T \lambda, \qquad \Phi(q) = 0 .

``M`` is block diagonal (``[[m_p + m_l, -m_l L_2/2 \sin\psi_1], [., m_l L_2^2/4 + I_l]]`` for
``(s, psi1)``; ``I_3 = m_w |r_{G3}|^2 + I_w`` for psi3),
``h = [-m_l (L_2/2) \cos\psi_1 \dot\psi_1^2, 0, 0]``. Each formulation below turns these into an
ODE ``y' = f(t, y)`` and maps ``y`` back to ``(q, qd)``; :func:`drs_model.integrators.simulate`
integrates any of them.

(a) Minimal coordinates, psi3 independent (``"psi3"``, state ``y = [psi3, psi3']``)
    Position from the closed form (``sin psi1 = (x_A - x_D + L_3 cos psi3)/L_2``, branch
    ``cos psi1 > 0``). With ``u = dq/dpsi3`` (``Phi_q u = 0``) and ``w = du/dpsi3`` (``Phi_q w =
    gamma(q, u)``) one has ``qd = u psi3'`` and ``qdd = u psi3'' + w psi3'^2``. Projecting the
    equations on ``u`` removes ``lambda`` (``u^T Phi_q^T = 0``, virtual work) and, ``h`` being
    quadratic in ``qd``:

    .. math::

        \ddot\psi_3 = \frac{u^T Q - \dot\psi_3^2\,(u^T M w + u^T h(q, u))}{u^T M u}.

    The dependent block's determinant is ``L2 cos psi1`` (~L2 over the stroke): regular
    everywhere, including through the dead centre, where ``s(psi3)`` merely has a minimum.

(b) Minimal coordinates, s independent (``"s"``, state ``y = [s, s']``)
    The same projection with ``u = dq/ds``, ``w = du/ds``. ``u`` holds ``dpsi3/ds =
    L2 cos(psi1)/(-L2 L3 cos(psi1 - psi3))`` which is infinite at the dead centre (B, C, D
    aligned, ``s_dead ~ -1.55 mm``, 1.75 mm below the closed stroke); below it the loop cannot close
    for any psi3. The formulation raises :class:`~drs_model.errors.SingularConfigurationError`
    when a step ends within ``dead_centre_margin`` of the dead centre, and whenever a stage asks for
    a stroke past it.

(c) Full coordinates at acceleration level (``"index1"``, ``"baumgarte"``; ``y = [q, qd]``)

    .. math::

        \begin{bmatrix} M & \Phi_q^T \\ \Phi_q & 0 \end{bmatrix}
        \begin{bmatrix} \ddot q \\ -\lambda \end{bmatrix} =
        \begin{bmatrix} Q - h \\ \gamma - 2\alpha\dot\Phi - \beta^2\Phi \end{bmatrix}

    solved by the Schur complement ``(Phi_q M^-1 Phi_q^T) lambda' = rhs``. With ``alpha = beta =
    0`` the position and velocity residuals drift (the constraint holds only at acceleration
    level: ``Phi`` grows like the integrated local error, roughly linearly or quadratically in t);
    Baumgarte's terms make ``Phi'' + 2 alpha Phi' + beta^2 Phi = 0`` a damped oscillator. A step
    that ends with ``max |Phi|`` above ``drift_bound`` raises
    :class:`~drs_model.errors.ConstraintDriftError`.

(d) Full coordinates with projection (``"projection"``)
    Formulation (c) without stabilisation, and after every accepted step the position is
    projected on ``Phi = 0`` (Newton in the metric of M: ``dq = -M^-1 Phi_q^T (Phi_q M^-1
    Phi_q^T)^-1 Phi``) and the velocity on ``Phi_q qd = 0`` (same projector), as in Eich (1993).

(e) Index-2 GGL form (``"ggl"``, ``y = [q, qd, mu]``) is not provided; see docs/forward.md.

All right-hand sides are scalar ``math`` kernels (numpy's per-call overhead on 3-vectors is several
microseconds); :func:`reference_rhs` gives the same right-hand sides from the numpy functions of
:mod:`drs_model.bodies`, :mod:`drs_model.constraints` and :mod:`drs_model.kinematics`, for tests.

Piston force inputs: a constant, a :class:`StepForce`, any callable of t, or the inverse-dynamics
force of the seed manoeuvre, :class:`ManoeuvreForce`. Each knows its ``breakpoints`` (the times
where it or its derivatives jump) so that the driver restarts the integration there, and gives the
smooth piece valid on a segment (``segment(a, b)``), so that no stage straddles a jump.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from .bodies import applied_forces, mass_matrix, velocity_forces
from .constraints import constraint, constraint_gamma, constraint_jacobian
from .errors import (
    ConstraintDriftError,
    InputError,
    IntegrationError,
    SingularConfigurationError,
)
from .kinematics import (
    dead_centre,
    flap_angle_limits,
    solve_acceleration,
    solve_position,
    solve_position_from_flap_angle,
    stroke_limits,
    velocity_ratio,
)
from .params import DRSParams
from .profile import drs_manoeuvre

ForceLike = float | Callable[[float], float]

__all__ = [
    "FORMULATIONS",
    "ConstantForce",
    "ForwardState",
    "Formulation",
    "FullCoordinates",
    "FunctionForce",
    "ManoeuvreForce",
    "Projected",
    "Psi3Minimal",
    "StepForce",
    "StrokeMinimal",
    "as_force",
    "get_formulation",
    "reference_rhs",
]


class ForwardState(NamedTuple):
    """Configurations and velocities along a trajectory: ``q``, ``qd`` of shape ``(n, 3)``
    [m, rad; m/s, rad/s] at the times ``t`` of shape ``(n,)`` [s]."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray


# ---- piston force inputs ------------------------------------------------------------------------
def _finite_force(value: float, t: float) -> float:
    if not math.isfinite(value):
        raise IntegrationError(f"piston force is not finite at t = {t!r} s: {value!r} N")
    return value


@dataclass(frozen=True)
class ConstantForce:
    """A constant piston force ``value`` [N]."""

    value: float

    def __post_init__(self) -> None:
        v = float(self.value)
        if not math.isfinite(v):
            raise InputError(f"constant piston force must be finite, got {self.value!r} N")
        object.__setattr__(self, "value", v)

    breakpoints: tuple[float, ...] = ()

    def __call__(self, t: float) -> float:
        return self.value

    def segment(self, a: float, b: float) -> Callable[[float], float]:
        value = self.value
        return lambda t: value


@dataclass(frozen=True)
class StepForce:
    """``before`` [N] for ``t < t_step`` [s], ``after`` [N] from ``t_step`` on."""

    before: float
    after: float
    t_step: float

    def __post_init__(self) -> None:
        for name in ("before", "after", "t_step"):
            v = float(getattr(self, name))
            if not math.isfinite(v):
                raise InputError(f"step force {name} must be finite, got {getattr(self, name)!r}")
            object.__setattr__(self, name, v)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return (self.t_step,)

    def __call__(self, t: float) -> float:
        return self.before if t < self.t_step else self.after

    def segment(self, a: float, b: float) -> Callable[[float], float]:
        value = self.before if 0.5 * (a + b) < self.t_step else self.after
        return lambda t: value


@dataclass(frozen=True)
class FunctionForce:
    """A callable ``fun(t) -> F`` [N]; ``breakpoints`` [s] are the times where it is not smooth.
    A non-finite value raises :class:`IntegrationError` when it is met."""

    fun: Callable[[float], float]
    breakpoints: tuple[float, ...] = ()

    def __call__(self, t: float) -> float:
        return _finite_force(float(self.fun(t)), t)

    def segment(self, a: float, b: float) -> Callable[[float], float]:
        fun = self.fun

        def piece(t: float) -> float:
            value = float(fun(t))
            if value != value or value in (math.inf, -math.inf):
                raise IntegrationError(f"piston force is not finite at t = {t!r} s: {value!r} N")
            return value

        return piece


def as_force(force) -> ConstantForce | StepForce | FunctionForce | ManoeuvreForce:
    """Normalise a piston-force input: a number, a force object, or a callable of t [s].

    A force object is any callable ``F(t)`` [N] with ``breakpoints`` (times [s] where it is not
    smooth) and ``segment(a, b)`` (the smooth piece valid on ``[a, b]``); it is used as is.
    """
    if isinstance(force, (ConstantForce, StepForce, FunctionForce, ManoeuvreForce)):
        return force
    if callable(force) and hasattr(force, "segment") and hasattr(force, "breakpoints"):
        return force  # the force protocol: __call__(t), segment(a, b), breakpoints
    if isinstance(force, bool):
        raise InputError(f"piston force must be a number or a callable of t, got {force!r}")
    if isinstance(force, (int, float, np.floating, np.integer)):
        return ConstantForce(float(force))
    if callable(force):
        bps = tuple(float(b) for b in getattr(force, "breakpoints", ()))
        return FunctionForce(force, bps)
    raise InputError(f"piston force must be a number or a callable of t, got {force!r}")


# ---- scalar model -------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Consts:
    """Every number the scalar kernels need, read once from DRSParams."""

    L1: float
    L2: float
    L3: float
    xA: float
    yA: float
    xD: float
    yD: float
    m_ps: float  # m_pist + m_link [kg]
    m_l: float
    m_w: float
    g: float
    half_L2: float
    M11: float  # m_l L2^2/4 + I_l [kg m^2]
    M22: float  # m_w |r_G3|^2 + I_w [kg m^2]
    gx: float  # G3 in the flap frame RF3 [m]
    gy: float
    drag0: float  # drag = drag0 + drag1 * psi3 [N]
    drag1: float
    down0: float
    down1: float
    grav0: float  # -(m_pist + m_link) g [N]


def _consts(p: DRSParams, flap_limits: tuple[float, float] | None = None) -> _Consts:
    psi_c, psi_o = flap_angle_limits(p) if flap_limits is None else flap_limits
    xg, yg = p.flap_com_local
    gx, gy = p.d_tip - p.L_wing + xg, yg
    k_drag = (p.F_drag_closed - p.F_drag_open) / (psi_c - psi_o)
    k_down = (p.F_down_closed - p.F_down_open) / (psi_c - psi_o)
    return _Consts(
        L1=p.L1,
        L2=p.L2,
        L3=p.L3,
        xA=p.x_A,
        yA=p.y_A,
        xD=p.x_D,
        yD=p.y_D,
        m_ps=p.m_pist + p.m_link,
        m_l=p.m_link,
        m_w=p.m_wing,
        g=p.g,
        half_L2=0.5 * p.L2,
        M11=p.m_link * p.L2**2 / 4.0 + p.Iz_link,
        M22=p.m_wing * (gx * gx + gy * gy) + p.Iz_wing,
        gx=gx,
        gy=gy,
        drag0=p.F_drag_open - k_drag * psi_o,
        drag1=k_drag,
        down0=p.F_down_open - k_down * psi_o,
        down1=k_down,
        grav0=-(p.m_pist + p.m_link) * p.g,
    )


def psi3_kernel_constants(c: _Consts) -> tuple[float, ...]:
    """The 18 constants of :func:`psi3_acceleration` and :func:`psi3_configuration`, in order:
    ``(x_A - x_D, y_D - y_A - L1, L2, L3, m_p + m_l, m_l, m_w, g, L2/2, M11, M22, gx, gy, drag0,
    drag1, down0, down1, -(m_p + m_l) g)``."""
    return (
        c.xA - c.xD, c.yD - c.yA - c.L1, c.L2, c.L3, c.m_ps, c.m_l, c.m_w, c.g, c.half_L2,
        c.M11, c.M22, c.gx, c.gy, c.drag0, c.drag1, c.down0, c.down1, c.grav0,
    )  # fmt: skip


def psi3_acceleration(b: float, bd: float, force: float, kc) -> float:
    """Formulation (a): psi3'' [rad/s^2] at psi3 = ``b`` [rad], psi3' = ``bd`` [rad/s] under the
    piston force [N]; NaN where the loop cannot close (a trial stage the error control rejects).

    ``kc`` holds :func:`psi3_kernel_constants` (a tuple, or a float64 array when numba compiles
    this same function in :mod:`drs_model.compiled`).
    """
    ax, s_off, L2, L3, m_ps, m_l, m_w, g, hl2, M11, M22, gx, gy, d0, d1, w0_, w1_, grav0 = kc
    sb, cb = math.sin(b), math.cos(b)
    sa = (ax + L3 * cb) / L2
    ca2 = 1.0 - sa * sa
    if not ca2 > 0.0:  # no assembly (or NaN)
        return math.nan
    ca = math.sqrt(ca2)
    u1 = -L3 * sb / (L2 * ca)
    u0 = L2 * sa * u1 - L3 * cb
    w1 = (L2 * sa * u1 * u1 - L3 * cb) / (L2 * ca)
    w0 = L2 * sa * w1 + L2 * ca * u1 * u1 + L3 * sb
    m01 = -m_l * hl2 * sa
    umu = m_ps * u0 * u0 + 2.0 * m01 * u0 * u1 + M11 * u1 * u1 + M22
    umw = m_ps * u0 * w0 + m01 * (u0 * w1 + u1 * w0) + M11 * u1 * w1
    uh = -u0 * m_l * hl2 * ca * u1 * u1
    rx = cb * gx - sb * gy
    ry = sb * gx + cb * gy
    q2 = -(m_w * g + w0_ + w1_ * b) * rx - (d0 + d1 * b) * ry
    uq = u0 * (force + grav0) + u1 * m_l * g * hl2 * sa + q2
    return (uq - bd * bd * (umw + uh)) / umu


def psi3_configuration(b: float, kc) -> tuple[float, float, float, float]:
    """``(s, psi1, u_s, u_psi1)`` at psi3 = ``b`` [rad]: the dependent coordinates [m, rad] and
    their rates per unit psi3 rate (closed form; ``kc`` as for :func:`psi3_acceleration`)."""
    ax, s_off, L2, L3 = kc[0], kc[1], kc[2], kc[3]
    sb, cb = math.sin(b), math.cos(b)
    sa = (ax + L3 * cb) / L2
    ca = math.sqrt(max(1.0 - sa * sa, 0.0))
    u1 = -L3 * sb / (L2 * ca) if ca > 0.0 else math.inf
    return (
        s_off - L3 * sb - L2 * ca,
        math.asin(max(-1.0, min(1.0, sa))),
        L2 * sa * u1 - L3 * cb,
        u1,
    )


def make_psi3_kernel(c: _Consts) -> tuple[Callable, Callable]:
    """Scalar kernels of formulation (a) for the constants ``c``.

    Returns ``accel(psi3, psi3d, F) -> psi3dd`` [rad/s^2] and ``config(psi3) -> (s, psi1, u_s,
    u_psi1)``: :func:`psi3_acceleration` and :func:`psi3_configuration` bound to ``c``.
    """
    kc = psi3_kernel_constants(c)

    def accel(b: float, bd: float, force: float) -> float:
        return psi3_acceleration(b, bd, force, kc)

    def config(b: float) -> tuple[float, float, float, float]:
        return psi3_configuration(b, kc)

    return accel, config


def make_stroke_kernel(c: _Consts) -> tuple[Callable, Callable]:
    """Scalar kernels with s independent.

    Returns ``config(s) -> (psi1, psi3, u_psi1, u_psi3, w_psi1, w_psi3, measure)`` and
    ``terms(s) -> (uMu, uMw + uh, uQ0, config)`` with ``uQ0 = u.Q(q, F=0)`` so that
    ``u.(M qdd + h - Q) = uMu s'' + (uMw + uh) s'^2 - uQ0 - F`` (``u_s = 1``).
    Raises :class:`SingularConfigurationError` past the dead centre (no assembly).
    """
    L2, L3, L1 = c.L2, c.L3, c.L1
    xA, yA, xD, yD = c.xA, c.yA, c.xD, c.yD
    m_ps, m_l, m_w, g = c.m_ps, c.m_l, c.m_w, c.g
    hl2, M11, M22 = c.half_L2, c.M11, c.M22
    gx, gy = c.gx, c.gy
    d0, d1, w0_, w1_ = c.drag0, c.drag1, c.down0, c.down1
    grav0 = c.grav0
    sin, cos, atan2, acos = math.sin, math.cos, math.atan2, math.acos
    L2L3 = L2 * L3

    def config(s: float):
        by = yA + L1 + s
        dx, dy = xD - xA, yD - by
        rho = math.hypot(dx, dy)
        carg = (rho * rho + L3 * L3 - L2 * L2) / (2.0 * L3 * rho)
        if not carg <= 1.0:  # also NaN
            raise SingularConfigurationError(
                f"stroke s = {s!r} m is past the dead centre: with s independent the loop "
                f"cannot close (|cos| = {carg!r} > 1); use the 'psi3' formulation"
            )
        b = atan2(dy, dx) - acos(carg)
        sb, cb = sin(b), cos(b)
        cx, cy = xD - L3 * cb, yD - L3 * sb
        a = atan2(xA - cx, cy - by)
        sa, ca = sin(a), cos(a)
        det = -L2L3 * (ca * cb + sa * sb)  # -L2 L3 cos(psi1 - psi3)
        if det == 0.0:
            raise SingularConfigurationError(f"stroke s = {s!r} m is the dead centre")
        u1 = -L3 * sb / det
        u2 = L2 * ca / det
        # Phi_q w = gamma(q, u), w_s = 0: [[L2 ca, L3 sb], [L2 sa, -L3 cb]] [w1, w2] = [g1, g2]
        g1 = L2 * sa * u1 * u1 - L3 * cb * u2 * u2
        g2 = -L2 * ca * u1 * u1 - L3 * sb * u2 * u2
        w1 = (g1 * (-L3 * cb) - L3 * sb * g2) / det
        w2 = (L2 * ca * g2 - L2 * sa * g1) / det
        return a, b, sa, ca, sb, cb, u1, u2, w1, w2, abs(ca * cb + sa * sb)

    def terms(s: float):
        cfg = config(s)
        a, b, sa, ca, sb, cb, u1, u2, w1, w2, _ = cfg
        m01 = -m_l * hl2 * sa
        umu = m_ps + 2.0 * m01 * u1 + M11 * u1 * u1 + M22 * u2 * u2
        umw = m01 * w1 + M11 * u1 * w1 + M22 * u2 * w2  # u0 = 1, w0 = 0
        uh = -m_l * hl2 * ca * u1 * u1
        rx = cb * gx - sb * gy
        ry = sb * gx + cb * gy
        q2 = -(m_w * g + w0_ + w1_ * b) * rx - (d0 + d1 * b) * ry
        uq0 = grav0 + u1 * m_l * g * hl2 * sa + u2 * q2
        return umu, umw + uh, uq0, cfg

    return config, terms


def make_full_kernel(c: _Consts) -> tuple[Callable, Callable]:
    """Scalar kernels of the full-coordinate formulations.

    Returns ``accel(y, F, alpha, beta) -> (sdd, psi1dd, psi3dd)`` solving the KKT system of (c)
    by the Schur complement, and ``project(y, tol, maxiter) -> y`` (formulation (d)).
    """
    L2, L3, L1 = c.L2, c.L3, c.L1
    ex, ey = c.xD - c.xA, c.yD - c.yA - L1
    m_ps, m_l, m_w, g = c.m_ps, c.m_l, c.m_w, c.g
    hl2, M11, M22 = c.half_L2, c.M11, c.M22
    gx, gy = c.gx, c.gy
    d0, d1, w0_, w1_ = c.drag0, c.drag1, c.down0, c.down1
    grav0 = c.grav0
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
        rx = cb * gx - sb * gy
        ry = sb * gx + cb * gy
        f0 = force + grav0 + m_l * hl2 * ca * ad * ad  # Q0 - h0
        f1 = m_l * g * hl2 * sa
        f2 = -(m_w * g + w0_ + w1_ * b) * rx - (d0 + d1 * b) * ry
        z0, z1, z2 = i00 * f0 + i01 * f1, i01 * f0 + i11 * f1, i22 * f2  # M^-1 (Q - h)
        gam1 = L2 * sa * ad * ad - L3 * cb * bd * bd
        gam2 = -L2 * ca * ad * ad - L3 * sb * bd * bd
        if alpha != 0.0 or beta != 0.0:
            pd1 = L2 * ca * ad + L3 * sb * bd
            pd2 = -sd + L2 * sa * ad - L3 * cb * bd
            p1 = L2 * sa - L3 * cb + ex
            p2 = -L2 * ca - L3 * sb - s + ey
            gam1 -= 2.0 * alpha * pd1 + beta * beta * p1
            gam2 -= 2.0 * alpha * pd2 + beta * beta * p2
        r1 = gam1 - (L2 * ca * z1 + L3 * sb * z2)
        r2 = gam2 - (-z0 + L2 * sa * z1 - L3 * cb * z2)
        det = a11 * a22 - a12 * a12
        l1 = (a22 * r1 - a12 * r2) / det
        l2 = (a11 * r2 - a12 * r1) / det
        return (
            z0 + x10 * l1 + x20 * l2,
            z1 + x11 * l1 + x21 * l2,
            z2 + x12 * l1 + x22 * l2,
        )

    def project(y, tol: float = 1e-15, maxiter: int = 6):
        s, a, b, sd, ad, bd = (float(v) for v in y)
        for _ in range(maxiter):
            sa, ca, sb, cb = sin(a), cos(a), sin(b), cos(b)
            p1 = L2 * sa - L3 * cb + ex
            p2 = -L2 * ca - L3 * sb - s + ey
            _, (x10, x11, x12, x20, x21, x22), (a11, a12, a22) = _schur(sa, ca, sb, cb)
            det = a11 * a22 - a12 * a12
            l1 = (a22 * p1 - a12 * p2) / det
            l2 = (a11 * p2 - a12 * p1) / det
            s -= x10 * l1 + x20 * l2
            a -= x11 * l1 + x21 * l2
            b -= x12 * l1 + x22 * l2
            if max(abs(p1), abs(p2)) <= tol:
                break
        sa, ca, sb, cb = sin(a), cos(a), sin(b), cos(b)
        _, (x10, x11, x12, x20, x21, x22), (a11, a12, a22) = _schur(sa, ca, sb, cb)
        v1 = L2 * ca * ad + L3 * sb * bd
        v2 = -sd + L2 * sa * ad - L3 * cb * bd
        det = a11 * a22 - a12 * a12
        l1 = (a22 * v1 - a12 * v2) / det
        l2 = (a11 * v2 - a12 * v1) / det
        return (
            s,
            a,
            b,
            sd - (x10 * l1 + x20 * l2),
            ad - (x11 * l1 + x21 * l2),
            bd - (x12 * l1 + x22 * l2),
        )

    return accel, project


# ---- formulations -------------------------------------------------------------------------------
class Formulation:
    """One way of writing the equations of motion as an ODE ``y' = f(t, y)``.

    Subclasses set ``name``, ``n_state``, ``coordinates`` and implement :meth:`fun`,
    :meth:`initial_state` and :meth:`to_q_qd`. ``project`` (``y -> y`` after each accepted step)
    is ``None`` unless the formulation projects; :meth:`check` raises a typed error for a state the
    formulation must refuse.
    """

    name: str = ""
    n_state: int = 0
    coordinates: tuple[str, ...] = ()
    full: bool = False  #: full coordinates (the constraint residual is meaningful)

    def __init__(self, p: DRSParams, flap_limits: tuple[float, float] | None = None) -> None:
        if not isinstance(p, DRSParams):
            raise InputError(f"p must be DRSParams, got {type(p).__name__}")
        self.p = p
        self.flap_limits = flap_limits
        self.consts = _consts(p, flap_limits)

    project: Callable[[np.ndarray], np.ndarray] | None = None

    def fun(self, force: Callable[[float], float]) -> Callable[[float, np.ndarray], np.ndarray]:
        """The right-hand side ``f(t, y)`` (shape ``(n_state,)``) under the piston force
        ``force(t)`` [N]."""
        raise NotImplementedError

    def initial_state(self, q, qd) -> np.ndarray:
        """``y0`` from a consistent configuration ``q`` (3,) and velocity ``qd`` (3,)."""
        raise NotImplementedError

    def to_q_qd(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q, qd)``, each ``(n, 3)``, from states ``y`` of shape ``(n_state, n)``."""
        raise NotImplementedError

    def check(self, t: float, y: np.ndarray) -> None:
        """Raise a typed error if the state ``y`` at ``t`` must be refused (after each step)."""
        if not np.all(np.isfinite(y)):
            raise IntegrationError(f"{self.name}: non-finite state at t = {t!r} s: {y.tolist()}")

    def residual(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(max |Phi| [m], max |Phi_q qd| [m/s])`` at each column of ``y`` (zeros for minimal
        coordinates, which satisfy the constraints by construction), shapes ``(n,)``."""
        q, qd = self.to_q_qd(y)
        phi = np.max(np.abs(constraint(q, self.p)), axis=-1)
        vel = np.einsum("nij,nj->ni", constraint_jacobian(q, self.p), qd)
        return phi, np.max(np.abs(vel), axis=-1)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


def _consistent(q, qd, p: DRSParams, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=float).reshape(3)
    qd = np.asarray(qd, dtype=float).reshape(3)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
        raise InputError(f"initial state must be finite, got q={q.tolist()}, qd={qd.tolist()}")
    res = float(np.max(np.abs(constraint(q, p))))
    vres = float(np.max(np.abs(constraint_jacobian(q, p) @ qd)))
    if res > tol or vres > tol:
        raise InputError(
            f"initial state violates the constraints: max|Phi| = {res:.3g} m, "
            f"max|Phi_q qd| = {vres:.3g} m/s (tolerance {tol:g})"
        )
    return q, qd


class _MinimalCoordinates(Formulation):
    """Two states ``[x, x']`` of one independent coordinate: the constraints hold by
    construction (the dependent coordinates come from the closed form)."""

    n_state = 2

    def residual(self, y):
        n = np.asarray(y).reshape(self.n_state, -1).shape[1]
        return np.zeros(n), np.zeros(n)


class Psi3Minimal(_MinimalCoordinates):
    """(a) Minimal coordinates ``y = [psi3, psi3']`` [rad, rad/s]; regular over the stroke.

    Parameters
    ----------
    min_cos_psi1 : float
        The psi3 parametrisation is singular where ``cos psi1 = 0`` (the link horizontal, far
        outside the stroke: ``cos psi1 > 0.79`` over it). A step ending with ``cos psi1 <
        min_cos_psi1`` raises :class:`SingularConfigurationError`.
    """

    name = "psi3"
    coordinates = ("psi3", "psi3_dot")

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        min_cos_psi1: float = 0.05,
    ) -> None:
        super().__init__(p, flap_limits)
        if not 0.0 <= min_cos_psi1 < 1.0:
            raise InputError(f"min_cos_psi1 must be in [0, 1), got {min_cos_psi1!r}")
        self.min_cos_psi1 = float(min_cos_psi1)
        self.accel, self.config = make_psi3_kernel(self.consts)

    def check(self, t, y):
        super().check(t, y)
        b = float(y[0])
        c = self.consts
        sa = (c.xA - c.xD + c.L3 * math.cos(b)) / c.L2
        cos1 = math.sqrt(max(0.0, 1.0 - sa * sa))
        if not cos1 >= self.min_cos_psi1:
            raise SingularConfigurationError(
                f"psi3 formulation: at psi3 = {b:.9g} rad (t = {t:.9g} s) cos psi1 = {cos1:.3g} < "
                f"min_cos_psi1 = {self.min_cos_psi1:g}: the link is nearly horizontal and psi3 "
                f"cannot stay the independent coordinate"
            )

    def fun(self, force):
        accel = self.accel

        def rhs(t, y):
            bd = float(y[1])
            return np.array([bd, accel(float(y[0]), bd, force(t))])

        return rhs

    def initial_state(self, q, qd) -> np.ndarray:
        q, qd = _consistent(q, qd, self.p)
        return np.array([q[2], qd[2]])

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(2, -1)
        q = solve_position_from_flap_angle(y[0], self.p)
        u = velocity_ratio(q, self.p, "psi3", check=False)
        return q, u * y[1][:, None]


class StrokeMinimal(_MinimalCoordinates):
    """(b) Minimal coordinates ``y = [s, s']`` [m, m/s]; singular at the dead centre.

    Parameters
    ----------
    dead_centre_margin : float
        A step ending with ``s < s_dead + dead_centre_margin`` [m] raises
        :class:`SingularConfigurationError` (default 0.25 mm; the closed stroke is 1.75 mm above
        the dead centre for the seed).
    """

    name = "s"
    coordinates = ("s", "s_dot")

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        dead_centre_margin: float = 2.5e-4,
    ) -> None:
        super().__init__(p, flap_limits)
        if not (math.isfinite(dead_centre_margin) and dead_centre_margin >= 0.0):
            raise InputError(f"dead_centre_margin must be >= 0 m, got {dead_centre_margin!r}")
        self.dead_centre_margin = float(dead_centre_margin)
        self.s_dead = dead_centre(p)
        self.config, self.terms = make_stroke_kernel(self.consts)

    def fun(self, force):
        terms = self.terms

        def rhs(t, y):
            s, sd = float(y[0]), float(y[1])
            try:
                umu, quad, uq0, _ = terms(s)
            except SingularConfigurationError:  # a trial stage past the dead centre: reject it
                return np.array([sd, math.nan])
            return np.array([sd, (uq0 + force(t) - quad * sd * sd) / umu])

        return rhs

    def initial_state(self, q, qd) -> np.ndarray:
        q, qd = _consistent(q, qd, self.p)
        self._check_stroke(0.0, q[0])
        return np.array([q[0], qd[0]])

    def _check_stroke(self, t: float, s: float) -> None:
        guard = self.s_dead + self.dead_centre_margin
        if not s >= guard:
            raise SingularConfigurationError(
                f"s formulation: stroke s = {s:.9g} m at t = {t:.9g} s is within "
                f"{self.dead_centre_margin:g} m of the dead centre s_dead = {self.s_dead:.9g} m "
                f"(dpsi3/ds is infinite there, and no s < s_dead assembles); use the 'psi3' "
                f"formulation"
            )

    def check(self, t, y):
        super().check(t, y)
        self._check_stroke(t, float(y[0]))

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(2, -1)
        q = solve_position(y[0], self.p)
        u = velocity_ratio(q, self.p, "s")
        return q, u * y[1][:, None]


class FullCoordinates(Formulation):
    """(c) Full coordinates ``y = [q, qd]`` at acceleration level, optionally Baumgarte-stabilised.

    Parameters
    ----------
    alpha, beta : float
        Baumgarte gains [1/s]: the acceleration constraint becomes ``Phi'' + 2 alpha Phi' +
        beta^2 Phi = 0``. ``0, 0`` is the plain index-1 form.
    drift_bound : float
        A step ending with ``max |Phi| > drift_bound`` [m] raises :class:`ConstraintDriftError`.
    """

    n_state = 6
    coordinates = ("s", "psi1", "psi3", "s_dot", "psi1_dot", "psi3_dot")
    full = True

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        alpha: float = 0.0,
        beta: float = 0.0,
        drift_bound: float = 1e-5,
    ) -> None:
        super().__init__(p, flap_limits)
        for key, value in (("alpha", alpha), ("beta", beta)):
            if not (math.isfinite(value) and value >= 0.0):
                raise InputError(f"Baumgarte gain {key} must be finite and >= 0 1/s, got {value!r}")
        if not drift_bound > 0.0:
            raise InputError(f"drift_bound must be > 0 m, got {drift_bound!r}")
        self.alpha, self.beta, self.drift_bound = float(alpha), float(beta), float(drift_bound)
        self.name = "baumgarte" if (alpha or beta) else "index1"
        self.accel, self._project = make_full_kernel(self.consts)
        self.ex = p.x_D - p.x_A
        self.ey = p.y_D - p.y_A - p.L1

    def fun(self, force):
        accel, alpha, beta = self.accel, self.alpha, self.beta

        def rhs(t, y):
            a = accel(y.tolist(), force(t), alpha, beta)
            return np.array([y[3], y[4], y[5], a[0], a[1], a[2]])

        return rhs

    def initial_state(self, q, qd) -> np.ndarray:
        q, qd = _consistent(q, qd, self.p)
        return np.concatenate([q, qd])

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(6, -1)
        return y[:3].T.copy(), y[3:].T.copy()

    def position_residual(self, y) -> float:
        """``max |Phi(q)|`` [m] at one state ``y`` (6,)."""
        s, a, b = float(y[0]), float(y[1]), float(y[2])
        p1 = self.p.L2 * math.sin(a) - self.p.L3 * math.cos(b) + self.ex
        p2 = -self.p.L2 * math.cos(a) - self.p.L3 * math.sin(b) - s + self.ey
        return max(abs(p1), abs(p2))

    def check(self, t, y):
        super().check(t, y)
        res = self.position_residual(y)
        if not res <= self.drift_bound:
            raise ConstraintDriftError(
                f"{self.name}: constraint residual max|Phi| = {res:.3g} m at t = {t:.9g} s "
                f"exceeds drift_bound = {self.drift_bound:g} m"
                + ("" if self.alpha or self.beta else "; use Baumgarte gains or projection")
            )


class Projected(FullCoordinates):
    """(d) Full coordinates, plain index-1 right-hand side, with the position projected on
    ``Phi = 0`` and the velocity on ``Phi_q qd = 0`` after each accepted step (in the M metric).
    """

    def __init__(
        self,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        drift_bound: float = 1e-5,
        tol: float = 1e-15,
    ) -> None:
        super().__init__(p, flap_limits, 0.0, 0.0, drift_bound)
        self.name = "projection"
        self.tol = float(tol)
        kernel = self._project

        def project(y: np.ndarray) -> np.ndarray:
            return np.array(kernel(y.tolist(), self.tol))

        self.project = project

    def to_q_qd(self, y):
        y = np.asarray(y, dtype=float).reshape(6, -1)
        out = np.array([self._project(col, self.tol) for col in y.T.tolist()]).reshape(-1, 6)
        return out[:, :3].copy(), out[:, 3:].copy()


#: Registry of formulations: name -> constructor ``(p, **options)``.
FORMULATIONS: Mapping[str, Callable[..., Formulation]] = MappingProxyType({
    "psi3": Psi3Minimal,
    "s": StrokeMinimal,
    "index1": lambda p, **kw: FullCoordinates(p, **kw),
    "baumgarte": lambda p, alpha=50.0, beta=50.0, **kw: FullCoordinates(
        p, alpha=alpha, beta=beta, **kw
    ),
    "projection": Projected,
})


def get_formulation(formulation, p: DRSParams, **options) -> Formulation:
    """A :class:`Formulation` instance from a name in :data:`FORMULATIONS` or an instance."""
    if isinstance(formulation, Formulation):
        if options:
            raise InputError("options go with a formulation name, not an instance")
        return formulation
    try:
        ctor = FORMULATIONS[formulation]
    except (KeyError, TypeError):
        raise InputError(
            f"formulation must be one of {sorted(FORMULATIONS)}, got {formulation!r}"
        ) from None
    return ctor(p, **options)


# ---- inverse-dynamics force of the manoeuvre ---------------------------------------------------
class ManoeuvreForce:
    """The piston force [N] that makes the mechanism follow the seed's open-hold-close manoeuvre
    exactly (inverse dynamics by virtual work with s independent, scalar kernel):

    ``F = u.(M qdd + h - Q(q, 0)) = uMu s'' + (uMw + uh) s'^2 - uQ0`` with ``u = dq/ds``.

    Each piece of the profile (rest, opening, hold, closing, rest) gives a smooth force;
    ``segment(a, b)`` returns the piece of the segment ``[a, b]`` (extended smoothly past its ends,
    so that integrator stages just outside a segment do not see the next piece), and
    ``breakpoints`` are the joints (0, 10, 40, 50 ms for the seed).

    Parameters
    ----------
    p : DRSParams
    s_limits : (float, float), optional
        ``(s_min, s_max)`` [m] of the manoeuvre (default: the gap-rule strokes).
    flap_limits : (float, float), optional
        ``(psi3_closed, psi3_open)`` [rad] of the air-force law (default: the gap-rule angles).
    """

    def __init__(self, p: DRSParams, s_limits=None, flap_limits=None) -> None:
        lo, hi = (None, None) if s_limits is None else s_limits
        self.manoeuvre = drs_manoeuvre(p, lo, hi)
        self.p = p
        _, self._terms = make_stroke_kernel(_consts(p, flap_limits))
        m = self.manoeuvre
        self._pieces = (
            (None, m.s_min),
            (m.opening, None),
            (None, m.s_max),
            (m.closing, None),
            (None, m.s_min),
        )
        self.breakpoints = tuple(float(t) for t in m.kinks)

    def _piece_index(self, t: float) -> int:
        bps = self.breakpoints
        for i, tb in enumerate(bps):
            if t < tb:
                return i
        return len(bps)

    def _piece_fun(self, index: int) -> Callable[[float], float]:
        seg, rest = self._pieces[index]
        terms = self._terms
        if seg is None:
            umu, quad, uq0, _ = terms(rest)
            value = -uq0

            return lambda t: value
        t0 = seg.t0
        c0, c1, c2, c3, c4, c5 = seg.coeffs

        def piece(t: float) -> float:
            tau = t - t0
            s = c0 + tau * (c1 + tau * (c2 + tau * (c3 + tau * (c4 + tau * c5))))
            v = c1 + tau * (2 * c2 + tau * (3 * c3 + tau * (4 * c4 + tau * 5 * c5)))
            a = 2 * c2 + tau * (6 * c3 + tau * (12 * c4 + tau * 20 * c5))
            umu, quad, uq0, _ = terms(s)
            return umu * a + quad * v * v - uq0

        return piece

    def __call__(self, t: float) -> float:
        return self._piece_fun(self._piece_index(float(t)))(float(t))

    def segment(self, a: float, b: float) -> Callable[[float], float]:
        return self._piece_fun(self._piece_index(0.5 * (a + b)))

    def profile(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The profile ``(s, s', s'')`` at times t (the exact solution under this force)."""
        return self.manoeuvre.evaluate(t)

    def initial_q_qd(self) -> tuple[np.ndarray, np.ndarray]:
        """The configuration at rest at the start of the manoeuvre (closed)."""
        q = solve_position(self.manoeuvre.s_min, self.p)
        return q, np.zeros(3)


# ---- numpy reference right-hand sides (for tests) ---------------------------------------------
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


def manoeuvre_initial_state(p: DRSParams, s_limits=None) -> tuple[np.ndarray, np.ndarray]:
    """``(q, qd)`` at rest at the manoeuvre's closed stroke."""
    s0 = stroke_limits(p)[0] if s_limits is None else float(s_limits[0])
    return solve_position(s0, p), np.zeros(3)
