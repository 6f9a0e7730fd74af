"""Scaling of ``drs study``: samples per second against Dask workers (1 and 2), the per-sample
cost against the single-run floor, and the scheduler's overhead per task.

* floor: the same rows, the same chunks, evaluated in this process one chunk after another
  (:func:`drs_model.study.evaluate`, no Dask): what a study cannot beat on one core;
* study: :func:`drs_model.study.run_study` on an embedded LocalCluster of 1 and of 2
  single-threaded worker processes, one cluster at a time (an idle one burns ~0.3 core), each
  warmed by a small study first (its start-up, ~2-4 s, and the workers' numba cache loads are not
  counted: a long study pays them once); the whole call is timed (design, tasks, gathering,
  Sobol' indices);
* the Python share: the per-sample stage (each sample's DRSParams and its constants,
  :func:`drs_model.study.evaluate.prepare`: the only per-sample Python) against the whole
  evaluation, in this process;
* CPU seconds (psutil), besides the wall clock: of the worker processes (the evaluation), and of
  this process (the client and the embedded scheduler) with the nannies (the overhead), per
  run: the workers' CPU per sample against the floor's says whether the work itself grows on
  Dask, whatever else runs on the machine;
* scheduler overhead: a no-op task mapped many times through :func:`drs_model.cluster.map_unordered`
  on the 1-worker cluster, wall time per task.

The three timings are interleaved (floor, 1 worker, 2 workers, again) and the medians reported:
the machine has 2 cores and is shared, so a single run says little. Wall clock
(``time.perf_counter``): a cluster's work happens in other processes.

Run: ``.venv/bin/python benchmarks/study_scaling.py [--samples 256] [--repeats 5] [--chunk 128]``
(writes ``benchmarks/results/study_scaling.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from dataclasses import replace
from pathlib import Path

import psutil

from drs_model.cluster import dask_client, map_unordered
from drs_model.study import evaluate, read_spec, run_study
from drs_model.study.design import design
from drs_model.study.evaluate import prepare
from drs_model.study.run import chunks

ROOT = Path(__file__).resolve().parents[1]


def _noop(x):
    return x


def _cpu(pid: int | None = None) -> float:
    t = psutil.Process(pid).cpu_times()
    return t.user + t.system


def cpu_seconds(pids) -> tuple[float, float]:
    """User + system CPU seconds so far: ``(the worker processes, this process and the
    nannies)``; ``pids = (workers, nannies)``. This process holds the client and the embedded
    scheduler (also the floor's evaluation, which then counts as 'workers')."""
    workers, nannies = pids
    if not workers:
        return _cpu(), 0.0
    return sum(_cpu(p) for p in workers), _cpu() + sum(_cpu(p) for p in nannies)


def cluster_pids(client) -> tuple[list[int], list[int]]:
    """The worker processes of ``client``'s cluster and their nannies."""
    workers = list(client.run(os.getpid).values())
    return workers, [psutil.Process(p).ppid() for p in workers]


def floor(spec, chunk: int) -> tuple[float, tuple[float, float]]:
    """(wall, (CPU, 0)) seconds to evaluate every row of ``spec`` here, chunk by chunk."""
    rows = design(spec).values
    c0, t0 = cpu_seconds(((), ())), time.perf_counter()
    for a, b in chunks(rows.shape[0], chunk):
        evaluate(spec.design, spec.scene, spec.fields, rows[a:b])
    c1 = cpu_seconds(((), ()))
    return time.perf_counter() - t0, (c1[0] - c0[0], 0.0)


def on_cluster(client, spec, chunk: int, pids) -> tuple[float, tuple[float, float]]:
    """(wall, (workers' CPU, client + scheduler + nannies CPU)) seconds of the whole study."""
    c0, t0 = cpu_seconds(pids), time.perf_counter()
    run_study(spec, client=client, chunk=chunk, progress=False)
    c1 = cpu_seconds(pids)
    return time.perf_counter() - t0, (c1[0] - c0[0], c1[1] - c0[1])


def python_share(spec) -> tuple[float, float]:
    """(seconds of the per-sample Python stage, :func:`drs_model.study.evaluate.prepare`, seconds
    of the whole evaluation), in this process."""
    rows = design(spec).values
    t0 = time.perf_counter()
    prepare(spec.design, spec.fields, rows)
    t1 = time.perf_counter()
    evaluate(spec.design, spec.scene, spec.fields, rows)
    return t1 - t0, time.perf_counter() - t1


def task_overhead(client, tasks: int) -> float:
    """Wall seconds per no-op task through map_unordered."""
    t0 = time.perf_counter()
    for _ in map_unordered(client, _noop, range(tasks), progress=False):
        pass
    return (time.perf_counter() - t0) / tasks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spec", default=str(ROOT / "config" / "study.toml"))
    ap.add_argument("--samples", type=int, default=256, help="base samples (runs: n (d + 2))")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--chunk", type=int, default=128)
    ap.add_argument("--tasks", type=int, default=2000, help="no-op tasks for the overhead")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "study_scaling.json"))
    args = ap.parse_args()
    spec = replace(read_spec(args.spec), samples=args.samples)
    small = replace(spec, samples=4)
    runs = spec.runs
    print(
        f"study: {runs} runs ({args.samples} base samples x {len(spec.fields) + 2}), "
        f"chunk {args.chunk}, {args.repeats} repeats, load {os.getloadavg()}"
    )
    floor(small, args.chunk)  # this process's numba loads
    times = {"floor": [], "1 worker": [], "2 workers": []}
    cpu = {k: [] for k in times}  # the workers' CPU seconds (the floor: this process's)
    other = {k: [] for k in times}  # client, scheduler and nannies
    with dask_client(jobs=1) as one:
        overhead = [task_overhead(one, args.tasks) for _ in range(3)]

    def study_on(jobs: int) -> tuple[float, tuple[float, float]]:
        # one cluster at a time: an idle LocalCluster burns ~0.3 core (heartbeats, the nannies'
        # memory monitors), which a 2-core machine cannot spare
        with dask_client(jobs=jobs) as client:
            pids = cluster_pids(client)
            on_cluster(client, small, args.chunk, pids)  # the workers' numba loads
            return on_cluster(client, spec, args.chunk, pids)

    for r in range(args.repeats):
        for key, run in (
            ("floor", lambda: floor(spec, args.chunk)),
            ("1 worker", lambda: study_on(1)),
            ("2 workers", lambda: study_on(2)),
        ):
            wall, (cpu_s, other_s) = run()
            times[key].append(wall)
            cpu[key].append(cpu_s)
            other[key].append(other_s)
        done = ", ".join(f"{k} {v[-1]:.2f} s ({cpu[k][-1]:.2f} s CPU)" for k, v in times.items())
        print(f"  repeat {r + 1}: {done}")
    py, total = python_share(spec)
    med = {k: statistics.median(v) for k, v in times.items()}
    med_cpu = {k: statistics.median(v) for k, v in cpu.items()}
    med_other = {k: statistics.median(v) for k, v in other.items()}
    per_sample = {k: v / runs for k, v in med.items()}
    speedup = med["1 worker"] / med["2 workers"]
    result = {
        "runs": runs,
        "chunk": args.chunk,
        "repeats": args.repeats,
        "load_after": os.getloadavg(),
        "seconds": times,
        "median_seconds": med,
        "ms_per_sample": {k: 1e3 * v for k, v in per_sample.items()},
        "samples_per_second": {k: runs / v for k, v in med.items()},
        "worker_cpu_seconds": cpu,
        "other_cpu_seconds": other,
        "worker_cpu_ms_per_sample": {k: 1e3 * v / runs for k, v in med_cpu.items()},
        "other_cpu_ms_per_sample": {k: 1e3 * v / runs for k, v in med_other.items()},
        "one_worker_over_floor": med["1 worker"] / med["floor"],
        "one_worker_over_floor_cpu": med_cpu["1 worker"] / med_cpu["floor"],
        "cpu_two_over_one_worker": med_cpu["2 workers"] / med_cpu["1 worker"],
        "speedup_1_to_2": speedup,
        "parallel_efficiency_2": speedup / 2.0,
        "python_parameters_share": py / total,
        "python_parameters_ms_per_sample": 1e3 * py / runs,
        "scheduler_overhead_ms_per_task": 1e3 * statistics.median(overhead),
    }
    print(
        f"per sample: floor {1e3 * per_sample['floor']:.3f} ms, 1 worker "
        f"{1e3 * per_sample['1 worker']:.3f} ms ({result['one_worker_over_floor']:.3f}x the "
        f"floor, target <= 1.2), 2 workers {1e3 * per_sample['2 workers']:.3f} ms"
    )
    print(
        "samples/s: " + ", ".join(f"{k} {v:.0f}" for k, v in result["samples_per_second"].items())
    )
    print(f"1 -> 2 workers: {speedup:.3f}x ({100 * speedup / 2:.1f} % of linear, target >= 90 %)")
    print(
        "workers' CPU per sample: "
        + ", ".join(f"{k} {v:.3f} ms" for k, v in result["worker_cpu_ms_per_sample"].items())
        + f"; 1 worker / floor "
        f"{result['one_worker_over_floor_cpu']:.3f}, 2 workers / 1 worker "
        f"{result['cpu_two_over_one_worker']:.3f}"
    )
    print(
        "client + scheduler + nannies, CPU per sample: "
        + ", ".join(f"{k} {v:.3f} ms" for k, v in result["other_cpu_ms_per_sample"].items())
    )
    print(
        f"per-sample Python (prepare): {result['python_parameters_ms_per_sample']:.3f} ms, "
        f"{100 * result['python_parameters_share']:.1f} % of the evaluation"
    )
    print(f"scheduler overhead: {result['scheduler_overhead_ms_per_task']:.3f} ms per task")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
