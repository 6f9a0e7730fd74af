"""Shutdown stress: stop the node at random moments under load, many times; every stop must be
clean (the test ``tests/test_node_robustness.py`` runs 12 stops, this runs more; its result of
60 stops is ``benchmarks/results/shutdown_stress.txt``).

Each round starts ``--parallel`` nodes (loopback-only DDS, 500 Hz publish, MCAP bag and rerun
recording), streams stroke commands at them and sends each SIGINT or SIGTERM at a random moment
0.1..1.6 s after its bag appears, while two processes keep both cores busy. A stop is good when
the node exits 0, its bag passes ``drs-bag check`` (every byte read, metadata.yaml counting what
the file holds) and its recording passes ``rerun rrd verify``. Prints the counts of each failure
and exits 1 if any.

``--mode start-up`` signals the command lines at any moment of their life instead: drs-node,
``drs-bag play`` of the example bag, ``drs excite``, ``drs-bag resimulate -o``, ``drs-check``
and ``drs-demo`` (the long-running ones), two at a time, each sent SIGINT or SIGTERM at a random
moment 0..3.5 s after it was started (its imports, its start, its run). A stop is good when the
tool exits 0 within 1 s of the signal without a traceback, and leaves no bag or one
``drs-bag check`` accepts (and no ``.rrd`` or one that ``rerun rrd verify`` passes). Its
result of 50 signals is ``benchmarks/results/shutdown_stress_startup.txt``.

Usage: ``python benchmarks/shutdown_stress.py [--stops 120] [--parallel 3] [--seed 16]
[--mode running|start-up]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from drs_ros.node.command_line import PYTHON_M_DRS_ROS, node_command


def start_node(bag: Path, env: dict) -> subprocess.Popen:
    args = node_command(
        {"bag_path": bag, "rrd_path": f"{bag}.rrd", "publish_rate_hz": 500.0, "flush_period": 0.1}
    )
    return subprocess.Popen(
        args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stops", type=int, default=120)
    ap.add_argument("--parallel", type=int, default=3)
    ap.add_argument("--seed", type=int, default=16)
    ap.add_argument("--domain", type=int, default=77)
    ap.add_argument("--mode", choices=("running", "start-up"), default="running")
    args = ap.parse_args(argv)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    work = Path(tempfile.mkdtemp(prefix="drs-stress-"))
    env = dict(os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_LOG_DIR=str(work / "log"))
    if args.mode == "start-up":
        return start_up_main(args, work, env)

    from drs_model.kinematics import stroke_limits
    from drs_model.params import DRSParams
    from drs_ros.bag.cli import main as bag_main
    from drs_ros.client import DRSClient
    from drs_ros.recording.rerun_cli import run_rerun_cli

    rng = random.Random(args.seed)
    lo, hi = stroke_limits(DRSParams())
    code = "while True: pass"
    burners = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(2)]
    client = DRSClient(args.domain, listen=(), client_name="stress_client")
    failures: Counter = Counter()
    done = 0
    t_start = time.monotonic()
    try:
        while done < args.stops:
            names = [f"s{done + i}" for i in range(min(args.parallel, args.stops - done))]
            procs = {n: start_node(work / n, env) for n in names}
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and not all(
                (work / n / f"{n}_0.mcap").exists() for n in names
            ):
                time.sleep(0.05)
            at = {n: time.monotonic() + 0.1 + 1.5 * rng.random() for n in names}
            sent: set = set()
            while len(sent) < len(names):
                client.stroke(lo + (hi - lo) * rng.random())
                client.spin(0.005)
                for n in names:
                    if n not in sent and time.monotonic() >= at[n]:
                        procs[n].send_signal(rng.choice([signal.SIGINT, signal.SIGTERM]))
                        sent.add(n)
            for n, proc in procs.items():
                try:
                    _, err = proc.communicate(timeout=60)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    _, err = proc.communicate()
                    failures["hung"] += 1
                if proc.returncode != 0:
                    failures[f"exit {proc.returncode}"] += 1
                    print(f"{n}: exit {proc.returncode}: {err[-500:]}", file=sys.stderr)
                with contextlib.redirect_stdout(io.StringIO()):  # the tables: not wanted here
                    checked = bag_main(["check", str(work / n)])
                if checked != 0:
                    failures["bag check"] += 1
                if run_rerun_cli(["rrd", "verify", f"{work / n}.rrd"]).returncode != 0:
                    failures["rrd verify"] += 1
                done += 1
            print(
                f"{done}/{args.stops} stops, failures so far: {dict(failures) or 'none'}",
                file=sys.stderr,
            )
    finally:
        client.close()
        for b in burners:
            b.kill()
    minutes = (time.monotonic() - t_start) / 60
    print(
        f"{done} stops in {minutes:.1f} min, both cores busy: "
        f"{sum(failures.values())} failed {dict(failures) or ''}"
    )
    return 1 if failures else 0


EXAMPLE = Path(__file__).resolve().parents[1] / "bags" / "example"
#: tool -> (its command for output path OUT, its share of the signals)
START_UP_TOOLS = {
    "drs-node": (
        lambda out: node_command(
            {"bag_path": out, "rrd_path": f"{out}.rrd", "flush_period": 0.1},
            program=PYTHON_M_DRS_ROS[1:],  # the interpreter is put first by start_up_signal
        ),
        2,
    ),
    "drs-bag play": (lambda out: ["-m", "drs_ros.bag.cli", "play", str(EXAMPLE)], 2),
    "drs excite": (
        lambda out: [
            "-m",
            "drs_model.cli",
            "excite",
            "m_wing",
            "--starts",
            "2",
            "-o",
            f"{out}.yaml",
        ],
        1,
    ),
    "drs-bag resimulate": (
        lambda out: ["-m", "drs_ros.bag.cli", "resimulate", str(EXAMPLE), "-o", str(out)],
        1,
    ),
    "drs-check": (
        lambda out: [
            "-c",
            "import sys; from drs_ros.bag.cli import check_alias; sys.exit(check_alias())",
            str(EXAMPLE),
        ],
        1,
    ),
    "drs-demo": (
        lambda out: ["-m", "drs_ros.demo", "--out", str(out.parent), "--name", out.name],
        1,
    ),
}
#: The longest a stop may take after its signal [s].
STOP_WITHIN_S = 1.0


def start_up_signal(tool: str, out: Path, env: dict, at_s: float, sig) -> dict:
    """Start ``tool``, send ``sig`` ``at_s`` after the start; what happened."""
    proc = subprocess.Popen(
        [sys.executable, *START_UP_TOOLS[tool][0](out)],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(at_s)
    sent = time.monotonic()
    running = proc.poll() is None  # a tool that ended before its moment met no signal
    if running:
        proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return {
        "status": proc.returncode,
        "after_s": time.monotonic() - sent,
        "stderr": err,
        "signalled": running,
    }


def judge_start_up(tool: str, out: Path, run: dict, bag_main, run_rerun_cli) -> list[str]:
    """The failures of one signalled run (an empty list: a good stop)."""
    failures = []
    if run["status"] != 0:
        failures.append(f"exit {run['status']}")
    if "Traceback" in run["stderr"]:
        failures.append("traceback")
    if run["after_s"] > STOP_WITHIN_S:
        failures.append(f"ended later than {STOP_WITHIN_S} s")
    if out.exists():
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            if bag_main(["check", str(out)]) != 0:
                failures.append("bag check")
    rrd = Path(f"{out}.rrd")
    if rrd.exists() and run_rerun_cli(["rrd", "verify", str(rrd)]).returncode != 0:
        failures.append("rrd verify")
    return failures


def start_up_main(args, work: Path, env: dict) -> int:
    """``--mode start-up``: ``--stops`` signals over :data:`START_UP_TOOLS` by their shares,
    ``--parallel`` tools at a time (threads: each waits for its own moment)."""
    from concurrent.futures import ThreadPoolExecutor

    from drs_ros.bag.cli import main as bag_main
    from drs_ros.recording.rerun_cli import run_rerun_cli

    env = dict(env, DRS_DEMO_DOMAIN=str(args.domain + 1))  # the demo's node and its driver
    rng = random.Random(args.seed)
    order = [tool for tool, (_, share) in START_UP_TOOLS.items() for _ in range(share)]
    plan = [
        (
            order[i % len(order)],
            work / f"s{i}",
            rng.uniform(0.0, 3.5),
            rng.choice([signal.SIGINT, signal.SIGTERM]),
        )
        for i in range(args.stops)
    ]
    failures: Counter = Counter()
    latencies: dict[str, list[float]] = {}
    t_start = time.monotonic()
    with ThreadPoolExecutor(args.parallel) as pool:
        runs = pool.map(lambda p: start_up_signal(p[0], p[1], env, p[2], p[3]), plan)
        for (tool, out, at_s, sig), run in zip(plan, runs, strict=True):
            bad = judge_start_up(tool, out, run, bag_main, run_rerun_cli)
            if run["signalled"]:
                latencies.setdefault(tool, []).append(run["after_s"])
            last = (run["stderr"].strip().splitlines() or [""])[-1]
            met = "" if run["signalled"] else " (ended before it)"
            print(
                f"{out.name} {tool}: {sig.name} at {at_s:.2f} s{met}, exit {run['status']} "
                f"{run['after_s']:.2f} s after: {', '.join(bad) or 'good'} | {last[:100]}"
            )
            for b in bad:
                failures[f"{tool}: {b}"] += 1
    minutes = (time.monotonic() - t_start) / 60
    for tool, values in latencies.items():
        print(
            f"{tool}: {len(values)} signals met it running, it ended "
            f"{min(values):.2f}..{max(values):.2f} s after the signal"
        )
    print(
        f"{args.stops} signals in {minutes:.1f} min: {sum(failures.values())} failed "
        f"{dict(failures) or ''}"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
