"""Piston-force inputs of the forward dynamics: a constant, a step, a function of t, or the
inverse-dynamics force of the seed manoeuvre.

Each knows its ``breakpoints`` (the times where it or its derivatives jump) so that the drivers
restart the integration there, and gives the smooth piece valid on a segment (``segment(a, b)``),
so that no stage straddles a jump.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..compiled.scalar import bind
from ..errors import InputError, IntegrationError
from ..inverse import FusedInverseDynamics
from ..kernels import fused_manoeuvre_force, profile_held
from ..params import DRSParams

ForceLike = float | Callable[[float], float]


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


class ManoeuvreForce:
    """The piston force [N] that makes the mechanism follow the seed's open-hold-close manoeuvre
    exactly: :func:`drs_model.kernels.fused_manoeuvre_force` (closed-form kinematics and
    d'Alembert's principle along ``dq/ds``), the kernel of
    :class:`~drs_model.inverse.FusedInverseDynamics` (compiled by numba when it is installed:
    :func:`drs_model.compiled.scalar.bind`).

    ``breakpoints`` are the joints of the profile (0, 10, 40, 50 ms for the seed), where the jerk
    jumps; between them the force is smooth.

    Parameters
    ----------
    p : DRSParams
    s_limits : (float, float), optional
        ``(s_min, s_max)`` [m] of the manoeuvre (default: the gap-rule strokes).
    flap_limits : (float, float), optional
        ``(psi3_closed, psi3_open)`` [rad] of the air-force law (default: the gap-rule angles).
    """

    def __init__(self, p: DRSParams, s_limits=None, flap_limits=None) -> None:
        self.p = p
        self.inverse = FusedInverseDynamics.from_params(p, flap_limits, s_limits)
        self.manoeuvre = self.inverse.manoeuvre
        self.breakpoints = tuple(float(t) for t in self.manoeuvre.kinks)
        self._force = bind(fused_manoeuvre_force, self.inverse.consts, self.inverse.profile)

    def __call__(self, t: float) -> float:
        return self._force(float(t))

    def segment(self, a: float, b: float) -> Callable[[float], float]:
        """The force on ``[a, b]`` [s]: one value where the manoeuvre rests over all of it
        (:func:`~drs_model.kernels.profile_held`), else the kernel at each t."""
        force = self._force
        if profile_held(a, b, self.inverse.profile):
            held = force(0.5 * (a + b))
            return lambda t: held
        return force

    def profile(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The profile ``(s, s', s'')`` at times t (the exact solution under this force)."""
        return self.manoeuvre.evaluate(t)
