"""What one command costs the node's real-time tick, and what one effect record or diagnostics
message costs to serialise: the message form (rclpy objects walked by ``cdr.serializer``)
beside the direct packer (``diagnostic_cdr``) that the node uses, in one run.

* serialise: an effect record of an accepted stroke command, and diagnostics with the node's own
  ~40 key/values, each both ways (the same bytes, checked), interleaved blocks, median per call;
* apply: a real :class:`~drs_ros.node.DRSNode` in this process (``tick_timer=False``, its MCAP bag
  recorded into a temporary directory) receives a stroke command through its intake (the executor
  thread's work) and applies it (``apply_pending``, the tick's work: the move planned and checked,
  its effect record packed, published and recorded); then two commands per step, the older one
  superseded (one more record). ``command_stroke`` is the actuator's share.

Thread CPU time (``time.thread_time_ns``), median of ``--rounds`` blocks of ``--n`` calls.

Usage: ``python benchmarks/command_cost.py [--n 1000] [--rounds 7] [--domain 0] [--json]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def per_call_us(fn, n: int) -> float:
    t0 = time.thread_time_ns()
    for _ in range(n):
        fn()
    return (time.thread_time_ns() - t0) / n / 1e3


def interleaved(fns: dict, n: int, rounds: int) -> dict[str, float]:
    """Median per call [us] of each of ``fns``, their blocks interleaved."""
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            times[name].append(per_call_us(fn, n))
    return {name: statistics.median(v) for name, v in times.items()}


def serialise_costs(n: int, rounds: int) -> dict[str, float]:
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

    from drs_ros.conversions import command_event_status, diagnostic_array_msg, diagnostics_status
    from drs_ros.recording import cdr
    from drs_ros.recording.diagnostic_cdr import diagnostic_array_cdr

    serialize = cdr.serializer(DiagnosticArray)
    stamp = time.time_ns()
    record = {
        "sim_time": repr(12.345),
        "step": 12345,
        "sequence": 17,
        "received_ns": stamp,
        "value": repr(0.0461),
    }
    values = {f"value_{k}": f"{k * 1.2345:.6g}" for k in range(40)}

    def event():
        return [
            command_event_status("/drs/stroke_cmd", "accepted", DiagnosticStatus.OK, "", record)
        ]

    def diag():
        return [diagnostics_status("drs", DiagnosticStatus.OK, "mode stroke", values)]

    fns = {
        "effect record: message + serializer": lambda: serialize(
            diagnostic_array_msg(stamp, event())
        ),
        "effect record: packed": lambda: diagnostic_array_cdr(stamp, event()),
        "diagnostics: message + serializer": lambda: serialize(diagnostic_array_msg(stamp, diag())),
        "diagnostics: packed": lambda: diagnostic_array_cdr(stamp, diag()),
    }
    for a, b in (list(fns.values())[:2], list(fns.values())[2:]):
        assert a() == b(), "the packer's bytes differ from the serializer's"
    return interleaved(fns, n, rounds)


def apply_costs(n: int, rounds: int, domain: int) -> dict[str, float]:
    import rclpy
    from rclpy.parameter import Parameter
    from std_msgs.msg import Float64

    from drs_ros.node import DRSNode
    from drs_ros.recording import cdr

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    tmp = Path(tempfile.mkdtemp(prefix="command_cost_"))
    node = DRSNode(
        context=ctx,
        tick_timer=False,
        parameter_overrides=[
            Parameter("physics_rate_hz", value=1000.0),
            Parameter("publish_rate_hz", value=1000.0),
            Parameter("bag_path", value=str(tmp / "bag")),
        ],
    )
    try:
        pack = cdr.flat_packer(Float64)
        lo, hi = node.sim.s_min, node.sim.s_max
        node.tick()
        flip = [0]

        def target() -> float:
            flip[0] += 1
            return hi if flip[0] % 2 else lo

        def receive_apply(commands: int) -> None:
            for _ in range(commands):
                node.intake.receive("stroke_cmd", pack(target()))
            with node._lock:
                node.intake.apply_pending(node._now_ns())

        def stroke():
            node.sim.command_stroke(target())

        out = interleaved(
            {
                "receive + apply, 1 command": lambda: receive_apply(1),
                "receive + apply, 2 (1 superseded)": lambda: receive_apply(2),
                "command_stroke (the actuator's)": stroke,
            },
            n,
            rounds,
        )
        # the tick's share apart: apply_pending of one waiting command
        t_apply = []
        for _ in range(rounds * n):
            node.intake.receive("stroke_cmd", pack(target()))
            t0 = time.thread_time_ns()
            with node._lock:
                node.intake.apply_pending(node._now_ns())
            t_apply.append(time.thread_time_ns() - t0)
        out["apply_pending, 1 command (tick)"] = statistics.median(t_apply) / 1e3
        return out
    finally:
        node.close_recordings()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    out = serialise_costs(args.n, args.rounds)
    out.update(apply_costs(args.n, args.rounds, args.domain))
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for name, us in out.items():
        print(f"{name:<40} {us:8.1f} us")


if __name__ == "__main__":
    main()
