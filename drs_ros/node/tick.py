"""The node's tick: catch the simulation up with the node clock, apply the newest commands and
faults, step the physics, publish.

Two parts, each owning its state:

* :class:`SimulationClock` ties simulated time to the node clock: the origin ``t0_ns`` (a stamp
  is ``t0 + simulated time``), the last tick's node and steady times, the jumps of the node clock
  and the deadlines missed. It knows nothing of ROS and is tested alone.
* :class:`Tick` runs one tick with the node's parts it is given (the actuator, the command intake,
  the fault parameters, the effect record) and hands the new state to ``publish``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from diagnostic_msgs.msg import DiagnosticStatus

from drs_model.errors import DRSError

from .. import commands
from ..names import RESET
from ..timestamps import ns_from_seconds, seconds_from_ns, steps_within

#: A wall clock that moves this much [s] more or less than the steady clock between two ticks
#: has jumped (NTP slews far slower: 0.5 ms/s at most).
CLOCK_JUMP_THRESHOLD_S = 0.01


class SimulationClock:
    """Simulated time against the node clock [ns]. ``wall_clock``: the node clock is the system
    clock (a jump is any difference with the steady clock); otherwise it is ``/clock``, which
    may run at any rate (only a step back is a jump). ``publish_period_ns``: under the wall clock,
    a tick more than 1.5 periods after the last one on the steady clock missed its deadline.
    Under ``/clock`` no tick is late: the ticks follow ``/clock``'s messages (``ros2 bag play
    --clock`` publishes 40 a second), so a coarse or paused clock is no missed deadline."""

    def __init__(self, wall_clock: bool, publish_period_ns: int) -> None:
        self.wall_clock = wall_clock
        self.late_ns = 3 * publish_period_ns // 2
        #: Node time [ns] at simulated time 0 (None until the first tick, and after a pause).
        self.t0_ns: int | None = None
        self._last_ns: int | None = None
        self._last_mono: int | None = None

    def pause(self) -> None:
        """Inactive: the time away is neither simulated nor a missed deadline; the next tick
        resumes from the held state."""
        self.t0_ns = None
        self._last_ns = None

    def start(self, now_ns: int, simulated_s: float) -> None:
        """A new origin: node time ``now_ns`` is simulated time ``simulated_s`` [s]."""
        self.t0_ns = now_ns - ns_from_seconds(simulated_s)

    def stamp_ns(self, simulated_s: float) -> int | None:
        """The node time [ns] of simulated time ``simulated_s`` [s] (a state's stamp); None
        before the first tick and after a pause (no origin)."""
        t0 = self.t0_ns
        return None if t0 is None else t0 + ns_from_seconds(simulated_s)

    def jump(self, now_ns: int, mono_ns: int) -> int:
        """The node clock's jump [ns] since the last tick (0: none), the origin moved by it."""
        if self._last_ns is None:
            return 0
        if self.wall_clock:  # the wall clock against the steady one: any difference is a jump
            jump = (now_ns - self._last_ns) - (mono_ns - self._last_mono)
            if abs(jump) < ns_from_seconds(CLOCK_JUMP_THRESHOLD_S):
                return 0
        else:
            if now_ns >= self._last_ns:
                return 0
            jump = now_ns - self._last_ns
        self.t0_ns += jump
        self._last_ns = now_ns  # no missed deadline for the jump itself
        return jump

    def since_last_if_late(self, mono_ns: int) -> int | None:
        """The steady time [ns] since the last tick when it is more than 1.5 periods (a missed
        deadline), else None; always None under ``/clock``. The steady clock, not the node's:
        a wall clock stepped by NTP moves no deadline."""
        if not self.wall_clock or self._last_ns is None or self._last_mono is None:
            return None
        if mono_ns - self._last_mono > self.late_ns:
            return mono_ns - self._last_mono
        return None

    def ticked(self, now_ns: int, mono_ns: int) -> None:
        self._last_ns, self._last_mono = now_ns, mono_ns

    def steps_due(self, now_ns: int, simulated_s: float, dt: float) -> int:
        """Physics steps of ``dt`` [s] from ``simulated_s`` to the node time ``now_ns``."""
        target = seconds_from_ns(now_ns - self.t0_ns)
        return steps_within(target - simulated_s, dt)

    def drop(self, steps: int, dt: float) -> None:
        """Move the origin on by ``steps`` physics steps that will not be simulated."""
        self.t0_ns += ns_from_seconds(steps * dt)


@dataclass(frozen=True)
class TickParts:
    """What a tick reads and drives: ``actuator()`` (the current rung), the command ``intake``,
    the ``fault_parameters``, the ``effects`` (record and counters), ``now_ns()`` (the node
    clock), ``publish(now_ns)`` (the new state out), ``choose_fidelity(now_ns)`` (``auto``'s
    choice, when due), ``fidelity_deadline()`` (steady time [s] before which ``auto`` still
    waits; None when chosen), ``stop_request()`` (the stop the node obeys, or None),
    ``log_info`` and ``log_warning`` (a line for the log)."""

    actuator: Callable
    intake: object
    fault_parameters: object
    effects: object
    now_ns: Callable[[], int]
    publish: Callable[[int], None]
    choose_fidelity: Callable[[int], None]
    fidelity_deadline: Callable[[], float | None]
    stop_request: Callable
    log_info: Callable[[str], None]
    log_warning: Callable[[str], None]


class Tick:
    """One tick of the node (:meth:`run`), on ``clock`` with a physics step ``physics_dt`` [s]
    and at most ``max_catch_up`` steps per tick (a stall beyond drops simulated time)."""

    def __init__(
        self, parts: TickParts, clock: SimulationClock, physics_dt: float, max_catch_up: int
    ) -> None:
        self.parts, self.clock = parts, clock
        self.physics_dt, self.max_catch_up = physics_dt, max_catch_up

    def run(self) -> None:
        """Catch the simulation up with the node clock, apply the newest commands, publish.
        One node time per tick: every stamp and log time of the tick derives from it, so a
        record of the tick (a new clock origin) is never logged after the states it governs."""
        parts, clock, effects = self.parts, self.clock, self.parts.effects
        now = parts.now_ns()
        if now == 0:  # use_sim_time before the first /clock message
            return
        deadline = parts.fidelity_deadline()
        if deadline is not None:
            if time.monotonic() < deadline:
                return  # auto: the subscribers are still being discovered
            parts.choose_fidelity(now)
        sim = parts.actuator()
        mono = time.monotonic_ns()
        if clock.t0_ns is None:
            clock.start(now, sim.t)
            effects.clock_origin(now)
        else:
            self._note_jump(clock.jump(now, mono), now)
        late = clock.since_last_if_late(mono)
        if late is not None:
            effects.missed_deadlines += 1
            effects.troubles.add(
                now, "missed_deadline", f"tick {seconds_from_ns(late) * 1e3:.1f} ms after the last"
            )
        clock.ticked(now, mono)
        effects.ticks += 1
        t = time.thread_time()  # this thread's own CPU: the executor's is not the tick's
        if parts.intake.waiting:
            parts.intake.apply_pending(now)
        if parts.fault_parameters.waiting:
            parts.fault_parameters.apply_pending(now)
        due = self._steps_due(now, sim)
        try:
            self._advance(sim, due)
        except DRSError as exc:  # the model refuses to go on: at rest where it is, and say why
            reason = effects.refuse("step", sim.mode, str(exc), now)
            s_rest = commands.reset_at_rest(sim)
            effects.event(
                RESET, RESET, DiagnosticStatus.WARN, reason, None, {"stroke": repr(s_rest)}, now
            )
        effects.cpu["model"] += time.thread_time() - t
        if due > 0 or effects.ticks == 1:  # publish new states only (stamps strictly increase)
            parts.publish(now)

    def _note_jump(self, jump: int, now: int) -> None:
        """A node clock that jumps (the system clock stepped by NTP or by hand; ``/clock`` going
        back, as ``drs-bag play --loop --clock`` does) moved the origin by the jump, as ROS 2's
        time-jump callbacks would: the simulation goes on from its state, and it is recorded."""
        if jump == 0:
            return
        effects = self.parts.effects
        effects.clock_jumps += 1
        way = "forward" if jump > 0 else "back"
        reason = f"node clock jumped {way} by {seconds_from_ns(abs(jump)):.6g} s"
        effects.troubles.add(now, "clock_jump", reason)
        self.parts.log_warning(f"{reason}: the simulation goes on from its state")
        effects.clock_origin(now, DiagnosticStatus.WARN, reason, jump_ns=jump)

    def _steps_due(self, now: int, sim) -> int:
        due = self.clock.steps_due(now, sim.t, self.physics_dt)
        if due <= self.max_catch_up:
            return due
        # too far behind (a stall): drop the excess instead of spiralling
        dropped = due - self.max_catch_up
        effects = self.parts.effects
        effects.dropped_steps += dropped
        effects.troubles.add(now, "dropped_steps", f"{dropped} physics steps dropped")
        self.clock.drop(dropped, self.physics_dt)
        effects.clock_origin(now, DiagnosticStatus.WARN, f"{dropped} steps dropped")
        return self.max_catch_up

    def _advance(self, sim, due: int) -> None:
        """``due`` physics steps, one at a time, each bounded (the hydraulic rung caps its
        sub-steps): a stop requested meanwhile ends the tick at the next step, so that a tick
        that overruns (a stall, a catch-up of many steps) stays stoppable within one step."""
        stop = self.parts.stop_request()
        for k in range(due):
            if stop is not None and stop.requested:
                self.parts.log_info(
                    f"stop requested: the last tick ends after {k} of its {due} physics steps, "
                    f"at simulated time {sim.t:.6f} s"
                )
                return
            sim.advance(1)


__all__ = ["CLOCK_JUMP_THRESHOLD_S", "SimulationClock", "Tick", "TickParts"]
