"""Peak memory of ``drs-bag check`` against the size of the bag, up to a gigabyte and more.

Writes bags of the seed manoeuvre repeated (the tests' ``long_bag_support.write_long_bag``:
the four checked topics at 1 kHz, plus one camera-like ``sensor_msgs/msg/Image`` of ``--image-kib``
per 50 ms manoeuvre, as a vehicle's bag holds) of each size in ``--sizes-mb`` into a temporary
directory (``--tmp``, /tmp by default), checks each with ``drs-bag check`` in its own process,
and reports that process's peak resident memory (``ru_maxrss`` of ``os.wait4``), its wall time,
and the bag's messages; each bag is deleted after its check. A tool holding the bag, or its
decoded messages, would grow with the size; this one must not.

Usage: ``python benchmarks/bag_memory.py [--sizes-mb 64,256,1100] [--image-kib 200]
[--json benchmarks/results/bag_memory.json]`` (about 5 minutes for the default sizes).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# the long bags are the tests' fixture (tests/long_bag_support.py), not a part of the product
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

ROOT = Path(__file__).resolve().parents[1]


def check_peak(bag: Path) -> dict:
    """``drs-bag check BAG`` in a fresh process: exit status, peak RSS [bytes], wall time [s]."""
    env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "drs_ros.bag.cli", "check", str(bag)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    # wait4 gives this child's own rusage (ru_maxrss in KiB on Linux); read the pipes after it
    # (the check prints a few lines only, far below a pipe's buffer)
    _pid, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    out = proc.stdout.read().decode()
    err = proc.stderr.read().decode()
    proc.returncode = os.waitstatus_to_exitcode(status)
    return {
        "status": proc.returncode,
        "peak_rss_bytes": usage.ru_maxrss * 1024,
        "wall_s": wall,
        "report": out.splitlines()[:3],
        "stderr": err[-500:],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes-mb", default="64,256,1100", help="bag sizes [MB], comma-separated")
    ap.add_argument("--image-kib", type=int, default=200, help="image per manoeuvre [KiB]")
    ap.add_argument("--tmp", default=tempfile.gettempdir(), help="where the bags are written")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    from long_bag_support import write_long_bag

    image = args.image_kib * 1024
    rows = []
    print(
        f"{'bag [MB]':>9} {'messages':>10} {'write [s]':>9} {'check [s]':>9} "
        f"{'peak RSS [MB]':>13} {'RSS/size':>8}  status"
    )
    for size_mb in (float(x) for x in args.sizes_mb.split(",")):
        # one manoeuvre: 50 states x 4 topics (~19.5 kB) and one image
        cycles = max(1, int(size_mb * 1e6 / (19_500 + image)))
        work = Path(tempfile.mkdtemp(prefix="drs-bag-memory-", dir=args.tmp))
        try:
            t0 = time.perf_counter()
            bag = write_long_bag(work / "bag", cycles, bulk_bytes=image)
            t_write = time.perf_counter() - t0
            size = sum(f.stat().st_size for f in bag.iterdir())
            res = check_peak(bag)
        finally:
            shutil.rmtree(work, ignore_errors=True)
        row = {
            "bag_bytes": size,
            "cycles": cycles,
            "messages": 1 + cycles * 201,
            "write_s": t_write,
            **res,
        }
        rows.append(row)
        print(
            f"{size / 1e6:>9.1f} {row['messages']:>10} {t_write:>9.1f} {res['wall_s']:>9.1f} "
            f"{res['peak_rss_bytes'] / 1e6:>13.1f} {res['peak_rss_bytes'] / size:>8.3f}  "
            f"{res['status']}"
        )
        if res["status"] != 0:
            print(res["stderr"], file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0 if all(r["status"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
