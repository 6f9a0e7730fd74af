"""Start-up of ``drs-node``: exec to its first ``/joint_states``, and where the imports' time
goes (``python -X importtime`` of what the node's entry imports, summed by top-level package).

Usage: ``python benchmarks/node_startup.py [--runs 5] [--domain 97]`` (``node_vs_floor.py
--startup N`` runs the same).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from node_rate import stop_node

#: What ``drs-node`` imports before it makes the node (its entry, then the runner's modules).
ENTRY_IMPORTS = (
    "import importlib; from drs_ros.node import entry; from drs_ros.node import runner; "
    "[importlib.import_module(m) for m in entry.MADE_WITH]"
)


def node_command() -> list[str]:
    """``drs-node`` as installed beside this interpreter, else ``python -m drs_ros``."""
    script = Path(sys.executable).with_name("drs-node")
    return [str(script)] if script.exists() else [sys.executable, "-m", "drs_ros"]


def startup_times(runs: int, domain: int, env: dict, tmp: Path) -> dict:
    """Seconds from exec of ``drs-node`` (both recordings on) to the first ``/joint_states``
    a subscriber made before the exec receives, ``runs`` times; their median."""
    from drs_ros.client import DRSClient

    times = []
    with DRSClient(domain, listen=("joint_states",), client_name="bench_startup") as client:
        for k in range(runs):
            out = tmp / f"startup{k}"
            params = {"bag_path": out / "bag", "rrd_path": out / "run.rrd"}
            args = [a for n, v in params.items() for a in ("-p", f"{n}:={v}")]
            before = client.seen["joint_states"]
            t0 = time.monotonic()
            node = subprocess.Popen(
                [*node_command(), "--ros-args", *args],
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
            try:
                seen = client.wait_for(lambda b=before: client.seen["joint_states"] > b, 60.0)
                times.append(time.monotonic() - t0 if seen else float("nan"))
            finally:
                stop_node(node)
            client.spin(0.5)  # the last messages of this node drain before the next
            print(f"start-up {k + 1}: exec to first /joint_states {times[-1]:.3f} s", flush=True)
    median = statistics.median(times)
    print(f"start-up: median {median:.3f} s of {runs} (goal <= 1.5 s)", flush=True)
    return {"exec_to_first_joint_states_s": times, "median_s": median}


def import_summary(top: int = 10) -> dict:
    """``python -X importtime`` of :data:`ENTRY_IMPORTS`: the cumulative time [s] of each
    top-level import, summed by package, the ``top`` largest and the total."""
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", ENTRY_IMPORTS],
        capture_output=True,
        text=True,
        check=True,
    )
    by_package: dict[str, float] = {}
    for line in out.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _self_us, cumulative_us, name = line.split(":", 1)[1].split("|")
        if name.startswith("  "):  # imported by another module: inside its parent's time
            continue
        package = name.strip().split(".")[0]
        by_package[package] = by_package.get(package, 0.0) + int(cumulative_us) / 1e6
    total = sum(by_package.values())
    largest = dict(sorted(by_package.items(), key=lambda kv: -kv[1])[:top])
    print(
        f"imports of drs-node: {total:.3f} s; largest: "
        + ", ".join(f"{k} {v:.3f} s" for k, v in largest.items()),
        flush=True,
    )
    return {"total_s": total, "largest_s": largest}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--domain", type=int, default=97)
    args = ap.parse_args(argv)
    env = dict(
        os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    with tempfile.TemporaryDirectory() as d:
        startup_times(args.runs, args.domain, env, Path(d))
    import_summary()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
