"""What a force-mode physics step costs: free flight at 1 kHz (the real-time loop's common case),
and at 100 Hz (every step in sub-steps of at most 1 ms), per simulated second too.

Free flight: from rest at 23 mm under the force that holds it there (an unstable equilibrium: the
flap drifts off slowly, so 200 steps stay clear of the stops), ``--repeat`` runs, the median per
step. Contact: -5 kN from 46 mm, the median cost of the step in which the flap reaches the closed
stop (the sub-step search), over ``--repeat`` runs.

Usage: ``python benchmarks/force_step_cost.py [--repeat 40] [--json]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from drs_model import kinematics as kin
from drs_model.actuator import ActuatorSim
from drs_model.errors import DRSError
from drs_model.inverse import inverse_dynamics
from drs_model.params import DRSParams

S_FREE = 0.023  # m
N_FREE = 200


def holding_force(p: DRSParams, s: float) -> float:
    st = kin.kinematic_state(np.atleast_1d(s), np.zeros(1), np.zeros(1), p)
    return float(inverse_dynamics(st, p, method="lagrange").piston_force[0])


def free_flight_us(p: DRSParams, dt: float, repeat: int) -> float:
    f = holding_force(p, S_FREE)
    a = ActuatorSim(p, dt=dt)
    n = max(1, int(round(N_FREE * 1e-3 / dt)))
    out = []
    for _ in range(repeat):
        a.reset(s=S_FREE)
        a.command_force(f)
        t0 = time.perf_counter()
        a.advance(n)
        out.append((time.perf_counter() - t0) / n)
        assert a.state.at_stop is None, "the free-flight run reached a stop"
    return 1e6 * statistics.median(out)


def contact_step_us(p: DRSParams, dt: float, repeat: int) -> float | None:
    """None where the model cannot take the step (without sub-steps, at 100 Hz, it raised)."""
    out = []
    for _ in range(repeat):
        a = ActuatorSim(p, dt=dt)
        a.reset(s=0.046)
        a.command_force(-5000.0)
        while True:
            t0 = time.perf_counter()
            try:
                a.advance(1)
            except DRSError:
                return None
            took = time.perf_counter() - t0
            if a.state.at_stop is not None:
                out.append(took)
                break
    return 1e6 * statistics.median(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=40)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    p = DRSParams()
    out = {
        "free_step_1kHz_us": free_flight_us(p, 1e-3, args.repeat),
        "free_step_100Hz_us": free_flight_us(p, 1e-2, args.repeat),
        "contact_step_1kHz_us": contact_step_us(p, 1e-3, args.repeat),
        "contact_step_100Hz_us": contact_step_us(p, 1e-2, args.repeat),
    }
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for k, v in out.items():
            print(f"{k:<28} {'refused' if v is None else f'{v:10.1f}'}")


if __name__ == "__main__":
    main()
