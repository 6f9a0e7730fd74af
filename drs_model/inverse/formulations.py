r"""Inverse dynamics of the DRS actuator: the piston force (and joint reactions) for a given motion.

Four formulations of seed 003's "Dynamics" part behind one interface (:class:`InverseMethod`)
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
D align: the dead centre, where no finite piston force moves the flap). Then the piston, with
``K1 = m1 (a_G1 - g)``: ``Np = K1x - rj1x``, ``F = K1y - rj1y``,
``Tp = I1 * 0 - (P - G1) x (Np, 0) - (B - G1) x rj1``. Written once, as
:func:`drs_model.kernels.newton_euler_reactions` (with the loads ``K_b`` of
:func:`~drs_model.kernels.dalembert_loads`): arithmetic alone, so arrays run it with numpy and
one sample (``q`` of shape ``(3,)``) runs it compiled by numba, on floats.

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
the dead centre, where the force is undefined.

Fused closed form (``"fused"``)
-------------------------------
The same principle as the seed writes it (its ``PVW_dynamic``): along ``u = dq/ds``, fused with
the closed-form kinematics of the stroke, so that it reads only ``s, s', s''`` of the state (on
assembly branch 1) and needs no numpy at all: :func:`drs_model.kernels.fused_force`, run by
:class:`~drs_model.inverse.fused.FusedInverseDynamics` (one sample in about a microsecond when
numba is installed; the actuator's and the manoeuvre's force). ``u_s = 1``; ``dpsi/ds`` is
infinite at the dead centre.

All four are exact for a consistent state and agree to rounding. Units: SI (m, rad, s, kg, N,
N m); forces in ground axes.
"""

from __future__ import annotations

import abc
import functools
import math
import types
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .. import kernels
from ..bodies import applied_forces, mass_matrix, model_constants, velocity_forces
from ..compiled.scalar import bind
from ..constraints import PSI1, PSI3, S, constraint_jacobian, singularity_measure
from ..errors import InputError, SingularConfigurationError
from ..kernels import SINGULAR_TOL
from ..kinematics import KinematicState, point_positions, velocity_ratio
from ..params import DRSParams
from .fused import FusedInverseDynamics

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
        arrays.append(arr)
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise InputError(
            f"q, qd, qdd must have equal shapes, got {arrays[0].shape}, {arrays[1].shape}, "
            f"{arrays[2].shape}"
        )
    if arrays[0].ndim == 1:  # one sample: nine floats, checked without numpy's reductions
        values = [*arrays[0].tolist(), *arrays[1].tolist(), *arrays[2].tolist()]
        finite = all(map(math.isfinite, values))
    else:  # one pass over the sum (a NaN or inf anywhere makes it non-finite)
        finite = bool(np.isfinite(arrays[0] + arrays[1] + arrays[2]).all())
    if not finite:  # which array, and its first bad value
        for name, arr in zip(("q", "qd", "qdd"), arrays, strict=True):
            if not np.isfinite(arr).all():
                bad = arr[~np.isfinite(arr)].ravel()[0]
                raise InputError(f"{name} must be finite, got {float(bad)!r}")
    if arrays[0].ndim == 1:  # a float from three floats (numpy's 0-d arithmetic costs ~3 us)
        meas = singularity_measure(tuple(values[:3]), p, "s")
        singular, bad = meas < SINGULAR_TOL, values[:3]
    else:
        meas = singularity_measure(arrays[0], p, "s")
        singular = (meas < SINGULAR_TOL).any()
        bad = arrays[0][meas < SINGULAR_TOL].reshape(-1, 3)[0].tolist() if singular else None
    if singular:
        raise SingularConfigurationError(
            f"no finite piston force at q = {bad}: B, C and D are aligned (dead centre, "
            f"|cos(psi1 - psi3)| = {float(np.min(meas)):.3g} < {SINGULAR_TOL:g})"
        )
    return tuple(arrays)


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


class _NewtonEulerTerms(NamedTuple):
    """What every body's Newton-Euler equations balance: the points ``P, G1, B, G2, C, G3, D``
    [m] (each ``(..., 2)``) and ``K_b = m_b (a_Gb - g) - F_air,b`` [N] (``g = (0, -g)``,
    :func:`drs_model.kernels.dalembert_loads`), each ``(..., 2)``."""

    pos: dict[str, np.ndarray]
    k1: np.ndarray
    k2: np.ndarray
    k3: np.ndarray


def _newton_euler_terms(q, qd, qdd, p: DRSParams, flap_limits) -> _NewtonEulerTerms:
    """The set-up of the Newton-Euler equations for :func:`newton_euler_system`."""
    pos = point_positions(q, p, ("P", "G1", "B", "G2", "C", "G3", "D"))
    k1y, k2x, k2y, k3x, k3y = kernels.dalembert_loads(
        *_angles(q), q[..., PSI3], *_rates(qd, qdd), _constants(p, flap_limits)
    )
    return _NewtonEulerTerms(
        pos,
        np.stack(np.broadcast_arrays(0.0, k1y), -1),
        np.stack((k2x, k2y), -1),
        np.stack((k3x, k3y), -1),
    )


def _angles(q: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(sin psi1, cos psi1, sin psi3, cos psi3)`` of ``q`` (..., 3)."""
    psi1, psi3 = q[..., PSI1], q[..., PSI3]
    return np.sin(psi1), np.cos(psi1), np.sin(psi3), np.cos(psi3)


def _rates(qd: np.ndarray, qdd: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(psi1', psi3', s'', psi1'', psi3'')``, the rates :func:`kernels.dalembert_loads` reads."""
    return qd[..., PSI1], qd[..., PSI3], qdd[..., S], qdd[..., PSI1], qdd[..., PSI3]


@functools.lru_cache(maxsize=32)
def _cached_constants(p: DRSParams, flap_limits: tuple[float, float] | None) -> tuple[float, ...]:
    return model_constants(p, flap_limits)


def _constants(p: DRSParams, flap_limits) -> tuple[float, ...]:
    """:func:`~drs_model.bodies.model_constants` of ``p`` and the air law, computed once per
    parameter set (it solves the gap rule for the flap angles: ~50 us, more than the force)."""
    key = None if flap_limits is None else tuple(float(x) for x in flap_limits)
    return _cached_constants(p, key)


@functools.lru_cache(maxsize=32)
def _newton_euler_bound(consts: tuple[float, ...]):
    return bind(kernels.newton_euler_reactions, consts)


@functools.lru_cache(maxsize=32)
def _newton_euler_sample(p: DRSParams, flap_limits: tuple[float, float] | None):
    """:func:`kernels.newton_euler_reactions` bound to the constants of ``p`` and the air law,
    compiled when numba is installed (one sample: its floats in, nine floats out); one cache
    look-up per sample (hashing the 23 constants again would cost more than the kernel)."""
    return _newton_euler_bound(_constants(p, flap_limits))


class NewtonEuler(InverseMethod):
    """Per-body Newton-Euler with every joint reaction, in closed form
    (:func:`drs_model.kernels.newton_euler_reactions`; the module docstring has the equations).

    One sample (``q`` of shape ``(3,)``) runs the kernel compiled, on floats; arrays run the same
    kernel on numpy arrays."""

    name = "newton-euler"

    def solve(self, q, qd, qdd, p, flap_limits=None) -> InverseDynamicsResult:
        if q.ndim == 1:
            key = None if flap_limits is None else tuple(float(x) for x in flap_limits)
            s, psi1, psi3 = q.tolist()
            _, psi1d, psi3d = qd.tolist()
            sin, cos = math.sin, math.cos
            out = _newton_euler_sample(p, key)(
                s, sin(psi1), cos(psi1), sin(psi3), cos(psi3), psi3, psi1d, psi3d, *qdd.tolist()
            )
            out = tuple(map(np.float64, out))
        else:
            out = kernels.newton_euler_reactions(
                q[..., S], *_angles(q), q[..., PSI3], *_rates(qd, qdd), _constants(p, flap_limits)
            )
        reactions = types.MappingProxyType(dict(zip(REACTION_NAMES, out[:-1], strict=True)))
        return InverseDynamicsResult(self.name, out[-1], reactions, None)


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


class Fused(InverseMethod):
    """d'Alembert's principle along ``u = dq/ds`` fused with the closed-form kinematics
    (:func:`drs_model.kernels.fused_force`, the seed's ``PVW_dynamic``): reads ``s, s', s''`` of
    the state, on assembly branch 1."""

    name = "fused"

    def solve(self, q, qd, qdd, p, flap_limits=None) -> InverseDynamicsResult:
        fused = FusedInverseDynamics.from_params(p, flap_limits)
        force = fused.force_array(q[..., S], qd[..., S], qdd[..., S])
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
    {f.name: f for f in (NewtonEuler(), Lagrange(), VirtualWork(), Fused())}
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
    method : {"newton-euler", "lagrange", "virtual-work", "fused"} or InverseMethod
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
    pos, k1, k2, k3 = _newton_euler_terms(q, qd, qdd, p, flap_limits)
    ix = {name: i for i, name in enumerate(NE_UNKNOWNS)}
    a = np.zeros(q.shape[:-1] + (9, 9))
    b = np.zeros(q.shape[:-1] + (9,))

    def moment(row: int, r: np.ndarray, fx: str, fy: str, sign: float) -> None:
        # residual -= sign * (r x (fx, fy)) = -sign * (r_x fy - r_y fx)
        a[..., row, ix[fy]] += -sign * r[..., 0]
        a[..., row, ix[fx]] += sign * r[..., 1]

    # piston: forces Np (x) at P, F (y) at P, rj1 at B; torque Tp
    a[..., 0, ix["Np"]] = a[..., 0, ix["rj1x"]] = -1.0
    b[..., 0] = -k1[..., 0]
    a[..., 1, ix["F"]] = a[..., 1, ix["rj1y"]] = -1.0
    b[..., 1] = -k1[..., 1]
    rp, rb = pos["P"] - pos["G1"], pos["B"] - pos["G1"]
    a[..., 2, ix["Tp"]] = -1.0
    a[..., 2, ix["Np"]] += rp[..., 1]  # -(r x (Np, 0)) = r_y Np
    a[..., 2, ix["F"]] += -rp[..., 0]  # -(r x (0, F)) = -r_x F
    moment(2, rb, "rj1x", "rj1y", 1.0)
    b[..., 2] = 0.0  # Iz_pist * 0: the piston does not rotate
    # link: -rj1 at B, rj2 at C
    a[..., 3, ix["rj1x"]], a[..., 3, ix["rj2x"]] = 1.0, -1.0
    b[..., 3] = -k2[..., 0]
    a[..., 4, ix["rj1y"]], a[..., 4, ix["rj2y"]] = 1.0, -1.0
    b[..., 4] = -k2[..., 1]
    moment(5, pos["B"] - pos["G2"], "rj1x", "rj1y", -1.0)
    moment(5, pos["C"] - pos["G2"], "rj2x", "rj2y", 1.0)
    b[..., 5] = -p.Iz_link * qdd[..., PSI1]
    # flap: -rj2 at C, rj3 at D, air at G3 (no moment about G3)
    a[..., 6, ix["rj2x"]], a[..., 6, ix["rj3x"]] = 1.0, -1.0
    b[..., 6] = -k3[..., 0]
    a[..., 7, ix["rj2y"]], a[..., 7, ix["rj3y"]] = 1.0, -1.0
    b[..., 7] = -k3[..., 1]
    moment(8, pos["C"] - pos["G3"], "rj2x", "rj2y", -1.0)
    moment(8, pos["D"] - pos["G3"], "rj3x", "rj3y", 1.0)
    b[..., 8] = -p.Iz_wing * qdd[..., PSI3]
    return a, b
