"""Node rate benchmark: CPU and missed deadlines of the drs node, executors side by side.

Each configuration runs ``drs-node`` as its own process (loopback-only DDS, 1 kHz physics,
recording MCAP and rerun) for ``--duration`` wall seconds while a driver in this process opens
and closes the flap through the service and sends stroke and force commands every 100 ms. The
node's CPU is read from ``/proc/<pid>/stat`` (user + system) over the measured window, so the
driver is not counted. The node's own diagnostics give its ticks, missed deadlines (a tick later
than 1.5 periods) and its CPU split per publish cycle (model, publish, recording; the rest is the
executor, DDS and the recorders' threads).

Configurations, measured in one run: ``single`` (today's SingleThreadedExecutor with a 250 Hz
timer) and ``deadline`` (ticks on absolute deadlines, executor thread for the rest) at 250 Hz,
interleaved over ``--rounds`` repeats (the median is quoted: the cores are shared), then
``deadline`` at 100, 500 and 1000 Hz publish. Then the recorder's cost per message (exact
CDR + MCAP write) against rclpy's serialize_message + a bare mcap writer, and the bytes per
message of both serialisations.

``--stress``: the deadline loop at 1 kHz publish, idle, beside two busy processes (one per
core), and under a 10 kHz stroke-command flood from another process, interleaved.

Usage: ``python benchmarks/node_rate.py [--duration 12] [--rounds 3] [--quick]
[--trajectory | --tf-cost | --stress]``
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User + system CPU of a process so far [s]."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def thread_cpu_seconds(pid: int) -> dict[str, float]:
    """User + system CPU so far [s] of each of a process's threads, summed by the thread's
    name as the kernel knows it (``/proc/<pid>/task/<tid>/comm``; the node's own threads are
    named, ``drs_ros.threads``), the main thread (the node's ticks) as ``main``. A thread that
    ended meanwhile is not counted."""
    out: dict[str, float] = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            name = (task / "comm").read_text().strip()
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # the thread ended between the listing and the read
            continue
        name = "main" if task.name == str(pid) else name
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / CLK_TCK
    return out


def stop_node(proc: subprocess.Popen, timeout_s: float = 30.0) -> None:
    """SIGINT to a node (it finishes its recordings), killed if it has not ended in
    ``timeout_s`` [s]."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()


def big_trajectory(n: int = 10_000, span_s: float = 5.0):
    """The largest trajectory the node takes: ``n`` points of a 2 Hz sine of the stroke over
    ``span_s`` [s], ending at rest at its start (mid-stroke)."""
    import numpy as np
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from drs_model.kinematics import stroke_limits
    from drs_model.params import DRSParams

    lo, hi = stroke_limits(DRSParams())
    t = span_s * np.arange(1, n + 1) / n
    s = 0.5 * (lo + hi) + 0.3 * (hi - lo) * np.sin(2 * np.pi * 2.0 * t)
    s[-1] = 0.5 * (lo + hi)
    msg = JointTrajectory(joint_names=["drs_piston", "drs_link", "drs_flap"])
    for tk, sk in zip(t, s, strict=True):
        sec, ns = divmod(int(round(tk * 1e9)), 10**9)
        msg.points.append(
            JointTrajectoryPoint(
                positions=[float(sk), 0.0, 0.0], time_from_start=Duration(sec=sec, nanosec=ns)
            )
        )
    return msg


def measure(
    executor: str,
    publish_hz: float,
    duration: float,
    domain: int,
    tmp: Path,
    load: str = "commands",
    node_args: tuple[str, ...] = (),
    observe=None,
) -> dict:
    """One run. ``load``: ``commands`` (open, close, stroke, force, one every 100 ms) or
    ``trajectory`` (a 10,000-point trajectory every second, each replacing the last).
    ``node_args``: more ``name:=value`` parameters of the node. ``observe(pid)``, if given, is
    called with the node's pid as the measured window opens and returns what to call as it
    closes (a profiler's start and stop)."""
    from drs_ros.client import DRSClient

    out = tmp / f"{executor}-{publish_hz:g}-{load}"
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "drs_ros",
            "--ros-args",
            "-p",
            f"executor:={executor}",
            "-p",
            f"publish_rate_hz:={publish_hz}",
            "-p",
            f"bag_path:={out / 'bag'}",
            "-p",
            f"rrd_path:={out / 'run.rrd'}",
            *[a for v in node_args for a in ("-p", v)],
        ],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    driver = DRSClient(domain, listen=("joint_states", "diagnostics"), client_name="bench_driver")
    big = big_trajectory() if load == "trajectory" else None
    try:
        driver.wait_for(lambda: driver.seen["joint_states"] >= 50 and driver.seen["diag"])
        first = dict(driver.seen["diag"] or {})
        wall0, cpu0 = time.monotonic(), cpu_seconds(proc.pid)
        closing = observe(proc.pid) if observe is not None else None
        k = 0
        while time.monotonic() - wall0 < duration:
            step = k % 5
            if big is not None:
                if k % 10 == 0:
                    driver.trajectory(big)
            elif step in (0, 1):
                driver.request_drs(step == 0)  # open, then close; the answer is not awaited
            elif step == 2:
                driver.stroke(0.02)
            else:
                driver.force(1500.0 if step == 3 else 0.0)
            k += 1
            driver.spin(0.1)
        if closing is not None:
            closing()
        driver.spin(1.1)  # one more diagnostics message
        wall, cpu = time.monotonic() - wall0, cpu_seconds(proc.pid) - cpu0
        last = dict(driver.seen["diag"] or {})
    finally:
        stop_node(proc)
        driver.close()

    def delta(key: str, cast=float) -> float:
        return cast(last[key]) - cast(first[key])

    ticks = max(delta("ticks", int), 1)
    stats = {
        "executor": executor,
        "load": load,
        "publish_rate_hz": publish_hz,
        "wall_s": wall,
        "cpu_share_of_core": cpu / wall,
        "ticks": ticks,
        "missed_deadlines": delta("missed_deadlines", int),
        "dropped_steps": delta("dropped_steps", int),
        "exit_code": proc.returncode,
        # since the node's start (a histogram has no window); deadline executor only
        "tick_policy": last.get("tick_policy", "?"),
        **{
            f"lateness_{q}_us": float(last.get(f"tick_lateness_{q}_us", "nan"))
            for q in ("p50", "p99", "max")
        },
    }
    stats["missed_share"] = stats["missed_deadlines"] / ticks
    split = 0.0
    for key in ("model", "publish", "record"):
        seconds = delta(f"cpu_{key}_s")
        split += seconds
        stats[f"us_per_cycle_{key}"] = 1e6 * seconds / ticks
    # cpu of the diagnostics window is cut at its own edges: scale the rest to the measured span
    stats["us_per_cycle_rest"] = 1e6 * (cpu - split) / (ticks * wall / max(wall - 1.1, 1e-9))
    return stats


def recorder_cost(n: int, repeats: int, tmp: Path) -> dict[str, float]:
    """Per-message CPU of the node's recording route (exact CDR + McapRecorder.write of the
    bytes) against rclpy's serialize_message + a bare mcap writer; bytes per message of both."""
    from builtin_interfaces.msg import Duration
    from mcap.writer import Writer
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from drs_model.inverse import REACTION_NAMES
    from drs_ros.recording import cdr
    from drs_ros.recording.mcap_recorder import McapRecorder
    from drs_ros.recording.msgdefs import full_definition

    msg = JointState()
    msg.name = ["drs_piston", "drs_link", "drs_flap"]
    msg.position, msg.velocity, msg.effort = [0.01, 0.1, 0.9], [1.0, 2.0, 3.0], [1e3, 0.0, 0.0]
    ours, bare = [], []
    serialize = cdr.serializer(JointState)
    for r in range(repeats):
        with McapRecorder(tmp / f"ours{r}", flush_thread=False) as rec:
            rec.register_topic("/joint_states", JointState, 10)
            t0 = time.process_time()
            for k in range(n):
                rec.write("/joint_states", serialize(msg), log_time_ns=k)
            ours.append((time.process_time() - t0) / n)
        with open(tmp / f"bare{r}.mcap", "wb") as f:
            w = Writer(f)
            w.start(profile="ros2", library="bench")
            sid = w.register_schema(
                "sensor_msgs/msg/JointState", "ros2msg", full_definition(JointState).encode()
            )
            cid = w.register_channel("/joint_states", "cdr", sid)
            t0 = time.process_time()
            for k in range(n):
                w.add_message(cid, log_time=k, data=serialize_message(msg), publish_time=k)
            bare.append((time.process_time() - t0) / n)
            w.finish()
    traj = JointTrajectory(
        joint_names=["drs_piston"],
        points=[
            JointTrajectoryPoint(positions=[0.03], time_from_start=Duration(nanosec=20_000_000)),
            JointTrajectoryPoint(positions=[0.01], time_from_start=Duration(nanosec=40_000_000)),
        ],
    )
    reactions = JointState(name=list(REACTION_NAMES), effort=[1.0] * len(REACTION_NAMES))
    o, b = statistics.median(ours), statistics.median(bare)
    return {
        "ours_us_per_msg": 1e6 * o,
        "bare_us_per_msg": 1e6 * b,
        "ratio": o / b,
        "trajectory_bytes_rclpy": len(serialize_message(traj)),
        "trajectory_bytes_exact": len(cdr.serializer(JointTrajectory)(traj)),
        "reactions_bytes_rclpy": len(serialize_message(reactions)),
        "reactions_bytes_exact": len(serialize(reactions)),
    }


FLOOD = """
import os, sys, time, rclpy
from std_msgs.msg import Float64
rclpy.init()
node = rclpy.create_node("bench_flood")
pub = node.create_publisher(Float64, "/drs/stroke_cmd", 10)
period = 1.0 / float(sys.argv[1])
lo, hi = float(sys.argv[2]), float(sys.argv[3])
deadline, k = time.perf_counter(), 0
while True:
    deadline += period
    pub.publish(Float64(data=lo if k % 2 else hi))
    k += 1
    wait = deadline - time.perf_counter()
    if wait > 0:
        time.sleep(wait)
    elif wait < -0.1:
        deadline = time.perf_counter()
"""


def background(kind: str, domain: int) -> list[subprocess.Popen]:
    """What else runs during a measurement: ``idle`` (nothing), ``hogs`` (two busy processes,
    one per core) or ``flood`` (stroke commands at 10 kHz from another process)."""
    if kind == "hogs":
        return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
    if kind == "flood":
        from drs_model.kinematics import stroke_limits
        from drs_model.params import DRSParams

        lo, hi = stroke_limits(DRSParams())
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
        return [
            subprocess.Popen(
                [
                    sys.executable,
                    "-c",
                    FLOOD,
                    "10000",
                    str(0.2 * hi + 0.8 * lo),
                    str(0.8 * hi + 0.2 * lo),
                ],
                env=env,
            )
        ]
    return []


def median_run(runs: list[dict]) -> dict:
    """The run with the median CPU share of repeats of one configuration (noise: shared cores)."""
    runs = sorted(runs, key=lambda r: r["cpu_share_of_core"])
    out = dict(runs[len(runs) // 2])
    out["cpu_share_runs"] = [r["cpu_share_of_core"] for r in runs]
    out["missed_share_runs"] = [r["missed_share"] for r in runs]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=12.0, help="wall seconds per run")
    ap.add_argument(
        "--rounds",
        type=int,
        default=3,
        help="repeats of single and deadline at 250 Hz, interleaved (median quoted)",
    )
    ap.add_argument("--quick", action="store_true", help="5 s per run, 1 round")
    ap.add_argument(
        "--trajectory",
        action="store_true",
        help="only: deadline at 250 Hz under the command cycle and under a "
        "10,000-point trajectory a second, interleaved",
    )
    ap.add_argument(
        "--tf-cost",
        action="store_true",
        help="only: deadline at 250 Hz under the command cycle with publish_tf true (/tf at each "
        "joint state: tf_rate_hz 2000) and false, interleaved (what /tf costs)",
    )
    ap.add_argument(
        "--stress",
        action="store_true",
        help="only: deadline at 1 kHz idle, beside two busy processes and under a 10 kHz "
        "command flood, interleaved",
    )
    ap.add_argument("--domain", type=int, default=91)
    ap.add_argument("--json", default="benchmarks/results/node_rate.json")
    args = ap.parse_args(argv)
    duration, rounds = (5.0, 1) if args.quick else (args.duration, args.rounds)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    by_config: dict[tuple, list[dict]] = {}
    plan = [("single", 250.0, "commands"), ("deadline", 250.0, "commands")] * rounds + [
        ("deadline", 100.0, "commands"),
        ("deadline", 500.0, "commands"),
        ("deadline", 1000.0, "commands"),
    ]
    if args.trajectory:
        plan = [("deadline", 250.0, "commands"), ("deadline", 250.0, "trajectory")] * rounds
    if args.tf_cost:
        plan = [
            ("deadline", 250.0, "commands", ("publish_tf:=true", "tf_rate_hz:=2000.0")),
            ("deadline", 250.0, "commands", ("publish_tf:=false",)),
        ] * rounds
    if args.stress:
        plan = [
            ("deadline", 1000.0, "commands", (), beside) for beside in ("idle", "hogs", "flood")
        ] * rounds
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        os.environ.setdefault("ROS_LOG_DIR", str(tmp / "log"))
        for k, (executor, hz, load, *more) in enumerate(plan):
            node_args = more[0] if more else ()
            beside = more[1] if len(more) > 1 else "idle"
            others = background(beside, args.domain)
            try:
                r = measure(executor, hz, duration, args.domain, tmp / str(k), load, node_args)
            finally:
                for proc in others:
                    proc.kill()
                    proc.wait()
            r["node_args"], r["beside"] = list(node_args), beside
            by_config.setdefault((executor, hz, load, node_args, beside), []).append(r)
            print(
                f"{executor:>8} {hz:6.0f} Hz, {load:>10} {' '.join(node_args)} ({beside}): CPU "
                f"{100 * r['cpu_share_of_core']:5.1f} % of a core, missed "
                f"{r['missed_deadlines']}/{r['ticks']} "
                f"({100 * r['missed_share']:.2f} %), per cycle: model "
                f"{r['us_per_cycle_model']:.0f} us, publish {r['us_per_cycle_publish']:.0f} us, "
                f"record {r['us_per_cycle_record']:.0f} us, rest {r['us_per_cycle_rest']:.0f} us;"
                f" lateness p50/p99/max {r['lateness_p50_us']:.0f}/{r['lateness_p99_us']:.0f}/"
                f"{r['lateness_max_us']:.0f} us ({r['tick_policy']})",
                flush=True,
            )
        write = recorder_cost(20000, 5, tmp) if not args.stress else None
    rows = [median_run(runs) for runs in by_config.values()]
    if args.stress:
        for r in rows:
            print(
                f"deadline 1 kHz {r['beside']:>5}: CPU {100 * r['cpu_share_of_core']:.1f} % of "
                f"a core, missed {100 * r['missed_share']:.2f} %, lateness p99 "
                f"{r['lateness_p99_us']:.0f} us, max {r['lateness_max_us']:.0f} us"
            )
        out = Path(args.json).with_name("node_rate_stress.json")
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({"runs": rows}, indent=2))
        print(f"wrote {out}")
        return 0
    if args.tf_cost:
        on, off = rows
        share_on, share_off = on["cpu_share_of_core"], off["cpu_share_of_core"]
        per_cycle_us = 1e6 * (share_on - share_off) / 250.0
        print(
            f"deadline 250 Hz, medians of {rounds}: publish_tf true {100 * share_on:.1f} %, "
            f"false {100 * share_off:.1f} % of a core: /tf costs {per_cycle_us:.0f} us of CPU "
            "a publish cycle"
        )
        out = Path(args.json).with_name("node_rate_tf.json")
        out.write_text(json.dumps({"runs": rows}, indent=2))
        print(f"wrote {out}")
        return 0
    if args.trajectory:
        for r in rows:
            print(
                f"deadline 250 Hz under {r['load']}: missed deadlines per run "
                f"{[round(100 * x, 2) for x in r['missed_share_runs']]} %, CPU per run "
                f"{[round(100 * x, 1) for x in r['cpu_share_runs']]} % of a core"
            )
        out = Path(args.json).with_name("node_rate_trajectory.json")
        out.write_text(json.dumps({"runs": rows}, indent=2))
        print(f"wrote {out}")
        return 0
    single, deadline = rows[0], rows[1]
    ratio = single["cpu_share_of_core"] / deadline["cpu_share_of_core"]
    print(
        f"\nmedians of {rounds} interleaved runs at 250 Hz publish: single "
        f"{100 * single['cpu_share_of_core']:.1f} %, deadline "
        f"{100 * deadline['cpu_share_of_core']:.1f} % of a core (ratio {ratio:.2f}x); missed "
        f"{100 * single['missed_share']:.2f} % and {100 * deadline['missed_share']:.2f} % "
        f"(target: deadline <= 15 % of a core, <= 0.1 % missed)"
    )
    print(
        f"recorder: exact CDR + write {write['ours_us_per_msg']:.1f} us/msg, rclpy "
        f"serialize_message + bare mcap {write['bare_us_per_msg']:.1f} us/msg "
        f"(ratio {write['ratio']:.2f})"
    )
    print(
        f"bytes per message, rclpy serialize_message -> exact: trajectory (2 points) "
        f"{write['trajectory_bytes_rclpy']} -> {write['trajectory_bytes_exact']}, reactions "
        f"{write['reactions_bytes_rclpy']} -> {write['reactions_bytes_exact']}"
    )
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(
        json.dumps({"runs": rows, "single_over_deadline": ratio, "recorder": write}, indent=2)
    )
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
