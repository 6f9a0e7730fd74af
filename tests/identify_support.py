"""Runs of the rungs with known parameters, sampled as a bag would be, for the identification
tests (no bag, no rclpy): the truth is what the rung was given, the noise the stroke sensor's
own (:class:`drs_model.fidelity.sensor_faults.StrokeSensor`, seeded)."""

from __future__ import annotations

import numpy as np

from drs_model.fidelity import make_rung
from drs_model.fidelity.faults import RunFaults
from drs_model.fidelity.sensor_faults import SensorFaults, StrokeSensor
from drs_model.identify.record import Record

#: Columns of :func:`run_rung`'s table.
COLUMNS = (
    "t",
    "stroke",
    "stroke_rate",
    "stroke_acceleration",
    "piston_force",
    "pressure_a",
    "pressure_b",
    "supply_pressure",
    "spool",
)


def run_rung(
    rung: str,
    p,
    moves=((0, True), (40, False)),
    steps: int = 80,
    dt: float = 1e-3,
    hydraulic=None,
    trajectory=None,
    supply=(),
    faults=(),
) -> np.ndarray:
    """Rows of :data:`COLUMNS` at every physics step of ``rung``: the flap opened and closed
    through ``command_drs`` at the steps of ``moves`` (or ``trajectory = (times, strokes,
    rates)`` commanded at step 0); ``supply``: ``(step, pressure [Pa], ramp [s])``, the supply
    pressure set then (``set_supply_pressure``); ``faults``: ``(step, name, value)``, a fault
    applied then as the node applies its ``fault.*`` parameters
    (:class:`~drs_model.fidelity.faults.RunFaults`)."""
    options = {"hydraulic": hydraulic} if rung == "hydraulic" else {}
    sim = make_rung(rung, p, dt, **options)
    if trajectory is not None:
        sim.command_trajectory(*trajectory)
    actions: dict[int, list] = {}
    for k, open_flap in () if trajectory is not None else moves:
        actions.setdefault(k, []).append(lambda o=open_flap: sim.command_drs(o))
    for k, pressure, ramp in supply:
        actions.setdefault(k, []).append(lambda a=pressure, r=ramp: sim.set_supply_pressure(a, r))
    run_faults = RunFaults(sim)
    for k, name, value in faults:
        actions.setdefault(k, []).append(lambda n=name, v=value: run_faults.apply(n, v))
    return _sampled(sim, steps, actions)


def _sampled(sim, steps: int, actions: dict) -> np.ndarray:
    """Rows of :data:`COLUMNS` of ``sim`` at rest and after each of ``steps`` physics steps,
    each of ``actions[k]`` called before step ``k``; a pressure the rung lacks is NaN."""

    def row():
        st = sim.state
        return (
            st.t,
            st.q[0],
            st.qd[0],
            st.qdd[0],
            st.piston_force,
            *(
                np.nan if v is None else v
                for v in (st.pressure_a, st.pressure_b, st.supply_pressure, st.spool)
            ),
        )

    rows = [row()]
    for k in range(steps):
        for act in actions.get(k, ()):
            act()
        sim.step()
        rows.append(row())
    return np.array(rows)


def hydraulic_signals(table: np.ndarray) -> dict:
    """The signals the hydraulic rung's output error compares, of a :func:`run_rung` table."""
    cols = dict(zip(COLUMNS, table.T, strict=True))
    return {k: cols[k] for k in ("stroke", "piston_force", "pressure_a", "pressure_b")}


def noisy_record(
    table: np.ndarray, noise: float = 0.0, seed: int = 0, stops_hold: bool = False, **drop
) -> Record:
    """The record of a :func:`run_rung` table, its stroke as a sensor of ``noise`` [m] (seed
    ``seed``) reads it; ``drop`` names signals to leave out (``stroke_rate=True``);
    ``stops_hold``: whether the run's commands may have held the rod on a stop (a force
    command's run; :func:`run_rung`'s stroke commands do not)."""
    cols = dict(zip(COLUMNS, table.T, strict=True))
    if noise:
        sensor = StrokeSensor(SensorFaults(noise=noise, seed=seed))
        pairs = enumerate(zip(cols["t"], cols["stroke"], strict=True))
        cols["stroke"] = np.array([sensor.read(t, k, s) for k, (t, s) in pairs])
    for name in COLUMNS[5:]:
        if np.all(np.isnan(cols[name])):
            cols[name] = None
    for name, gone in drop.items():
        if gone:
            cols[name] = None
    return Record(**cols, stops_hold=stops_hold)


def force_run(
    p,
    forces=((0, 1500.0), (60, 0.0), (120, 2500.0), (180, 0.0)),
    steps: int = 240,
    dt: float = 1e-3,
) -> np.ndarray:
    """Rows of :data:`COLUMNS` of the ``rigid`` rung under piston force commands [N] at the
    steps of ``forces``: 1500 N drives the flap onto its open stop, 0 N lets the air load close
    it onto the closed one (inelastic stops: the rod rests on them, held by the stop)."""
    sim = make_rung("rigid", p, dt)
    actions = {k: [lambda f=force: sim.command_force(f)] for k, force in forces}
    return _sampled(sim, steps, actions)
