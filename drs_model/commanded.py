"""The commanded actuator: what every rung of the ladder offers the node and the scene runner
(commands, stepping, the state snapshot, the faults it models), written once.

:class:`CommandedActuator` is an abstract base in scipy's ``OdeSolver`` manner: it owns a
:class:`~drs_model.motion.StrokeMotion` (clock, mode, commanded path, kinematic state) and the
piston force, and a rung supplies what it models differently: :meth:`_force_now` (the force of
the present motion), :meth:`_advance_one` (one step), :meth:`command_force`, and the faults it
models (:meth:`models`, :meth:`check_fault`, :meth:`apply_fault`).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from . import kernels
from . import kinematics as kin
from .errors import DRSError, ForceLimitError, InputError, UnsupportedCommandError
from .motion import StrokeMotion
from .params import FORCE_LIMIT_DEFAULT_N, DRSParams
from .profile import QuinticPath, QuinticSegment, TrajectoryPlan, quintic_move
from .timebase import steps_within

#: Why a rung without forces refuses what needs them.
NO_FORCES = "it models no forces; use 'quasi-static', 'rigid' or 'hydraulic'"
#: Why a rung without hydraulics refuses a hydraulic fault.
NO_HYDRAULICS = "it has no valve, oil or friction; run fidelity 'hydraulic'"
#: Most moves a stroke command without a duration tries before its refusal (two or three fit).
FIT_DURATION_TRIES = 8
#: The faults of the oil circuit (:data:`drs_model.fidelity.faults.FAULTS`).
HYDRAULIC_FAULTS = ("stuck_valve", "leak_m3_per_s_per_pa", "jam_friction_n")


def check_methods(integrator: str, force_method: str) -> None:
    """Refuse an unknown force-mode integrator (a key of
    :data:`drs_model.forward.FIXED_STEP_METHODS`) or inverse-dynamics method, with the valid
    names: every rung takes the node's names, also one that models neither."""
    from .forward.fixed_step import FIXED_STEP_METHODS
    from .inverse import get_method

    get_method(force_method)
    if integrator not in FIXED_STEP_METHODS:
        raise InputError(f"method must be one of {sorted(FIXED_STEP_METHODS)}, got {integrator!r}")


#: How many path peaks an actuator keeps (:meth:`CommandedActuator._path_peak`).
KEPT_PEAKS = 8


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


#: The method options' defaults (:class:`CommandedActuator`'s constructor).
METHOD_DEFAULTS = {"integrator": "rk4", "force_method": "fused"}


class CommandedActuator:
    """The shell of a fixed-step actuator (module docstring).

    Parameters
    ----------
    p : DRSParams
    dt : float
        Physics step [s], in (0, 0.01].
    force_limit : float
        Largest accepted |piston force| [N], of a force command and (``limit_moves``) of a
        move's inverse-dynamics peak (default :data:`~drs_model.params.FORCE_LIMIT_DEFAULT_N`).
    integrator, force_method : str
        The force-mode integrator and the inverse-dynamics method: checked here (every rung
        takes the node's names), used by the rungs that have them (:class:`ActuatorSim`).
    limit_moves : bool
        Keep moves within ``force_limit`` (default; :attr:`limit_moves`).
    """

    #: The rung's name in :data:`drs_model.fidelity.RUNGS`.
    name = ""
    #: The snapshot's type (a subclass adds fields: :class:`drs_model.fidelity.RungState`).
    state_type = ActuatorState
    #: Whether the state at each step follows from the time and the commands alone (nothing is
    #: integrated): :meth:`advance` then evaluates only the last of its steps, to the same bits.
    path_is_state = False
    #: Whether the rung has fluid: chamber pressures and a spool to publish, and a stiffness the
    #: physics step must resolve (:meth:`check_stiffness`).
    has_fluid = False
    #: The method options (``integrator``, ``force_method``) the rung uses: a value other than
    #: the default for one it does not use is refused, never silently ignored.
    method_options: frozenset[str] = frozenset()

    def __init__(
        self,
        p: DRSParams,
        dt: float = 1e-3,
        force_limit: float = FORCE_LIMIT_DEFAULT_N,
        integrator: str = "rk4",
        force_method: str = "fused",
        limit_moves: bool = True,
    ) -> None:
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and 0.0 < dt <= 0.01):
            raise InputError(f"dt must be a finite number in (0, 0.01] s, got {dt!r}")
        if not (math.isfinite(force_limit) and force_limit > 0.0):
            raise InputError(f"force_limit must be a finite number > 0 N, got {force_limit!r}")
        check_methods(integrator, force_method)
        self._refuse_unused_methods(integrator=integrator, force_method=force_method)
        self.p = p
        self.dt = float(dt)
        self.force_limit = float(force_limit)
        self.motion = StrokeMotion(p, self.dt)
        self.motion.check_path = self._check_path
        self.motion.fit_duration = self._fit_duration
        self._limit_moves = bool(limit_moves)
        self.s_min, self.s_max = self.motion.s_min, self.motion.s_max
        self.s_dead = kin.dead_centre(p)
        self._statics = None  # FusedInverseDynamics, built for the first stretched move
        # the last paths' peaks: {(params, coefficients' and durations' bytes): PathPeak}
        # (an OrderedDict: its popitem is one step, so a caller on another thread,
        # drs_duration, cannot break an eviction)
        self._peaks: OrderedDict = OrderedDict()
        # the last drs_duration: ((open_flap, start, limit_moves, force_limit), duration), one
        # tuple (read and replaced whole: drs_duration may run on another thread)
        self._drs_duration_kept: tuple | None = None
        self._force = math.nan

    def _refuse_unused_methods(self, **given: str) -> None:
        """Refuse a method option this rung does not use (see :attr:`method_options`) given a
        value other than its default."""
        for option, value in given.items():
            default = METHOD_DEFAULTS[option]
            if option not in self.method_options and value != default:
                raise InputError(
                    f"the {self.name} rung does not use {option}: got {value!r}, only its "
                    f"default {default!r} is accepted"
                )

    def check_stiffness(self) -> int:
        """The sub-steps one physics step needs: 1 for a rung without fluid (nothing stiff to
        resolve; :class:`~drs_model.fidelity.HydraulicRung` measures its own)."""
        return 1

    # ---- what a rung supplies ------------------------------------------------------------------
    def _force_now(self) -> float:
        """The piston force [N] of the present motion."""
        raise NotImplementedError

    def _advance_one(self) -> None:
        """One physics step."""
        raise NotImplementedError

    def command_force(self, force: float) -> None:
        """Apply ``force`` [N] from now on."""
        raise NotImplementedError

    # ---- clock and mode ------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time [s]."""
        return self.motion.t

    @t.setter
    def t(self, value: float) -> None:
        self.motion.t = float(value)

    @property
    def steps(self) -> int:
        """Steps taken since the last :meth:`reset`."""
        return self.motion.steps

    @property
    def mode(self) -> str:
        """``"hold"``, ``"stroke"`` or ``"force"``."""
        return self.motion.mode

    # ---- state ---------------------------------------------------------------------------------
    def reset(self, t: float = 0.0, s: float | None = None) -> ActuatorState:
        """At rest at stroke ``s`` (default closed) at time ``t``, in hold mode."""
        s = self.s_min if s is None else float(kin.check_stroke(s, self.p))
        self.motion.reset(t, s)
        self._force = self._force_now()
        return self.state

    def _set_kinematic(self, s: float, sd: float, sdd: float) -> None:
        self.motion.set_state(s, sd, sdd)
        self._force = self._force_now()

    def _arrays(self) -> kin.KinematicState:
        m = self.motion
        return kin.KinematicState(np.array([m.q]), np.array([m.qd]), np.array([m.qdd]))

    def _state_extras(self) -> dict:
        """The snapshot's fields beyond :class:`ActuatorState`'s."""
        return {"rung": self.name} if self.name else {}

    @property
    def state(self) -> ActuatorState:
        """The snapshot now (~20 us)."""
        m = self.motion
        psi1, psi3 = m.q[1], m.q[2]
        return self.state_type(
            t=m.t,
            q=np.array(m.q),
            qd=np.array(m.qd),
            qdd=np.array(m.qdd),
            piston_force=self._force,
            gap=kernels.flap_gap(math.sin(psi3), *self.p.gap_constants),
            mode=m.mode,
            at_stop=m.at_stop,
            target=m.target,
            dead_centre_distance=m.q[0] - self.s_dead,
            transmission=abs(math.cos(psi1 - psi3)),
            **self._state_extras(),
        )

    def sample(self) -> tuple[float, float, float, float]:
        """``(t, s, psi3, piston_force)`` [s, m, rad, N] now, without building the state
        snapshot: what a scene samples every step."""
        m = self.motion
        return m.t, float(m.q[0]), float(m.q[2]), float(self._force)

    def reactions(self) -> dict[str, float]:
        """Joint reactions of the current state by Newton-Euler [N, N m] (seed's names)."""
        from .inverse import inverse_dynamics

        res = inverse_dynamics(self._arrays(), self.p, method="newton-euler")
        return {k: float(np.asarray(v).ravel()[0]) for k, v in res.reactions.items()}

    # ---- commands ------------------------------------------------------------------------------
    @property
    def limit_moves(self) -> bool:
        """Whether a timed move (a trajectory, a stroke command given its duration) whose
        inverse-dynamics peak force exceeds ``force_limit`` is refused
        (:class:`ForceLimitError`), naming the peak and the limit, and a move whose time is the
        seed's (a stroke command given none, the DRS manoeuvre) takes longer instead. On by
        default (the seed's own 10 ms opening, 25.4 kN, fits the default 30 kN); off, a
        move is carried out whatever force it needs (bags recorded before the option)."""
        return self._limit_moves

    @limit_moves.setter
    def limit_moves(self, value: bool) -> None:
        self._limit_moves = bool(value)
        self.motion.forget_checked_plans()  # plans checked under the other rule: check again

    def _check_path(self, coeffs, durations, first: int) -> None:
        """Refuse a commanded path (quintics ``coeffs`` [local time] of ``durations`` [s], the
        first being segment ``first``) with a segment shorter than the physics step (it would
        pass between two steps, its force never seen), or, with :attr:`limit_moves`, whose
        inverse-dynamics peak |F| exceeds ``force_limit``."""
        durations = np.asarray(durations, dtype=float)
        short = np.flatnonzero(durations < self.dt * (1.0 - 1e-9))
        if short.size:
            k = int(short[0])
            raise InputError(
                f"segment {first + k} of the move lasts {durations[k]:.6g} s, "
                f"shorter than the physics step dt = {self.dt:g} s"
            )
        if not self.limit_moves:
            return
        peak = self._path_peak(coeffs, durations)
        if abs(peak.force) > self.force_limit:
            raise ForceLimitError(
                f"the move needs a piston force of {peak.force:.6g} N (inverse dynamics, "
                f"{peak.time:.6g} s into segment {first + peak.segment}, at stroke "
                f"{peak.stroke:.6g} m), beyond force_limit {self.force_limit:g} N: give it "
                "more time"
            )

    def _fit_duration(self, target: float, duration: float, start: tuple) -> float:
        """A stroke command's own duration [s]: ``duration`` (the seed's, scaled by the
        distance) or, with :attr:`limit_moves`, longer until the move's inverse-dynamics peak
        fits ``force_limit``. Along a move from rest the force is ``g(s) + h(u) / T^2`` (statics,
        and inertia with the velocity terms, at the same fraction ``u`` of the path), so each
        stretch aims at 0.1 % under the limit from the peak's own split; a move no duration
        fits (statics beyond the limit, a fast start) is left to the refusal, which names its
        peak."""
        if not self.limit_moves or not math.isfinite(target):
            return duration
        from .inverse import FusedInverseDynamics

        if self._statics is None:
            self._statics = FusedInverseDynamics.from_params(self.p)
        limits = (self.s_min, self.s_max)
        for _ in range(FIT_DURATION_TRIES):
            try:
                seg = quintic_move(self.p, target, duration, *start, limits=limits)
            except DRSError:
                return duration  # the command refuses it, with the reason
            peak = self._path_peak([seg.coeffs], [seg.duration])
            static = abs(self._statics.force(peak.stroke, 0.0, 0.0))
            aim = (1.0 - 1e-3) * self.force_limit
            if abs(peak.force) <= self.force_limit or static >= aim:
                return duration
            duration *= max(math.sqrt((abs(peak.force) - static) / (aim - static)), 1.01)
        return duration

    def _path_peak(self, coeffs, durations):
        """:func:`drs_model.inverse.path_peak_force` of this path, for these parameters. The
        last :data:`KEPT_PEAKS` results are kept: a stroke command's stretched duration is
        checked again on the very same segment (bit for bit), an opening and a closing from rest
        are the same segments each time, and a caller may evaluate a command's path ahead of it
        (:meth:`drs_duration`); each evaluation of a move costs ~10 us (the compiled scan of
        :mod:`drs_model.inverse.path_peak`; without numba, in Python, ~1 ms)."""
        from .inverse import path_peak_force

        c = np.ascontiguousarray(coeffs, dtype=float)
        d = np.ascontiguousarray(durations, dtype=float)
        key = (id(self.p), c.tobytes(), d.tobytes())
        kept = self._peaks.get(key)
        if kept is not None and kept[0] is self.p:
            return kept[1]
        peak = path_peak_force(self.p, c, d)
        if len(self._peaks) >= KEPT_PEAKS:
            self._peaks.popitem(last=False)  # the oldest
        self._peaks[key] = (self.p, peak)
        return peak

    def _command_start(self) -> tuple[float, float, float]:
        """``(s, s', s'')`` a new command starts from: the present state."""
        return self.motion.start()

    def stroke_duration(self, target: float) -> float:
        """The duration [s] :meth:`command_stroke` takes now to ``target`` [m] given none (a
        finite ``target``; the move itself is checked by the command)."""
        return self.motion.stroke_duration(float(target), self._command_start())

    def command_stroke(self, target: float, duration: float | None = None) -> QuinticSegment:
        """Move smoothly to ``target`` [m] from the current state; refuse a bad target.

        ``duration`` [s] defaults to the seed's opening time scaled by the distance (full stroke in
        ``T_opening``), at least 2 steps, and with :attr:`limit_moves` longer where the move
        needs more than ``force_limit`` in that time (a short move off the closed stop). A move
        whose path would leave ``[s_min, s_max]`` (large current velocity) is refused, and with
        :attr:`limit_moves` one whose given ``duration`` needs more than ``force_limit``.
        """
        return self.motion.command_stroke(target, duration)

    def plan_trajectory(self, times, strokes, rates=None) -> TrajectoryPlan:
        """:func:`drs_model.profile.plan_trajectory` for this actuator's parameters: validate a
        trajectory and build all of it that does not depend on the actuator's state (all but
        the first one or two segments), for a later :meth:`command_trajectory` ``(plan)``.

        Reads only the actuator's parameters, which never change: it may run in another thread
        while the actuator steps (the node: in the subscription callback, outside its tick).
        Raises as :meth:`command_trajectory` does, except for the first segment(s)' paths.
        """
        return self.motion.plan_trajectory(times, strokes, rates)

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
        return self.motion.command_trajectory(times, strokes, rates)

    def command_drs(self, open_flap: bool) -> QuinticSegment:
        """Open (True) or close (False) with the seed's manoeuvre times or, with
        :attr:`limit_moves`, longer where the move needs more than ``force_limit`` in them (a
        heavier flap): the times are the seed's, not the caller's, as a stroke command's."""
        target, _ = self.motion.drs_move(open_flap)
        return self.command_stroke(target, self.drs_duration(open_flap))

    def drs_duration(self, open_flap: bool) -> float:
        """The duration [s] :meth:`command_drs` takes from the present state: the seed's, or
        longer under :attr:`limit_moves`. Changes nothing but the kept peaks and the last
        answer, so a caller may ask it ahead of the command, outside a lock the simulation's
        steps take; the command, from the same state, then takes that answer."""
        start = tuple(float(x) for x in self._command_start())
        key = (bool(open_flap), start, self._limit_moves, self.force_limit)
        kept = self._drs_duration_kept
        if kept is not None and kept[0] == key:  # asked ahead of the command, from this state
            return kept[1]
        target, duration = self.motion.drs_move(open_flap)
        duration = self._fit_duration(target, duration, start)
        self._drs_duration_kept = (key, duration)
        return duration

    def _checked_force(self, force: float) -> float:
        """``force`` [N] as a float; refuse NaN or |F| > force_limit."""
        force = float(force)
        if not math.isfinite(force):
            raise InputError(f"force command must be finite, got {force!r}")
        if abs(force) > self.force_limit:
            raise InputError(
                f"force command {force!r} N is outside "
                f"[-{self.force_limit:g}, {self.force_limit:g}] N"
            )
        return force

    def lose_supply(self, ramp_s: float = 0.0) -> None:
        """The hydraulic supply fails now: the piston gives no more force (here: a zero force
        command, the documented equivalent of an ideal piston; the hydraulic rung: the supply
        pressure falls to the return pressure over ``ramp_s`` [s])."""
        self.command_force(0.0)

    # ---- stepping ------------------------------------------------------------------------------
    def step(self) -> ActuatorState:
        """Advance one step ``dt``; returns the new state."""
        self._advance_one()
        return self.state

    def advance(self, n: int) -> None:
        """Advance ``n`` steps without building a snapshot per step (the real-time loop's way:
        :attr:`state` builds one, ~20 us)."""
        if self.path_is_state:
            if n > 0:
                self.motion.steps += n - 1  # the steps between leave nothing behind
                self._advance_one()
            return
        for _ in range(n):
            self._advance_one()

    def advance_to(self, t: float, max_steps: int | None = None) -> int:
        """Step until the simulated time reaches ``t`` [s] (at most ``max_steps``); returns the
        number of steps taken."""
        n = steps_within(t - self.t, self.dt)
        if max_steps is not None:
            n = min(n, max_steps)
        self.advance(max(n, 0))
        return max(n, 0)

    # ---- faults --------------------------------------------------------------------------------
    def models(self, fault: str) -> bool:
        """Whether this actuator can represent ``fault`` (a name of
        :data:`drs_model.fidelity.faults.FAULTS` other than the sensor's) away from healthy."""
        return fault not in HYDRAULIC_FAULTS

    def check_fault(self, fault: str, value) -> None:
        """Refuse an unhealthy ``value`` of ``fault`` this actuator cannot represent
        (:class:`UnsupportedCommandError`, with the reason)."""
        if not self.models(fault):
            why = NO_HYDRAULICS if fault in HYDRAULIC_FAULTS else NO_FORCES
            raise UnsupportedCommandError(
                f"the {self.name or 'rigid'!r} rung cannot model fault {fault}: {why}"
            )

    def apply_fault(self, fault: str, value, ramp_s: float = 0.0) -> None:
        """Fault ``fault`` set to ``value`` now (checked by :meth:`check_fault`): a supply loss
        is a zero force from now on (the air load closes the flap); its end changes nothing
        until the next command; a healthy hydraulic fault changes nothing."""
        if fault == "supply_loss" and value:
            self.lose_supply()
