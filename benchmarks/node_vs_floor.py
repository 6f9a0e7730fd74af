"""The node against the middleware's floor, measured in one run, interleaved.

The floor (``floor_process.py floor``): a bare process that publishes, at the node's rate, on
the node's deadlines and tick policy, exactly the messages the node hands DDS each tick (the
node's own publishers and serialisers; the topics a listener subscribes to), with the listener
(``floor_process.py listener``, a subscriber to each of those topics at the node's QoS) in
another process. The node: ``drs-node`` at 1 kHz physics publishing at the rate, both
recordings on (MCAP bag and rerun file), the same listener beside it and a command client in
this process at ~100 Hz (open, close, a stroke, a force and none, in turn). Rounds alternate
floor and node (``--rounds``, medians quoted). The CPU share of a core of each process is its
user + system time from ``/proc/<pid>/stat`` over the measured window, and the node's, thread
by thread (``/proc/<pid>/task``, by the names ``drs_ros.threads`` gives them); the node's missed
deadlines come from its diagnostics (a tick later than 1.5 periods; the lateness quantiles are
its histogram's since the start, ``drs_ros.node.tick_schedule``).

``--loads``: also the node under other command loads, in the same rounds (``none``: no command;
``drs``, ``stroke``, ``force``: one kind of command at ~100 Hz), to split the node's share
between its ticks and the commands it takes. ``--flood HZ``: also the node at 1 kHz with and
without a stroke-command flood at ``HZ`` from another process, interleaved; the missed
deadlines of each. ``--startup N``: exec of
``drs-node`` to its first ``/joint_states`` (median of ``N``), and where the imports' time goes
(``python -X importtime``, summed by top-level package). ``--env NAME=VALUE``: a variable for
the floor and the node of the ``profiled`` rounds, measured interleaved with the defaults (e.g.
a Fast DDS XML profile). ``--tick-cpu N``: the ``profiled`` rounds' node with ``tick_cpu:=N`` and
their floor's loop on CPU N.

Usage: ``python benchmarks/node_vs_floor.py [--rates 1000 250] [--duration 10] [--rounds 3]
[--listen joint_states ...] [--loads mix none drs stroke force] [--flood 10000] [--startup 5]
[--env NAME=VALUE ...] [--tick-cpu N]
[--domain 97] [--output benchmarks/results/node_vs_floor.json]``
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

from floor_process import STATE_ROLES
from node_rate import FLOOD, cpu_seconds, stop_node, thread_cpu_seconds
from node_startup import import_summary, node_command, startup_times

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "node_vs_floor.json"
#: The goal: the node's share within this many points of a core of the floor's, at most this
#: share of missed deadlines (1 kHz); at 250 Hz within 2 points and none missed.
GOALS = {1000.0: (0.04, 0.001), 250.0: (0.02, 0.0)}
PHYSICS_HZ = 1000.0
COMMAND_PERIOD_S = 0.01  # the command client's ~100 Hz


def start_listener(roles: list[str], env: dict) -> subprocess.Popen:
    """The listener process, returned once its subscriptions exist."""
    proc = subprocess.Popen(
        [sys.executable, str(HERE / "floor_process.py"), "listener", *roles],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    if "ready" not in line:
        proc.kill()
        raise RuntimeError(f"the listener did not start: {line!r}")
    return proc


#: How long [s] the listener is given after each SIGINT before it is sent another, then killed.
LISTENER_STOP_WAITS_S = (10.0, 20.0)


def stop_listener(proc: subprocess.Popen) -> dict[str, int]:
    """SIGINT the listener; what it received by topic. A listener still spinning 10 s after
    its SIGINT gets another (rclpy's spin once missed the first, 2026-11-29, and the run
    stopped on the timeout); one still there after 20 s more is killed, its counts lost
    (``{}``)."""
    for wait_s in LISTENER_STOP_WAITS_S:
        proc.send_signal(signal.SIGINT)
        try:
            out = proc.communicate(timeout=wait_s)[0].strip().splitlines()
        except subprocess.TimeoutExpired:
            continue
        return json.loads(out[-1])["received"] if out else {}
    proc.kill()
    proc.communicate()
    print("the listener did not stop on SIGINT: killed, its counts lost", file=sys.stderr)
    return {}


def floor_run(
    rate_hz: float, duration_s: float, roles: list[str], env: dict, tick_cpu: int = -1
) -> dict:
    """One floor run beside the listener (its thread on CPU ``tick_cpu``, -1: any)."""
    listener = start_listener(roles, env)
    try:
        cmd = [
            sys.executable,
            str(HERE / "floor_process.py"),
            "floor",
            str(rate_hz),
            str(duration_s),
            *(["--tick-cpu", str(tick_cpu)] if tick_cpu >= 0 else []),
            *roles,
        ]
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True, timeout=120)
        result = json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        received = stop_listener(listener)
    result.update(kind="floor", rate_hz=rate_hz, received=received)
    return result


#: The command client's commands (a ``~/drs`` call's answer is not awaited).
COMMANDS = {
    "open": lambda client: client.request_drs(True),
    "close": lambda client: client.request_drs(False),
    "stroke 20 mm": lambda client: client.stroke(0.02),
    "stroke 30 mm": lambda client: client.stroke(0.03),
    "force 1500 N": lambda client: client.force(1500.0),
    "force 0 N": lambda client: client.force(0.0),
}
#: What the client sends in turn, one command each ~10 ms (``--loads``): ``mix`` is the goal's
#: load; the others split its cost by kind of command (``none``: the client only listens).
LOADS = {
    "mix": ("open", "close", "stroke 20 mm", "force 1500 N", "force 0 N"),
    "none": (),
    "drs": ("open", "close"),
    "stroke": ("stroke 20 mm", "stroke 30 mm"),
    "force": ("force 1500 N", "force 0 N"),
}


def drive(client, duration_s: float, load: str = "mix") -> int:
    """The commands of ``load`` (:data:`LOADS`) in turn at ~100 Hz for ``duration_s`` [s]; how
    many were sent."""
    cycle = LOADS[load]
    k, t0 = 0, time.monotonic()
    while time.monotonic() - t0 < duration_s:
        if cycle:
            COMMANDS[cycle[k % len(cycle)]](client)
            k += 1
        client.spin(COMMAND_PERIOD_S)
    return k


def diag_delta(first: dict, last: dict, key: str) -> int:
    return int(last[key]) - int(first[key])


def node_run(
    rate_hz: float,
    duration_s: float,
    roles: list[str],
    env: dict,
    out: Path,
    domain: int,
    flood_hz: float | None = None,
    load: str = "mix",
    tick_cpu: int = -1,
) -> dict:
    """One run of the node beside the listener and the command client sending ``load`` (and
    the flood); ``tick_cpu`` >= 0: the node's ``tick_cpu``."""
    from drs_ros.client import DRSClient

    listener = start_listener(roles, env)
    flood = None
    if flood_hz:
        from drs_model.kinematics import stroke_limits
        from drs_model.params import DRSParams

        lo, hi = stroke_limits(DRSParams())
        strokes = (str(0.2 * hi + 0.8 * lo), str(0.8 * hi + 0.2 * lo))  # as node_rate's flood
        flood = subprocess.Popen([sys.executable, "-c", FLOOD, str(flood_hz), *strokes], env=env)
    params = {
        "physics_rate_hz": PHYSICS_HZ,
        "publish_rate_hz": rate_hz,
        "bag_path": out / "bag",
        "rrd_path": out / "run.rrd",
    }
    if tick_cpu >= 0:
        params["tick_cpu"] = tick_cpu
    args = [a for k, v in params.items() for a in ("-p", f"{k}:={v}")]
    node = subprocess.Popen(
        [*node_command(), "--ros-args", *args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    client = DRSClient(domain, listen=("diagnostics",), client_name="bench_commands")
    try:
        client.wait_for(lambda: client.seen["diag"] is not None)
        client.spin(1.0)  # warm-up: the listener matched, the first moves planned
        first = dict(client.seen["diag"] or {})
        wall0, cpu0 = time.monotonic(), cpu_seconds(node.pid)
        threads0 = thread_cpu_seconds(node.pid)
        sent = drive(client, duration_s, load)
        wall, cpu = time.monotonic() - wall0, cpu_seconds(node.pid) - cpu0
        threads = thread_cpu_seconds(node.pid)
        client.spin(1.1)  # one more diagnostics message
        last = dict(client.seen["diag"] or {})
    finally:
        stop_node(node)
        client.close()
        if flood is not None:
            flood.kill()
            flood.wait()
        received = stop_listener(listener)
    ticks = max(diag_delta(first, last, "ticks"), 1)
    missed = diag_delta(first, last, "missed_deadlines")
    return {
        "kind": "node",
        "rate_hz": rate_hz,
        "load": load,
        "flood_hz": flood_hz or 0,
        "cpu_share": cpu / wall,
        "thread_shares": {
            name: (seconds - threads0.get(name, 0.0)) / wall
            for name, seconds in sorted(threads.items())
            if seconds - threads0.get(name, 0.0) > 0.0
        },
        "ticks": ticks,
        "missed": missed,
        "missed_share": missed / ticks,
        "commands": sent,
        "exit_code": node.returncode,
        "received": received,
        "policy": last.get("tick_policy", "?"),
        **{
            f"lateness_{q}_us": float(last.get(f"tick_lateness_{q}_us", "nan"))
            for q in ("p50", "p99", "max")
        },
    }


def parse_env(pairs: list[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise SystemExit(f"--env takes NAME=VALUE, got {pair!r}")
        out[name] = value
    return out


def median_of(runs: list[dict], key: str) -> float:
    return statistics.median(r[key] for r in runs) if runs else float("nan")


def summarise(runs: list[dict], rates: list[float], variants: list[str]) -> list[dict]:
    """Per rate and variant: the medians of the floor and the node, their difference, the goal."""
    rows = []
    for rate in rates:
        for variant in variants:
            mine = [
                r
                for r in runs
                if r["rate_hz"] == rate
                and r["variant"] == variant
                and not r.get("flood_hz")
                and r.get("load", "mix") == "mix"
            ]
            floor = [r for r in mine if r["kind"] == "floor"]
            node = [r for r in mine if r["kind"] == "node"]
            points, missed = GOALS.get(rate, (float("nan"), float("nan")))
            row = {
                "rate_hz": rate,
                "variant": variant,
                "floor_cpu_share": median_of(floor, "cpu_share"),
                "node_cpu_share": median_of(node, "cpu_share"),
                "node_missed_share": median_of(node, "missed_share"),
                "floor_missed_share": median_of(floor, "missed_share"),
                "goal_points": points,
                "goal_missed_share": missed,
            }
            row["node_thread_shares"] = median_thread_shares(node)
            row["difference_points"] = row["node_cpu_share"] - row["floor_cpu_share"]
            row["meets_goal"] = row["difference_points"] <= points and (
                row["node_missed_share"] <= missed
            )
            rows.append(row)
    return rows


def median_thread_shares(runs: list[dict]) -> dict[str, float]:
    """Each thread name's median share of a core over ``runs`` (0 in a run without it)."""
    names = sorted({n for r in runs for n in r.get("thread_shares", {})})
    return {n: statistics.median(r["thread_shares"].get(n, 0.0) for r in runs) for n in names}


def print_table(rows: list[dict], rounds: int) -> None:
    print(f"\nmedians of {rounds} interleaved rounds (share of a core):")
    print(
        "| rate | variant | floor | node | node - floor | goal | floor missed | node missed "
        "| goal |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['rate_hz']:g} Hz | {r['variant']} | {100 * r['floor_cpu_share']:.1f} % | "
            f"{100 * r['node_cpu_share']:.1f} % | {100 * r['difference_points']:+.1f} | "
            f"<= {100 * r['goal_points']:g} | {100 * r['floor_missed_share']:.2f} % | "
            f"{100 * r['node_missed_share']:.2f} % | <= {100 * r['goal_missed_share']:g} % |"
        )
    for r in rows:
        threads = sorted(r["node_thread_shares"].items(), key=lambda kv: -kv[1])
        listed = ", ".join(f"{name} {100 * share:.1f}" for name, share in threads)
        print(f"node at {r['rate_hz']:g} Hz, {r['variant']}, by thread (% of a core): {listed}")


def print_run(r: dict) -> None:
    what = f"{r['kind']:>5} {r['rate_hz']:6g} Hz {r['variant']:>8}"
    if r.get("load", "mix") != "mix":
        what += f" load {r['load']}"
    if r.get("flood_hz"):
        what += f" flood {r['flood_hz']:g} Hz"
    print(
        f"{what}: {100 * r['cpu_share']:5.1f} % of a core, missed {r['missed']}/{r['ticks']} "
        f"({100 * r['missed_share']:.2f} %), lateness p99 {r['lateness_p99_us']:.0f} us, "
        f"received {r['received']}",
        flush=True,
    )


def plan_runs(args, variants: list[str]) -> list[tuple]:
    """(kind, rate, variant, flood Hz, load) in the order they run: floor and node alternate,
    then the node under each other load of ``--loads`` (the default variant)."""
    plan = []
    for _ in range(args.rounds):
        for rate in args.rates:
            for variant in variants:
                plan += [("floor", rate, variant, 0, "mix"), ("node", rate, variant, 0, "mix")]
            plan += [("node", rate, "default", 0, load) for load in args.loads if load != "mix"]
        if args.flood:
            plan += [
                ("node", PHYSICS_HZ, "default", 0, "mix"),
                ("node", PHYSICS_HZ, "default", args.flood, "mix"),
            ]
    return plan


def loads_summary(runs: list[dict], rows: list[dict], loads: list[str]) -> list[dict]:
    """Per rate and load (the default variant): the node's median share, by thread, its missed
    deadlines, and its difference with the floor of the same rounds."""
    out = []
    for row in (r for r in rows if r["variant"] == "default"):
        for load in loads:
            mine = [
                r
                for r in runs
                if r["kind"] == "node"
                and r["variant"] == "default"
                and r["rate_hz"] == row["rate_hz"]
                and r.get("load", "mix") == load
                and not r.get("flood_hz")
            ]
            share = median_of(mine, "cpu_share")
            out.append(
                {
                    "rate_hz": row["rate_hz"],
                    "load": load,
                    "runs": len(mine),
                    "node_cpu_share": share,
                    "node_thread_shares": median_thread_shares(mine),
                    "node_missed_share": median_of(mine, "missed_share"),
                    "difference_points": share - row["floor_cpu_share"],
                }
            )
    print("\nthe node by command load (medians; the floor of the same rounds):")
    print("| rate | load | node | node - floor | main | executor | missed |")
    print("|---|---|---|---|---|---|---|")
    for r in out:
        threads = r["node_thread_shares"]
        print(
            f"| {r['rate_hz']:g} Hz | {r['load']} | {100 * r['node_cpu_share']:.1f} % | "
            f"{100 * r['difference_points']:+.1f} | {100 * threads.get('main', 0.0):.1f} | "
            f"{100 * threads.get('drs-executor', 0.0):.1f} | "
            f"{100 * r['node_missed_share']:.2f} % |"
        )
    return out


def flood_summary(runs: list[dict], flood_hz: float) -> dict:
    at = [
        r
        for r in runs
        if r["kind"] == "node"
        and r["rate_hz"] == PHYSICS_HZ
        and r["variant"] == "default"
        and r.get("load", "mix") == "mix"
    ]
    quiet = [r for r in at if not r["flood_hz"]]
    flooded = [r for r in at if r["flood_hz"]]
    out = {
        "flood_hz": flood_hz,
        "missed_share_without": median_of(quiet, "missed_share"),
        "missed_share_with": median_of(flooded, "missed_share"),
        "cpu_share_without": median_of(quiet, "cpu_share"),
        "cpu_share_with": median_of(flooded, "cpu_share"),
    }
    print(
        f"\n1 kHz, {flood_hz:g} Hz command flood: missed {100 * out['missed_share_with']:.2f} % "
        f"against {100 * out['missed_share_without']:.2f} % without (goal: <= +0.1 points); "
        f"CPU {100 * out['cpu_share_with']:.1f} % against "
        f"{100 * out['cpu_share_without']:.1f} %"
    )
    return out


def arguments(argv):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", type=float, nargs="+", default=[1000.0, 250.0], help="[Hz]")
    ap.add_argument("--duration", type=float, default=10.0, help="measured seconds a run")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument(
        "--listen",
        nargs="+",
        choices=STATE_ROLES,
        default=["joint_states"],
        help="the state topics the listener takes (default: the joint states)",
    )
    ap.add_argument(
        "--loads",
        nargs="+",
        choices=list(LOADS),
        default=["mix"],
        help="the command client's loads the node runs under (the goal: mix)",
    )
    ap.add_argument("--flood", type=float, default=0.0, help="command flood [Hz] (0: none)")
    ap.add_argument("--startup", type=int, default=0, help="start-ups to time (0: none)")
    ap.add_argument("--env", nargs="*", default=[], help="NAME=VALUE of the profiled variant")
    ap.add_argument(
        "--tick-cpu",
        type=int,
        default=-1,
        help="the profiled variant: the node's tick_cpu and the floor's thread on this CPU",
    )
    ap.add_argument("--domain", type=int, default=97)
    ap.add_argument("--output", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    args.loads = list(dict.fromkeys(args.loads))  # each load once a round
    return args


def main(argv: list[str] | None = None) -> int:
    args = arguments(argv)
    base = dict(
        os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    envs, tick_cpus = {"default": base}, {"default": -1}
    if args.env or args.tick_cpu >= 0:
        envs["profiled"] = dict(base, **parse_env(args.env))
        tick_cpus["profiled"] = args.tick_cpu
    runs = []
    with tempfile.TemporaryDirectory() as d:
        for k, (kind, rate, variant, flood, load) in enumerate(plan_runs(args, list(envs))):
            env = envs[variant]
            if kind == "floor":
                r = floor_run(rate, args.duration, args.listen, env, tick_cpus[variant])
            else:
                r = node_run(
                    rate,
                    args.duration,
                    args.listen,
                    env,
                    Path(d) / str(k),
                    args.domain,
                    flood,
                    load,
                    tick_cpus[variant],
                )
            r.update(variant=variant, flood_hz=flood, tick_cpu=tick_cpus[variant])
            if tick_cpus[variant] >= 0 and f"on CPU {tick_cpus[variant]}" not in r["policy"]:
                raise SystemExit(f"the {kind} did not keep its tick on CPU: {r['policy']!r}")
            print_run(r)
            runs.append(r)
        startup = startup_times(args.startup, args.domain, base, Path(d)) if args.startup else None
    rows = summarise(runs, args.rates, list(envs))
    print_table(rows, args.rounds)
    result = {
        "listen": args.listen,
        "duration_s": args.duration,
        "rounds": args.rounds,
        "env": parse_env(args.env),
        "tick_cpu": tick_cpus,
        "summary": rows,
        "runs": runs,
    }
    if args.loads != ["mix"]:
        result["loads"] = loads_summary(runs, rows, ["mix", *(x for x in args.loads if x != "mix")])
    if args.flood:
        result["flood"] = flood_summary(runs, args.flood)
    if startup is not None:
        result["startup"] = startup
        result["imports"] = import_summary()
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
