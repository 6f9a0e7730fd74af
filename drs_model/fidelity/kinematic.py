"""The ``kinematic`` rung: the stroke follows each command through its quintic move; positions,
rates and gap from the closed forms (:mod:`drs_model.kinematics`), no forces.

The cheapest rung: what a lap simulation needs (the gap, at 1 kHz, for hours). It moves exactly
as the ``rigid`` rung does in stroke mode (both follow :class:`~drs_model.profile.QuinticPath`),
and refuses what needs forces (a force command, a supply loss) with
:class:`~drs_model.errors.UnsupportedCommandError`. ``piston_force`` is NaN.
"""

from __future__ import annotations

import math

import numpy as np

from .. import kinematics as kin
from ..actuator import ActuatorSim
from .base import RungMixin


class KinematicRung(RungMixin, ActuatorSim):
    """Positions and rates from the commanded moves alone (module docstring)."""

    name = "kinematic"
    has_forces = False

    def _inverse_force(self) -> float:
        return math.nan

    def command_force(self, force: float) -> None:
        self.refuse(f"a force command ({force!r} N)")


def gap_stream(path_samples, p) -> np.ndarray:
    """The gap [m] at strokes ``path_samples`` [m] (any shape), from the closed forms on arrays:
    the kinematic rung's batch path (an hour of 1 kHz samples in one call)."""
    q = kin.solve_position(np.asarray(path_samples, dtype=float), p)
    return kin.gap(q, p)
