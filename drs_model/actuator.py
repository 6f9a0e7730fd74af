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
mechanism can never be driven through the dead centre.

Commands are validated at the boundary: a refused command raises a :class:`DRSError` subclass with
the reason and leaves the actuator unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import kernels
from . import kinematics as kin
from .errors import InputError, StrokeRangeError
from .params import DRSParams
from .profile import QuinticSegment, quintic_move

MODES = ("hold", "stroke", "force")


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
        self._segments: tuple[QuinticSegment, ...] = ()
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

    @property
    def state(self) -> ActuatorState:
        q = np.array(self._q)
        psi1, psi3 = self._q[1], self._q[2]
        return ActuatorState(
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
        self._segments, self._target, self.mode = (seg,), target, "stroke"
        self._settled = False
        self._at_stop = None
        return seg

    def command_trajectory(self, times, strokes, rates=None) -> tuple[QuinticSegment, ...]:
        """Follow a trajectory of the piston: reach ``strokes[k]`` [m] at ``times[k]`` [s from
        now] with rate ``rates[k]`` [m/s] (default: the mean of the neighbouring slopes, and rest
        at the last point), through one quintic per interval starting from the current state.

        Refused (nothing changes) unless the times strictly increase from > 0, every value is
        finite, every stroke lies in ``[s_min, s_max]`` and the whole path stays inside it. A
        trajectory ends at rest: a last point with a non-zero rate is refused (holding a stroke
        at a speed is no state the mechanism can be in).
        """
        t = np.asarray(times, dtype=float).ravel()
        s = np.asarray(strokes, dtype=float).ravel()
        n = t.size
        if n == 0 or n > 10_000 or s.size != n:
            raise InputError(
                f"a trajectory needs 1..10000 points with one stroke per time, got {n} times and "
                f"{s.size} strokes"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(s))):
            raise InputError("trajectory times and strokes must be finite")
        if t[0] <= 0.0 or np.any(np.diff(t) <= 0.0):
            raise InputError(
                f"trajectory times must increase strictly from > 0 s, got {t.tolist()[:5]}..."
            )
        kin.check_stroke(s, self.p)
        if rates is None:
            knots_t = np.concatenate([[0.0], t])
            knots_s = np.concatenate([[self._q[0]], s])
            v = np.zeros(n)
            if n > 1:  # interior points: the slope across the neighbours (a C1 path)
                v[:-1] = (knots_s[2:] - knots_s[:-2]) / (knots_t[2:] - knots_t[:-2])
        else:
            v = np.asarray(rates, dtype=float).ravel()
            if v.size != n or not np.all(np.isfinite(v)):
                raise InputError(f"trajectory rates must be {n} finite values, got {v.size}")
            if v[-1] != 0.0:
                raise InputError(
                    f"a trajectory must end at rest: the last point's velocity is {v[-1]!r} m/s, "
                    "give 0 (or no velocities)"
                )
        segs = []
        s0, v0, a0, t0 = self._q[0], self._qd[0], self._qdd[0], self.t
        for k in range(n):
            seg = QuinticSegment.between(t0, self.t + t[k] - t0, s0, s[k], v0, v[k], a0, 0.0)
            path = seg.evaluate(np.linspace(seg.t0, seg.t1, 65))[0]
            if path.min() < self.s_min - 1e-12 or path.max() > self.s_max + 1e-12:
                raise StrokeRangeError(
                    f"the trajectory leaves [s_min, s_max] = [{self.s_min:.9g}, "
                    f"{self.s_max:.9g}] m on its way to point {k} (of 0..{n - 1}), reaching "
                    f"{path.min():.6g}..{path.max():.6g} m"
                )
            segs.append(seg)
            s0, v0, a0, t0 = float(s[k]), float(v[k]), 0.0, seg.t1
        self._segments, self._target, self.mode = tuple(segs), float(s[-1]), "stroke"
        self._settled = False
        self._at_stop = None
        return self._segments

    def _active_segment(self) -> QuinticSegment:
        for seg in self._segments:
            if self.t <= seg.t1 + 1e-12:
                return seg
        return self._segments[-1]

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
        self.mode, self._segments, self._target = "force", (), None

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
            if self.t >= self._segments[-1].t1:
                # every move ends at rest at its target: from its end on, that is the state
                # exactly (the polynomial at t1 leaves ~1e-14 m/s of round-off)
                self._settled = True
                self._set_kinematic(self._target, 0.0, 0.0)
            else:
                seg = self._active_segment()
                s, v, a = kernels.quintic(min(max(self.t - seg.t0, 0.0), seg.duration),
                                          seg.coeffs, 0)  # fmt: skip
                self._set_kinematic(s, v, a)
        # hold mode (and a settled move) keeps the state reset() or the last step computed

    def _flap_acceleration(self, psi3: float, psi3d: float) -> float:
        return self._stepper.form.accel(psi3, psi3d, self._force_cmd)

    def _step_force(self) -> None:
        from .errors import SingularConfigurationError

        stepper, f = self._stepper, self._force_cmd
        if self._at_stop is not None:
            # resting on a stop: it stays unless the free acceleration points away from the stop
            # (psi3 decreases as the flap opens)
            acc = self._flap_acceleration(self._q[2], 0.0)
            leaving = acc < 0.0 if self._at_stop == "closed" else acc > 0.0
            if not leaving:
                self._hold_at(self._at_stop)
                return
            self._at_stop = None
            stepper.reset(psi3=float(self._q[2]), psi3_dot=0.0, t=self.t - self.dt)
        try:
            st = stepper.step(f)
        except (StrokeRangeError, SingularConfigurationError):
            # the step would pass a stop (or the dead centre beyond the closed stop); one step
            # cannot cross half the stroke, so the nearer stop is the one it hits
            nearer_open = self._q[0] > 0.5 * (self.s_min + self.s_max)
            self._hold_at("open" if nearer_open else "closed")
            return
        if st.s <= self.s_min or st.s >= self.s_max:
            self._hold_at("closed" if st.s <= self.s_min else "open")
            return
        q = (st.s, st.psi1, st.psi3)
        qd = (st.s_dot, st.psi1_dot, st.psi3_dot)
        psi3dd = self._flap_acceleration(st.psi3, st.psi3_dot)
        self._q, self._qd = q, qd
        self._qdd = kin.accelerations_from_flap_scalar(q, qd, psi3dd, self.p)
        self._force = f

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
