"""Bags per second: ``drs-bag index`` against ``drs-bag check``, and the fleet check on 1 and 2
Dask workers; the scheduler's overhead per task.

Copies ``bags/example`` (8517 messages, 1.4 MB, 3.5 s of a run) ``--bags`` times into a temporary
directory and measures in one run, each ``--repeats`` times (medians reported):

* ``index``: :func:`drs_ros.bag.season.catalogue.catalogue_row` of every bag in this process
  (summaries
  only, no message decoded);
* ``check, 1 process``: :func:`drs_ros.bag.check.command.check_one` of every bag in this process,
  one
  after the other (no Dask: the floor a fleet run is compared with);
* ``check on N workers``: the fleet's tasks (:func:`drs_ros.bag.season.fleet.timed_row` of
  :func:`drs_ros.bag.check.command.fleet_row`) on an embedded LocalCluster of N single-threaded
  worker
  processes (:func:`drs_model.cluster.dask_client`), started and warmed (one task per worker)
  before the clock starts; the cluster's start-up is reported apart;
* the scheduler's overhead per task: ``--tiny`` tasks of a function that returns at once, on one
  worker, their wall time divided by their number.

Usage: ``python benchmarks/bag_fleet.py [--bags 12] [--repeats 3] [--tiny 400]
[--json benchmarks/results/bag_fleet.json]`` (about 3 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "bags" / "example"


def _noop(x):
    return x


def _check_args(bags: list[str]) -> argparse.Namespace:
    from drs_ros.bag.check import command as check

    ap = argparse.ArgumentParser()
    check.add_arguments(ap)
    return ap.parse_args(bags)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bags", type=int, default=12, help="copies of bags/example")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tiny", type=int, default=400, help="tasks of the overhead measurement")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    from drs_model.cluster import dask_client, map_unordered
    from drs_ros.bag.check import command as check
    from drs_ros.bag.season import fleet
    from drs_ros.bag.season.catalogue import catalogue_row

    load_before = os.getloadavg()[0]
    work = Path(tempfile.mkdtemp(prefix="drs-bag-fleet-"))
    try:
        bags = []
        for i in range(args.bags):
            shutil.copytree(EXAMPLE, work / f"run{i:03d}")
            bags.append(str(work / f"run{i:03d}"))
        check_args = _check_args(bags)
        times: dict[str, list[float]] = {}

        def timed(name, fn):
            start = time.perf_counter()
            fn()
            times.setdefault(name, []).append(time.perf_counter() - start)

        for _ in range(args.repeats):
            timed("index", lambda: [catalogue_row(b) for b in bags])
            timed(
                "check, 1 process",
                lambda: [check.check_one(b, check_args, stats=True) for b in bags],
            )
        startup = {}
        for jobs in (1, 2):  # one cluster at a time (two clients in one process race)
            t0 = time.perf_counter()
            with dask_client(jobs=jobs) as client:
                startup[jobs] = time.perf_counter() - t0
                # warm: every worker imports the tools and loads numba's cache once
                list(
                    map_unordered(
                        client,
                        fleet.timed_row,
                        bags[:jobs],
                        progress=False,
                        row_function=check.fleet_row,
                        args=check_args,
                    )
                )
                for _ in range(args.repeats):
                    timed(
                        f"check on {jobs} worker(s)",
                        lambda client=client: list(
                            map_unordered(
                                client,
                                fleet.timed_row,
                                bags,
                                progress=False,
                                row_function=check.fleet_row,
                                args=check_args,
                            )
                        ),
                    )
                    if jobs == 1:
                        timed(
                            "tiny tasks, 1 worker",
                            lambda client=client: list(
                                map_unordered(client, _noop, range(args.tiny), progress=False)
                            ),
                        )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    med = {k: statistics.median(v) for k, v in times.items()}
    n = args.bags
    rows = []
    print(f"{args.bags} bags of {EXAMPLE.name} (8517 messages each), medians of {args.repeats}")
    print(f"{'':<26} {'time [s]':>9} {'bags/s':>8} {'vs 1 process':>13}")
    for name in ("index", "check, 1 process", "check on 1 worker(s)", "check on 2 worker(s)"):
        rate = n / med[name]
        ratio = med["check, 1 process"] / med[name]
        rows.append({"what": name, "seconds": med[name], "bags_per_s": rate, "speed_up": ratio})
        print(f"{name:<26} {med[name]:>9.2f} {rate:>8.2f} {ratio:>12.2f}x")
    overhead = med["tiny tasks, 1 worker"] / args.tiny
    scaling = med["check on 1 worker(s)"] / med["check on 2 worker(s)"]
    print(f"1 -> 2 workers: {scaling:.2f}x ({100 * scaling / 2:.0f} % of linear)")
    print(f"scheduler overhead per task: {overhead * 1e3:.2f} ms ({args.tiny} tasks of a no-op)")
    print(f"cluster start-up: {startup[1]:.2f} s (1 worker), {startup[2]:.2f} s (2 workers)")
    per_bag = med["check, 1 process"] / n
    print(
        f"check per bag: {per_bag:.3f} s in one process; the overhead is "
        f"{100 * overhead / per_bag:.2f} % of it"
    )
    load = (load_before, os.getloadavg()[0])
    print(
        f"load average (1 min) before and after: {load[0]:.2f}, {load[1]:.2f} "
        f"({os.cpu_count()} cores; other work on the machine shares them)"
    )
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "bags": n,
                    "repeats": args.repeats,
                    "rows": rows,
                    "scaling_1_to_2": scaling,
                    "overhead_per_task_s": overhead,
                    "startup_s": startup,
                    "check_per_bag_s": per_bag,
                    "load_average": load,
                    "raw": times,
                },
                indent=2,
            )
            + "\n"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
