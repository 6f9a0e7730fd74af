r"""Rotating-frame kinematics of a point sliding along a rotating link (seed 000, Coriolis motion).

Collar on a rotating rod (seed examples 1 and 2)
------------------------------------------------
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

Slotted link (seed example 3)
-----------------------------
A wheel of radius ``r`` turns about A = (0, 0) with angle ``theta`` (CCW from X), rate ``omega`` and
acceleration ``alpha``; its rim pin B = r (cos theta, sin theta) carries a rod that slides through a
collar pivoting at C = (d, 0). With ``rho = B - C``, the stroke ``L = |rho|`` (pin-to-collar length
of rod) and the rod angle ``phi = atan2(rho_Y, rho_X)`` (direction C -> B, CCW from X):

.. math::

    L^2 &= d^2 + r^2 - 2 d r\cos\theta \\
    \omega_{rod} = \dot\phi &= \omega r (r - d\cos\theta) / L^2 \\
    \dot L &= \omega d r \sin\theta / L \\
    \alpha_{rod} = \ddot\phi &= [\alpha r (r - d\cos\theta) + \omega^2 d r\sin\theta] / L^2
        - 2 \dot L\,\omega_{rod} / L \\
    \ddot L &= [d r (\alpha\sin\theta + \omega^2\cos\theta) - \dot L^2] / L

(:func:`slotted_link_closed_form`). The seed instead writes the closure at C in the frame of the rod
(:func:`slotted_link_closure`): the collar point C is fixed, so, with ``u = rho / L`` and
``n = k x u``, ``0 = v_B + omega_rod k x (C - B) - L' u`` and
``0 = a_B + alpha_rod k x (C - B) - omega_rod^2 (C - B) - 2 omega_rod L' n - L'' u``,
each a 2x2 linear system in ``(omega_rod, L')`` and ``(alpha_rod, L'')``; its determinant is ``-L``.

Sign conventions and units. This module: SI units, radians, every angular rate counter-clockwise
positive, ``L' > 0`` when the pin moves away from the collar. The seed: lengths in mm, angles in
degrees, ``omega_AC`` and ``alpha_AC`` clockwise positive, and ``v_stroke``, ``a_stroke`` the
sliding of the rod through the collar, positive when ``L`` shrinks (the rod moves through C from
the pin's side to the far side). So
``omega_AC = -omega_rod``, ``alpha_AC = -alpha_rod``, ``v_stroke [mm/s] = -1000 L'``,
``a_stroke [mm/s^2] = -1000 L''`` (:func:`to_seed_convention`). The seed's closed-form MATLAB
expressions agree with the ones above under that mapping. The wheel's ``omega`` and ``alpha`` are
instantaneous values: the seed holds both constant while sweeping ``theta``, as the functions here
allow (arguments broadcast).

The pin reaches the pivot (``L = 0``, rod angle undefined) when ``r = d`` at ``theta = 0``; for
``r > d`` the pivot lies inside the wheel rim. Both raise :class:`DegenerateGeometryError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from .errors import AssemblyError, InputError, ParameterError
from .params import real_number

#: Below this distance [m] between a point and its pivot the link angle is undefined.
MIN_RADIUS = 1e-12


class DegenerateGeometryError(AssemblyError):
    """The pin reaches the pivot (zero length between them) or the pivot lies inside the wheel."""


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


# ---- validation ---------------------------------------------------------------------------------
def _finite(name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real number or array, got {value!r}") from None
    if not np.all(np.isfinite(arr)):
        bad = float(arr[~np.isfinite(arr)].ravel()[0])
        raise InputError(f"{name} must be finite (-inf < {name} < inf), got {bad!r}")
    return arr


def _broadcast(**arrays: np.ndarray) -> list[np.ndarray]:
    try:
        return [np.array(a) for a in np.broadcast_arrays(*arrays.values())]
    except ValueError:
        shapes = ", ".join(f"{k} {np.shape(v)}" for k, v in arrays.items())
        raise InputError(f"arguments must broadcast to one shape, got {shapes}") from None


def _vector(name: str, value) -> np.ndarray:
    arr = _finite(name, value)
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise InputError(
            f"{name} must have shape (..., 2) (planar X, Y components), got {arr.shape}"
        )
    return arr


def _positive(name: str, arr: np.ndarray, error: type[Exception] = InputError) -> None:
    if np.any(arr <= 0.0):
        bad = float(arr[arr <= 0.0].ravel()[0])
        raise error(f"{name} must be > 0 m, got {bad!r}")


def _check_wheel(r: np.ndarray, d: np.ndarray, error: type[Exception] = InputError) -> None:
    _positive("r", r, error)
    _positive("d", d, error)
    r_b, d_b = np.broadcast_arrays(r, d)
    bad = r_b >= d_b
    if np.any(bad):
        rb, db = float(r_b[bad].ravel()[0]), float(d_b[bad].ravel()[0])
        where = (
            "the pin B reaches the collar pivot C at theta = 0 (L = 0)"
            if rb == db
            else "the collar pivot C lies inside the wheel rim"
        )
        raise DegenerateGeometryError(f"{where}: r = {rb!r} m, d = {db!r} m; need 0 < r < d")


# ---- frames -------------------------------------------------------------------------------------
def _stack(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.stack(np.broadcast_arrays(x, y), axis=-1)


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


# ---- slotted link -------------------------------------------------------------------------------
def _wheel_inputs(theta, omega, alpha, r, d):
    values = {
        "theta": _finite("theta", theta),
        "omega": _finite("omega", omega),
        "alpha": _finite("alpha", alpha),
        "r": _finite("r", r),
        "d": _finite("d", d),
    }
    _check_wheel(values["r"], values["d"])
    return _broadcast(**values)


def slotted_link_position(theta, r=0.25, d=1.0) -> tuple[np.ndarray, np.ndarray]:
    """Rod angle ``phi`` [rad] (direction C -> B) and stroke ``L = |CB|`` [m] at wheel angle(s).

    Parameters
    ----------
    theta : array_like
        Wheel angle [rad], CCW from the line A -> C.
    r : array_like
        Wheel radius (A -> pin B) [m], ``0 < r < d``.
    d : array_like
        Distance A -> collar pivot C [m].

    Raises
    ------
    InputError
        Non-finite or non-positive values, shapes that do not broadcast.
    DegenerateGeometryError
        ``r >= d``.
    """
    theta, _, _, r, d = _wheel_inputs(theta, 0.0, 0.0, r, d)
    rho_x, rho_y = r * np.cos(theta) - d, r * np.sin(theta)
    return np.arctan2(rho_y, rho_x), np.hypot(rho_x, rho_y)


def slotted_link_closed_form(theta, omega=10.0, alpha=2.0, r=0.25, d=1.0) -> SlottedLinkMotion:
    """Rod motion of the slotted link from the closed-form expressions (module docstring).

    Parameters
    ----------
    theta : array_like
        Wheel angle [rad], CCW from the line A -> C.
    omega, alpha : array_like
        Wheel angular velocity [rad/s] and acceleration [rad/s^2], CCW positive.
    r, d : array_like
        Wheel radius and distance A -> C [m], ``0 < r < d``. Defaults: seed example 3.

    Returns
    -------
    SlottedLinkMotion
        Arrays of the broadcast shape; rates CCW positive, ``stroke_velocity > 0`` when the pin
        moves away from the collar.

    Raises
    ------
    InputError, DegenerateGeometryError
        As :func:`slotted_link_position`.
    """
    theta, omega, alpha, r, d = _wheel_inputs(theta, omega, alpha, r, d)
    c, s = np.cos(theta), np.sin(theta)
    rho_x, rho_y = r * c - d, r * s
    L2 = d**2 + r**2 - 2.0 * d * r * c
    L = np.sqrt(L2)
    omega_rod = omega * r * (r - d * c) / L2
    L_dot = omega * d * r * s / L
    alpha_rod = (alpha * r * (r - d * c) + omega**2 * d * r * s) / L2 - 2.0 * L_dot * omega_rod / L
    L_ddot = (d * r * (alpha * s + omega**2 * c) - L_dot**2) / L
    return SlottedLinkMotion(
        theta, np.arctan2(rho_y, rho_x), L, omega_rod, L_dot, alpha_rod, L_ddot
    )


def slotted_link_closure(theta, omega=10.0, alpha=2.0, r=0.25, d=1.0) -> SlottedLinkMotion:
    """Rod motion of the slotted link from the seed's closure equations at C.

    Per angle, two 2x2 linear systems (module docstring): the velocity of the collar point C,
    written through the rotating rod, is zero; so is its acceleration (with the Coriolis term
    ``2 omega_rod x v_rel``). Same parameters, result and errors as
    :func:`slotted_link_closed_form`.
    """
    theta, omega, alpha, r, d = _wheel_inputs(theta, omega, alpha, r, d)
    pin = collar_kinematics(theta, omega, alpha, r, 0.0, 0.0).fixed  # rim pin: r fixed on wheel
    rho = pin.position - _stack(d, np.zeros_like(d))  # B - C
    c_minus_b = -rho
    L = np.hypot(rho[..., 0], rho[..., 1])
    u = rho / L[..., None]  # unit vector C -> B, along the rod
    n = _stack(-u[..., 1], u[..., 0])
    k_cross_cb = _stack(-c_minus_b[..., 1], c_minus_b[..., 0])
    A = np.stack((k_cross_cb, -u), axis=-1)  # columns: coefficient of (omega_rod, L')
    omega_rod, L_dot = np.moveaxis(
        np.linalg.solve(A, -pin.velocity.total[..., None])[..., 0], -1, 0
    )
    known = (
        pin.acceleration.total
        - (omega_rod**2)[..., None] * c_minus_b
        - (2.0 * omega_rod * L_dot)[..., None] * n
    )
    alpha_rod, L_ddot = np.moveaxis(np.linalg.solve(A, -known[..., None])[..., 0], -1, 0)
    rod_angle = np.arctan2(rho[..., 1], rho[..., 0])
    return SlottedLinkMotion(theta, rod_angle, L, omega_rod, L_dot, alpha_rod, L_ddot)


#: Solvers of the slotted link, one result type.
SLOTTED_LINK_METHODS = MappingProxyType(
    {"closure": slotted_link_closure, "closed-form": slotted_link_closed_form}
)


def to_seed_convention(motion: SlottedLinkMotion) -> dict[str, np.ndarray]:
    """The seed's example-3 quantities: degrees, mm, clockwise-positive rod rates.

    Returns ``theta_deg``, ``omega_AC`` [rad/s, CW], ``v_stroke`` [mm/s, positive when L
    shrinks], ``alpha_AC`` [rad/s^2, CW], ``a_stroke`` [mm/s^2].
    """
    return {
        "theta_deg": np.degrees(motion.theta),
        "omega_AC": -motion.omega_rod,
        "v_stroke": -1000.0 * motion.stroke_velocity,
        "alpha_AC": -motion.alpha_rod,
        "a_stroke": -1000.0 * motion.stroke_acceleration,
    }


@dataclass(frozen=True)
class SlottedLinkExample:
    """Example 3 of seed 000 (defaults): wheel r = 250 mm about A, collar pivot C at d = 1000 mm.

    r, d [m]; omega [rad/s], alpha [rad/s^2] of the wheel, CCW positive.
    """

    r: float = 0.250
    d: float = 1.000
    omega: float = 10.0
    alpha: float = 2.0

    def __post_init__(self) -> None:
        for name in ("r", "d", "omega", "alpha"):
            object.__setattr__(self, name, real_number(name, getattr(self, name)))
        _check_wheel(np.asarray(self.r), np.asarray(self.d), ParameterError)

    def solve(self, theta, method: str = "closed-form") -> SlottedLinkMotion:
        """Rod motion at wheel angle(s) ``theta`` [rad] by ``method`` (SLOTTED_LINK_METHODS)."""
        if method not in SLOTTED_LINK_METHODS:
            raise InputError(
                f"method must be one of {sorted(SLOTTED_LINK_METHODS)}, got {method!r}"
            )
        return SLOTTED_LINK_METHODS[method](theta, self.omega, self.alpha, self.r, self.d)


#: Example 3 of seed 000.
SEED_SLOTTED_LINK = SlottedLinkExample()
