"""The re-run of a recorded run (:func:`resimulate`): the recorded commands fed, at the simulated
instants the effect record says they took effect, to a fresh rung of :mod:`drs_model.fidelity`
(no DDS), which steps as the comparison asks for its states.
"""

from __future__ import annotations

from dataclasses import dataclass

from drs_model.errors import DRSError
from drs_model.fidelity import make_rung
from drs_model.fidelity.faults import RunFaults
from drs_model.params import DRSParams
from drs_ros import commands
from drs_ros.bag.read.effects import (
    FAULT_PREFIX,
    apply_fault_record,
    is_fault_record,
)
from drs_ros.bag.read.recorded_run import RecordedRun, ResimulationError
from drs_ros.names import ACCEPTED, RESET
from drs_ros.timestamps import nearest_step

#: Re-simulated steps kept behind the latest one asked for (a recorded state is compared with
#: the step its stamp names; a bag in the node's order never looks back more than a few).
STATE_WINDOW = 65536

#: What a re-run says of a bag whose ``force_method`` is ``virtual-work``: a bag of that name may
#: hold the fused closed form's forces, and does not say which formulation ran; the two agree to
#: 1e-9 relative (~1e-14 measured, docs/dynamics.md), far inside the force's tolerance.
VIRTUAL_WORK_NOTE = (
    "force_method 'virtual-work': re-run with the virtual-work formulation, which agrees with "
    "the fused closed form to 1e-9 relative: forces recorded by either compare within tolerance"
)


class Rerun:
    """A re-run of ``run``'s commands on the rung ``sim`` with step ``dt`` [s]: its states are
    computed as they are asked for (:meth:`state_at`), every record up to that step acted on
    first as the node did; memory holds the last :data:`STATE_WINDOW` steps. ``notes`` says
    where the re-run differs from the run (a step or a command its model refuses)."""

    def __init__(
        self, run: RecordedRun, sim, dt: float, faults_left_out: frozenset[str] = frozenset()
    ):
        self.run, self.sim, self.dt = run, sim, dt
        self.faults_left_out = faults_left_out
        self.piston = list(run.node_parameters["joint_names"])[0]
        self.faults = RunFaults(sim)  # the faults set at run time, and the stroke as published
        self.states: dict[int, tuple] = {}
        self.notes: list[str] = []
        # the steps at which the run's model refused to go on and the node held the flap
        self.reset_steps = {self.step_of(r.sim_time) for r in run.records if r.outcome == RESET}
        self.pending = [r for r in run.records if r.outcome in (ACCEPTED, RESET)]
        self.applied = 0  # records of ``pending`` acted on so far
        self.keep()

    def step_of(self, t: float) -> int:
        """The step of simulated time ``t`` [s]."""
        return nearest_step(t, self.dt)

    def keep(self) -> None:
        """Keep the rung's state as the node published it (a sensor fault changes the stroke)."""
        st = self.sim.state
        q = st.q.copy()
        q[0] = self.faults.published_stroke(st.t, q[0])
        self.states[self.step_of(st.t)] = (q, st.qd.copy(), st.piston_force, st.gap, st.qdd[0])

    def advance_to(self, t: float) -> None:
        """Step the rung to simulated time ``t`` [s], keeping each state."""
        sim, dt = self.sim, self.dt
        while sim.t < t - 0.5 * dt:
            try:
                sim.step()
            except DRSError as exc:
                # the re-run's model refuses to go on: hold where it is, as the node does; the
                # run's RESET record, if it has one here, follows
                s_hold = commands.reset_at_rest(sim)
                if self.step_of(sim.t) not in self.reset_steps:
                    self.notes.append(
                        f"at {sim.t:.6f} s the re-run's model refuses a step the "
                        f"run took ({exc}); held at {s_hold!r} m as the node "
                        "would"
                    )
            self.keep()

    def apply(self, r) -> None:
        """Advance to the instant ``r`` took effect and act on it as the node did."""
        self.advance_to(r.sim_time)
        if r.outcome == RESET:
            self._reset(r)
        elif is_fault_record(r):  # a fault set at run time, applied at its tick as the node did
            self._fault(r)
        else:
            self._command(r)

    def _reset(self, r) -> None:
        # the node's model refused a step; the node held the flap at the recorded stroke at
        # that step's time and published that state: the same here, whether or not this
        # model refuses the step (a later model may take it)
        sim = self.sim
        if abs(sim.t - r.sim_time) > 0.5 * self.dt:
            raise ResimulationError(
                f"the effect record resets at {r.sim_time!r} s, which the re-run passed "
                f"({sim.t!r} s): the records are out of order"
            )
        sim.reset(r.sim_time, float(r.values["stroke"]))
        self.keep()

    def _fault(self, r) -> None:
        if r.source.removeprefix(FAULT_PREFIX) in self.faults_left_out:
            return
        try:
            apply_fault_record(self.faults, r)
        except DRSError as exc:
            self.notes.append(
                f"at {r.sim_time:.6f} s the re-run refuses {r.source} "
                f"{r.values.get('value', '')}: {exc}"
            )
        if self.sim.steps == 0 and self.sim.t == 0.0:  # given at start: the node's first tick
            self.keep()  # applies it before it publishes the first state

    def _command(self, r) -> None:
        key = self.run.command_key(r.source)
        if key == commands.SERVICE_KEY:
            msg = _Value(r.values["value"] == "True")
        elif key == commands.ACTION_KEY:  # the action's moves are in the record itself
            msg = commands.move_from_record(r.values)
        else:
            msg = self.run.commands.get((r.source, int(r.values["sequence"])))
            if msg is None:
                raise ResimulationError(
                    f"the effect record names {r.source} message {r.values['sequence']}, which "
                    "the bag does not hold"
                )
        planned = r.values.get("planned_ns")  # a stamped trajectory: the time it was read against
        try:
            commands.apply(
                self.sim, key, msg, self.piston, None, None if planned is None else int(planned)
            )
        except DRSError as exc:
            self.notes.append(
                f"at {r.sim_time:.6f} s the re-run refuses {r.source} "
                f"{r.values.get('value', '')}: {exc}"
            )
        # no keep(): the node published this step's state before the command acted on it

    def state_at(self, k: int):
        """The re-simulated state of step ``k`` (None if the re-run has none there): every
        record up to that step acted on first (a reset at ``k`` replaces its state); states more
        than :data:`STATE_WINDOW` steps before ``k`` are forgotten."""
        while (
            self.applied < len(self.pending)
            and self.step_of(self.pending[self.applied].sim_time) <= k
        ):
            self.applied += 1
            self.apply(self.pending[self.applied - 1])
        self.advance_to(k * self.dt)
        states = self.states
        while states and next(iter(states)) < k - STATE_WINDOW:
            del states[next(iter(states))]
        return states.get(k)

    def finish(self) -> None:
        """Act on the records after the last compared state (their notes belong to the run)."""
        while self.applied < len(self.pending):
            self.applied += 1
            self.apply(self.pending[self.applied - 1])


def resimulate(
    run: RecordedRun,
    model: DRSParams,
    fidelity: str | None = None,
    *,
    rung_options: dict | None = None,
    faults_left_out: frozenset[str] = frozenset(),
) -> dict:
    """The re-run of the recorded commands on the recorded rung (``rigid`` for a bag recorded
    before the ``fidelity`` parameter), or on ``fidelity``, step by step as
    :func:`.deviations.compare` asks for its states (``state_at(step)``), and its notes:
    memory holds the last :data:`STATE_WINDOW` steps (a :class:`Rerun`). The rung takes the
    recorded ``force_limit``, ``integrator``, ``force_method`` and ``limit_moves`` (off for a
    bag without it); ``rung_options`` go to the rung over them (``hydraulic=`` its
    HydraulicParams); the recorded faults named in ``faults_left_out`` (names of
    :data:`~drs_model.fidelity.faults.FAULTS`) are not applied (a fit estimates what a leak or
    a jam changed, and reads a sensor's faults as the record's noise).

    Returns a dict: ``sim`` (the rung), ``states`` (step -> state kept), ``dt`` [s],
    ``notes``, and the :class:`Rerun`'s ``advance_to``, ``state_at`` and ``finish``."""
    np_ = run.node_parameters
    dt = 1.0 / float(np_["physics_rate_hz"])
    options = {
        "force_limit": float(np_["force_limit"]),
        "integrator": str(np_["integrator"]),
        "force_method": str(np_["force_method"]),
        # the node's rule for moves beyond force_limit; a bag from before the rule carried out
        # every move
        "limit_moves": bool(np_.get("limit_moves", False)),
        **(rung_options or {}),
    }
    sim = make_rung(fidelity or run.rung(), model, dt, **options)
    rerun = Rerun(run, sim, dt, faults_left_out)
    if np_["force_method"] == "virtual-work":
        rerun.notes.append(VIRTUAL_WORK_NOTE)
    return {
        "sim": sim,
        "states": rerun.states,
        "dt": dt,
        "notes": rerun.notes,
        "advance_to": rerun.advance_to,
        "state_at": rerun.state_at,
        "finish": rerun.finish,
    }


@dataclass
class _Value:
    data: object


__all__ = ["STATE_WINDOW", "VIRTUAL_WORK_NOTE", "Rerun", "resimulate"]
