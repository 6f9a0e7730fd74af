"""The middleware's floor under the node's rate goals: what publishing the node's messages costs a
process that does nothing else, on this machine, with the pinned rclpy and Fast DDS.

A publisher process sleeps to absolute deadlines as the node's tick thread does
(``deadline_floor.DeadlineLoop``; SCHED_FIFO when allowed, through the node's own
``apply_tick_policy``) and at each deadline publishes the node's
per-tick messages as bytes serialised once (``Publisher.publish(bytes)``: no message building,
no packing, no model, no recording, no executor). A second process subscribes as the
``node_rate.py`` driver does (reliable, depth 10, to ``/joint_states``; ``--tf-subscribed`` adds
``/tf``, as RViz or robot_state_publisher's consumers would) and counts what it receives; a run
whose subscriber received fewer than the messages of the measured window (it may miss some of
the warm-up, before its side of the match) is marked so.

Configurations, interleaved over ``--rounds`` and quoted as medians: ``loop`` (the deadline loop
alone), ``joint_states`` (one JointState a tick), ``joint_states + /tf`` (and one TFMessage of
the three moving transforms, as the node published with ``publish_tf`` true before ``tf_rate_hz``
gave /tf its own rate, 100 Hz by default). The CPU share is
the publisher process's (all its threads: ``time.process_time``) over the measured window. The
rate goals for the whole node (1 kHz within 15 % of a core, 250 Hz within 6 %) are printed
beside: whatever this floor takes, the node's Python, recordings and executor add to it.

Usage: ``python benchmarks/middleware_floor.py [--rates 1000 250] [--duration 8] [--rounds 3]
[--tf-subscribed] [--domain 93]``
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

from deadline_floor import publish_on_deadlines  # the node's loop, counted as the node counts

RESULTS = Path(__file__).with_name("results") / "middleware_floor.json"
CONFIGS = ("loop", "joint_states", "joint_states + /tf")
GOALS = {1000.0: 0.15, 250.0: 0.06}  # the rate goals: the whole node's share of a core
BASE_FRAME = "drs_base"  # the node's frame_id by default


def node_messages() -> dict[str, bytes]:
    """The node's per-tick messages at the seed's closed stroke, serialised once: a JointState
    of its default joints and the TFMessage of their three moving transforms, built by the
    node's own description (``description.moving_transforms``, ``tf_tree.transform_msg``)."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    from drs_model import DRSParams
    from drs_model.kinematics import solve_position, stroke_limits
    from drs_ros.names import DEFAULT_JOINT_NAMES
    from drs_ros.stack import description
    from drs_ros.stack.tf_tree import transform_msg

    p = DRSParams()
    q = solve_position(stroke_limits(p)[0], p)
    states = JointState(
        name=list(DEFAULT_JOINT_NAMES),
        position=[float(v) for v in q],
        velocity=[0.0, 0.0, 0.0],
        effort=[0.0, 0.0, 0.0],
    )
    states.header.frame_id = BASE_FRAME
    frames = description.Frames.of(DEFAULT_JOINT_NAMES, BASE_FRAME)
    moving = description.moving_transforms(q, description.JointOrigins.of(p), frames)
    return {
        "/joint_states": serialize_message(states),
        "/tf": serialize_message(TFMessage(transforms=[transform_msg(t, 0) for t in moving])),
    }


def publisher(
    config: str, rate_hz: float, duration_s: float, warm_s: float, subscribed: list[str]
) -> dict:
    """The publisher process's loop: returns its CPU share and deadlines over the window (after
    ``warm_s`` [s] of warm-up, once the subscriber matched the ``subscribed`` topics)."""
    import rclpy
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    from drs_ros.publishing import create_publisher

    rclpy.init()
    node = rclpy.create_node("floor_publisher")
    messages = node_messages()
    made = {}
    if config != "loop":
        made["/joint_states"] = create_publisher(
            node, JointState, "/joint_states", QoSProfile(depth=10)
        )
    if config == "joint_states + /tf":
        made["/tf"] = create_publisher(node, TFMessage, "/tf", QoSProfile(depth=100))
    pubs = [(pub, messages[topic]) for topic, pub in made.items()]
    give_up = time.monotonic() + 20.0
    for topic in set(made) & set(subscribed):  # the subscriber in the other process matched
        while made[topic].get_subscription_count() < 1 and time.monotonic() < give_up:
            time.sleep(0.05)
    cpu, wall, loop, policy = publish_on_deadlines(pubs, rate_hz, warm_s, duration_s)
    node.destroy_node()
    rclpy.shutdown()
    return {
        "config": config,
        "rate_hz": rate_hz,
        "policy": policy,
        "cpu_share": cpu / wall,
        **loop.counts(),
        "published": loop.lateness.count if pubs else 0,  # a message a tick of the window
    }


def subscriber(topics: list[str]) -> None:
    """Count what arrives on ``topics`` until SIGTERM; print the counts as JSON."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    types = {"/joint_states": (JointState, 10), "/tf": (TFMessage, 100)}
    counts = dict.fromkeys(topics, 0)
    rclpy.init()
    node = rclpy.create_node("floor_subscriber")

    def counter(topic):
        def count(_data):
            counts[topic] += 1

        return count

    for topic in topics:
        msg_type, depth = types[topic]
        node.create_subscription(msg_type, topic, counter(topic), QoSProfile(depth=depth), raw=True)
    # rclpy's own handlers (SIGINT and SIGTERM) end the spin
    try:
        rclpy.spin(node)
    except (ExternalShutdownException, KeyboardInterrupt):
        pass
    print(json.dumps(counts), flush=True)


def run(config: str, rate_hz: float, duration_s: float, topics: list[str], env: dict) -> dict:
    """One publisher run beside its subscriber; the subscriber's counts are checked."""
    me = [sys.executable, __file__]
    sub = subprocess.Popen(
        [*me, "--role", "subscriber", "--topics", *topics],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        role = [
            "--role",
            "publisher",
            "--config",
            config,
            "--rates",
            str(rate_hz),
            "--duration",
            str(duration_s),
            "--topics",
            *topics,
        ]
        out = subprocess.run(
            [*me, *role], env=env, capture_output=True, text=True, check=True, timeout=120
        )
        result = json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        sub.send_signal(signal.SIGTERM)
        counts = json.loads(sub.communicate(timeout=30)[0].strip().splitlines()[-1])
    sent = {"loop": (), "joint_states": ("/joint_states",), "joint_states + /tf": topics}[config]
    expected = {t: result["published"] for t in sent}
    result["received"] = counts
    result["delivered"] = all(counts[t] >= n for t, n in expected.items())
    return result


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", type=float, nargs="+", default=[1000.0, 250.0], help="[Hz]")
    ap.add_argument("--duration", type=float, default=8.0, help="measured seconds a run")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved repeats")
    ap.add_argument("--tf-subscribed", action="store_true", help="the subscriber takes /tf too")
    ap.add_argument("--domain", type=int, default=93)
    ap.add_argument("--output", type=Path, default=RESULTS)
    ap.add_argument(
        "--role",
        choices=("main", "publisher", "subscriber"),
        default="main",
        help=argparse.SUPPRESS,
    )
    ap.add_argument("--config", choices=CONFIGS, help=argparse.SUPPRESS)
    ap.add_argument("--topics", nargs="*", default=[], help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.role == "publisher":
        print(json.dumps(publisher(args.config, args.rates[0], args.duration, 1.0, args.topics)))
        return 0
    if args.role == "subscriber":
        subscriber(args.topics)
        return 0
    env = dict(
        os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    topics = ["/joint_states", "/tf"] if args.tf_subscribed else ["/joint_states"]
    runs = []
    for k in range(args.rounds):
        for rate in args.rates:
            for config in CONFIGS:
                r = run(config, rate, args.duration, topics, env)
                runs.append(r)
                print(
                    f"round {k + 1} {rate:6g} Hz {config:>18}: {100 * r['cpu_share']:5.1f} % "
                    f"of a core, missed {100 * r['missed_share']:.2f} %, p99 "
                    f"{r['lateness_p99_us']:.0f} us, received {r['received']}"
                    f"{'' if r['delivered'] else ' (NOT all delivered)'}",
                    flush=True,
                )
    summary = {}
    for rate in args.rates:
        for config in CONFIGS:
            mine = [r for r in runs if r["rate_hz"] == rate and r["config"] == config]
            share = statistics.median(r["cpu_share"] for r in mine)
            summary[f"{rate:g} Hz {config}"] = share
            goal = GOALS.get(rate)
            beside = f" (the whole node's goal: {100 * goal:g} %)" if goal else ""
            print(f"{rate:6g} Hz {config:>18}: median {100 * share:5.1f} % of a core{beside}")
    out = {"subscribed": topics, "policy": runs[0]["policy"], "summary": summary, "runs": runs}
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
