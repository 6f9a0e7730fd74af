r"""The slotted link of seed 000 (example 3): a wheel's pin drives a rod through a pivoting collar.

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

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from ..errors import InputError, ParameterError
from ..params import real_number
from ._checks import _broadcast, _check_wheel, _finite, _stack
from .rotating_rod import SlottedLinkMotion, collar_kinematics


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
