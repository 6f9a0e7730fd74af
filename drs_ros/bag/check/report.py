"""The report of ``drs-bag check`` on one bag: a plain-text table (counts per topic, the faults
the run recorded, one row per check) or JSON."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import asdict

from drs_ros.bag.check.model_checks import CheckResult
from drs_ros.bag.read.decoded import BagData
from drs_ros.bag.read.nodes import BagNode
from drs_ros.timestamps import seconds_from_ns


def format_table(data: BagData, results: Sequence[CheckResult], faults: Sequence[dict] = ()) -> str:
    """A plain-text report: counts per topic, the faults recorded (:func:`format_faults`), then
    one row per check."""
    lines = [f"bag: {data.path}" + ("  (recovered prefix)" if data.recovered else "")]
    lines += [f"note: {n}" for n in data.notes]
    width = max([28, *map(len, data.counts)])  # topic names as long as a namespace makes them
    for topic, n in sorted(data.counts.items()):
        lines.append(f"  {topic:<{width}} {n:>8} messages")
    lines += format_faults(faults, data.start_ns)
    # times are shown from the earliest header stamp (the checks report stamps, epoch seconds)
    t0 = min(data.first_stamp_s.values(), default=0.0)
    tw = max([20, *(len(r.topic) for r in results)])
    head = (
        f"{'check':<38} {'topic':<{tw}} {'n':>7} {'max error':>11} {'at t-t0 [s]':>12} "
        f"{'tol':>9}  status"
    )
    lines += ["", head, "-" * len(head)]
    for r in results:
        err = "-" if math.isnan(r.max_error) else f"{r.max_error:.3e}"
        at = "-" if math.isnan(r.at_time_s) else f"{r.at_time_s - t0:.6f}"
        row = (
            f"{r.name + ' [' + r.unit + ']':<38} {r.topic:<{tw}} {r.samples:>7} {err:>11} "
            f"{at:>12} {r.tol:>9.2g}  {r.status}"
        )
        lines.append(row + (f"  ({r.note})" if r.note else ""))
    return "\n".join(lines)


def format_faults(faults: Sequence[dict], start_ns: int | None) -> list[str]:
    """The recorded faults' spans, one line each: simulated time [s] and log time [s] from the
    bag's first message."""
    if not faults:
        return []
    start = start_ns or 0

    def log(ns):
        return "end" if ns is None else f"{seconds_from_ns(ns - start):.6f}"

    lines = [
        "",
        "faults (from the effect record; simulated time, and log time from the bag's "
        "first message) [s]:",
    ]
    for f in faults:
        to = "end" if f["sim_to_s"] is None else f"{f['sim_to_s']:.6f}"
        lines.append(
            f"  {f['fault'] + ' = ' + repr(f['value']):<40} sim {f['sim_from_s']:.6f} .. "
            f"{to}   log {log(f['log_from_ns'])} .. {log(f['log_to_ns'])}"
        )
    return lines


def to_json(
    data: BagData,
    results: Sequence[CheckResult],
    faults: Sequence[dict] = (),
    node: BagNode | None = None,
) -> str:
    """The report as JSON (NaN written as null; ``node``: the drs node checked, if any)."""

    def clean(value):
        return None if isinstance(value, float) and math.isnan(value) else value

    return json.dumps(
        {
            "bag": str(data.path),
            "node": None if node is None else node.name,
            "recovered": data.recovered,
            "notes": data.notes,
            "messages": data.counts,
            "faults": list(faults),
            "checks": [{k: clean(v) for k, v in asdict(r).items()} for r in results],
            "ok": not any(r.status == "FAIL" for r in results),
        },
        indent=2,
    )


__all__ = ["format_faults", "format_table", "to_json"]
