"""Where the node's CPU goes at 1 kHz: by thread and by library, sampled by ``perf``.

Runs ``drs-node`` as ``node_rate.py`` runs it (deadline loop, 1 kHz physics and publish, the MCAP
bag and the rerun recording, a driver cycling open, close, stroke and force commands every 100
ms and listening to ``/joint_states`` and ``/diagnostics``) and samples the node's threads with
``perf record`` (the Linux profiler: Debian's ``linux-perf``; it needs root or
``kernel.perf_event_paranoid`` <= 1) over the measured window. The samples are counted per
thread and per shared object, then grouped:

* threads: the tick (the process's main thread runs the deadline loop), Fast DDS's own threads
  (named ``dds.*``: its timed events, its shared-memory and UDP receivers), rerun's native
  threads, and the other Python threads (the executor, the bag's flush, the rerun sender);
* libraries: the Python interpreter (``libpython``: the node's Python code), the kernel (system
  calls, thread wake-ups), ROS 2 and Fast DDS (rclpy, rcl, rmw, Fast DDS, Fast CDR), numpy, the C
  and C++ runtimes, rerun, and the rest (numba's compiled kernels among them).

A share is of the node's samples, which are its CPU: the samples are taken at a fixed rate of
each thread's CPU time, so a sleeping thread gives none.

Run: ``python benchmarks/node_perf.py [--duration 10] [--frequency 4000]``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import node_rate  # noqa: E402 - the run itself is node_rate's

#: Shared object -> its group, by the first prefix of the object's name that matches.
LIBRARY_GROUPS = (
    ("libpython", "Python interpreter"),
    ("[kernel", "kernel"),
    ("libfastrtps", "ROS 2 and Fast DDS"),
    ("libfastcdr", "ROS 2 and Fast DDS"),
    ("librmw", "ROS 2 and Fast DDS"),
    ("librcl", "ROS 2 and Fast DDS"),
    ("librcutils", "ROS 2 and Fast DDS"),
    ("_rclpy", "ROS 2 and Fast DDS"),
    ("libtracetools", "ROS 2 and Fast DDS"),
    ("_multiarray", "numpy"),
    ("libc.", "C and C++ runtimes"),
    ("libstdc++", "C and C++ runtimes"),
    ("libm.", "C and C++ runtimes"),
    ("ld-linux", "C and C++ runtimes"),
    ("[vdso]", "C and C++ runtimes"),
    ("rerun", "rerun"),
)
#: Native threads that rerun's bindings start (their kernel names).
RERUN_THREADS = ("tokio-rt-worker", "ChunkBatcher", "RecordingStream", "file_writer", "jemalloc")

#: One line of ``perf report --sort pid,dso``: share, tid:comm, shared object.
REPORT_LINE = re.compile(r"^\s*([\d.]+)%\s+(\d+):(.+?)\s{2,}(\S.*?)\s*$")


def library_group(dso: str) -> str:
    for prefix, group in LIBRARY_GROUPS:
        if dso.startswith(prefix):
            return group
    return "other"


def thread_group(tid: int, comm: str, pid: int) -> str:
    if tid == pid:
        return "tick (main thread)"
    if comm.startswith("dds."):
        return "Fast DDS threads"
    if comm.startswith(RERUN_THREADS):
        return "rerun's native threads"
    return "other Python threads"


def shares(report: str, pid: int) -> dict[str, dict[str, float]]:
    """Thread group -> library group -> share [%] of the node's samples, from the text of
    ``perf report --sort pid,dso``."""
    out: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    for line in report.splitlines():
        m = REPORT_LINE.match(line)
        if m is None:
            continue
        share, tid, comm, dso = float(m[1]), int(m[2]), m[3], m[4]
        out[thread_group(tid, comm, pid)][library_group(dso)] += share
    if not out:
        raise RuntimeError(f"perf report gave no sample line:\n{report[:2000]}")
    return {t: dict(libs) for t, libs in out.items()}


class PerfRecord:
    """``observe`` for :func:`node_rate.measure`: ``perf record`` of the node's threads for
    ``seconds`` into ``data``; ``pid`` is the node's, once the run started."""

    def __init__(self, data: Path, frequency: int, seconds: float) -> None:
        self.perf = shutil.which("perf")
        if self.perf is None:
            raise SystemExit("node_perf: `perf` is not installed (Debian: apt install linux-perf)")
        self.data, self.frequency, self.seconds = data, frequency, seconds
        self.pid: int | None = None

    def __call__(self, pid: int):
        self.pid = pid
        proc = subprocess.Popen(
            [
                self.perf,
                "record",
                "-F",
                str(self.frequency),
                "-p",
                str(pid),
                "-o",
                str(self.data),
                "--",
                "sleep",
                f"{self.seconds:g}",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )

        def stop() -> None:
            _out, err = proc.communicate(timeout=self.seconds + 60)
            if proc.returncode != 0 or not self.data.exists():
                raise SystemExit(f"node_perf: perf record failed ({proc.returncode}): {err}")

        return stop


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=10.0, help="wall seconds of the run")
    ap.add_argument("--frequency", type=int, default=4000, help="samples per CPU second")
    ap.add_argument("--domain", type=int, default=92)
    ap.add_argument("--json", default="benchmarks/results/node_perf.json")
    args = ap.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        os.environ.setdefault("ROS_LOG_DIR", str(tmp / "log"))
        data = tmp / "perf.data"
        observe = PerfRecord(data, args.frequency, args.duration - 0.5)
        run = node_rate.measure(
            "deadline", 1000.0, args.duration, args.domain, tmp / "run", observe=observe
        )
        report = subprocess.run(
            [
                observe.perf,
                "report",
                "-i",
                str(data),
                "--no-children",
                "--sort",
                "pid,dso",
                "--stdio",
                "-g",
                "none",
                "--percent-limit",
                "0",
            ],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    by_thread = shares(report, observe.pid)
    libraries = {lib for libs in by_thread.values() for lib in libs}
    totals = {t: sum(libs.values()) for t, libs in by_thread.items()}
    print(
        f"drs-node, deadline loop at 1 kHz: {100 * run['cpu_share_of_core']:.1f} % of a core, "
        f"missed {100 * run['missed_share']:.2f} %; perf samples by thread and library, % of "
        f"the node's"
    )
    width = max(len(lib) for lib in libraries)
    print(f"{'':<{width}}  " + "  ".join(f"{t[:24]:>24}" for t in totals))
    for lib in sorted(libraries, key=lambda x: -sum(v.get(x, 0) for v in by_thread.values())):
        print(
            f"{lib:<{width}}  " + "  ".join(f"{by_thread[t].get(lib, 0.0):24.1f}" for t in totals)
        )
    print(f"{'all':<{width}}  " + "  ".join(f"{totals[t]:24.1f}" for t in totals))
    Path(args.json).write_text(json.dumps({"run": run, "shares_percent": by_thread}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
