"""The piston's commanded motion: the clock of a fixed-step actuator, its mode, and the path that
the stroke commands (a move, the DRS open/close, a trajectory) set and the actuator follows.

Every rung of the ladder owns one :class:`StrokeMotion` (composition, not a base class): the
kinematic rung reads its state as it is, the others add forces to it. It knows nothing of forces;
the ``force`` mode is only a name here, set by the rung that models it.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable

import numpy as np

from . import kinematics as kin
from .errors import InputError, StrokeRangeError
from .params import DRSParams
from .path_range import leaving_paths
from .profile import (
    QuinticPath,
    TrajectoryPlan,
    plan_trajectory,
    quintic_move,
)


class StrokeMotion:
    """The clock (``t``, ``steps``), the mode (``hold``, ``stroke``, ``force``), the commanded
    path and the kinematic state ``q, qd, qdd`` (``[s, psi1, psi3]`` and rates [m, rad; /s;
    /s^2]) of an actuator stepped at ``dt`` [s] with parameters ``p``."""

    def __init__(self, p: DRSParams, dt: float) -> None:
        self.p = p
        self.dt = float(dt)
        self.s_min, self.s_max = kin.stroke_limits(p)
        #: ``check_path(coeffs, durations, first)``: the owner's refusal of a path's segments
        #: (local-time quintics, segment ``first`` on), called before a path is taken or planned
        self.check_path: Callable[[np.ndarray, np.ndarray, int], None] | None = None
        #: ``fit_duration(target, duration, start)``: the owner's duration [s] for a stroke
        #: command given none (``duration`` the seed's, ``start`` ``(s, s', s'')``)
        self.fit_duration: Callable[[float, float, tuple], float] | None = None
        self._checked_plans: weakref.WeakSet = weakref.WeakSet()
        self.reset(0.0, self.s_min)

    def reset(self, t: float, s: float) -> None:
        """At rest at stroke ``s`` [m] (checked by the caller) at time ``t`` [s], in hold mode."""
        self.t = float(t)
        self.t_reset = float(t)
        self.steps = 0
        self.mode = "hold"
        self.path: QuinticPath | None = None
        self.settled = False
        self.target: float | None = None
        self.at_stop: str | None = None
        self.set_state(s, 0.0, 0.0)

    def set_state(self, s: float, sd: float, sdd: float) -> None:
        """The state of stroke ``s``, rate ``sd``, acceleration ``sdd`` [m, m/s, m/s^2]."""
        self.q, self.qd, self.qdd = kin.kinematic_state_scalar(s, sd, sdd, self.p)

    def tick(self) -> None:
        """The clock one step on (from the reset time: no accumulated round-off)."""
        self.steps += 1
        self.t = self.t_reset + self.steps * self.dt

    def follow(self) -> bool:
        """In stroke mode, the state of the path at the present time; whether it changed."""
        if self.mode != "stroke" or self.settled:
            return False
        if self.t >= self.path.t_end:
            # every move ends at rest at its target: from its end on, that is the state exactly
            # (the polynomial at t1 leaves ~1e-14 m/s of round-off)
            self.settled = True
            self.set_state(self.target, 0.0, 0.0)
        else:
            self.set_state(*self.path.at(self.t))  # the segment in force found by bisection
        return True

    def reference(self, t: float) -> tuple[float, float, float] | None:
        """``(s, v, a)`` of the path at ``t`` [s] (the target at rest past its end); None outside
        stroke mode."""
        if self.mode != "stroke":
            return None
        if t >= self.path.t_end:
            return self.target, 0.0, 0.0
        return self.path.at(t)

    def start(self) -> tuple[float, float, float]:
        """``(s, s', s'')`` now: where a new command starts from."""
        return float(self.q[0]), float(self.qd[0]), float(self.qdd[0])

    # ---- commands ------------------------------------------------------------------------------
    def stroke_duration(self, target: float, start) -> float:
        """The duration [s] of a stroke command to ``target`` [m] given none, from ``start``
        (``(s, s', s'')``): the seed's opening time scaled by the distance (a full stroke in
        ``T_opening``), at least 2 steps, or the owner's :attr:`fit_duration` of it."""
        frac = abs(target - start[0]) / (self.s_max - self.s_min)
        duration = max(self.p.T_opening * frac, 2 * self.dt)
        if self.fit_duration is not None:
            duration = self.fit_duration(target, duration, tuple(start))
        return duration

    def command_stroke(self, target: float, duration: float | None = None, start=None):
        """Move smoothly to ``target`` [m] from ``start`` (``(s, s', s'')``, default the state);
        refuse a bad target (:meth:`drs_model.actuator.ActuatorSim.command_stroke`)."""
        target = float(target)
        if not math.isfinite(target):
            raise InputError(f"stroke command must be finite, got {target!r}")
        s0, v0, a0 = self.start() if start is None else start
        if duration is None:
            duration = self.stroke_duration(target, (s0, v0, a0))
        limits = (self.s_min, self.s_max)
        seg = quintic_move(self.p, target, duration, s0, v0, a0, t0=self.t, limits=limits)
        # the trajectories' check of a segment (its samples in local time), on this one segment
        if leaving_paths(seg.coeffs, seg.duration, limits)[0].size:
            raise StrokeRangeError(
                f"the move to {target!r} m from s = {s0:.6g} m at {v0:.3g} m/s would leave "
                f"[s_min, s_max] = [{self.s_min:.9g}, {self.s_max:.9g}] m"
            )
        if self.check_path is not None:
            self.check_path(np.asarray(seg.coeffs)[None], np.array([seg.duration]), 0)
        self._follow(QuinticPath.of_segment(seg), target)
        return seg

    def plan_trajectory(self, times, strokes, rates=None) -> TrajectoryPlan:
        """:func:`drs_model.profile.plan_trajectory` for these parameters (reads nothing else),
        its state-independent segments refused by :attr:`check_path`."""
        plan = plan_trajectory(self.p, times, strokes, rates)
        self._check_tail(plan)
        return plan

    def forget_checked_plans(self) -> None:
        """Check every plan again when commanded (the owner's rule changed)."""
        self._checked_plans = weakref.WeakSet()

    def _check_tail(self, plan: TrajectoryPlan) -> None:
        if self.check_path is None or plan in self._checked_plans:
            return
        m = plan.n_head
        if len(plan) > m:
            coeffs = np.frombuffer(plan.coeffs, dtype=float).reshape(-1, 6)[m:]
            self.check_path(coeffs, np.frombuffer(plan.durations, dtype=float)[m:], m)
        self._checked_plans.add(plan)

    def command_trajectory(self, times, strokes=None, rates=None, start=None) -> QuinticPath:
        """Follow a trajectory (or a :class:`TrajectoryPlan`) from ``start`` (default the state):
        :meth:`drs_model.actuator.ActuatorSim.command_trajectory`."""
        if isinstance(times, TrajectoryPlan):
            if strokes is not None or rates is not None:
                raise InputError(
                    "command_trajectory takes a TrajectoryPlan alone or times and strokes "
                    "(and rates), not both"
                )
            plan = times
            if plan.limits != (self.s_min, self.s_max):
                raise InputError(
                    f"the trajectory plan was checked against [s_min, s_max] = "
                    f"[{plan.limits[0]:.9g}, {plan.limits[1]:.9g}] m, this actuator's stroke "
                    f"range is [{self.s_min:.9g}, {self.s_max:.9g}] m: plan it with its params"
                )
        else:
            if strokes is None:
                raise InputError("command_trajectory needs strokes with its times")
            plan = plan_trajectory(self.p, times, strokes, rates)
        self._check_tail(plan)
        head = plan.head(*(self.start() if start is None else start))
        if self.check_path is not None:
            self.check_path(head, np.frombuffer(plan.durations, dtype=float)[: plan.n_head], 0)
        path = QuinticPath.of_plan(plan, self.t, head)
        self._follow(path, float(plan.strokes[-1]))
        return path

    def drs_move(self, open_flap: bool) -> tuple[float, float]:
        """``(target, duration)`` [m, s] of the seed's open (True) or close (False) manoeuvre."""
        if open_flap:
            return self.s_max, self.p.T_opening
        return self.s_min, self.p.T_closing

    def _follow(self, path: QuinticPath, target: float) -> None:
        self.path, self.target, self.mode = path, target, "stroke"
        self.settled = False
        self.at_stop = None

    def hold_force_mode(self) -> None:
        """Force mode from now on: no path, no target."""
        self.mode, self.path, self.target = "force", None, None
