"""Node rate benchmark: does the node hold its physics rate while recording MCAP and rerun?

Runs the drs node in this process (SingleThreadedExecutor, loopback-only DDS) for ``--duration``
seconds of wall time while a driver node opens and closes the flap through the service and sends
stroke and force commands. It reports:

* physics steps vs wall time, publish ticks, missed publish deadlines (a tick later than 1.5
  periods) as a share of ticks, and steps dropped after stalls;
* CPU per publish cycle, split into model (physics steps), publish (message build + rclpy
  publish), recording (MCAP + rerun) and the rest (executor, timers, the driver);
* the MCAP write cost per message of our recorder against a bare ``serialize_message`` + mcap
  ``Writer.add_message`` baseline, measured side by side in the same run.

Usage: ``python benchmarks/node_rate.py [--duration 60] [--physics-rate 1000] [--publish-rate 250]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path


def run_node(duration: float, physics_hz: float, publish_hz: float, out: Path, domain: int):
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from std_msgs.msg import Float64
    from std_srvs.srv import SetBool

    from drs_ros.node import DRSNode

    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = DRSNode(
        context=ctx,
        parameter_overrides=[
            Parameter("physics_rate_hz", value=float(physics_hz)),
            Parameter("publish_rate_hz", value=float(publish_hz)),
            Parameter("bag_path", value=str(out / "bag")),
            Parameter("rrd_path", value=str(out / "run.rrd")),
        ],
    )
    driver = Node("bench_driver", context=ctx)
    client = driver.create_client(SetBool, "/drs/drs")
    stroke = driver.create_publisher(Float64, "/drs/stroke_cmd", 10)
    force = driver.create_publisher(Float64, "/drs/force_cmd", 10)
    phase = {"k": 0}

    def scenario() -> None:  # every 100 ms: open, close, a stroke, a force step, close
        k = phase["k"] = phase["k"] + 1
        step = k % 5
        if step == 0:
            client.call_async(SetBool.Request(data=True))
        elif step == 1:
            client.call_async(SetBool.Request(data=False))
        elif step == 2:
            stroke.publish(Float64(data=0.02))
        elif step == 3:
            force.publish(Float64(data=1500.0))
        else:
            force.publish(Float64(data=0.0))

    driver.create_timer(0.1, scenario)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    ex.add_node(driver)
    client.wait_for_service(timeout_sec=5.0)
    wall0, cpu0 = time.monotonic(), time.process_time()
    sim0, ticks0 = node.sim.t, node.ticks
    end = wall0 + duration
    while time.monotonic() < end:
        ex.spin_once(timeout_sec=0.01)
    wall, cpu = time.monotonic() - wall0, time.process_time() - cpu0
    stats = {
        "duration_wall_s": wall,
        "sim_time_s": node.sim.t - sim0,
        "physics_rate_hz": physics_hz,
        "publish_rate_hz": publish_hz,
        "physics_steps_per_s": (node.sim.t - sim0) / node.physics_dt / wall,
        "ticks": node.ticks - ticks0,
        "missed_deadlines": node.missed_deadlines,
        "missed_share": node.missed_deadlines / max(node.ticks - ticks0, 1),
        "dropped_steps": node.dropped_steps,
        "refused": node.refused,
        "cpu_total_s": cpu,
        "cpu_share_of_core": cpu / wall,
        "cpu_model_s": node._cpu["model"],
        "cpu_publish_s": node._cpu["publish"],
        "cpu_record_s": node._cpu["record"],
    }
    ticks = max(node.ticks - ticks0, 1)
    for key in ("model", "publish", "record"):
        stats[f"us_per_cycle_{key}"] = 1e6 * node._cpu[key] / ticks
    rest = cpu - sum(node._cpu.values())
    stats["us_per_cycle_rest"] = 1e6 * rest / ticks
    node.close_recordings()
    ex.shutdown()
    driver.destroy_node()
    node.destroy_node()
    rclpy.try_shutdown(context=ctx)
    return stats


def mcap_write_cost(n: int, repeats: int, tmp: Path) -> dict[str, float]:
    """Per-message CPU of McapRecorder.write vs a bare serialize_message + mcap writer."""
    from mcap.writer import Writer
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from drs_ros.msgdefs import full_definition
    from drs_ros.recording import McapRecorder

    msg = JointState()
    msg.name = ["drs_piston", "drs_link", "drs_flap"]
    msg.position, msg.velocity, msg.effort = [0.01, 0.1, 0.9], [1.0, 2.0, 3.0], [1e3, 0.0, 0.0]
    ours, bare = [], []
    for r in range(repeats):
        with McapRecorder(tmp / f"ours{r}", flush_thread=False) as rec:
            rec.register_topic("/joint_states", JointState, 10)
            t0 = time.process_time()
            for k in range(n):
                rec.write("/joint_states", msg, log_time_ns=k)
            ours.append((time.process_time() - t0) / n)
        with open(tmp / f"bare{r}.mcap", "wb") as f:
            w = Writer(f)
            w.start(profile="ros2", library="bench")
            sid = w.register_schema("sensor_msgs/msg/JointState", "ros2msg",
                                    full_definition(JointState).encode())
            cid = w.register_channel("/joint_states", "cdr", sid)
            t0 = time.process_time()
            for k in range(n):
                w.add_message(cid, log_time=k, data=serialize_message(msg), publish_time=k)
            bare.append((time.process_time() - t0) / n)
            w.finish()
    o, b = statistics.median(ours), statistics.median(bare)
    return {"ours_us_per_msg": 1e6 * o, "bare_us_per_msg": 1e6 * b, "ratio": o / b}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="wall seconds (default 60)")
    ap.add_argument("--physics-rate", type=float, default=1000.0)
    ap.add_argument("--publish-rate", type=float, default=250.0)
    ap.add_argument("--domain", type=int, default=91)
    ap.add_argument("--json", default="benchmarks/results/node_rate.json")
    args = ap.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        os.environ.setdefault("ROS_LOG_DIR", str(tmp / "log"))
        node = run_node(args.duration, args.physics_rate, args.publish_rate, tmp, args.domain)
        write = mcap_write_cost(20000, 5, tmp)
    print(f"node: {node['duration_wall_s']:.1f} s wall, {node['sim_time_s']:.2f} s simulated, "
          f"{node['physics_steps_per_s']:.0f} physics steps/s (target {args.physics_rate:g})")
    print(f"  publish ticks {node['ticks']}, missed deadlines {node['missed_deadlines']} "
          f"({100 * node['missed_share']:.2f} %, target <= 1 %), dropped steps "
          f"{node['dropped_steps']}")
    print(f"  CPU {100 * node['cpu_share_of_core']:.1f} % of a core; per publish cycle: model "
          f"{node['us_per_cycle_model']:.0f} us, publish {node['us_per_cycle_publish']:.0f} us, "
          f"recording {node['us_per_cycle_record']:.0f} us, executor/rest "
          f"{node['us_per_cycle_rest']:.0f} us")
    print(f"mcap write: ours {write['ours_us_per_msg']:.1f} us/msg, bare serialize+mcap "
          f"{write['bare_us_per_msg']:.1f} us/msg, ratio {write['ratio']:.2f}")
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"node": node, "mcap_write": write}, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
