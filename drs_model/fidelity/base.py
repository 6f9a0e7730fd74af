"""What the fidelity rungs share beyond :class:`~drs_model.commanded.CommandedActuator`: the
snapshot with the hydraulic quantities (:class:`RungState`, ``None`` on the rungs without
hydraulics).

The interface every rung implements (commands, stepping, state, the faults it models) is
:class:`~drs_model.commanded.CommandedActuator`'s; each rung owns a
:class:`~drs_model.motion.StrokeMotion` and changes only what it models differently.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..commanded import NO_FORCES, ActuatorState
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


def refuse(rung: str, what: str) -> None:
    """Raise :class:`UnsupportedCommandError` for a command the rung ``rung``, which models no
    forces, cannot represent."""
    raise UnsupportedCommandError(f"the {rung!r} rung cannot represent {what}: {NO_FORCES}")
