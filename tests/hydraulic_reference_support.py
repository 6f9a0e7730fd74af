"""A reference for the hydraulic rung computed independently of its stepping: scipy's Radau on the
rung's right-hand side (``state_rate``), tight, restarted at each of a scene's commands and at
each crossing of the switching functions asked for, located by solve_ivp's event search (so
that Radau integrates smooth pieces only, across a jump of the rate too). Model tests: no
rclpy."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from drs_model import DRSParams, kernels
from drs_model.bodies import model_constants
from drs_model.fidelity import hydraulic_kernels as hk
from drs_model.fidelity import make_rung
from drs_model.fidelity.hydraulic_steps import state_rate
from drs_model.fidelity.scenes import Scene, _apply

#: Each stop crossed both ways under force commands: a 1500 N step from rest closed (off the
#: closed stop, onto the open one at ~108 ms), -1500 N at 0.2 s (off the open stop, onto the
#: closed one at ~257 ms, where the rod bounces once), 1500 N at 0.35 s (off it, onto the open
#: stop again at ~451 ms).
STOPS_BOTH_WAYS = Scene(
    "stops-both-ways",
    0.5,
    ((0.005, "force", 1500.0), (0.2, "force", -1500.0), (0.35, "force", 1500.0)),
)
#: The relief valve crossed both ways: the relief scene (full spool holds the rod on its open
#: stop; the supply at 300 bar from 0.15 s, the piston side above the relief's 250 bar) with the
#: supply back at 210 bar at 0.25 s (the piston side falls below the setting again).
RELIEF_BOTH_WAYS = Scene(
    "relief-both-ways",
    0.35,
    ((0.0, "force", 1.0e4), (0.15, "supply", 300e5), (0.25, "supply", 210e5)),
)

#: Radau's absolute tolerances on (psi3 [rad], psi3' [rad/s], x_A [Pa], x_B [Pa], x_v [-]).
ATOL = np.array([1e-12, 1e-9, 1e-3, 1e-3, 1e-12])
#: After a located crossing the integration restarts this long [s] after it, along the rate on
#: the new side (the root is located to a few ulps of t; this puts the state past it).
RESTART = 1e-12


@dataclass
class Reference:
    """Samples at every 1 ms: ``t`` [s], ``y`` (the rung's states), ``stroke`` [m], ``force``
    [N] (the rod force the rung publishes), ``pressure_a``, ``pressure_b`` [Pa]; ``events``:
    ``(t [s], index)`` of each located crossing of :func:`hk.switching_functions`'s entry."""

    t: np.ndarray
    y: np.ndarray
    stroke: np.ndarray
    force: np.ndarray
    pressure_a: np.ndarray
    pressure_b: np.ndarray
    events: list = field(default_factory=list)

    def crossings(self, index: int) -> list[float]:
        """The times [s] the switching function ``index`` changed sign."""
        return [t for t, i in self.events if i == index]


def radau_reference(
    scene: Scene, watched, p: DRSParams | None = None, rtol: float = 1e-10, **rung_options
) -> Reference:
    """The reference of ``scene`` (module docstring) from the rung's start state, restarted at
    each crossing of the switching functions ``watched`` (indices). The servo's references, the
    mode, the force command and the supply come from a rung used as the commands' clock (they
    are functions of time and of the commands alone, planned from the reference, never from the
    rod); its own states are not used."""
    p = DRSParams() if p is None else p
    clock = make_rung("hydraulic", p, 1e-3, **rung_options)
    c, h = (np.asarray(a) for a in clock._consts)
    y = np.array(clock.y)

    def args(t):
        s_ref, v_ref = clock._reference(t)
        mode = hk.MODE_FORCE if clock.mode == "force" else hk.MODE_STROKE
        return mode, s_ref, v_ref, clock._force_cmd, clock.supply_pressure(t), 0.0

    def rhs(t, y):
        mode, s_ref, v_ref, f_ref, ps, held = args(t)
        return state_rate(y, mode, s_ref, v_ref, f_ref, ps, held, c, h)

    def switch(i):
        def g(t, y):
            return hk.switching_functions(*y, *args(t), c, h)[i]

        g.terminal = True
        return g

    events = sorted(scene.events, key=lambda e: e[0])
    ts, ys, crossed, t0, k = [], [], [], 0.0, 0
    for tb in sorted({e[0] for e in events} | {scene.duration}):
        while k < len(events) and events[k][0] <= t0 + 1e-12:
            _apply(clock, events[k][1], events[k][2])
            k += 1
        ta, armed = t0, list(watched)
        while tb > ta:
            grid = np.arange(np.floor(ta * 1e3 + 1e-6) + 1, round(tb * 1e3) + 1) * 1e-3
            grid = np.minimum(grid[grid > ta], tb)  # k * 1e-3 may round just past tb
            sol = solve_ivp(
                rhs,
                (ta, tb),
                y,
                method="Radau",
                rtol=rtol,
                atol=ATOL,
                t_eval=grid,
                events=[switch(i) for i in armed],
            )
            assert sol.success, sol.message
            start = {i: switch(i)(ta, y) > 0.0 for i in armed}  # each function's side before
            if len(sol.t):  # no sample between two close crossings
                ts.append(sol.t)
                ys.append(sol.y.T)
            if sol.status == 0:
                y, ta = sol.y[:, -1], tb
                continue
            hit = next(j for j, te in enumerate(sol.t_events) if len(te))
            te, y, i = float(sol.t_events[hit][0]), sol.y_events[hit][0], armed[hit]
            y, ta = y + RESTART * rhs(te, y), te + RESTART  # restart just past the crossing
            if (switch(i)(ta, y) > 0.0) == start[i]:
                armed.remove(i)  # a graze (no speed across: no jump either), till the next command
            else:
                crossed.append((te, i))
        while clock.t < tb - 1e-9:
            clock.advance(1)
        t0 = tb
    return _sampled(np.concatenate(ts), np.concatenate(ys), crossed, p, h)


def _sampled(t, y, crossed, p, h) -> Reference:
    cc = model_constants(p)
    conf = np.array([kernels.psi3_configuration(b, cc) for b in y[:, 0]])
    stroke, sd = conf[:, 0], conf[:, 2] * y[:, 1]
    pv = h[hk.P_VAPOUR]
    pa, pb = np.maximum(y[:, 2], pv), np.maximum(y[:, 3], pv)
    force = np.array([hk.rod_force(a, b, v, h) for a, b, v in zip(pa, pb, sd, strict=True)])
    return Reference(t, y, stroke, force, pa, pb, crossed)
