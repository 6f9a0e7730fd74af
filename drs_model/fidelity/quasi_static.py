"""The ``quasi-static`` rung: the ``kinematic`` motion plus the piston force of the statics
(gravity and the air load through the transmission, no inertia): the fused inverse dynamics
(:func:`drs_model.kernels.fused_force`) at zero rate and acceleration.

Under a force command (or a supply loss, a zero force) the mechanism goes at once to where the
force balances the statics, or to the stop it is pushed onto: no inertia, no travel time. It
equals the ``rigid`` force wherever the motion has no rate and no acceleration.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from ..actuator import ActuatorSim
from ..inverse import FusedInverseDynamics
from .base import RungMixin

#: Strokes sampled to find where a force balances the statics (the static force is smooth).
_GRID = 129


class QuasiStaticRung(RungMixin, ActuatorSim):
    """Kinematics and the static piston force (module docstring)."""

    name = "quasi-static"

    def __init__(self, *args, **kwargs) -> None:
        self._static = None
        super().__init__(*args, **kwargs)

    def static_force(self, s: float) -> float:
        """The piston force [N] that holds the mechanism at rest at stroke ``s`` [m]."""
        if self._static is None:
            self._static = FusedInverseDynamics.from_params(self.p)
        return self._static.force(s, 0.0, 0.0)

    def _inverse_force(self) -> float:
        return self.static_force(float(self._q[0]))

    def command_force(self, force: float) -> None:
        """The mechanism at rest where ``force`` [N] balances the statics, or on the stop the
        net force pushes it onto (validated like :meth:`ActuatorSim.command_force`)."""
        super().command_force(force)
        s = self._equilibrium(float(force), float(self._q[0]))
        self._set_kinematic(s, 0.0, 0.0)
        self._force = float(force)
        self._at_stop = "closed" if s == self.s_min else "open" if s == self.s_max else None

    def _equilibrium(self, force: float, s0: float) -> float:
        """From ``s0``, the stroke the net force ``force - static(s)`` drives the rod to: the
        first balance point in its direction, else the stop."""
        excess = force - self.static_force(s0)
        if excess == 0.0:
            return s0
        end = self.s_max if excess > 0.0 else self.s_min
        grid = np.linspace(s0, end, _GRID)
        prev = grid[0]
        for s in grid[1:]:
            e = force - self.static_force(float(s))
            if e == 0.0 or math.copysign(1.0, e) != math.copysign(1.0, excess):
                return float(brentq(lambda x: force - self.static_force(x), prev, s, xtol=1e-15))
            prev = s
        return end

    def _advance_one(self) -> None:
        if self.mode == "force":  # at rest where the force put it: time passes, nothing moves
            self.steps += 1
            self.t = self._t_reset + self.steps * self.dt
            return
        super()._advance_one()
