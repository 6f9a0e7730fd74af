"""The hydraulic supply's pressure over time: a step or a linear ramp between two set values (a
supply loss, its return, a pressure set by a scene)."""

from __future__ import annotations

import math

from ..errors import InputError


class SupplyPressure:
    """The supply pressure [Pa], ``pressure`` from time ``t`` [s] on until it is set again."""

    def __init__(self, t: float, pressure: float) -> None:
        self._ramp = (float(t), float(pressure), float(t), float(pressure))

    def at(self, t: float) -> float:
        """The supply pressure [Pa] at time ``t`` [s] (a ramp between two set values)."""
        t0, p0, t1, p1 = self._ramp
        if t >= t1:
            return p1
        if t <= t0:
            return p0
        return p0 + (p1 - p0) * (t - t0) / (t1 - t0)

    def set(self, now: float, pressure: float, ramp_time: float = 0.0) -> None:
        """From its value at ``now`` [s] to ``pressure`` [Pa] over ``ramp_time`` [s]."""
        if not (math.isfinite(pressure) and pressure >= 0.0):
            raise InputError(f"supply pressure must be a finite number >= 0 Pa, got {pressure!r}")
        if not (math.isfinite(ramp_time) and ramp_time >= 0.0):
            raise InputError(f"ramp_time must be a finite number >= 0 s, got {ramp_time!r}")
        self._ramp = (now, self.at(now), now + ramp_time, float(pressure))
