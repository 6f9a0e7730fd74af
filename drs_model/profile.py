r"""Stroke profiles: rest-to-rest quintics and the seed's open-hold-close manoeuvre.

A quintic segment ``s(t) = sum a_k (t - t0)^k`` on ``[t0, t0 + T]`` matches position, velocity and
acceleration at both ends (seed 003, "Opening profile"). For a rest-to-rest move of amplitude
``h`` with ``u = (t - t0)/T``: ``s = s0 + h (10 u^3 - 15 u^4 + 6 u^5)``.

The manoeuvre (seed): opening ``s_min -> s_max`` in ``T_opening``, hold ``T_still``, closing back in
``T_closing``. Jerk jumps at the segment joints (0, 10, 40, 50 ms): s, s', s'' are continuous,
s''' is not, which an integrator with error control sees as a kink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import elementwise, kernels
from .errors import InputError, StrokeRangeError
from .kinematics import stroke_limits
from .params import DRSParams


def quintic_coefficients(
    duration: float, s0: float, s1: float, v0=0.0, v1=0.0, a0=0.0, a1=0.0
) -> np.ndarray:
    """Coefficients ``a_0..a_5`` in local time ``tau = t - t0`` [s] of the quintic through the
    boundary values (position [m], velocity [m/s], acceleration [m/s^2])."""
    T = float(duration)
    if not (math.isfinite(T) and T > 0.0):
        raise InputError(f"duration must be a finite number > 0 s, got {duration!r}")
    h = s1 - s0
    c0, c1, c2 = s0, v0, a0 / 2.0
    # the closed-form solution of the 3 end conditions for a3..a5
    c3 = (20 * h - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T**2) / (2 * T**3)
    c4 = (-30 * h + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T**2) / (2 * T**4)
    c5 = (12 * h - 6 * (v1 + v0) * T + (a1 - a0) * T**2) / (2 * T**5)
    return np.array([c0, c1, c2, c3, c4, c5])


def shift_polynomial(coeffs: np.ndarray, t0: float) -> np.ndarray:
    """Coefficients in absolute time t of ``sum c_k (t - t0)^k`` (how the seed prints them)."""
    poly = np.polynomial.Polynomial(coeffs)
    shifted = poly(np.polynomial.Polynomial([-t0, 1.0]))
    out = np.zeros(len(coeffs))
    out[: len(shifted.coef)] = shifted.coef
    return out


@dataclass(frozen=True)
class QuinticSegment:
    """A quintic move starting at ``t0`` [s] lasting ``duration`` [s]; holds its end values after
    its end and its start values before its start.

    ``coeffs`` are in local time; :meth:`absolute_coefficients` gives them in absolute time.
    """

    t0: float
    duration: float
    coeffs: tuple[float, ...]

    @classmethod
    def between(cls, t0, duration, s0, s1, v0=0.0, v1=0.0, a0=0.0, a1=0.0) -> QuinticSegment:
        c = quintic_coefficients(duration, s0, s1, v0, v1, a0, a1)
        return cls(float(t0), float(duration), tuple(float(x) for x in c))

    @property
    def t1(self) -> float:
        return self.t0 + self.duration

    def absolute_coefficients(self) -> np.ndarray:
        return shift_polynomial(np.array(self.coeffs), self.t0)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` at time(s) t [s]; outside the segment the end state is held."""
        t = np.asarray(t, dtype=float)
        tau = np.clip(t - self.t0, 0.0, self.duration)
        c = self.coeffs
        s, v, a = kernels.quintic(tau, c, 0)
        outside = (t < self.t0) | (t > self.t1)
        if np.any(outside):
            # beyond the ends the move is at rest only if it ends at rest; hold position and
            # report the end rates (a rest-to-rest move gives zeros)
            v = np.where(outside, np.where(t < self.t0, c[1], v), v)
            a = np.where(outside, np.where(t < self.t0, 2 * c[2], a), a)
        return s, v, a


@dataclass(frozen=True)
class Manoeuvre:
    """The seed's open-hold-close manoeuvre: three segments on ``[0, T_total]``, at rest outside."""

    opening: QuinticSegment
    closing: QuinticSegment
    s_min: float
    s_max: float

    @property
    def t_end(self) -> float:
        return self.closing.t1

    @property
    def kinks(self) -> tuple[float, ...]:
        """Times [s] where the jerk jumps (the segment joints)."""
        return (self.opening.t0, self.opening.t1, self.closing.t0, self.closing.t1)

    def constants(self) -> tuple[float, ...]:
        """The 18 constants of :func:`drs_model.kernels.manoeuvre_profile`: ``(t0, T, 6
        coefficients)`` of the opening and of the closing, then ``s_min`` and ``s_max``."""
        o, c = self.opening, self.closing
        return (o.t0, o.duration, *o.coeffs, c.t0, c.duration, *c.coeffs, self.s_min, self.s_max)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, s', s'')`` [m, m/s, m/s^2] at time(s) t [s] (any shape): the kernel
        :func:`drs_model.kernels.manoeuvre_profile` at each time."""
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise InputError("time must be finite")
        return elementwise.manoeuvre_profile(t, self.constants())


def drs_manoeuvre(
    p: DRSParams, s_min: float | None = None, s_max: float | None = None
) -> Manoeuvre:
    """The open-hold-close manoeuvre of ``p`` between ``s_min`` and ``s_max`` [m].

    The defaults are our exact gap-rule strokes; pass the seed's NLPSolve values to reproduce its
    printed coefficients.
    """
    lo, hi = stroke_limits(p)
    s_min = lo if s_min is None else float(s_min)
    s_max = hi if s_max is None else float(s_max)
    opening = QuinticSegment.between(0.0, p.T_opening, s_min, s_max)
    closing = QuinticSegment.between(p.T_opening + p.T_still, p.T_closing, s_max, s_min)
    return Manoeuvre(opening, closing, s_min, s_max)


def quintic_move(
    p: DRSParams,
    s_target: float,
    duration: float,
    s0: float,
    v0: float = 0.0,
    a0: float = 0.0,
    t0: float = 0.0,
    tol: float = 1e-12,
) -> QuinticSegment:
    """A quintic from the current state ``(s0, v0, a0)`` at ``t0`` to rest at ``s_target`` [m].

    Raises :class:`StrokeRangeError` for a target outside ``[s_min, s_max]`` and
    :class:`InputError` for a non-finite input or a non-positive duration. The path may overshoot
    the target when the start velocity is large; callers that need a bounded path check it.
    """
    for name, value in (("s_target", s_target), ("s0", s0), ("v0", v0), ("a0", a0), ("t0", t0)):
        if not math.isfinite(float(value)):
            raise InputError(f"{name} must be finite, got {value!r}")
    if not (math.isfinite(float(duration)) and duration > 0.0):
        raise InputError(f"duration must be a finite number > 0 s, got {duration!r}")
    lo, hi = stroke_limits(p)
    if not lo - tol <= s_target <= hi + tol:
        raise StrokeRangeError(
            f"target stroke {s_target!r} m is outside [s_min, s_max] = [{lo:.9g}, {hi:.9g}] m"
        )
    return QuinticSegment.between(t0, duration, s0, s_target, v0, 0.0, a0, 0.0)
