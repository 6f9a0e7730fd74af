"""Many bags at once: ``drs-bag check`` and ``drs-bag resimulate`` over a fleet of bags, on Dask.

The bags are named by paths, directories (searched recursively: a directory holding
``metadata.yaml``, or ``.mcap`` / ``.db3`` files, is one bag; others are searched) and globs
(``'runs/**/*.mcap'``, quoted, expanded here). Each bag is one task on a
:func:`drs_model.cluster.dask_client` (an embedded ``LocalCluster`` of ``--jobs`` worker processes,
or the cluster at ``--scheduler``), run by the verb's row function, which never raises for the
bag's faults: a damaged bag is a row with its error, never the end of the run. The result is one
table, one row per bag in the order the bags were found, written as Parquet (``-o table.parquet``,
pyarrow) and printed as a summary; a progress bar shows on a terminal.

Columns every verb writes (:func:`base_row`, :func:`count_columns`, :func:`param_columns`):
``bag``, ``verdict``, ``exit_status`` (what the verb alone would exit with), ``error`` (null when
there is none), ``task_s`` (wall time of the task [s]), ``storage``, ``messages`` (all topics),
``counts`` (topic -> messages), ``start_ns``, ``duration_s``, ``recovered``, and ``param_<name>``
(the model parameters used, SI units). The verb adds its own (:mod:`drs_ros.bag.check`,
:mod:`drs_ros.bag.resimulate`).

Exit status of a fleet run (docs/cli.md): 0 every bag passed, 1 any bag did not (the table says
which and why), 2 no bag was found, an option is invalid, or the table cannot be written.
"""

from __future__ import annotations

import argparse
import glob
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from drs_model.cli.exit_status import EXIT_FAILED, EXIT_INTERNAL, EXIT_OK, EXIT_USAGE
from drs_model.errors import DRSError
from drs_model.params import NUMERIC_FIELDS

from ..errors import DRSRosError
from ..timestamps import seconds_from_ns

_BAG_SUFFIXES = (".mcap", ".db3")
_GLOB_CHARS = set("*?[")


class FleetError(DRSRosError):
    """A fleet run cannot start: no bag found, or an invalid option."""


def add_fleet_arguments(ap: argparse.ArgumentParser, *table_flags: str) -> None:
    """``--jobs``, ``--scheduler``, and (``table_flags``, e.g. ``-o``) the table's path."""
    if table_flags:
        ap.add_argument(*table_flags, dest="output", default=None,
                        help="with many bags: write the table, one row per bag, to this "
                        ".parquet file")  # fmt: skip
    ap.add_argument("--jobs", type=int, default=None,
                    help="with many bags: worker processes of the embedded Dask cluster "
                    "(default: the usable cores)")  # fmt: skip
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="with many bags: run on the Dask cluster at ADDRESS "
                    "(tcp://host:8786) instead of an embedded one")  # fmt: skip


def _is_bag(path: Path) -> bool:
    """A bag by itself: a file, or a directory holding metadata.yaml or bag files."""
    if path.is_file():
        return True
    return path.is_dir() and ((path / "metadata.yaml").is_file() or
                              any(p.suffix in _BAG_SUFFIXES for p in path.iterdir()))  # fmt: skip


def table_path(args: argparse.Namespace) -> str | None:
    """The table's path, if ``-o`` names one (``.parquet``)."""
    out = getattr(args, "output", None)
    return out if out and str(out).endswith(".parquet") else None


def is_fleet(args: argparse.Namespace) -> bool:
    """Whether ``args`` ask for a fleet run: more than one path, a glob, a directory of bags,
    a table, ``--jobs`` or ``--scheduler``. One bag (or a path that is no bag: its error) runs
    as it always did."""
    specs = list(args.bag)
    if len(specs) != 1 or table_path(args) or args.jobs is not None or args.scheduler:
        return True
    spec = specs[0]
    if _GLOB_CHARS & set(spec):
        return True
    path = Path(spec)
    return path.is_dir() and not _is_bag(path) and bool(find_bags([spec], missing_ok=True))


def find_bags(specs: Sequence[str], missing_ok: bool = False) -> list[Path]:
    """The bags ``specs`` name, in order, each once: files and bag directories as given, globs
    expanded (sorted), other directories searched recursively (sorted).

    Raises
    ------
    FleetError
        A path that does not exist or a glob that matches nothing (unless ``missing_ok``).
    """
    found: dict[Path, None] = {}

    def search(directory: Path) -> None:
        if _is_bag(directory):
            found[directory] = None
            return
        for child in sorted(directory.iterdir()):
            if child.is_dir():
                search(child)
            elif child.suffix in _BAG_SUFFIXES:  # pragma: no cover - _is_bag took the dir
                found[child] = None

    for spec in specs:
        matches = sorted(glob.glob(spec, recursive=True)) if _GLOB_CHARS & set(spec) else [spec]
        if not matches and not missing_ok:
            raise FleetError(f"{spec!r} matches no file or directory")
        for match in matches:
            path = Path(match)
            if path.is_file():
                if path.suffix in _BAG_SUFFIXES or path.name == "metadata.yaml":
                    found[path.parent if path.name == "metadata.yaml" else path] = None
            elif path.is_dir():
                search(path)
            elif not missing_ok:
                raise FleetError(f"{str(path)!r}: no such bag file or directory")
    # a file inside a bag directory that is also listed is that bag, not another
    return [p for p in found if not (p.is_file() and p.parent in found)]


def base_row(bag: str, status: int, verdict: str, error: str) -> dict[str, Any]:
    """The columns every verb's row starts with."""
    return {"bag": str(bag), "verdict": verdict, "exit_status": int(status),
            "error": error or None, "storage": _storage(bag), "messages": None, "counts": {},
            "start_ns": None, "duration_s": math.nan, "recovered": None}  # fmt: skip


def _storage(bag: str) -> str | None:
    from .files import BagReadError, resolve

    try:
        return resolve(bag, require_metadata=False).storage
    except BagReadError:
        return None


def count_columns(counts: dict[str, int], start_ns: int | None, end_ns: int | None,
                  recovered: bool) -> dict[str, Any]:  # fmt: skip
    """Messages in all, per topic, the first log time [ns] and the duration [s]."""
    duration = (seconds_from_ns(end_ns - start_ns)
                if start_ns is not None and end_ns is not None else None)  # fmt: skip
    return {"messages": sum(counts.values()), "counts": dict(counts), "start_ns": start_ns,
            "duration_s": math.nan if duration is None else duration,
            "recovered": bool(recovered)}  # fmt: skip


def param_columns(params) -> dict[str, float]:
    """``param_<name>`` of every numeric model parameter (NaN when none was used)."""
    return {f"param_{k}": (math.nan if params is None else float(getattr(params, k)))
            for k in NUMERIC_FIELDS}  # fmt: skip


def timed_row(bag: str, row_function: Callable, args: argparse.Namespace) -> dict:
    """``row_function(bag, args)`` with its wall time as ``task_s`` (what a worker runs)."""
    start = time.perf_counter()
    row = row_function(bag, args)
    row["task_s"] = time.perf_counter() - start
    return row


def run_rows(row_function: Callable, bags: Sequence[str], args: argparse.Namespace,
             description: str, progress: bool | None = None) -> list[dict]:  # fmt: skip
    """One row per bag, in order, computed on Dask (``args.jobs``, ``args.scheduler``); a task
    that raised anyway is a row with its error."""
    from drs_model.cluster import TaskFailure, dask_client, map_unordered

    rows: list[dict | None] = [None] * len(bags)
    with dask_client(args.scheduler, args.jobs) as client:
        for i, result in map_unordered(client, timed_row, bags, description=description,
                                       progress=progress, row_function=row_function,
                                       args=args):  # fmt: skip
            if isinstance(result, TaskFailure):
                result = base_row(bags[i], EXIT_INTERNAL, "INTERNAL ERROR",
                                  f"internal error: {result}")  # fmt: skip
                result["task_s"] = math.nan
            rows[i] = result
    return [r for r in rows if r is not None]


def to_table(rows: list[dict]):
    """The rows as a ``pyarrow.Table`` (columns in the order they first appear; a dict value a
    map column, e.g. ``counts`` of topic to messages; a list a list of strings; a NaN a null)."""
    import pyarrow as pa

    columns: dict[str, None] = {}
    for row in rows:
        columns.update(dict.fromkeys(row))
    data = {c: [row.get(c) for row in rows] for c in columns}
    fields = []
    for name, values in data.items():
        sample = next((v for v in values if v not in (None, {}, [])), None)
        if isinstance(sample, dict):  # topic -> count or type: a map column
            inner = next(iter(sample.values()))
            kind = pa.map_(pa.string(), pa.int64() if isinstance(inner, int) else pa.string())
            data[name] = [list((v or {}).items()) for v in values]
        elif any(isinstance(v, list) for v in values):  # empty in every row, too
            kind = pa.list_(pa.string())
        else:
            kind = (pa.bool_() if isinstance(sample, bool) else
                    pa.int64() if isinstance(sample, int) else
                    pa.float64() if isinstance(sample, float) else pa.string())  # fmt: skip
            if kind == pa.float64():  # NaN (nothing to say) is a null: a missing value
                data[name] = [None if v is None or v != v else float(v) for v in values]
        fields.append(pa.field(name, kind))
    return pa.table(data, schema=pa.schema(fields))


def format_summary(rows: list[dict], columns: Sequence[str]) -> str:
    """One line per bag (verdict, the ``columns`` given, the error), then the verdicts counted."""
    lines = []
    width = max([len(r["bag"]) for r in rows] + [3])
    head = f"{'bag':<{width}}  {'verdict':<14}" + "".join(f" {c:>14}" for c in columns)
    lines += [head, "-" * len(head)]
    for r in rows:
        cells = []
        for c in columns:
            v = r.get(c)
            if v is None or (isinstance(v, float) and math.isnan(v)):
                cells.append(f" {'-':>14}")
            else:
                cells.append(f" {v:>14.4g}" if isinstance(v, float) else f" {v!s:>14}")
        line = f"{r['bag']:<{width}}  {r['verdict']:<14}" + "".join(cells)
        lines.append(line + (f"  {r['error']}" if r.get("error") else ""))
    tally: dict[str, int] = {}
    for r in rows:
        tally[r["verdict"]] = tally.get(r["verdict"], 0) + 1
    lines.append("")
    lines.append(f"{len(rows)} bags: " + ", ".join(f"{n} {v}" for v, n in sorted(tally.items())))
    return "\n".join(lines)


def run_fleet(row_function: Callable, args: argparse.Namespace, prog: str, done: str,
              columns: Sequence[str] = ("messages", "duration_s")) -> int:  # fmt: skip
    """A verb over many bags: find them, run ``row_function`` on each on Dask, write the table
    (``-o``), print the summary; the exit status (see the module docstring)."""
    try:
        if args.output and not table_path(args):
            raise FleetError(f"-o {args.output!r}: with many bags, -o names the table, a "
                             ".parquet file")  # fmt: skip
        bags = [str(b) for b in find_bags(args.bag)]
        if not bags:
            raise FleetError(f"no bag under {', '.join(map(repr, args.bag))}")
        rows = run_rows(row_function, bags, args, f"bags {done}")
        out = table_path(args)
        if out:
            import pyarrow.parquet as pq

            try:
                pq.write_table(to_table(rows), out)
            except OSError as exc:
                raise FleetError(f"cannot write the table {out!r}: {exc}") from exc
    except (FleetError, DRSError) as exc:  # the fleet's own, or the cluster's (--jobs, --scheduler)
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    print(format_summary(rows, columns))
    if out:
        print(f"table: {out} ({len(rows)} rows)")
    return EXIT_OK if all(r["exit_status"] == EXIT_OK for r in rows) else EXIT_FAILED


__all__ = [
    "FleetError",
    "add_fleet_arguments",
    "base_row",
    "count_columns",
    "find_bags",
    "format_summary",
    "is_fleet",
    "param_columns",
    "run_fleet",
    "run_rows",
    "table_path",
    "timed_row",
    "to_table",
]
