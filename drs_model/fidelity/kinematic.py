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

from ..commanded import HYDRAULIC_FAULTS, CommandedActuator
from ..params import FORCE_LIMIT_DEFAULT_N
from ..timebase import steps_within
from .base import RungState, refuse


class KinematicRung(CommandedActuator):
    """Positions and rates from the commanded moves alone (module docstring)."""

    name = "kinematic"
    state_type = RungState
    path_is_state = True

    def __init__(
        self, p, dt: float = 1e-3, force_limit: float = FORCE_LIMIT_DEFAULT_N, **methods
    ) -> None:
        """As :class:`~drs_model.actuator.ActuatorSim` (``integrator`` and ``force_method`` are
        checked and unused: no forward dynamics here, one force formula; ``limit_moves`` as
        there)."""
        super().__init__(p, dt, force_limit, **methods)
        self.reset()

    def _force_now(self) -> float:
        return math.nan

    def _advance_one(self) -> None:
        self.motion.tick()
        self.motion.follow()

    def command_force(self, force: float) -> None:
        refuse(self.name, f"a force command ({force!r} N)")

    def lose_supply(self, ramp_s: float = 0.0) -> None:
        refuse(self.name, "a supply loss")

    def models(self, fault: str) -> bool:
        return fault != "supply_loss" and fault not in HYDRAULIC_FAULTS

    def skip_to(self, t: float) -> None:
        """Jump to the step at (or just before) time ``t`` [s] at once: the kinematic rung has no
        state to integrate, its state at any time is the commanded path's."""
        m = self.motion
        n = steps_within(t - m.t_reset, self.dt)
        if n > m.steps:
            self.advance(n - m.steps)

    def samples(self, times: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The stroke [m] at ``times`` [s] (sorted, none before now and none past the next
        command) from the path in force, on arrays: the batch path of a scene. Written into
        ``out`` (the shape of ``times``) when given, and returned."""
        m = self.motion
        times = np.asarray(times, dtype=float)
        s = np.empty(times.shape) if out is None else out
        s[:] = float(m.q[0])
        if m.mode != "stroke" or m.settled:
            return s
        # sorted: each stretch is a slice found by bisection, not a mask over every time
        s[np.searchsorted(times, m.path.t_end, side="left") :] = m.target
        for seg in m.path:
            first, stop = np.searchsorted(times, (seg.t0, seg.t1), side="left")
            if stop > first:
                s[first:stop] = seg.evaluate(times[first:stop])[0]
        return s


def batch_strokes(rung: KinematicRung, events, times: np.ndarray) -> np.ndarray:
    """The stroke [m] at every time of ``times`` [s] (sorted, from the rung's time on) under the
    commands ``events`` (``(t, apply)`` pairs, ``apply(rung)`` issues one command): the rung
    jumps from command to command and evaluates each stretch between them on arrays, in place
    (a fresh array of a lap's samples costs more in the kernel's page faults than its values)."""
    out = np.empty(times.shape)
    bounds = [e[0] for e in events] + [math.inf]
    start = 0
    # a command at t acts on the steps after t: the sample at t is the state before it
    k_stop = int(np.searchsorted(times, bounds[0], side="right"))
    rung.samples(times[start:k_stop], out[start:k_stop])
    for i, (t_event, apply) in enumerate(events):
        rung.skip_to(t_event)
        apply(rung)
        start, k_stop = k_stop, int(np.searchsorted(times, bounds[i + 1], side="right"))
        rung.samples(times[start:k_stop], out[start:k_stop])
    return out
