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

from ..commanded import CommandedActuator
from ..inverse import FusedInverseDynamics
from ..params import FORCE_LIMIT_DEFAULT_N
from .base import RungState

#: Strokes sampled to find where a force balances the statics (the static force is smooth).
_GRID = 129


class QuasiStaticRung(CommandedActuator):
    """Kinematics and the static piston force (module docstring)."""

    name = "quasi-static"
    state_type = RungState
    path_is_state = True

    def __init__(
        self, p, dt: float = 1e-3, force_limit: float = FORCE_LIMIT_DEFAULT_N, **methods
    ) -> None:
        """As :class:`~drs_model.actuator.ActuatorSim` (``integrator`` and ``force_method`` are
        checked and unused: no forward dynamics here, one force formula; ``limit_moves`` as
        there)."""
        super().__init__(p, dt, force_limit, **methods)
        self._static = FusedInverseDynamics.from_params(p)
        self.reset()

    def static_force(self, s: float) -> float:
        """The piston force [N] that holds the mechanism at rest at stroke ``s`` [m]."""
        return self._static.force(s, 0.0, 0.0)

    def _force_now(self) -> float:
        return self.static_force(float(self.motion.q[0]))

    def _advance_one(self) -> None:
        # in force mode the mechanism stays at rest where the force put it: time passes
        self.motion.tick()
        if self.motion.follow():
            self._force = self._force_now()

    def command_force(self, force: float) -> None:
        """The mechanism at rest where ``force`` [N] balances the statics, or on the stop the
        net force pushes it onto (validated like :meth:`ActuatorSim.command_force`)."""
        force = self._checked_force(force)
        m = self.motion
        m.hold_force_mode()
        s = self._equilibrium(force, float(m.q[0]))
        m.set_state(s, 0.0, 0.0)
        self._force = force
        m.at_stop = "closed" if s == self.s_min else "open" if s == self.s_max else None

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
