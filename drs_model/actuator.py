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

import numpy as np

from . import kinematics as kin
from .commanded import ActuatorState, CommandedActuator
from .errors import IntegrationError, SingularConfigurationError, StrokeRangeError
from .params import FORCE_LIMIT_DEFAULT_N, DRSParams

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


__all__ = ["MAX_FORCE_STEP", "ActuatorSim", "ActuatorState"]


class ActuatorSim(CommandedActuator):
    """Fixed-step simulation of the rigid actuator (module docstring): the commanded actuator
    (:class:`~drs_model.commanded.CommandedActuator`) with the inverse dynamics along the moves
    and the forward dynamics under a force command.

    Parameters
    ----------
    p : DRSParams
    dt : float
        Physics step [s] (> 0).
    force_limit : float
        Largest accepted |piston force| [N] (a force command; a move's peak with
        ``limit_moves``).
    integrator : str
        Fixed-step method for force mode (see :class:`drs_model.forward.FixedStepIntegrator`).
    force_method : str
        Inverse-dynamics formulation for stroke and hold modes, a name of
        :data:`drs_model.inverse.INVERSE_METHODS`; ``"fused"`` (the default) is the one-sample
        fused kernel, every other name runs that formulation (``"virtual-work"`` the virtual
        work along ``dq/dpsi3``) through :func:`drs_model.inverse.inverse_dynamics`.
    limit_moves : bool
        Refuse a move whose inverse-dynamics peak exceeds ``force_limit`` (default).
    """

    method_options = frozenset({"integrator", "force_method"})

    def __init__(
        self,
        p: DRSParams,
        dt: float = 1e-3,
        force_limit: float = FORCE_LIMIT_DEFAULT_N,
        integrator: str = "rk4",
        force_method: str = "fused",
        limit_moves: bool = True,
    ) -> None:
        super().__init__(p, dt, force_limit, integrator, force_method, limit_moves)
        self.force_method = force_method
        self.integrator_name = integrator
        self.psi3_closed, self.psi3_open = kin.flap_angle_limits(p)
        from .inverse import FusedInverseDynamics

        self._scalar_force = (
            FusedInverseDynamics.from_params(p) if force_method == "fused" else None
        )
        # force mode: a step of at most MAX_FORCE_STEP is first tried whole (the real-time loop's
        # common case); a longer one, or one that fails or meets a stop, in `_pieces` equal
        # sub-steps (at least two, none longer than MAX_FORCE_STEP), halved where needed
        self._whole_steps = self.dt <= MAX_FORCE_STEP * (1.0 + 1e-9)
        self._pieces = max(2, math.ceil(self.dt / MAX_FORCE_STEP * (1.0 - 1e-9)))
        # built now, not at the first force command: importing the integrators (scipy.integrate)
        # mid-run stalls a real-time loop for ~0.4 s
        from .forward import FixedStepIntegrator

        self._stepper = FixedStepIntegrator(self.p, self.dt, method=self.integrator_name)
        self.reset()

    def _force_now(self) -> float:
        m = self.motion
        if self._scalar_force is not None:
            return self._scalar_force.force(float(m.q[0]), float(m.qd[0]), float(m.qdd[0]))
        from .inverse import inverse_dynamics

        res = inverse_dynamics(self._arrays(), self.p, method=self.force_method)
        return float(np.asarray(res.piston_force).ravel()[0])

    def reset(self, t: float = 0.0, s: float | None = None) -> ActuatorState:
        """At rest at stroke ``s`` (default closed) at time ``t``, in hold mode."""
        self._force_cmd = 0.0
        return super().reset(t, s)

    def command_force(self, force: float) -> None:
        """Apply ``force`` [N] from now on (forward dynamics); refuse NaN or |F| > force_limit."""
        force = self._checked_force(force)
        m = self.motion
        if m.mode != "force":
            self._stepper.reset(psi3=m.q[2], psi3_dot=m.qd[2], t=m.t)
        elif m.at_stop is None:
            # already stepping this very state: put it back as it is, without reset's
            # constraint checks (~0.1 ms of numpy a command warm, ~0.3 ms cold; the same state)
            self._stepper.restore(m.t, (m.q[2], m.qd[2]))
        self._force_cmd = force
        self._force = force
        m.hold_force_mode()

    # ---- stepping ------------------------------------------------------------------------------
    def _advance_one(self) -> None:
        m = self.motion
        m.tick()
        if m.mode == "force":
            self._step_force()
        elif m.follow():
            self._force = self._force_now()
        # hold mode (and a settled move) keeps the state reset() or the last step computed

    def _flap_acceleration(self, psi3: float, psi3d: float) -> float:
        return self._stepper.form.accel(psi3, psi3d, self._force_cmd)

    def _leaves_stop(self, stop: str) -> bool:
        """Whether the flap, at rest on ``stop`` (the current state), is pulled away from it: the
        free acceleration points away from the stop (psi3 decreases as the flap opens)."""
        acc = self._flap_acceleration(self.motion.q[2], 0.0)
        return acc < 0.0 if stop == "closed" else acc > 0.0

    def _step_force(self) -> None:
        stepper, f = self._stepper, self._force_cmd
        if self.motion.at_stop is not None:
            # resting on a stop: it stays unless the force pulls the flap away from it
            if not self._leaves_stop(self.motion.at_stop):
                self._hold_at(self.motion.at_stop)
                return
            self.motion.at_stop = None
            stepper.restore(self.t - self.dt, (self.motion.q[2], 0.0))
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
        self.motion.q, self.motion.qd = q, qd
        self.motion.qdd = kin.accelerations_from_flap_scalar(q, qd, psi3dd, self.p)
        self._force = f

    def _split_step(self):
        """This step (from the motion's state at ``t - dt``) in sub-steps: a contact with a stop is
        found from the motion, the flap placed on the stop it reaches (perfectly inelastic),
        and the rest of the step goes on from there (resting on the stop, or leaving it if
        the force pulls the flap away).

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
        stepper.restore(t_start, (self.motion.q[2], self.motion.qd[2]))
        pos, size, contacts, stop = 0, top, 0, None
        while pos < total:
            if stop is not None:
                if contacts >= MAX_CONTACTS_PER_STEP or not self._leaves_stop(stop):
                    return None
                # pulled away at once: on from rest at the stop, with the largest sub-step
                # that fits the time already taken
                stepper.restore(t_start + pos * unit, (self.motion.q[2], 0.0))
                self.motion.at_stop = stop = None
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
        self.motion.set_state(s, 0.0, 0.0)
        self.motion.at_stop = stop
        self._force = self._force_cmd
