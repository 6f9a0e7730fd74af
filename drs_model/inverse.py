r"""Inverse dynamics of the DRS actuator: the piston force (and joint reactions) for a given motion.

Three formulations of seed 003's "Dynamics" part behind one interface (:class:`InverseMethod`)
and one registry (:data:`INVERSE_METHODS`), as sympy puts Kane and Lagrange behind ``MethodBase``
and scipy its solvers behind ``METHODS``. Each takes the full state ``q = [s, psi1, psi3]``,
``qd``, ``qdd`` (shape ``(..., 3)``, consistent with the loop constraints) and returns an
:class:`InverseDynamicsResult`.

Forces (seed's ``make_FORCE`` calls, all components in ground axes, x to the rear, y up)
-----------------------------------------------------------------------------------------
* piston force ``F`` along +y at P, on the piston;
* prismatic joint: ``(Np, 0)`` at P and torque ``Tp`` on the piston (from ground);
* pin B: ``rj1 = (rj1x, rj1y)`` on the piston, ``-rj1`` on the link;
* pin C: ``rj2`` on the link, ``-rj2`` on the flap (applied at the link's C, as the seed does);
* pivot D: ``rj3`` on the flap from ground;
* gravity ``(0, -m g)`` at each centre of mass; air ``(F_drag, -F_down)`` at G3, linear in psi3
  between the closed and open flap angles (the seed's ``air_forces_law``).

Newton-Euler (``"newton-euler"``)
---------------------------------
Per body, Newton ``m a_G = sum F`` and Euler about the centre of mass ``I alpha = sum M_G``; the
seed writes each as ``m a_G - sum F = 0`` (:func:`newton_euler_system` gives these 9 equations in
the 9 unknowns ``Np, Tp, rj1x, rj1y, rj2x, rj2y, rj3x, rj3y, F`` in the seed's order and signs).
Closed form: with ``K2 = m2 (a_G2 - g)`` and ``K3 = m3 (a_G3 - g) - F_air`` (``g = (0, -g)``), the
link and flap Newton equations give ``rj1 = rj2 - K2`` and ``rj3 = rj2 + K3``; their Euler equations
then read

.. math::

    (C - B) \times r_{j2} = I_2 \ddot\psi_1 - (B - G_2) \times K_2, \qquad
    (D - C) \times r_{j2} = I_3 \ddot\psi_3 - (D - G_3) \times K_3,

a 2 x 2 system of determinant ``(C - B) x (D - C) = -L2 L3 cos(psi1 - psi3)`` (zero where B, C,
D align: the dead centre, where no finite piston force moves the flap). Then the piston:
``Np = m1 a_G1x - rj1x``, ``F = m1 (a_G1y + g) - rj1y``,
``Tp = I1 * 0 - (P - G1) x (Np, 0) - (B - G1) x rj1``.

Lagrange with multipliers (``"lagrange"``)
------------------------------------------
.. math::  M(q) \ddot q + h(q, \dot q) + \Phi_q^T \lambda = Q_0(q) + F e_s

with ``M``, ``h``, ``Q_0`` (gravity and air, no piston force) of :mod:`drs_model.bodies`. This is
the sign of sympy's ``LagrangesMethod`` (``eom = ... - lam_coeffs.T lam``, ``lam_coeffs = -Phi_q``)
and of the seed: with ``Phi = r_C3 - r_C`` the multipliers are the pin-C reaction on the link,
``lambda = rj2`` (the seed prints ``lambda(0) = [-172.7346128, -1002.044240]`` next to
``rj2(0) = [-172.7335602, -1002.038132]``). Solved as a batched 3 x 3 linear system in
``(F, lambda1, lambda2)``.

Virtual work / d'Alembert (``"virtual-work"``)
----------------------------------------------
Along any admissible virtual displacement ``delta q = u delta psi3`` with ``u = dq/dpsi3`` (so
``Phi_q u = 0``: the reactions do no work), the d'Alembert forces balance the applied ones:

.. math::  F = \frac{u^T (M \ddot q + h - Q_0)}{u_s}, \qquad u = \frac{dq}{d\psi_3}

``u`` is regular over the whole stroke (the psi3 parametrisation); ``u_s = ds/dpsi3`` vanishes at
the dead centre, where the force is undefined. The seed writes the same principle with
``u = dq/ds`` (its ``PVW_dynamic``); :class:`FusedInverseDynamics` uses that form, fused with the
closed-form kinematics, for one sample at a time.

All three are exact for a consistent state and agree to rounding. Units: SI (m, rad, s, kg, N,
N m); forces in ground axes.
"""

from __future__ import annotations

import abc
import math
import types
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from . import elementwise, kernels
from .bodies import air_forces, applied_forces, mass_matrix, model_constants, velocity_forces
from .compiled.scalar import bind
from .constraints import PSI1, PSI3, S, constraint_jacobian, singularity_measure
from .errors import AssemblyError, InputError, SingularConfigurationError
from .kernels import SINGULAR_TOL
from .kinematics import (
    KinematicState,
    kinematic_state,
    point_accelerations,
    point_positions,
    solve_position,
    velocity_ratio,
)
from .params import DRSParams
from .profile import Manoeuvre, drs_manoeuvre

#: Unknowns of the Newton-Euler system, in the seed's order (``rvars`` then the piston force).
NE_UNKNOWNS = ("Np", "Tp", "rj1x", "rj1y", "rj2x", "rj2y", "rj3x", "rj3y", "F")
#: Keys of :attr:`InverseDynamicsResult.reactions` (all but the piston force).
REACTION_NAMES = NE_UNKNOWNS[:-1]


# ---- result ------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class InverseDynamicsResult:
    """Outcome of an inverse-dynamics formulation for ``N`` samples (leading shape ``...``).

    Attributes
    ----------
    method : str
        Registry name of the formulation.
    piston_force : ndarray, shape (...)
        Piston force ``F`` [N] along +y at P (positive pushes the rod out).
    reactions : mapping of str to ndarray, shape (...), or None
        Joint reactions of Newton-Euler (:data:`REACTION_NAMES`): ``Np`` [N], ``Tp`` [N m],
        ``rj1x`` ... ``rj3y`` [N], with the seed's signs (see the module docstring).
    multipliers : ndarray, shape (..., 2), or None
        Lagrange multipliers [N] (``lambda = rj2``, the pin-C reaction on the link).
    """

    method: str
    piston_force: np.ndarray
    reactions: Mapping[str, np.ndarray] | None = None
    multipliers: np.ndarray | None = None


# ---- validation ---------------------------------------------------------------------------------
def _as_state(state: KinematicState | tuple, p: DRSParams) -> tuple[np.ndarray, ...]:
    """Validate ``(q, qd, qdd)``: finite, shape ``(..., 3)``, equal shapes, not at dead centre."""
    if not isinstance(p, DRSParams):
        raise InputError(f"p must be DRSParams, got {type(p).__name__}")
    try:
        q, qd, qdd = state
    except (TypeError, ValueError):
        raise InputError(
            "state must be a KinematicState or a (q, qd, qdd) triple of arrays of shape (..., 3)"
        ) from None
    arrays = []
    for name, value in (("q", q), ("qd", qd), ("qdd", qdd)):
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise InputError(
                f"{name} must be an array of floats, got {type(value).__name__}"
            ) from None
        if arr.ndim == 0 or arr.shape[-1] != 3:
            raise InputError(f"{name} must have shape (..., 3) = [s, psi1, psi3], got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            bad = arr[~np.isfinite(arr)].ravel()[0]
            raise InputError(f"{name} must be finite, got {float(bad)!r}")
        arrays.append(arr)
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise InputError(
            f"q, qd, qdd must have equal shapes, got {arrays[0].shape}, {arrays[1].shape}, "
            f"{arrays[2].shape}"
        )
    meas = singularity_measure(arrays[0], p, "s")
    if np.any(meas < SINGULAR_TOL):
        bad = arrays[0][meas < SINGULAR_TOL].reshape(-1, 3)[0]
        raise SingularConfigurationError(
            f"no finite piston force at q = {bad.tolist()}: B, C and D are aligned (dead centre, "
            f"|cos(psi1 - psi3)| = {float(np.min(meas)):.3g} < {SINGULAR_TOL:g})"
        )
    return tuple(arrays)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component of the planar cross product ``a x b``, shapes ``(..., 2)`` -> ``(...)``."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


# ---- formulations -------------------------------------------------------------------------------
class InverseMethod(abc.ABC):
    """One formulation of the inverse dynamics (a stateless strategy, like sympy's MethodBase).

    Subclasses implement :meth:`solve` on validated arrays; :meth:`__call__` validates.
    """

    name: str = ""

    def __call__(
        self,
        state: KinematicState | tuple,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
    ) -> InverseDynamicsResult:
        """Piston force (and what else the formulation gives) for ``state = (q, qd, qdd)``.

        Parameters
        ----------
        state : KinematicState or tuple of ndarray, each of shape (..., 3)
            ``q`` [m, rad, rad], ``qd`` [m/s, rad/s], ``qdd`` [m/s^2, rad/s^2], consistent with the
            loop constraints.
        p : DRSParams
        flap_limits : (float, float), optional
            ``(psi3_closed, psi3_open)`` [rad] of the air law; default: our exact gap-rule angles.

        Raises
        ------
        InputError
            Non-finite values or wrong shapes.
        SingularConfigurationError
            A sample at the dead centre (B, C, D aligned).
        """
        q, qd, qdd = _as_state(state, p)
        return self.solve(q, qd, qdd, p, flap_limits)

    @abc.abstractmethod
    def solve(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        qdd: np.ndarray,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
    ) -> InverseDynamicsResult:
        """The formulation proper, on validated float arrays of shape ``(..., 3)``."""


class NewtonEuler(InverseMethod):
    """Per-body Newton-Euler with every joint reaction, in closed form (module docstring)."""

    name = "newton-euler"

    def solve(self, q, qd, qdd, p, flap_limits=None) -> InverseDynamicsResult:
        pos = point_positions(q, p, ("P", "G1", "B", "G2", "C", "G3", "D"))
        acc = point_accelerations(q, qd, qdd, p, ("G1", "G2", "G3"))
        drag, down = air_forces(q[..., PSI3], p, flap_limits)
        k2 = p.m_link * acc["G2"]
        k2[..., 1] += p.m_link * p.g
        k3 = p.m_wing * acc["G3"]
        k3[..., 0] -= drag
        k3[..., 1] += p.m_wing * p.g + down
        e = pos["C"] - pos["B"]
        f = pos["D"] - pos["C"]
        c1 = p.Iz_link * qdd[..., PSI1] - _cross(pos["B"] - pos["G2"], k2)
        c2 = p.Iz_wing * qdd[..., PSI3] - _cross(pos["D"] - pos["G3"], k3)
        det = _cross(e, f)
        rj2x = (c1 * f[..., 0] - e[..., 0] * c2) / det
        rj2y = (c1 * f[..., 1] - e[..., 1] * c2) / det
        rj1x, rj1y = rj2x - k2[..., 0], rj2y - k2[..., 1]
        rj3x, rj3y = rj2x + k3[..., 0], rj2y + k3[..., 1]
        a1 = acc["G1"]
        np_ = p.m_pist * a1[..., 0] - rj1x
        force = p.m_pist * (a1[..., 1] + p.g) - rj1y
        rp = pos["P"] - pos["G1"]
        rb = pos["B"] - pos["G1"]
        # I1 alpha1 = Tp + (P - G1) x (Np, 0) + (P - G1) x (0, F) + (B - G1) x rj1, alpha1 = 0
        tp = rp[..., 1] * np_ - rp[..., 0] * force - (rb[..., 0] * rj1y - rb[..., 1] * rj1x)
        reactions = types.MappingProxyType(
            dict(zip(REACTION_NAMES, (np_, tp, rj1x, rj1y, rj2x, rj2y, rj3x, rj3y), strict=True))
        )
        return InverseDynamicsResult(self.name, force, reactions, None)


class Lagrange(InverseMethod):
    """Lagrange's equations with multipliers, ``M qdd + h + Phi_q^T lambda = Q0 + F e_s``."""

    name = "lagrange"

    def solve(self, q, qd, qdd, p, flap_limits=None) -> InverseDynamicsResult:
        r = _dalembert_residual(q, qd, qdd, p, flap_limits)
        jac = constraint_jacobian(q, p)
        a = np.zeros(q.shape[:-1] + (3, 3))
        a[..., S, 0] = 1.0
        a[..., :, 1:] = -np.swapaxes(jac, -1, -2)
        x = np.linalg.solve(a, r[..., None])[..., 0]
        return InverseDynamicsResult(self.name, x[..., 0], None, x[..., 1:])


class VirtualWork(InverseMethod):
    """d'Alembert's principle along ``u = dq/dpsi3``: ``F = u.(M qdd + h - Q0) / u_s``."""

    name = "virtual-work"

    def solve(self, q, qd, qdd, p, flap_limits=None) -> InverseDynamicsResult:
        r = _dalembert_residual(q, qd, qdd, p, flap_limits)
        u = velocity_ratio(q, p, "psi3", check=False)
        force = np.einsum("...i,...i->...", u, r) / u[..., S]
        return InverseDynamicsResult(self.name, force, None, None)


def _dalembert_residual(q, qd, qdd, p, flap_limits) -> np.ndarray:
    """``M qdd + h - Q0`` [N, N m, N m], shape ``(..., 3)`` (Q0 without the piston force)."""
    m = mass_matrix(q, p)
    return (
        np.einsum("...ij,...j->...i", m, qdd)
        + velocity_forces(q, qd, p)
        - applied_forces(q, 0.0, p, flap_limits)
    )


#: Registry of formulations: name -> instance (read-only).
INVERSE_METHODS: Mapping[str, InverseMethod] = types.MappingProxyType(
    {f.name: f for f in (NewtonEuler(), Lagrange(), VirtualWork())}
)


def get_method(method: str | InverseMethod) -> InverseMethod:
    """The formulation registered as ``method`` (or ``method`` itself if it is an InverseMethod)."""
    if isinstance(method, InverseMethod):
        return method
    try:
        return INVERSE_METHODS[method]
    except (KeyError, TypeError):
        raise InputError(
            f"method must be one of {sorted(INVERSE_METHODS)}, got {method!r}"
        ) from None


def inverse_dynamics(
    state: KinematicState | tuple,
    p: DRSParams,
    method: str | InverseMethod = "newton-euler",
    flap_limits: tuple[float, float] | None = None,
) -> InverseDynamicsResult:
    """Piston force and (per method) reactions or multipliers for a given motion.

    Parameters
    ----------
    state : KinematicState or (q, qd, qdd)
        Arrays of shape ``(..., 3)``: ``q = [s, psi1, psi3]`` [m, rad, rad] and its first two time
        derivatives, consistent with the loop (e.g. from
        :func:`~drs_model.kinematics.kinematic_state`).
    p : DRSParams
    method : {"newton-euler", "lagrange", "virtual-work"} or InverseMethod
    flap_limits : (float, float), optional
        ``(psi3_closed, psi3_open)`` [rad] of the air law (default: our exact gap-rule angles).

    Returns
    -------
    InverseDynamicsResult
        ``piston_force`` of shape ``(...)`` [N].

    Raises
    ------
    InputError
        Unknown method, non-finite values, wrong shapes.
    SingularConfigurationError
        A sample at the dead centre.
    """
    return get_method(method)(state, p, flap_limits)


def newton_euler_system(
    state: KinematicState | tuple,
    p: DRSParams,
    flap_limits: tuple[float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The seed's 9 Newton-Euler equations as ``A x = b`` (for inspection and a generic solve).

    Rows in the seed's order (``eqns_NE``): piston x, y, Euler; link x, y, Euler; flap x, y,
    Euler. Each is written ``m a - sum F = 0`` (Newton) or
    ``I alpha - sum M_G = 0`` (Euler about the centre of mass), i.e. ``A[i] . x - b[i]`` is the
    seed's printed expression, with ``x`` the unknowns :data:`NE_UNKNOWNS`. The pin-C reaction acts
    at the link's C on both link and flap, as in the seed.

    Returns
    -------
    A : ndarray, shape (..., 9, 9)
        Coefficients [1 for forces, m for moments].
    b : ndarray, shape (..., 9)
        Right-hand sides [N, N m].
    """
    q, qd, qdd = _as_state(state, p)
    pos = point_positions(q, p, ("P", "G1", "B", "G2", "C", "G3", "D"))
    acc = point_accelerations(q, qd, qdd, p, ("G1", "G2", "G3"))
    drag, down = air_forces(q[..., PSI3], p, flap_limits)
    ix = {name: i for i, name in enumerate(NE_UNKNOWNS)}
    a = np.zeros(q.shape[:-1] + (9, 9))
    b = np.zeros(q.shape[:-1] + (9,))

    def moment(row: int, r: np.ndarray, fx: str, fy: str, sign: float) -> None:
        # residual -= sign * (r x (fx, fy)) = -sign * (r_x fy - r_y fx)
        a[..., row, ix[fy]] += -sign * r[..., 0]
        a[..., row, ix[fx]] += sign * r[..., 1]

    m1, m2, m3 = p.m_pist, p.m_link, p.m_wing
    # piston: forces Np (x) at P, F (y) at P, rj1 at B; torque Tp
    a[..., 0, ix["Np"]] = a[..., 0, ix["rj1x"]] = -1.0
    b[..., 0] = -m1 * acc["G1"][..., 0]
    a[..., 1, ix["F"]] = a[..., 1, ix["rj1y"]] = -1.0
    b[..., 1] = -m1 * (acc["G1"][..., 1] + p.g)
    rp, rb = pos["P"] - pos["G1"], pos["B"] - pos["G1"]
    a[..., 2, ix["Tp"]] = -1.0
    a[..., 2, ix["Np"]] += rp[..., 1]  # -(r x (Np, 0)) = r_y Np
    a[..., 2, ix["F"]] += -rp[..., 0]  # -(r x (0, F)) = -r_x F
    moment(2, rb, "rj1x", "rj1y", 1.0)
    b[..., 2] = 0.0  # Iz_pist * 0: the piston does not rotate
    # link: -rj1 at B, rj2 at C
    a[..., 3, ix["rj1x"]], a[..., 3, ix["rj2x"]] = 1.0, -1.0
    b[..., 3] = -m2 * acc["G2"][..., 0]
    a[..., 4, ix["rj1y"]], a[..., 4, ix["rj2y"]] = 1.0, -1.0
    b[..., 4] = -m2 * (acc["G2"][..., 1] + p.g)
    moment(5, pos["B"] - pos["G2"], "rj1x", "rj1y", -1.0)
    moment(5, pos["C"] - pos["G2"], "rj2x", "rj2y", 1.0)
    b[..., 5] = -p.Iz_link * qdd[..., PSI1]
    # flap: -rj2 at C, rj3 at D, air at G3 (no moment about G3)
    a[..., 6, ix["rj2x"]], a[..., 6, ix["rj3x"]] = 1.0, -1.0
    b[..., 6] = -(m3 * acc["G3"][..., 0] - drag)
    a[..., 7, ix["rj2y"]], a[..., 7, ix["rj3y"]] = 1.0, -1.0
    b[..., 7] = -(m3 * (acc["G3"][..., 1] + p.g) + down)
    moment(8, pos["C"] - pos["G3"], "rj2x", "rj2y", -1.0)
    moment(8, pos["D"] - pos["G3"], "rj3x", "rj3y", 1.0)
    b[..., 8] = -p.Iz_wing * qdd[..., PSI3]
    return a, b


# ---- the manoeuvre ------------------------------------------------------------------------------
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
    method: str | InverseMethod = "virtual-work",
    s_limits: tuple[float, float] | None = None,
    flap_limits: tuple[float, float] | None = None,
) -> np.ndarray:
    """Piston force [N] along the seed's open-hold-close manoeuvre at times ``t`` [s].

    Profile -> kinematics -> force, shape of ``t``. ``"virtual-work"`` (the default) takes the
    fused closed form of :class:`FusedInverseDynamics` (closed-form kinematics and d'Alembert's
    principle along ``dq/ds``, evaluated in cache-sized blocks: the fast path); the other methods go
    through :func:`~drs_model.kinematics.kinematic_state` and :func:`inverse_dynamics`. All agree
    to ~1e-12 relative. For one sample at a time use :meth:`FusedInverseDynamics.force_at`.

    Raises
    ------
    InputError
        Unknown method or non-finite time.
    """
    formulation = get_method(method)
    if formulation.name == VirtualWork.name:
        return FusedInverseDynamics.from_params(p, flap_limits, s_limits).force_at_times(t)
    _, state = manoeuvre_state(t, p, s_limits)
    return formulation(state, p, flap_limits).piston_force


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
    method: str | InverseMethod = "virtual-work",
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


# ---- the fused closed form ----------------------------------------------------------------------
@dataclass(frozen=True)
class FusedInverseDynamics:
    """Piston force from :func:`drs_model.kernels.fused_force`: closed-form kinematics fused with
    d'Alembert's principle along ``u = dq/ds`` (the seed's ``PVW_dynamic``).

    Build once with :meth:`from_params`. One sample (:meth:`force`, :meth:`force_at`) runs the
    kernel compiled by numba (~1 us; the plain Python kernel without numba); arrays
    (:meth:`force_array`, :meth:`force_at_times`) run it on every element
    (:mod:`drs_model.elementwise`). Same equations as :class:`VirtualWork` (tested against all
    formulations).

    Attributes
    ----------
    consts : tuple of float
        :func:`drs_model.bodies.model_constants` of the parameters and air law.
    manoeuvre : Manoeuvre
    profile : tuple of float
        :meth:`Manoeuvre.constants <drs_model.profile.Manoeuvre.constants>` of ``manoeuvre``.
    """

    consts: tuple[float, ...]
    manoeuvre: Manoeuvre
    profile: tuple[float, ...]

    @classmethod
    def from_params(
        cls,
        p: DRSParams,
        flap_limits: tuple[float, float] | None = None,
        s_limits: tuple[float, float] | None = None,
    ) -> FusedInverseDynamics:
        """Precompute the constants of ``p`` (and the manoeuvre for :meth:`force_at`)."""
        man = drs_manoeuvre(p, *(s_limits if s_limits is not None else (None, None)))
        return cls(model_constants(p, flap_limits), man, man.constants())

    @cached_property
    def _force(self):
        return bind(kernels.fused_force, self.consts)

    @cached_property
    def _force_at(self):
        return bind(kernels.fused_manoeuvre_force, self.consts, self.profile)

    def force(self, s: float, sd: float, sdd: float) -> float:
        """Piston force [N] for stroke ``s`` [m], rate ``sd`` [m/s], acceleration ``sdd`` [m/s^2].

        Raises
        ------
        InputError
            A non-finite input.
        AssemblyError
            The loop cannot close at ``s``.
        SingularConfigurationError
            ``s`` at the dead centre.
        """
        if not (math.isfinite(s) and math.isfinite(sd) and math.isfinite(sdd)):
            raise InputError(f"s, sd, sdd must be finite, got {(s, sd, sdd)!r}")
        force = self._force(s, sd, sdd)
        if math.isnan(force):
            self._diagnose(np.array([s]))
        return force

    def force_at(self, t: float) -> float:
        """Piston force [N] at time ``t`` [s] of the open-hold-close manoeuvre."""
        if not math.isfinite(t):
            raise InputError(f"time must be finite, got {t!r}")
        return self._force_at(t)

    def force_array(self, s, sd, sdd) -> np.ndarray:
        """The same kernel on numpy arrays.

        ``s`` [m], ``sd`` [m/s], ``sdd`` [m/s^2] broadcast to a common shape; returns [N].
        """
        s, sd, sdd = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (s, sd, sdd)))
        for name, x in (("s", s), ("sd", sd), ("sdd", sdd)):
            if not np.all(np.isfinite(x)):
                bad = float(x[~np.isfinite(x)].ravel()[0])
                raise InputError(f"{name} must be finite, got {bad!r}")
        out = np.asarray(elementwise.fused_force(s, sd, sdd, self.consts), dtype=float)
        if np.any(np.isnan(out)):
            self._diagnose(s.ravel())
        return out

    def force_at_times(self, t) -> np.ndarray:
        """Piston force [N] along the manoeuvre at times ``t`` [s] (any shape)."""
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise InputError(f"time must be finite, got {float(t[~np.isfinite(t)].ravel()[0])!r}")
        return np.asarray(
            elementwise.fused_manoeuvre_force(t, self.consts, self.profile), dtype=float
        )

    def _diagnose(self, s: np.ndarray) -> None:
        """Raise the typed error of the first stroke [m] of ``s`` where the kernel gave NaN."""
        *angles, h2 = elementwise.stroke_position(s, self.consts, 1.0)
        if np.any(h2 < -kernels.ASSEMBLY_TOL):
            raise AssemblyError(
                f"the loop cannot close at stroke {float(s[h2 < -kernels.ASSEMBLY_TOL][0])!r} m: "
                "it lies beyond a singular stroke (see `drs limits`)"
            )
        sin1, cos1, sin3, cos3 = angles
        dead = np.abs(cos1 * cos3 + sin1 * sin3) < SINGULAR_TOL
        raise SingularConfigurationError(
            f"stroke {float(s[dead][0]) if np.any(dead) else float(s[0])!r} m is a singular "
            "stroke (dead centre): no finite piston force moves the flap there"
        )
