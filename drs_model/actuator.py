"""The DRS actuator as a fixed-step simulation: modes, commands, end stops (what the node runs).

The actuator is in one of three modes:

``stroke``
    The piston follows a quintic from its current state ``(s, s', s'')`` to a target stroke
    (``command_stroke``, or ``command_drs`` for the seed's open/close with its manoeuvre
    times), then
    holds it. Kinematics come from the profile; the piston force is the inverse dynamics of that
    motion.
``force``
    A commanded piston force acts from now on (``command_force``); the forward dynamics are stepped
    at the fixed ``dt``.
``hold``
    At rest at the current stroke (after start-up); the force is the static inverse dynamics.

End stops (force mode): the working stroke ``[s_min, s_max]`` is bounded by mechanical stops at
the closed (10 mm gap) and open (50 mm gap) positions. A commanded force that drives the flap into a
stop is not refused: the flap stops there (a perfectly inelastic contact: the velocity into the stop
is removed), the stop carries the excess load, and ``at_stop`` says which stop. A force that pulls
the flap away from the stop releases it. The closed stop sits 1.75 mm above the dead centre, so the
mechanism can never be driven through the dead centre. A step that fails as a whole (at a low
physics rate, dt up to 10 ms) or ends on or past a stop is taken again in sub-steps, so that the
stop is the one the motion reaches, at the time it reaches it, and the rest of the step goes on
from there (``ActuatorSim._split_step``); force mode never raises from :meth:`ActuatorSim.step`.
A step longer than :data:`MAX_FORCE_STEP` (1 ms) is always taken in sub-steps of at most 1 ms.

Commands are validated at the boundary: a refused command raises a :class:`DRSError` subclass with
the reason and leaves the actuator unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import kernels
from . import kinematics as kin
from .errors import (
    InputError,
    IntegrationError,
    SingularConfigurationError,
    StrokeRangeError,
)
from .params import DRSParams
from .profile import QuinticPath, QuinticSegment, TrajectoryPlan, plan_trajectory, quintic_move

MODES = ("hold", "stroke", "force")
#: Longest integrator step [s] of force mode: a longer physics step (a rate below 1 kHz) is taken
#: in equal sub-steps no longer than this (a 10 ms RK4 step can carry the flap, which crosses its
#: stroke in ~5 ms under a large force, past a stop and back within the step).
MAX_FORCE_STEP = 1e-3
#: Halvings of a sub-step that meets a stop: the contact is located to ``MAX_FORCE_STEP / 2**10``.
SEARCH_LEVELS = 10
#: Contacts resolved within one step; after the last the flap stays on its stop for the step.
MAX_CONTACTS_PER_STEP = 4
#: What the fixed-step integrator raises for a step it refuses (past a stop, non-finite).
_REFUSED_STEP = (StrokeRangeError, SingularConfigurationError, IntegrationError)


@dataclass(frozen=True)
class ActuatorState:
    """A snapshot of the actuator at simulated time ``t`` [s].

    ``q``, ``qd``, ``qdd`` are ``[s, psi1, psi3]`` and their rates [m, rad; /s; /s^2];
    ``piston_force`` [N]; ``gap`` [m]; ``at_stop`` is ``"closed"``, ``"open"`` or ``None``.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    piston_force: float
    gap: float
    mode: str
    at_stop: str | None
    target: float | None  # target stroke [m] in stroke mode
    dead_centre_distance: float  # s - s_dead [m]
    transmission: float  # |cos(psi1 - psi3)|, 0 at the dead centre


class ActuatorSim:
    """Fixed-step simulation of the actuator.

    Parameters
    ----------
    p : DRSParams
    dt : float
        Physics step [s] (> 0).
    force_limit : float
        Largest accepted |piston force| command [N].
    integrator : str
        Fixed-step method for force mode (see :class:`drs_model.forward.FixedStepIntegrator`).
    force_method : str
        Inverse-dynamics formulation for stroke and hold modes, a name of
        :data:`drs_model.inverse.INVERSE_METHODS`; ``"fused"`` (the default) is the one-sample
        fused kernel. ``"virtual-work"`` is read as ``"fused"``: it named this path here before
        issue 17, and the node's ``force_method`` parameter and recorded bags still say it.
    """

    def __init__(
        self,
        p: DRSParams,
        dt: float = 1e-3,
        force_limit: float = 2.0e4,
        integrator: str = "rk4",
        force_method: str = "fused",
    ) -> None:
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and 0.0 < dt <= 0.01):
            raise InputError(f"dt must be a finite number in (0, 0.01] s, got {dt!r}")
        if not (math.isfinite(force_limit) and force_limit > 0.0):
            raise InputError(f"force_limit must be a finite number > 0 N, got {force_limit!r}")
        self.p = p
        self.dt = float(dt)
        self.force_limit = float(force_limit)
        self.force_method = force_method
        self.integrator_name = integrator
        self.s_min, self.s_max = kin.stroke_limits(p)
        self.psi3_closed, self.psi3_open = kin.flap_angle_limits(p)
        self.s_dead = kin.dead_centre(p)
        from .inverse import FusedInverseDynamics, get_method

        get_method(force_method)  # refuse an unknown name now, with the valid ones
        self._scalar_force = (
            FusedInverseDynamics.from_params(p)
            if force_method in ("fused", "virtual-work")
            else None
        )
        # force mode: a step of at most MAX_FORCE_STEP is first tried whole (the real-time loop's
        # common case); a longer one, or one that fails or meets a stop, in `_pieces` equal
        # sub-steps (at least two, none longer than MAX_FORCE_STEP), halved where needed
        self._whole_steps = self.dt <= MAX_FORCE_STEP * (1.0 + 1e-9)
        self._pieces = max(2, math.ceil(self.dt / MAX_FORCE_STEP * (1.0 - 1e-9)))
        self._stepper = None
        # built now, not at the first force command: importing the integrators (scipy.integrate)
        # mid-run stalls a real-time loop for ~0.4 s
        self._ensure_stepper()
        self.reset()

    # ---- state ----------------------------------------------------------------------------------
    def reset(self, t: float = 0.0, s: float | None = None) -> ActuatorState:
        """At rest at stroke ``s`` (default closed) at time ``t``, in hold mode."""
        s = self.s_min if s is None else float(kin.check_stroke(s, self.p))
        self.t = float(t)
        self._t_reset = float(t)
        self.steps = 0
        self.mode = "hold"
        self._path: QuinticPath | None = None
        self._settled = False
        self._target: float | None = None
        self._force_cmd = 0.0
        self._at_stop: str | None = None
        self._set_kinematic(s, 0.0, 0.0)
        return self.state

    def _set_kinematic(self, s: float, sd: float, sdd: float) -> None:
        self._q, self._qd, self._qdd = kin.kinematic_state_scalar(s, sd, sdd, self.p)
        self._force = self._inverse_force()

    def _inverse_force(self) -> float:
        if self._scalar_force is not None:
            return self._scalar_force.force(
                float(self._q[0]), float(self._qd[0]), float(self._qdd[0])
            )
        from .inverse import inverse_dynamics

        res = inverse_dynamics(self._arrays(), self.p, method=self.force_method)
        return float(np.asarray(res.piston_force).ravel()[0])

    def _arrays(self) -> kin.KinematicState:
        return kin.KinematicState(np.array([self._q]), np.array([self._qd]), np.array([self._qdd]))

    #: The snapshot's type (a subclass adds fields: :class:`drs_model.fidelity.RungState`).
    state_type = ActuatorState

    def _state_extras(self) -> dict:
        """The snapshot's fields beyond :class:`ActuatorState`'s (none here)."""
        return {}

    @property
    def state(self) -> ActuatorState:
        q = np.array(self._q)
        psi1, psi3 = self._q[1], self._q[2]
        return self.state_type(
            t=self.t,
            q=q,
            qd=np.array(self._qd),
            qdd=np.array(self._qdd),
            piston_force=self._force,
            gap=kernels.flap_gap(math.sin(psi3), *self.p.gap_constants),
            mode=self.mode,
            at_stop=self._at_stop,
            target=self._target,
            dead_centre_distance=self._q[0] - self.s_dead,
            transmission=abs(math.cos(psi1 - psi3)),
            **self._state_extras(),
        )

    # ---- commands ------------------------------------------------------------------------------
    def command_stroke(self, target: float, duration: float | None = None) -> QuinticSegment:
        """Move smoothly to ``target`` [m] from the current state; refuse a bad target.

        ``duration`` [s] defaults to the seed's opening time scaled by the distance (full stroke in
        ``T_opening``), at least 2 steps. A move whose path would leave ``[s_min, s_max]`` (large
        current velocity) is refused.
        """
        target = float(target)
        if not math.isfinite(target):
            raise InputError(f"stroke command must be finite, got {target!r}")
        s0, v0, a0 = self._q[0], self._qd[0], self._qdd[0]
        if duration is None:
            frac = abs(target - s0) / (self.s_max - self.s_min)
            duration = max(self.p.T_opening * frac, 2 * self.dt)
        seg = quintic_move(self.p, target, duration, s0, v0, a0, t0=self.t)
        path = seg.evaluate(np.linspace(seg.t0, seg.t1, 65))[0]
        if path.min() < self.s_min - 1e-12 or path.max() > self.s_max + 1e-12:
            raise StrokeRangeError(
                f"the move to {target!r} m from s = {s0:.6g} m at {v0:.3g} m/s would leave "
                f"[s_min, s_max] = [{self.s_min:.9g}, {self.s_max:.9g}] m"
            )
        self._path, self._target, self.mode = QuinticPath.of_segment(seg), target, "stroke"
        self._settled = False
        self._at_stop = None
        return seg

    def plan_trajectory(self, times, strokes, rates=None) -> TrajectoryPlan:
        """:func:`drs_model.profile.plan_trajectory` for this actuator's parameters: validate a
        trajectory and build all of it that does not depend on the actuator's state (all but
        the first one or two segments), for a later :meth:`command_trajectory` ``(plan)``.

        Reads only the actuator's parameters, which never change: it may run in another thread
        while the actuator steps (the node: in the subscription callback, outside its tick).
        Raises as :meth:`command_trajectory` does, except for the first segment(s)' paths.
        """
        return plan_trajectory(self.p, times, strokes, rates)

    def command_trajectory(self, times, strokes=None, rates=None) -> QuinticPath:
        """Follow a trajectory of the piston: reach ``strokes[k]`` [m] at ``times[k]`` [s from
        now] with rate ``rates[k]`` [m/s] (default: the mean of the neighbouring slopes, and rest
        at the last point), through one quintic per interval starting from the current state.

        ``times`` may instead be a :class:`~drs_model.profile.TrajectoryPlan` from
        :meth:`plan_trajectory` (``strokes`` and ``rates`` then omitted): only the segments
        that depend on the current state (the first, and with default rates the second) are
        built and checked here, in microseconds; given arrays, this plans first (a few ms for
        10,000 points). The result is the same to the bit either way.

        Refused (nothing changes) unless the times strictly increase from > 0, every value is
        finite, every stroke lies in ``[s_min, s_max]`` and the whole path stays inside it
        (checked at 65 instants per segment); at most 10,000 points. A trajectory ends at rest:
        a last point with a non-zero rate is refused (holding a stroke at a speed is no state
        the mechanism can be in). Where several segments leave the range, the one named is the
        first of those built without the state, else the first of the others.

        Returns the path followed (a sequence of :class:`QuinticSegment`, built on access).
        """
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
        head = plan.head(float(self._q[0]), float(self._qd[0]), float(self._qdd[0]))
        path = QuinticPath.of_plan(plan, self.t, head)
        self._path, self._target, self.mode = path, float(plan.strokes[-1]), "stroke"
        self._settled = False
        self._at_stop = None
        return path

    def command_drs(self, open_flap: bool) -> QuinticSegment:
        """Open (True) or close (False) with the seed's manoeuvre times."""
        target = self.s_max if open_flap else self.s_min
        duration = self.p.T_opening if open_flap else self.p.T_closing
        return self.command_stroke(target, duration)

    def command_force(self, force: float) -> None:
        """Apply ``force`` [N] from now on (forward dynamics); refuse NaN or |F| > force_limit."""
        force = float(force)
        if not math.isfinite(force):
            raise InputError(f"force command must be finite, got {force!r}")
        if abs(force) > self.force_limit:
            raise InputError(
                f"force command {force!r} N is outside "
                f"[-{self.force_limit:g}, {self.force_limit:g}] N"
            )
        stepper = self._ensure_stepper()
        if self.mode != "force" or self._at_stop is None:
            stepper.reset(psi3=self._q[2], psi3_dot=self._qd[2], t=self.t)
        self._force_cmd = force
        self._force = force
        self.mode, self._path, self._target = "force", None, None

    # ---- stepping ------------------------------------------------------------------------------
    def _ensure_stepper(self):
        if self._stepper is None:
            from .forward import FixedStepIntegrator

            self._stepper = FixedStepIntegrator(self.p, self.dt, method=self.integrator_name)
        return self._stepper

    def step(self) -> ActuatorState:
        """Advance one step ``dt``; returns the new state."""
        self._advance_one()
        return self.state

    def advance(self, n: int) -> None:
        """Advance ``n`` steps without building a snapshot per step (the real-time loop's way:
        :attr:`state` builds one, ~20 us)."""
        for _ in range(n):
            self._advance_one()

    def _advance_one(self) -> None:
        self.steps += 1
        self.t = self._t_reset + self.steps * self.dt  # no accumulated round-off
        if self.mode == "force":
            self._step_force()
        elif self.mode == "stroke" and not self._settled:
            # past the last segment the end state no longer changes: computed once, then kept
            if self.t >= self._path.t_end:
                # every move ends at rest at its target: from its end on, that is the state
                # exactly (the polynomial at t1 leaves ~1e-14 m/s of round-off)
                self._settled = True
                self._set_kinematic(self._target, 0.0, 0.0)
            else:
                s, v, a = self._path.at(self.t)  # the segment in force found by bisection
                self._set_kinematic(s, v, a)
        # hold mode (and a settled move) keeps the state reset() or the last step computed

    def _flap_acceleration(self, psi3: float, psi3d: float) -> float:
        return self._stepper.form.accel(psi3, psi3d, self._force_cmd)

    def _leaves_stop(self, stop: str) -> bool:
        """Whether the flap, at rest on ``stop`` (the current state), is pulled away from it: the
        free acceleration points away from the stop (psi3 decreases as the flap opens)."""
        acc = self._flap_acceleration(self._q[2], 0.0)
        return acc < 0.0 if stop == "closed" else acc > 0.0

    def _step_force(self) -> None:
        stepper, f = self._stepper, self._force_cmd
        if self._at_stop is not None:
            # resting on a stop: it stays unless the force pulls the flap away from it
            if not self._leaves_stop(self._at_stop):
                self._hold_at(self._at_stop)
                return
            self._at_stop = None
            stepper.restore(self.t - self.dt, (self._q[2], 0.0))
        st = None
        if self._whole_steps:
            try:
                st = stepper.step(f)
            except _REFUSED_STEP:
                pass
        if st is None or not self.s_min < st.s < self.s_max:
            # a long step, or one that fails or ends on or past a stop (rare at 1 kHz)
            st = self._split_step()
            if st is None:
                return  # on a stop at the end of the step
        q = (st.s, st.psi1, st.psi3)
        qd = (st.s_dot, st.psi1_dot, st.psi3_dot)
        psi3dd = self._flap_acceleration(st.psi3, st.psi3_dot)
        self._q, self._qd = q, qd
        self._qdd = kin.accelerations_from_flap_scalar(q, qd, psi3dd, self.p)
        self._force = f

    def _split_step(self):
        """This step (from ``self._q``, ``self._qd`` at ``t - dt``) in sub-steps: a contact with
        a stop is found from the motion, the flap placed on the stop it reaches (perfectly
        inelastic), and the rest of the step goes on from there (resting on the stop, or leaving
        it if the force pulls the flap away).

        Sub-steps are ``dt / m`` [s] (``m >= 2``, the least with ``dt / m <= MAX_FORCE_STEP``);
        one that fails or ends on or past a stop is halved, down to :data:`SEARCH_LEVELS`
        halvings (~1 us at 1 ms), and grows back once past: at the finest the stop its end lies
        on or past is the one reached. If even a finest
        sub-step is refused (no state to read), the flap goes on the stop its motion points to:
        the sign of ``psi3'`` at the last good state, else of ``psi3''`` there, else the nearer
        stop. At most :data:`MAX_CONTACTS_PER_STEP` contacts per step; after the last the flap
        stays on its stop for the rest of the step. Deterministic: the same state, force and
        ``dt`` give the same sub-steps and the same bits.

        Returns the integrator's state at the end of the step (in free flight), or None with
        the flap placed on a stop.
        """
        stepper, f = self._stepper, self._force_cmd
        top = 1 << SEARCH_LEVELS  # the largest sub-step, in units of the finest
        total = self._pieces * top  # the step, in the same units
        unit = self.dt / total
        t_start = self.t - self.dt
        stepper.restore(t_start, (self._q[2], self._qd[2]))
        pos, size, contacts, stop = 0, top, 0, None
        while pos < total:
            if stop is not None:
                if contacts >= MAX_CONTACTS_PER_STEP or not self._leaves_stop(stop):
                    return None
                # pulled away at once: on from rest at the stop, with the largest sub-step
                # that fits the time already taken
                stepper.restore(t_start + pos * unit, (self._q[2], 0.0))
                self._at_stop = stop = None
                size = min(top, pos & -pos)
            before = stepper.state
            try:
                st = stepper.step_by(f, size * unit)
            except _REFUSED_STEP:
                st = None
            if st is not None and self.s_min < st.s < self.s_max:
                pos += size
                while size < top and pos % (size << 1) == 0:  # back to the larger sub-step
                    size <<= 1
                continue
            if st is not None:  # ended on or past a stop: back to where the sub-step began
                stepper.restore(before.t, (before.psi3, before.psi3_dot))
            if size > 1:
                size >>= 1
                continue
            stop = self._stop_reached(st, before)
            self._hold_at(stop)
            contacts += 1
            pos += size
        return None if stop is not None else stepper.state

    def _stop_reached(self, st, before) -> str:
        """The stop a finest sub-step reaches: the one its end lies on or past; if the sub-step
        was refused (``st`` None), the one the motion at ``before`` points to."""
        if st is not None:
            return "closed" if st.s <= self.s_min else "open"
        direction = before.psi3_dot
        if direction == 0.0:
            direction = self._flap_acceleration(before.psi3, 0.0)
        if direction < 0.0:
            return "open"  # psi3 decreases as the flap opens
        if direction > 0.0:
            return "closed"
        return "open" if before.s > 0.5 * (self.s_min + self.s_max) else "closed"

    def _hold_at(self, stop: str) -> None:
        s = self.s_min if stop == "closed" else self.s_max
        self._q, self._qd, self._qdd = kin.kinematic_state_scalar(s, 0.0, 0.0, self.p)
        self._at_stop = stop
        self._force = self._force_cmd

    def advance_to(self, t: float, max_steps: int | None = None) -> int:
        """Step until the simulated time reaches ``t`` [s] (at most ``max_steps``); returns the
        number of steps taken."""
        n = int(math.floor((t - self.t) / self.dt + 1e-9))
        if max_steps is not None:
            n = min(n, max_steps)
        self.advance(max(n, 0))
        return max(n, 0)

    def reactions(self) -> dict[str, float]:
        """Joint reactions of the current state by Newton-Euler [N, N m] (seed's names)."""
        from .inverse import inverse_dynamics

        res = inverse_dynamics(self._arrays(), self.p, method="newton-euler")
        return {k: float(np.asarray(v).ravel()[0]) for k, v in res.reactions.items()}
