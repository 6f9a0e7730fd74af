"""Standard scenes of the fidelity chart, and running one on a rung.

A scene is a list of timed commands (the actuator's: ``drs`` open/close, ``force`` [N],
``lose_supply``) and a duration; :func:`run_scene` steps a rung through it at the physics step
``dt`` and samples every step. :data:`STANDARD_SCENES`:

``open-hold-close``
    the seed's manoeuvre: open (10 ms), hold, close at 40 ms (10 ms); 0.2 s, so that the
    hydraulic rung, slower than the seed's moves, settles.
``open-hold-close-100ms``
    the same with 100 ms moves and a 300 ms hold: what the hydraulic rung can follow.
``force-step``
    at rest closed; a 1500 N force step at 5 ms (the demo's): the flap goes onto its open stop.
``supply-loss``
    open, then the supply fails at 0.1 s (the controller commands closed, its fail-safe).
``supply-return``
    the supply loss's end: open, the supply fails at 0.1 s (the rod side cavitates), returns at
    0.3 s in a step (as the node's ``fault.supply_loss`` cleared: the cavity refills and closes),
    and the flap opens again at 0.32 s.
``relief``
    a 10 kN force command (more than the cylinder gives: full spool) holds the flap on its open
    stop; at 0.15 s the supply rises to 300 bar (its regulator fails) and the piston side's relief
    valve opens at 250 bar.
``gap-stream``
    a lap of 90 s at 1 kHz with two DRS zones (open at 12 s and 55 s for 8 s and 5 s, 100 ms
    moves): what a
    lap simulation needs, the gap. The hour is 40 such laps: its cost is 40x the lap's (the laps
    repeat exactly, so errors repeat too).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .. import kinematics as kin
from ..errors import InputError, UnsupportedCommandError
from ..params import DRSParams
from ..timebase import nearest_step
from . import make_rung
from .kinematic import KinematicRung, batch_strokes


@dataclass(frozen=True)
class Scene:
    """A scene: ``events`` are ``(t [s], action, argument)`` with action ``"drs"`` (argument: open
    True/False, the seed's move times), ``"move"`` (``(open, duration [s])``), ``"force"`` (N),
    ``"lose_supply"`` (ramp time [s]), ``"restore_supply"`` (the supply loss's end, over a ramp
    time [s]) or ``"supply"`` (a new supply pressure [Pa], at once; only
    a rung with a supply takes it); ``duration`` [s];
    ``repeat`` is how many times the scene stands for itself (the hour of laps)."""

    name: str
    duration: float
    events: tuple[tuple[float, str, object], ...]
    repeat: int = 1
    description: str = ""


STANDARD_SCENES = (
    Scene(
        "open-hold-close",
        0.2,
        ((0.0, "drs", True), (0.04, "drs", False)),
        description="the seed's manoeuvre: open 10 ms, hold to 40 ms, close 10 ms",
    ),
    Scene(
        "open-hold-close-100ms",
        0.6,
        ((0.0, "move", (True, 0.1)), (0.3, "move", (False, 0.1))),
        description="open in 100 ms, hold to 300 ms, close in 100 ms (what the valve can follow)",
    ),
    Scene(
        "force-step",
        0.2,
        ((0.005, "force", 1500.0),),
        description="a 1500 N force step from rest closed at 5 ms",
    ),
    Scene(
        "supply-loss",
        0.4,
        ((0.0, "drs", True), (0.1, "lose_supply", 0.0)),
        description="open; the supply fails at 0.1 s",
    ),
    Scene(
        "supply-return",
        0.45,
        (
            (0.0, "drs", True),
            (0.1, "lose_supply", 0.0),
            (0.3, "restore_supply", 0.0),
            (0.32, "drs", True),
        ),
        description="open; the supply fails at 0.1 s, returns at 0.3 s; open again at 0.32 s",
    ),
    Scene(
        "relief",
        0.3,
        ((0.0, "force", 1.0e4), (0.15, "supply", 300e5)),
        description="open stop under full spool; the supply rises to 300 bar at 0.15 s",
    ),
    Scene(
        "gap-stream",
        90.0,
        (
            (12.0, "move", (True, 0.1)),
            (20.0, "move", (False, 0.1)),
            (55.0, "move", (True, 0.1)),
            (60.0, "move", (False, 0.1)),
        ),
        repeat=40,
        description="a 90 s lap at 1 kHz with two DRS zones (100 ms moves); the hour is 40 laps",
    ),
)
SCENES = {s.name: s for s in STANDARD_SCENES}


@dataclass
class Trace:
    """A rung's run of a scene: samples at every step (``t`` [s], ``stroke`` [m], ``gap`` [m],
    ``force`` [N], NaN where the rung has none; the chamber pressures [Pa] and vapour cavities
    [m^3] ``pressure_a``, ``pressure_b``, ``cavity_a``, ``cavity_b`` of a rung with chambers,
    else empty), the wall-clock ``cost`` [s] of the stepping, and ``refused`` (the reason) where
    the rung cannot represent a command of the scene."""

    rung: str
    scene: str
    t: np.ndarray = field(default_factory=lambda: np.empty(0))
    stroke: np.ndarray = field(default_factory=lambda: np.empty(0))
    gap: np.ndarray = field(default_factory=lambda: np.empty(0))
    force: np.ndarray = field(default_factory=lambda: np.empty(0))
    pressure_a: np.ndarray = field(default_factory=lambda: np.empty(0))
    pressure_b: np.ndarray = field(default_factory=lambda: np.empty(0))
    cavity_a: np.ndarray = field(default_factory=lambda: np.empty(0))
    cavity_b: np.ndarray = field(default_factory=lambda: np.empty(0))
    cost: float = float("nan")
    refused: str | None = None

    @property
    def cost_per_second(self) -> float:
        """Wall-clock seconds per simulated second."""
        return self.cost / float(self.t[-1] - self.t[0]) if len(self.t) > 1 else float("nan")


def _apply(rung, action: str, argument) -> None:
    if action == "drs":
        rung.command_drs(bool(argument))
    elif action == "force":
        rung.command_force(float(argument))
    elif action == "move":  # (open, duration [s]): a move to a stop in the given time
        open_flap, duration = argument
        rung.command_stroke(rung.s_max if open_flap else rung.s_min, duration)
    elif action == "lose_supply":
        rung.lose_supply(float(argument))
    elif action == "restore_supply":  # as the node's fault.supply_loss set back to false
        rung.apply_fault("supply_loss", False, float(argument))
    elif action == "supply":
        if not hasattr(rung, "set_supply_pressure"):
            raise UnsupportedCommandError(
                f"the {rung.name!r} rung has no supply whose pressure could change"
            )
        rung.set_supply_pressure(float(argument))
    else:  # pragma: no cover - the scenes above use only these
        raise ValueError(f"unknown scene action {action!r}")


def gaps(s: np.ndarray, p: DRSParams) -> np.ndarray:
    """The gap [m] at the strokes ``s`` [m] (closed forms, on arrays), solved only where the
    stroke changes from one sample to the next (a lap holds still most of the time) and repeated
    over each stretch of rest: the values of every sample solved alone."""
    moves = np.empty(s.shape, dtype=bool)
    moves[0] = True
    np.not_equal(s[1:], s[:-1], out=moves[1:])
    starts = np.flatnonzero(moves)
    psi3_at = kin.solve_position(s[starts], p)[:, 2]
    return np.repeat(kin.gap_from_flap_angle(psi3_at, p), np.diff(starts, append=s.size))


def run_scene(
    rung_name: str,
    scene: Scene,
    p: DRSParams | None = None,
    dt: float = 1e-3,
    batch: bool = False,
    **options,
) -> Trace:
    """Run the rung ``rung_name`` through ``scene`` at ``dt`` [s], sampling every step: stepped
    as the node steps it, or with ``batch`` (the kinematic rung only) on arrays, command to
    command. The cost covers the run and the gap's computation.

    ``options`` go to the rung (:func:`drs_model.fidelity.make_rung`). A command the rung
    cannot represent ends the run with ``refused`` set (no samples)."""
    p = DRSParams() if p is None else p
    rung = make_rung(rung_name, p, dt, **options)
    n = nearest_step(scene.duration, dt)
    events = sorted(scene.events, key=lambda e: e[0])
    st = rung.state
    clock = time.perf_counter()
    try:
        if batch:
            if not isinstance(rung, KinematicRung):
                raise InputError(f"batch runs only the kinematic rung, not {rung_name!r}")
            t = np.arange(n + 1, dtype=float)  # rung.t + dt k, in place: no second array
            t *= dt
            t += rung.t
            actions = [(e[0], lambda r, e=e: _apply(r, e[1], e[2])) for e in events]
            s, force = batch_strokes(rung, actions, t), np.full(n + 1, np.nan)
            gap = gaps(s, p)
        else:
            t, s, psi3, force = (np.empty(n + 1) for _ in range(4))
            t[0], s[0], psi3[0], force[0] = st.t, st.q[0], st.q[2], st.piston_force
            chambers = _ChamberLog(rung, n)
            k_event = 0
            for k in range(1, n + 1):
                while k_event < len(events) and events[k_event][0] <= rung.t + 1e-12:
                    _apply(rung, events[k_event][1], events[k_event][2])
                    k_event += 1
                rung.advance(1)
                t[k], s[k], psi3[k], force[k] = rung.sample()
                chambers.sample(k)
            gap = kin.gap_from_flap_angle(psi3, p)
    except UnsupportedCommandError as exc:
        return Trace(rung_name, scene.name, refused=str(exc))
    cost = time.perf_counter() - clock
    label = rung_name + (" (batch)" if batch else "")
    trace = Trace(label, scene.name, t, s, gap, force, cost=cost)
    if not batch:
        trace.pressure_a, trace.pressure_b, trace.cavity_a, trace.cavity_b = chambers.arrays()
    return trace


class _ChamberLog:
    """The chamber pressures and cavities of a rung that has them, at every step (nothing for
    the others)."""

    def __init__(self, rung, n: int) -> None:
        self._rung = rung if hasattr(rung, "chamber_pressures") else None
        self._rows = np.empty((n + 1 if self._rung else 0, 4))
        if self._rung:
            self.sample(0)

    def sample(self, k: int) -> None:
        if self._rung:
            self._rows[k] = (*self._rung.chamber_pressures(), *self._rung.cavity_volumes())

    def arrays(self):
        return tuple(self._rows.T.copy())
