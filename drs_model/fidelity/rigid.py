"""The ``rigid`` rung: :class:`~drs_model.actuator.ActuatorSim` as it is (inverse dynamics along
the commanded moves, forward dynamics under a force command, inelastic stops).

A supply loss is a zero force command: the ideal piston gives no force, the air load closes the
flap.
"""

from __future__ import annotations

from ..actuator import ActuatorSim
from .base import RungState


class RigidRung(ActuatorSim):
    """:class:`~drs_model.actuator.ActuatorSim` named as a rung, with :class:`RungState`."""

    name = "rigid"
    state_type = RungState
