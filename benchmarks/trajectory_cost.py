"""What a long trajectory costs the real-time loop: its command, and each physics step along it.

A 10,000-point trajectory (the most ``ActuatorSim.command_trajectory`` accepts): one point per
millisecond for 10 s, a sine of 0.5 s period over 80 % of the stroke, rates left to the actuator
(C1 through the points). Measured, each as the median of ``--repeat`` runs (the cores are shared):

* ``command_trajectory(times, strokes)`` on raw arrays (the whole validation in the call);
* where the model offers it (``drs_model.profile.plan_trajectory``), the plan alone (the part
  that can run outside the node's tick) and ``command_trajectory(plan)`` (the part in the tick);
* ``advance()`` per physics step (dt = 1 ms) along the trajectory: the median over blocks of 100
  steps taken across the whole 10 s, and over the last 10 blocks (the last second, where a
  linear scan of the segments is slowest).

Usage: ``python benchmarks/trajectory_cost.py [--repeat 7] [--json]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from drs_model import profile
from drs_model.actuator import ActuatorSim
from drs_model.kinematics import stroke_limits
from drs_model.params import DRSParams

N_POINTS = 10_000
DT = 1e-3
BLOCK = 100


def trajectory(p: DRSParams) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = stroke_limits(p)
    t = DT * np.arange(1, N_POINTS + 1)
    mid, amp = 0.5 * (lo + hi), 0.4 * (hi - lo)
    return t, mid - amp * np.cos(2 * np.pi * t / 0.5)


def timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    p = DRSParams()
    times, strokes = trajectory(p)
    # the cost of building and following the path: its first point, 4.6 mm off the closed stop
    # 1 ms after the start, needs far more than force_limit (limit_moves would refuse it)
    sim = ActuatorSim(p, dt=DT, limit_moves=False)
    sim.command_trajectory(times, strokes)  # warm-up (imports, caches)
    out: dict[str, float] = {}

    def fresh() -> ActuatorSim:
        sim.reset()
        return sim

    raw = [timed(lambda: fresh().command_trajectory(times, strokes)) for _ in range(args.repeat)]
    out["command_trajectory_raw_ms"] = 1e3 * statistics.median(raw)
    plan_fn = getattr(profile, "plan_trajectory", None)
    if plan_fn is not None:
        plans = [timed(lambda: plan_fn(p, times, strokes)) for _ in range(args.repeat)]
        plan = plan_fn(p, times, strokes)
        cmds = [timed(lambda: fresh().command_trajectory(plan)) for _ in range(args.repeat)]
        out["plan_trajectory_ms"] = 1e3 * statistics.median(plans)
        out["command_trajectory_plan_ms"] = 1e3 * statistics.median(cmds)
    blocks: list[float] = []
    for _ in range(max(1, args.repeat // 3)):
        fresh().command_trajectory(times, strokes)
        for _ in range(N_POINTS // BLOCK):
            blocks.append(timed(lambda: sim.advance(BLOCK)) / BLOCK)
    per_block = np.array(blocks).reshape(-1, N_POINTS // BLOCK)
    out["advance_per_step_median_us"] = 1e6 * float(np.median(per_block))
    out["advance_per_step_last_second_us"] = 1e6 * float(np.median(per_block[:, -10:]))
    fresh().command_stroke(0.5 * sum(stroke_limits(p)), duration=N_POINTS * DT)
    single = [timed(lambda: sim.advance(BLOCK)) / BLOCK for _ in range(N_POINTS // BLOCK)]
    out["advance_per_step_one_segment_us"] = 1e6 * statistics.median(single)
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for k, v in out.items():
            print(f"{k:<36} {v:10.3f}")


if __name__ == "__main__":
    main()
