r"""Rotating-frame kinematics of a collar sliding along a rotating rod (seed 000, examples 1 and 2).

A rod turns in the plane about a fixed pin O (the seed's A). Its angle ``theta`` is measured from
the fixed X axis, counter-clockwise positive; ``omega = theta'`` and ``alpha = theta''``. A collar
B slides along the rod at distance ``r`` from O with rates ``r_dot`` and ``r_ddot``. The rotating
frame xy is attached to the rod: ``e_x = (cos theta, sin theta)`` points from O to B and
``e_y = k x e_x = (-sin theta, cos theta)``. Then

.. math::

    \mathbf r_B &= r\,\mathbf e_x \\
    \mathbf v_B &= \underbrace{\dot r\,\mathbf e_x}_{\text{relative}}
        + \underbrace{\omega r\,\mathbf e_y}_{\text{transport } \boldsymbol\omega\times\mathbf r} \\
    \mathbf a_B &= \underbrace{\ddot r\,\mathbf e_x}_{\text{relative}}
        \underbrace{-\,\omega^2 r\,\mathbf e_x}_{\text{centripetal}}
        + \underbrace{\alpha r\,\mathbf e_y}_{\text{tangential } \boldsymbol\alpha\times\mathbf r}
        + \underbrace{2\omega\dot r\,\mathbf e_y}_{\text{Coriolis } 2\boldsymbol\omega\times
          \mathbf v_{rel}}

so in fixed components ``v_X = r_dot cos(theta) - omega r sin(theta)``,
``v_Y = r_dot sin(theta) + omega r cos(theta)``,
``a_X = (r_ddot - omega^2 r) cos(theta) - (alpha r + 2 omega r_dot) sin(theta)`` and
``a_Y = (r_ddot - omega^2 r) sin(theta) + (alpha r + 2 omega r_dot) cos(theta)``.
Only ``2 omega x v_rel`` is the Coriolis acceleration. The seed calls the whole velocity
``v_B`` a "Coriolis velocity" and the whole acceleration a "Coriolis acceleration": that is wrong,
there is no Coriolis velocity, and ``a_B`` has four terms of which one is Coriolis.
The seed's example-2 MATLAB ``VB_x = 0.5*(cosd(theta) - x.*sind(theta))`` is the general
``v_X`` with ``r_dot = omega = 0.5`` factored out; its ``aB_x``, ``aB_y`` are never defined, and are
``a_X``, ``a_Y`` above.

:func:`polar_kinematics` is the inverse: from a fixed-frame position, velocity and acceleration
of B relative to the pivot it returns ``theta, omega, alpha, r, r_dot, r_ddot``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..errors import DegenerateGeometryError, InputError, ParameterError
from ..params import real_number
from ._checks import _broadcast, _finite, _stack, _vector

#: Below this distance [m] between a point and its pivot the link angle is undefined.
MIN_RADIUS = 1e-12


# ---- result types -------------------------------------------------------------------------------
class LinkMotion(NamedTuple):
    """Motion of a link about its pivot and of a point along it; arrays of one shape ``(...)``.

    theta [rad], omega [rad/s], alpha [rad/s^2] (CCW positive, from the fixed X axis);
    r [m], r_dot [m/s], r_ddot [m/s^2] (distance pivot -> point along the link).
    """

    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    r: np.ndarray
    r_dot: np.ndarray
    r_ddot: np.ndarray


class VelocityTerms(NamedTuple):
    """Velocity of the point [m/s], each ``(..., 2)``: ``relative + transport = total``."""

    relative: np.ndarray
    transport: np.ndarray
    total: np.ndarray


class AccelerationTerms(NamedTuple):
    """Acceleration [m/s^2], each ``(..., 2)``; the four terms sum to ``total``.

    ``relative`` = r_ddot e_x, ``centripetal`` = -omega^2 r, ``tangential`` = alpha x r,
    ``coriolis`` = 2 omega x v_rel.
    """

    relative: np.ndarray
    centripetal: np.ndarray
    tangential: np.ndarray
    coriolis: np.ndarray
    total: np.ndarray


class FrameKinematics(NamedTuple):
    """Position [m], velocity and acceleration terms resolved in one frame's axes."""

    position: np.ndarray
    velocity: VelocityTerms
    acceleration: AccelerationTerms


class CollarKinematics(NamedTuple):
    """The inputs and the same vectors in fixed (X, Y) and rotating (x along the rod, y) axes."""

    motion: LinkMotion
    fixed: FrameKinematics
    rotating: FrameKinematics


class SlottedLinkMotion(NamedTuple):
    """Rod of the slotted link, arrays of one shape ``(...)``, SI, CCW positive.

    theta [rad] wheel angle; rod_angle [rad] direction C -> B; stroke [m] = L = |CB|;
    omega_rod [rad/s]; stroke_velocity [m/s] = L'; alpha_rod [rad/s^2]; stroke_acceleration
    [m/s^2] = L''.
    """

    theta: np.ndarray
    rod_angle: np.ndarray
    stroke: np.ndarray
    omega_rod: np.ndarray
    stroke_velocity: np.ndarray
    alpha_rod: np.ndarray
    stroke_acceleration: np.ndarray


# ---- frames -------------------------------------------------------------------------------------
def _rotate(vec: np.ndarray, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    x, y = vec[..., 0], vec[..., 1]
    return _stack(c * x - s * y, s * x + c * y)


# ---- collar on a rotating rod -------------------------------------------------------------------
def collar_kinematics(theta, omega, alpha, r, r_dot, r_ddot) -> CollarKinematics:
    """Position, velocity and acceleration of a collar sliding along a rotating rod.

    All arguments broadcast against each other.

    Parameters
    ----------
    theta : array_like
        Rod angle from the fixed X axis [rad], CCW positive.
    omega, alpha : array_like
        Angular velocity [rad/s] and acceleration [rad/s^2] of the rod, CCW positive.
    r, r_dot, r_ddot : array_like
        Distance pivot -> collar along the rod [m] and its rates [m/s], [m/s^2].

    Returns
    -------
    CollarKinematics
        ``motion`` (the broadcast inputs) and, in ``fixed`` and ``rotating`` axes, the position
        ``(..., 2)`` [m], the velocity terms [m/s] and the acceleration terms [m/s^2].

    Raises
    ------
    InputError
        A non-finite value, or shapes that do not broadcast.
    """
    names = ("theta", "omega", "alpha", "r", "r_dot", "r_ddot")
    values = {
        n: _finite(n, v)
        for n, v in zip(names, (theta, omega, alpha, r, r_dot, r_ddot), strict=True)
    }
    motion = LinkMotion(*_broadcast(**values))
    th, om, al, rr, rd, rdd = motion
    zero = np.zeros_like(rr)
    v_rel, v_tr = _stack(rd, zero), _stack(zero, om * rr)
    a_rel, a_cp = _stack(rdd, zero), _stack(-(om**2) * rr, zero)
    a_t, a_c = _stack(zero, al * rr), _stack(zero, 2.0 * om * rd)
    rotating = FrameKinematics(
        _stack(rr, zero),
        VelocityTerms(v_rel, v_tr, v_rel + v_tr),
        AccelerationTerms(a_rel, a_cp, a_t, a_c, a_rel + a_cp + a_t + a_c),
    )
    c, s = np.cos(th), np.sin(th)
    fixed = FrameKinematics(
        _rotate(rotating.position, c, s),
        VelocityTerms(*(_rotate(v, c, s) for v in rotating.velocity)),
        AccelerationTerms(*(_rotate(a, c, s) for a in rotating.acceleration)),
    )
    return CollarKinematics(motion, fixed, rotating)


def polar_kinematics(position, velocity, acceleration) -> LinkMotion:
    """Link angle and distance, and their rates, of a point from its fixed-frame motion.

    The inverse of :func:`collar_kinematics` for ``r > 0``.

    Parameters
    ----------
    position : array_like, shape (..., 2)
        Point relative to the pivot, fixed axes [m].
    velocity : array_like, shape (..., 2)
        Its velocity [m/s].
    acceleration : array_like, shape (..., 2)
        Its acceleration [m/s^2].

    Returns
    -------
    LinkMotion
        ``theta`` in (-pi, pi] [rad], ``omega`` [rad/s], ``alpha`` [rad/s^2], ``r > 0`` [m],
        ``r_dot`` [m/s], ``r_ddot`` [m/s^2].

    Raises
    ------
    InputError
        Non-finite values, a last axis other than 2, or shapes that do not broadcast.
    DegenerateGeometryError
        The point is on the pivot (``r <= MIN_RADIUS``): the link angle is undefined.
    """
    p = _vector("position", position)
    v = _vector("velocity", velocity)
    a = _vector("acceleration", acceleration)
    p, v, a = _broadcast(position=p, velocity=v, acceleration=a)
    r = np.hypot(p[..., 0], p[..., 1])
    if np.any(r <= MIN_RADIUS):
        bad = float(r[r <= MIN_RADIUS].ravel()[0])
        raise DegenerateGeometryError(
            f"the point lies on the pivot (r = {bad!r} m): the link angle is undefined; "
            f"need r > {MIN_RADIUS} m"
        )
    ex = p / r[..., None]
    ey = _stack(-ex[..., 1], ex[..., 0])
    r_dot = np.sum(v * ex, axis=-1)
    omega = np.sum(v * ey, axis=-1) / r
    r_ddot = np.sum(a * ex, axis=-1) + omega**2 * r
    alpha = (np.sum(a * ey, axis=-1) - 2.0 * omega * r_dot) / r
    theta = np.arctan2(p[..., 1], p[..., 0])
    return LinkMotion(theta, omega, alpha, r, r_dot, r_ddot)


@dataclass(frozen=True)
class CollarExample:
    """Example 1 of seed 000 (defaults): collar B on a rod turning about the pin A.

    omega [rad/s], alpha [rad/s^2] of the rod (CCW); r [m], r_dot [m/s], r_ddot [m/s^2] of the
    collar along the rod; theta [rad] the rod angle (the seed's marker point, 120 deg).
    ``r_max`` [m] and ``theta_max`` [rad] bound example 2's maps (0..10 m, 0..180 deg).
    """

    omega: float = 0.5
    alpha: float = 0.05
    r: float = 0.25
    r_dot: float = 0.5
    r_ddot: float = 0.1
    theta: float = 2.0 * math.pi / 3.0
    r_max: float = 10.0
    theta_max: float = math.pi

    def __post_init__(self) -> None:
        for name in ("omega", "alpha", "r", "r_dot", "r_ddot", "theta", "r_max", "theta_max"):
            object.__setattr__(self, name, real_number(name, getattr(self, name)))
        for name in ("r_max", "theta_max"):
            if getattr(self, name) <= 0.0:
                raise ParameterError(f"{name} must be > 0, got {getattr(self, name)!r}")

    def kinematics(self) -> CollarKinematics:
        """Collar kinematics at the example's instant (scalars, vectors of shape ``(2,)``)."""
        return collar_kinematics(
            self.theta, self.omega, self.alpha, self.r, self.r_dot, self.r_ddot
        )

    def grid(self, n_theta: int = 181, n_r: int = 41) -> CollarKinematics:
        """Example 2: kinematics over ``theta`` in [0, theta_max] x ``r`` in [0, r_max].

        Arrays of shape ``(n_theta, n_r)``: rows are angles, columns distances (MATLAB's
        ``meshgrid(x, theta)``).
        """
        for name, n in (("n_theta", n_theta), ("n_r", n_r)):
            if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
                raise InputError(f"{name} must be an integer >= 2, got {n!r}")
        r, theta = np.meshgrid(
            np.linspace(0.0, self.r_max, n_r), np.linspace(0.0, self.theta_max, n_theta)
        )
        return collar_kinematics(theta, self.omega, self.alpha, r, self.r_dot, self.r_ddot)


#: Example 1 of seed 000.
SEED_COLLAR = CollarExample()
