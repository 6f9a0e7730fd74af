"""The common interface of the fidelity rungs: the actuator's commands and state, as
:class:`~drs_model.actuator.ActuatorSim` offers them to the node, plus the supply.

Every rung is an :class:`ActuatorSim` (same constructor arguments, commands, stepping and
state), so the node and the scene runner drive any of them alike; each rung changes only what it
models differently. :class:`RungState` adds the hydraulic quantities (``None`` on the rungs
without hydraulics).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..actuator import ActuatorState
from ..errors import UnsupportedCommandError


@dataclass(frozen=True)
class RungState(ActuatorState):
    """:class:`~drs_model.actuator.ActuatorState` plus, on the hydraulic rung, the chamber
    pressures [Pa] (piston side A, rod side B), the normalised spool position (-1..1) and the
    supply pressure [Pa]; ``rung`` names the rung."""

    rung: str = ""
    pressure_a: float | None = None
    pressure_b: float | None = None
    spool: float | None = None
    supply_pressure: float | None = None


class RungMixin:
    """What every rung adds to :class:`~drs_model.actuator.ActuatorSim`: its ``name``, and
    :meth:`lose_supply` (the fail-safe scene)."""

    #: The rung's name in :data:`drs_model.fidelity.RUNGS`.
    name = ""
    #: Whether the rung models forces (a force command, the supply).
    has_forces = True

    def refuse(self, what: str) -> None:
        """Raise :class:`UnsupportedCommandError` for a command this rung cannot represent."""
        raise UnsupportedCommandError(
            f"the {self.name!r} rung cannot represent {what}: it models no forces; use "
            "'quasi-static', 'rigid' or 'hydraulic'"
        )

    def lose_supply(self, ramp_time: float = 0.0) -> None:
        """The hydraulic supply fails now: the piston gives no more force (rigid and
        quasi-static: a zero force command; the hydraulic rung: the supply pressure falls to
        the return pressure over ``ramp_time`` [s])."""
        if not self.has_forces:
            self.refuse("a supply loss")
        self.command_force(0.0)

    def sample(self) -> tuple[float, float, float, float]:
        """``(t, s, psi3, piston_force)`` [s, m, rad, N] now, without building the state
        snapshot (~20 us): what a scene samples every step."""
        return self.t, float(self._q[0]), float(self._q[2]), float(self._force)

    state_type = RungState

    def _state_extras(self) -> dict:
        return {"rung": self.name}
