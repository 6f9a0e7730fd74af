"""The fidelity ladder's speed goals, measured side by side in one run (medians of repeats; the
machine is shared, so only the ratios mean much):

* ``kinematic`` at least 50x cheaper than ``rigid`` per simulated second: the 1 kHz gap stream
  of a 90 s lap (the hour is 40 laps: 40x the lap's cost) and the 100 ms open-hold-close scene,
  the kinematic rung in batch and stepped;
* ``hydraulic`` at 1 kHz physics within 25 % of a core: stepped as the node steps it (one
  ``step()`` with its state snapshot per physics step), through the 100 ms open-hold-close
  scene and a hold, next to ``rigid`` stepped the same way.

Usage: ``python benchmarks/fidelity_speed.py [--repeat 5] [--json]``; writes
``benchmarks/results/fidelity_speed.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from drs_model import DRSParams
from drs_model.fidelity import make_rung
from drs_model.fidelity.scenes import SCENES, run_scene

ROOT = Path(__file__).resolve().parents[1]
P = DRSParams()


def node_like_cost(rung_name: str, seconds: float = 1.0) -> float:
    """Wall seconds per simulated second of ``step()`` at 1 kHz (the node's per-tick call, its
    snapshot included): open in 100 ms, hold, close in 100 ms, hold."""
    rung = make_rung(rung_name, P, 1e-3)
    n = int(seconds / 1e-3)
    clock = time.perf_counter()
    for k in range(n):
        if k == 0:
            rung.command_stroke(rung.s_max, 0.1)
        elif k == n // 2:
            rung.command_stroke(rung.s_min, 0.1)
        rung.step()
    return (time.perf_counter() - clock) / seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    runs = {
        "kinematic (batch)": ("kinematic", {"batch": True}),
        "kinematic": ("kinematic", {}),
        "rigid": ("rigid", {}),
    }
    scene_costs = {}
    for scene in ("gap-stream", "open-hold-close-100ms"):
        samples = {label: [] for label in runs}
        for _ in range(args.repeat):  # interleaved: the same load on every run
            for label, (rung, options) in runs.items():
                samples[label].append(run_scene(rung, SCENES[scene], P, **options).cost_per_second)
        scene_costs[scene] = {k: statistics.median(v) for k, v in samples.items()}
    node = {name: [] for name in ("rigid", "hydraulic")}
    for _ in range(args.repeat):
        for name in node:
            node[name].append(node_like_cost(name))
    node = {k: statistics.median(v) for k, v in node.items()}
    result = {
        "scenes": scene_costs,
        "ratios_rigid_over_kinematic": {
            s: {k: c["rigid"] / c[k] for k in ("kinematic (batch)", "kinematic")}
            for s, c in scene_costs.items()
        },
        "hour_of_gap_stream_seconds": {
            k: 40 * 90.0 * v for k, v in scene_costs["gap-stream"].items()
        },
        "node_1khz_core_fraction": node,
        "goals": {
            "kinematic >= 50x cheaper than rigid (gap stream, batch)": scene_costs["gap-stream"][
                "rigid"
            ]
            / scene_costs["gap-stream"]["kinematic (batch)"]
            >= 50.0,
            "hydraulic at 1 kHz within 25 % of a core": node["hydraulic"] <= 0.25,
        },
    }
    (ROOT / "benchmarks" / "results").mkdir(exist_ok=True)
    (ROOT / "benchmarks" / "results" / "fidelity_speed.json").write_text(
        json.dumps(result, indent=1)
    )
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for scene, costs in scene_costs.items():
        for label, cost in costs.items():
            ratio = costs["rigid"] / cost
            print(
                f"{scene:>22} {label:>18}: {cost * 1e3:8.3f} ms per simulated s "
                f"(rigid / this = {ratio:6.1f}x)"
            )
    for name, frac in node.items():
        print(f"node-like step() at 1 kHz, {name:>9}: {100 * frac:5.1f} % of a core")
    for goal, met in result["goals"].items():
        print(f"goal: {goal}: {'met' if met else 'MISSED'}")


if __name__ == "__main__":
    main()
