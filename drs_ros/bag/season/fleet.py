"""Many bags at once: ``drs-bag check`` and ``drs-bag resimulate`` over a fleet of bags, on Dask.

The bags are named by paths, directories (searched recursively: a directory holding
``metadata.yaml``, or ``.mcap`` / ``.db3`` files, is one bag; others are searched) and globs
(``'runs/**/*.mcap'``, quoted, expanded here). Each bag is one task on a
:func:`drs_model.cluster.dask_client` (an embedded ``LocalCluster`` of ``--jobs`` worker processes,
or the cluster at ``--scheduler``), run by the verb's row function, which never raises for the
bag's faults: a damaged bag is a row with its error, never the end of the run. The result is one
table, one row per drs node of each bag (:func:`row_nodes`: a bag of two actuators gives two
rows; ``--node NAME`` keeps that node's), in the order the bags were found, written as Parquet
(``-o table.parquet``, pyarrow) and printed as a summary; a progress bar shows on a terminal.

A directory is walked once per real directory: a symbolic link to a directory already walked,
or to one that holds it (a ``latest`` link in a season's tree), is not followed again, and a bag
reached by two paths is one bag (by its resolved path), named by the first path that found it;
a glob's ``**`` does not descend into linked directories.

Columns every verb writes (:func:`base_row`, :func:`count_columns`, :func:`param_columns`):
``bag``, ``node`` (the drs node's fully qualified name; null for a bag that names none),
``verdict``, ``exit_status`` (what the verb alone would exit with), ``error`` (null when
there is none), ``task_s`` (wall time of the task [s]), ``storage``, ``messages`` (all topics),
``counts`` (topic -> messages), ``start_ns``, ``duration_s``, ``recovered``, and ``param_<name>``
(the model parameters used, SI units). The verb adds its own (:mod:`drs_ros.bag.check.command`,
:mod:`drs_ros.bag.replay.resimulate`).

Exit status of a fleet run (docs/cli.md): 0 every bag passed, 1 any bag did not (the table says
which and why), 2 no bag was found, an option is invalid, or the table cannot be written.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import (
    EXIT_FAILED,
    EXIT_INTERNAL,
    EXIT_NOTHING_TO_RERUN,
    EXIT_OK,
    EXIT_RECOVERED,
    EXIT_UNREADABLE,
    EXIT_USAGE,
)
from drs_model.errors import DRSError
from drs_model.params import NUMERIC_FIELDS
from drs_ros.errors import DRSRosError
from drs_ros.timestamps import seconds_from_ns

_BAG_SUFFIXES = (".mcap", ".db3")
_GLOB_CHARS = set("*?[")


class FleetError(DRSRosError):
    """A fleet run cannot start: no bag found, or an invalid option."""


def add_fleet_arguments(ap: argparse.ArgumentParser, *table_flags: str) -> None:
    """``--jobs``, ``--scheduler``, and (``table_flags``, e.g. ``-o``) the table's path."""
    if table_flags:
        ap.add_argument(
            *table_flags,
            dest="output",
            default=None,
            type=output_path,
            help="with many bags: write the table, one row per bag, to this .parquet file",
        )
    ap.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="with many bags: worker processes of the embedded Dask cluster "
        "(default: the usable cores)",
    )
    ap.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="with many bags: run on the Dask cluster at ADDRESS "
        "(tcp://host:8786) instead of an embedded one",
    )


def _is_bag(path: Path) -> bool:
    """A bag by itself: a file, or a directory holding metadata.yaml or bag files."""
    if path.is_file():
        return True
    return path.is_dir() and (
        (path / "metadata.yaml").is_file() or any(p.suffix in _BAG_SUFFIXES for p in path.iterdir())
    )


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
    """The bags ``specs`` name, in order, each once (by its resolved path; named by the first
    path that found it): files and bag directories as given, globs expanded (sorted), other
    directories searched recursively (sorted, real directories before links; a link to a
    directory already searched, or to one being searched, is not followed).

    Raises
    ------
    FleetError
        A path that does not exist or a glob that matches nothing (unless ``missing_ok``).
    """
    found: dict[Path, Path] = {}  # resolved path -> the path that found it first
    walked: set[Path] = set()  # resolved directories searched (or being searched)

    def add(path: Path) -> None:
        found.setdefault(path.resolve(), path)

    def search(directory: Path) -> None:
        real = directory.resolve()
        if real in walked:
            return  # a link back into the tree, or to a directory already searched
        walked.add(real)
        if _is_bag(directory):
            add(directory)
            return
        children = sorted(directory.iterdir(), key=lambda c: (c.is_symlink(), c.name))
        for child in children:
            if child.is_dir():
                search(child)
            elif child.suffix in _BAG_SUFFIXES:  # pragma: no cover - _is_bag took the dir
                add(child)

    for spec in specs:
        matches = _glob(spec) if _GLOB_CHARS & set(spec) else [spec]
        if not matches and not missing_ok:
            raise FleetError(f"{spec!r} matches no file or directory")
        for match in matches:
            path = Path(match)
            if path.is_file():
                if path.suffix in _BAG_SUFFIXES or path.name == "metadata.yaml":
                    add(path.parent if path.name == "metadata.yaml" else path)
            elif path.is_dir():
                search(path)
            elif not missing_ok:
                raise FleetError(f"{str(path)!r}: no such bag file or directory")
    # a file inside a bag directory that is also listed is that bag, not another
    return [p for real, p in found.items() if not (real.is_file() and real.parent in found)]


def _glob(spec: str) -> list[str]:
    """A glob's matches, sorted (pathlib's: its ``**`` does not descend into a linked directory,
    where ``glob.glob``'s follows a link back up until the OS refuses, 2**40 paths for a tree
    with two such links)."""
    parts = Path(spec).parts
    first = next(i for i, part in enumerate(parts) if _GLOB_CHARS & set(part))
    base = Path(*parts[:first]) if first else Path()
    return sorted(str(p) for p in base.glob(str(Path(*parts[first:]))))


def row_nodes(bag: str, name: str | None) -> list:
    """The drs nodes of ``bag`` that get a row (:class:`drs_ros.bag.read.nodes.BagNode`): the one
    ``--node name`` picks, else every one; ``[None]`` for a bag that names none (one row).

    Raises
    ------
    NodeSelectionError
        ``name`` is given and names no node of the bag (:func:`no_node_row` is its row).
    """
    from drs_ros.bag.read.nodes import bag_nodes, select_node

    nodes = bag_nodes(bag)
    if name is not None:
        return [select_node(nodes, name, bag)]
    return list(nodes) or [None]


#: The verdict of each exit status that means the same in every verb (each verb names its own
#: verdicts of 0 and 1: :func:`verdicts`).
SHARED_VERDICTS = {
    EXIT_UNREADABLE: "UNREADABLE",
    EXIT_RECOVERED: "RECOVERED",
    EXIT_INTERNAL: "INTERNAL ERROR",
    EXIT_NOTHING_TO_RERUN: "NOTHING TO RE-RUN",
}


def verdicts(passed: str, failed: str) -> dict[int, str]:
    """A verb's verdict of each exit status: ``passed`` for 0, ``failed`` for 1 (a check fails,
    a re-run deviates, a fit is not determined), :data:`SHARED_VERDICTS` for the others."""
    return {EXIT_OK: passed, EXIT_FAILED: failed, **SHARED_VERDICTS}


def base_row(bag: str, status: int, verdict: str, error: str, node=None) -> dict[str, Any]:
    """The columns every verb's row starts with (``node``: the row's drs node, or None)."""
    return {
        "bag": str(bag),
        "node": None if node is None else node.name,
        "verdict": verdict,
        "exit_status": int(status),
        "error": error or None,
        "storage": _storage(bag),
        "messages": None,
        "counts": {},
        "start_ns": None,
        "duration_s": math.nan,
        "recovered": None,
    }


def no_node_row(bag: str, error: Exception) -> dict[str, Any]:
    """The row of a bag that holds no drs node of the name ``--node`` gives (a usage error, exit
    status 2, for that bag)."""
    return base_row(bag, EXIT_USAGE, "NO SUCH NODE", f"error: {error}")


def _storage(bag: str) -> str | None:
    from drs_ros.bag.read.files import BagReadError, resolve

    try:
        return resolve(bag, require_metadata=False).storage
    except BagReadError:
        return None


def count_columns(
    counts: dict[str, int], start_ns: int | None, end_ns: int | None, recovered: bool
) -> dict[str, Any]:
    """Messages in all, per topic, the first log time [ns] and the duration [s]."""
    duration = (
        seconds_from_ns(end_ns - start_ns) if start_ns is not None and end_ns is not None else None
    )
    return {
        "messages": sum(counts.values()),
        "counts": dict(counts),
        "start_ns": start_ns,
        "duration_s": math.nan if duration is None else duration,
        "recovered": bool(recovered),
    }


def param_columns(params) -> dict[str, float]:
    """``param_<name>`` of every numeric model parameter (NaN when none was used)."""
    return {
        f"param_{k}": (math.nan if params is None else float(getattr(params, k)))
        for k in NUMERIC_FIELDS
    }


def hydraulic_columns(node_parameters, hydraulic) -> dict[str, object]:
    """``param_hydraulic.<name>`` of every HydraulicParams field of ``hydraulic`` (the values
    used), only where the bag recorded its node's ``hydraulic.*`` parameters (none otherwise:
    a bag that never ran the hydraulic rung has no such columns)."""
    if hydraulic is None or not any(k.startswith("hydraulic.") for k in node_parameters or {}):
        return {}
    return {
        f"param_hydraulic.{f.name}": getattr(hydraulic, f.name)
        for f in dataclasses.fields(hydraulic)
    }


def timed_row(bag: str, row_function: Callable, args: argparse.Namespace) -> list[dict]:
    """``row_function(bag, args)`` (a bag's rows) with its wall time as each row's ``task_s``
    (what a worker runs)."""
    start = time.perf_counter()
    rows = row_function(bag, args)
    for row in rows:
        row["task_s"] = time.perf_counter() - start
    return rows


def run_rows(
    row_function: Callable,
    bags: Sequence[str],
    args: argparse.Namespace,
    description: str,
    progress: bool | None = None,
) -> list[dict]:
    """The rows of each bag (one per drs node), in order, computed on Dask (``args.jobs``,
    ``args.scheduler``); a task that raised anyway is a row with its error."""
    from drs_model.cluster import TaskFailure, dask_client, map_unordered

    rows: list[list[dict]] = [[] for _ in bags]
    with dask_client(args.scheduler, args.jobs) as client:
        for i, result in map_unordered(
            client,
            timed_row,
            bags,
            description=description,
            progress=progress,
            row_function=row_function,
            args=args,
        ):
            if isinstance(result, TaskFailure):
                failed = base_row(
                    bags[i],
                    EXIT_INTERNAL,
                    SHARED_VERDICTS[EXIT_INTERNAL],
                    f"internal error: {result}",
                )
                failed["task_s"] = math.nan
                result = [failed]
            rows[i] = result
    return [row for bag_rows in rows for row in bag_rows]


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
        if sample is None:  # only empty values, if any: their kind is the column's
            sample = next((v for v in values if v is not None), None)
        if isinstance(sample, dict):  # topic -> count or type: a map column
            inner = next(iter(sample.values()), 0)
            kind = pa.map_(pa.string(), pa.int64() if isinstance(inner, int) else pa.string())
            data[name] = [list((v or {}).items()) for v in values]
        elif any(isinstance(v, list) for v in values):  # empty in every row, too
            kind = pa.list_(pa.string())
        else:
            kind = (
                pa.bool_()
                if isinstance(sample, bool)
                else pa.int64()
                if isinstance(sample, int)
                else pa.float64()
                if isinstance(sample, float)
                else pa.string()
            )
            if kind == pa.float64():  # NaN (nothing to say) is a null: a missing value
                data[name] = [None if v is None or v != v else float(v) for v in values]
        fields.append(pa.field(name, kind))
    return pa.table(data, schema=pa.schema(fields))


def format_summary(rows: list[dict], columns: Sequence[str]) -> str:
    """One line per row (bag, its drs node when the bags name any, verdict, the ``columns``
    given, the error), then the verdicts counted."""
    lines = []
    width = max([len(r["bag"]) for r in rows] + [3])
    nodes = [r.get("node") or "-" for r in rows]
    node_width = max(len(n) for n in nodes) if any(r.get("node") for r in rows) else 0
    named = f" {'node':<{node_width}} " if node_width else ""
    head = f"{'bag':<{width}} {named} {'verdict':<14}" + "".join(f" {c:>14}" for c in columns)
    lines += [head, "-" * len(head)]
    for r, node in zip(rows, nodes, strict=True):
        cells = []
        for c in columns:
            v = r.get(c)
            if v is None or (isinstance(v, float) and math.isnan(v)):
                cells.append(f" {'-':>14}")
            else:
                cells.append(f" {v:>14.4g}" if isinstance(v, float) else f" {v!s:>14}")
        named = f" {node:<{node_width}} " if node_width else ""
        line = f"{r['bag']:<{width}} {named} {r['verdict']:<14}" + "".join(cells)
        lines.append(line + (f"  {r['error']}" if r.get("error") else ""))
    tally: dict[str, int] = {}
    for r in rows:
        tally[r["verdict"]] = tally.get(r["verdict"], 0) + 1
    bags = len({r["bag"] for r in rows})
    counted = f"{bags} bags" + (f", {len(rows)} rows" if len(rows) != bags else "")
    lines.append("")
    lines.append(f"{counted}: " + ", ".join(f"{n} {v}" for v, n in sorted(tally.items())))
    return "\n".join(lines)


def run_fleet(
    row_function: Callable,
    args: argparse.Namespace,
    prog: str,
    done: str,
    columns: Sequence[str] = ("messages", "duration_s"),
) -> int:
    """A verb over many bags: find them, run ``row_function`` on each on Dask, write the table
    (``-o``), print the summary; the exit status (see the module docstring)."""
    try:
        if args.output and not table_path(args):
            raise FleetError(
                f"-o {args.output!r}: with many bags, -o names the table, a .parquet file"
            )
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
    "SHARED_VERDICTS",
    "add_fleet_arguments",
    "base_row",
    "count_columns",
    "find_bags",
    "format_summary",
    "is_fleet",
    "no_node_row",
    "hydraulic_columns",
    "param_columns",
    "row_nodes",
    "run_fleet",
    "run_rows",
    "table_path",
    "timed_row",
    "to_table",
    "verdicts",
]
