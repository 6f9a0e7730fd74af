"""Replay benchmark: how exactly and how fast can ``drs-bag play`` replay a bag?

Plays a bag (``bags/example`` by default) with ``python -m drs_ros.bag.replay.play`` at a series of
``--rate`` values while a raw subscriber in this process (reliable, keep last 10000, one
subscription per topic, loopback-only DDS on its own domain) counts what arrives. It reports:

* the player's timing error: publish time minus scheduled time, per message, measured inside the
  player (its hidden ``--stats-json`` option), median, p99 and max [ms];
* per rate: messages expected and received, the loss, and the message rate achieved;
* the highest rate at which every message arrived (the rates stop after the first loss);

each for two publisher profiles side by side: the recorded offer as rosbag2 adapts it (keep last
10) and keep last 1000 (``--qos-profile-overrides-path``).

Usage: ``python benchmarks/replay.py [--bag bags/example] [--rates 1,2,5,10,20,50,100]
[--domain 195] [--json benchmarks/results/replay.json]`` (about a minute).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def recorded_counts(bag: Path) -> tuple[dict[str, str], dict[str, int]]:
    """Topic types and message counts, from the bag's summary (mcap's reader)."""
    from mcap.reader import make_reader

    path = next(bag.glob("*.mcap")) if bag.is_dir() else bag
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    types = {ch.topic: summary.schemas[ch.schema_id].name for ch in summary.channels.values()}
    counts = {
        summary.channels[cid].topic: n
        for cid, n in summary.statistics.channel_message_counts.items()
    }
    return types, {t: counts.get(t, 0) for t in types}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def play_once(bag, rate, sub, executor, expected, env, stats, extra=()):
    """One play at ``rate`` (``extra`` player options); returns a result row."""
    for lst in sub.values():
        lst.clear()
    cmd = [
        sys.executable,
        "-m",
        "drs_ros.bag.replay.play",
        str(bag),
        "--rate",
        f"{rate:g}",
        "--wait-for-subscribers",
        "--wait-for-all-acked",
        "2000",
        "--stats-json",
        str(stats),
        *extra,
    ]
    proc = subprocess.Popen(cmd, env=env, stderr=subprocess.PIPE, text=True)
    while proc.poll() is None:
        executor.spin_once(timeout_sec=0.01)
    grace = time.monotonic() + 1.0  # what is still queued in this process
    while time.monotonic() < grace and sum(map(len, sub.values())) < expected:
        executor.spin_once(timeout_sec=0.01)
    err = proc.stderr.read()
    if proc.returncode != 0:
        raise SystemExit(f"play failed ({proc.returncode}): {err}")
    received = sum(map(len, sub.values()))
    data = json.loads(stats.read_text())
    offsets = data["offsets"]
    late_ms = [(actual - scheduled) * 1e3 for scheduled, actual in offsets]
    span = offsets[-1][1] - offsets[0][1] if len(offsets) > 1 else float("nan")
    return {
        "rate": rate,
        "expected": expected,
        "published": data["published"],
        "received": received,
        "lost": expected - received,
        "play_s": span,
        "msgs_per_s": (len(offsets) - 1) / span if span > 0 else float("nan"),
        "late_p50_ms": statistics.median(late_ms),
        "late_p99_ms": percentile(late_ms, 99),
        "late_max_ms": max(late_ms),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bag", default=str(ROOT / "bags" / "example"))
    ap.add_argument("--rates", default="1,2,5,10,20,50,100")
    ap.add_argument("--domain", type=int, default=195)
    ap.add_argument("--json", default=None, help="write the rows as JSON here")
    args = ap.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    tmp = Path(tempfile.mkdtemp(prefix="drs-replay-"))
    os.environ.setdefault("ROS_LOG_DIR", str(tmp / "ros-log"))
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from drs_ros.recording.msgdefs import message_class

    bag = Path(args.bag)
    types, counts = recorded_counts(bag)
    expected = sum(counts.values())
    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain), PYTHONPATH=str(ROOT))
    ctx = Context()
    rclpy.init(context=ctx, domain_id=args.domain)
    node = rclpy.create_node("replay_bench", context=ctx)
    qos = QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE)  # never the limit
    sub: dict[str, list] = {}
    for topic, type_name in types.items():
        sub[topic] = []
        node.create_subscription(message_class(type_name), topic, sub[topic].append, qos, raw=True)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    overrides = tmp / "overrides.yaml"
    overrides.write_text("".join(f"{t}:\n  depth: 1000\n" for t in types))
    profiles = {
        "recorded (keep last 10)": (),
        "keep last 1000": ("--qos-profile-overrides-path", str(overrides)),
    }
    rows = []
    try:
        for qos_name, extra in profiles.items():
            for rate in (float(r) for r in args.rates.split(",")):
                row = play_once(bag, rate, sub, executor, expected, env, tmp / "s.json", extra)
                rows.append({"qos": qos_name, **row})
                if row["lost"]:
                    break
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
    print(f"bag {bag}: {expected} messages, {len(types)} topics; {os.cpu_count()} cores")
    print(
        f"{'rate':>6} {'received':>9} {'lost':>5} {'play s':>7} {'msg/s':>7} "
        f"{'late p50 ms':>11} {'p99 ms':>7} {'max ms':>7}"
    )
    for qos_name in profiles:
        series = [r for r in rows if r["qos"] == qos_name]
        print(f"-- publisher QoS: {qos_name}")
        for r in series:
            print(
                f"{r['rate']:>6g} {r['received']:>9} {r['lost']:>5} {r['play_s']:>7.2f} "
                f"{r['msgs_per_s']:>7.0f} {r['late_p50_ms']:>11.3f} {r['late_p99_ms']:>7.2f} "
                f"{r['late_max_ms']:>7.2f}"
            )
        lossless = [r["rate"] for r in series if not r["lost"]]
        best = max(lossless) if lossless else "none"
        tail = "" if series[-1]["lost"] else " (no loss at any rate tried)"
        print(f"   highest rate with every message received: {best}{tail}")
    if args.json:
        Path(args.json).write_text(json.dumps({"bag": str(bag), "rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
