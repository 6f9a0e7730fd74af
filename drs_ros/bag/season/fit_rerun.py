"""A bag's run re-simulated for a fit: the recorded commands on the rung, with trial parameter
values, sampled where the bag's signals were (the output error's model).

Each call is one re-run through :func:`drs_ros.bag.replay.rerun.resimulate` (the same commands,
effect record and resets as ``drs-bag resimulate``), on the rung the fit runs on, with the
recorded faults that change what it estimates left out (:data:`FAULTS_LEFT_OUT`): a fit
estimates what a leak or a jam changed instead of being told, and a sensor's faults are the
record's, not the model's. The others (a lost supply, a stuck valve) are events no parameter
describes, and are re-run as recorded: left out, the re-run could not follow the bag. The rungs
step their compiled kernels (numba).
"""

from __future__ import annotations

import math

import numpy as np

from drs_model.fidelity.faults import FAULTS
from drs_model.fidelity.hydraulic_params import HydraulicParams
from drs_model.identify.parameters import with_values
from drs_model.params import DRSParams
from drs_ros.bag.read.recorded_run import RecordedRun
from drs_ros.bag.replay.rerun import resimulate
from drs_ros.timestamps import nearest_step

#: The signals a re-simulation gives (the output error compares those the bag recorded; the
#: chamber pressures on the hydraulic rung only).
SIMULATED_SIGNALS = ("stroke", "stroke_rate", "piston_force", "pressure_a", "pressure_b")


#: The recorded faults a fit's re-run leaves out: a leak and a jam (the fit estimates
#: ``leak_to_outside`` and the friction they changed) and the stroke sensor's (the record's
#: noise, bias and losses, which the output error's residual is).
FAULTS_LEFT_OUT = frozenset(
    {"leak_m3_per_s_per_pa", "jam_friction_n", *(n for n in FAULTS if n.startswith("sensor."))}
)


class RunResimulation:
    """``simulate({name: value}) -> {signal: array}`` of a recorded run (module docstring) at
    the physics steps ``steps`` of the measured samples."""

    def __init__(
        self,
        run: RecordedRun,
        model: DRSParams,
        hydraulic: HydraulicParams,
        rung: str,
        steps: np.ndarray,
    ) -> None:
        self.run, self.model, self.hydraulic, self.rung = run, model, hydraulic, rung
        self.steps = np.asarray(steps, dtype=np.int64)

    def __call__(self, values: dict[str, float]) -> dict[str, np.ndarray]:
        p, hp = with_values(values, self.model, self.hydraulic)
        # the moves the node carried out, whatever force the candidate's model needs for them
        options = {"limit_moves": False, **({"hydraulic": hp} if self.rung == "hydraulic" else {})}
        result = resimulate(
            self.run, p, self.rung, rung_options=options, faults_left_out=FAULTS_LEFT_OUT
        )
        n = self.steps.size
        kept = SIMULATED_SIGNALS if self.rung == "hydraulic" else SIMULATED_SIGNALS[:3]
        out = {k: np.full(n, math.nan) for k in kept}
        sim, dt = result["sim"], result["dt"]
        for i, k in enumerate(self.steps):
            state = result["state_at"](int(k))
            if state is None:
                continue
            q, qd, force, _gap, _acc = state
            out["stroke"][i], out["stroke_rate"][i], out["piston_force"][i] = q[0], qd[0], force
            if sim.has_fluid and nearest_step(sim.t, dt) == k:  # the rung is at this step
                out["pressure_a"][i], out["pressure_b"][i] = sim.y[2], sim.y[3]
        return out


__all__ = ["SIMULATED_SIGNALS", "RunResimulation"]
