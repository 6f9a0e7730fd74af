"""The fail-safe through the node, per rung: a node opens the flap (``~/drs`` true), holds it,
and then the supply is lost at run time (``fault.supply_loss`` set through the parameter
service, with ``fault.supply_loss_ramp_s``); how long the air load takes to close the flap.

The time runs from the simulated instant the fault took effect (its effect record) to the gap's
first falling within 5 % of its travel from closed, read at every physics step of the bag's
exact re-run (``drs-bag resimulate``'s model run, checked to reproduce the published states).

Usage: ``python benchmarks/failsafe_node.py [--ramp 0.0] [--json]``; writes
``benchmarks/results/failsafe_node.json`` (``failsafe_node_ramp<R>s.json`` with a ramp). Sets
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and uses ROS_DOMAIN_ID (0) unless given ``--domain``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# the node is driven as the tests drive it (tests/node_support.py)
sys.path.insert(0, str(ROOT / "tests"))
RUNGS = ("quasi-static", "rigid", "hydraulic")  # kinematic refuses the fault (no forces)


def run_node(rung: str, bag: Path, ramp: float, domain: int) -> dict:
    """One node run on ``rung``, recorded to ``bag``; what the parameter service answered."""
    from node_support import node_with_client
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    from std_srvs.srv import SetBool

    overrides = [
        Parameter("fidelity", value=rung),
        Parameter("bag_path", value=str(bag)),
        Parameter("publish_rate_hz", value=250.0),
    ]
    with node_with_client(domain, overrides, "failsafe_client") as (_node, client, ex):

        def spin(seconds: float, done=None) -> None:
            end = time.monotonic() + seconds
            while time.monotonic() < end and not (done and done()):
                ex.spin_once(timeout_sec=0.01)

        drs = client.create_client(SetBool, "/drs/drs")
        params = AsyncParameterClient(client, "/drs")
        assert drs.wait_for_service(timeout_sec=10.0) and params.wait_for_services(10.0)
        fut = drs.call_async(SetBool.Request(data=True))
        spin(5.0, fut.done)
        spin(0.4)  # open (the hydraulic rung takes ~55 ms) and hold
        fut = params.set_parameters_atomically(
            [
                Parameter("fault.supply_loss_ramp_s", value=ramp),
                Parameter("fault.supply_loss", value=True),
            ]
        )
        spin(5.0, fut.done)
        result = fut.result().result
        spin(0.6)
        return {"successful": result.successful, "reason": result.reason}


def closing_time(bag: Path) -> dict:
    """From the bag: the fault's simulated instant, the re-run's deviation from the recording,
    and the time to 5 % of the gap's travel from closed."""
    from drs_model.params import DRSParams
    from drs_ros.bag.read.recorded_run import read_run, run_params
    from drs_ros.bag.replay.deviations import SIGNALS, compare
    from drs_ros.bag.replay.rerun import resimulate

    run = read_run(bag)
    model = run_params(run.node_parameters)
    result = resimulate(run, model)
    rows = compare(run, result, {k: tol for k, (_, tol) in SIGNALS.items()})
    (fault,) = [r for r in run.records if r.source == "fault.supply_loss"]
    p = model if isinstance(model, DRSParams) else DRSParams()
    threshold = p.gap_closed + 0.05 * (p.gap_open - p.gap_closed)
    dt = result["dt"]
    k0 = int(round(fault.sim_time / dt))
    states = result["states"]
    closed = [k for k in sorted(states) if k > k0 and states[k][3] <= threshold]
    return {
        "fault_sim_time_s": fault.sim_time,
        "gap_at_fault_m": states[k0][3],
        "closing_time_s": (closed[0] - k0) * dt if closed else None,
        "rerun_exact": all(r["max_deviation"] == 0.0 for r in rows),
        "chambers_after_fault": chambers_after(run, model, k0, max(states)),
    }


def chambers_after(run, model, k0: int, k_end: int) -> dict | None:
    """Each chamber's lowest pressure [Pa] and the time [s] it spends with a vapour cavity open
    (at the vapour pressure), from the fault's step to the run's last, at every physics step of
    a second re-run of the bag (None for a rung without chambers)."""
    from drs_ros.bag.replay.rerun import resimulate

    rerun = resimulate(run, model)
    sim = rerun["sim"]
    if not hasattr(sim, "chamber_pressures"):
        return None
    rows = []
    for k in range(k_end + 1):
        rerun["state_at"](k)
        if k >= k0:
            rows.append((*sim.chamber_pressures(), *sim.cavity_volumes()))
    pa, pb, cav_a, cav_b = zip(*rows, strict=True)
    dt = rerun["dt"]
    return {
        "lowest_pressure_a_pa": min(pa),
        "lowest_pressure_b_pa": min(pb),
        "time_at_floor_a_s": dt * sum(c > 0.0 for c in cav_a),
        "time_at_floor_b_s": dt * sum(c > 0.0 for c in cav_b),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ramp", type=float, default=0.0, help="supply loss ramp [s]")
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", 0)))
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args()
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    out = {"ramp_s": args.ramp, "rungs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for rung in RUNGS:
            bag = Path(tmp) / rung
            answer = run_node(rung, bag, args.ramp, args.domain)
            row = dict(answer)
            if answer["successful"]:
                row.update(closing_time(bag))
            out["rungs"][rung] = row
            if not args.json:
                print(rung, row)
        answer = run_node("kinematic", Path(tmp) / "kinematic", args.ramp, args.domain)
        out["rungs"]["kinematic"] = answer
        if not args.json:
            print("kinematic", answer)
    name = "failsafe_node.json" if args.ramp == 0.0 else f"failsafe_node_ramp{args.ramp:g}s.json"
    results = ROOT / "benchmarks" / "results" / name
    results.write_text(json.dumps(out, indent=2) + "\n")
    if args.json:
        print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
