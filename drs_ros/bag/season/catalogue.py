"""``drs-bag index DIR -o catalogue.parquet``: a catalogue of many bags from their summaries
alone, for fast queries (DuckDB, pandas, pyarrow).

For each bag :func:`drs_ros.bag.season.fleet.find_bags` finds, the columns of the fleet table that a
summary can give: ``bag``, ``storage``, ``source`` (where the figures come from), ``files``,
``size_bytes``, ``messages``, ``counts`` (topic -> messages), ``topics`` (topic -> type),
``start_ns``, ``duration_s``, ``ros_distro``, ``error``, and ``nodes``: the drs nodes the bag
holds, by their fully qualified names (:func:`drs_ros.bag.read.nodes.bag_nodes`: the only messages
decoded are the nodes' start records, from the chunks that hold them). They
come from ``metadata.yaml`` (as ``ros2 bag info`` reads it), else from each MCAP file's summary
section (its statistics and channels: a few KiB at the end of the file), else, for a ``.db3``,
from the database's ``topics`` table and the ``messages`` table's count and time range. A bag
whose summary cannot be read (an unfinished recording, a damaged file) is a row with its error.
Nothing is verified: ``drs-bag check`` does that, and its table has the same columns and more.

Exit status: 0 every bag was catalogued, 1 some rows carry an error, 2 no bag was found or the
table cannot be written.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from drs_ros.bag.read.files import BagReadError, resolve
from drs_ros.bag.read.nodes import bag_nodes
from drs_ros.bag.season import fleet


def _mcap_summary(files) -> tuple[dict, dict, int | None, int | None]:
    """counts, types, start [ns], end [ns] from the MCAP files' summary sections."""
    from mcap.reader import make_reader

    counts: dict[str, int] = {}
    types: dict[str, str] = {}
    start = end = None
    for file in files:
        try:
            with open(file, "rb") as f:
                summary = make_reader(f).get_summary()
        except Exception as exc:  # the mcap library's errors: a bad file, not a crash
            raise BagReadError(
                f"{str(file)!r}: no readable MCAP summary ({type(exc).__name__}: {exc})"
            ) from exc
        if summary is None or summary.statistics is None:
            raise BagReadError(
                f"{str(file)!r}: no summary statistics (an unfinished recording? "
                "drs-bag recover makes it whole)"
            )
        for cid, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            types.setdefault(channel.topic, schema.name if schema is not None else "")
            n = summary.statistics.channel_message_counts.get(cid, 0)
            counts[channel.topic] = counts.get(channel.topic, 0) + n
        stats = summary.statistics
        if stats.message_count:
            first, last = stats.message_start_time, stats.message_end_time
            start = first if start is None else min(start, first)
            end = last if end is None else max(end, last)
    return counts, types, start, end


def _sqlite_summary(bag) -> tuple[dict, dict, int | None, int | None]:
    """counts, types, start [ns], end [ns] of a sqlite3 bag's tables (no row decoded)."""
    import sqlite3

    counts: dict[str, int] = {}
    types: dict[str, str] = {}
    start = end = None
    for file in bag.files:
        try:
            with sqlite3.connect(f"file:{file}?mode=ro&immutable=1", uri=True) as db:
                rows = db.execute(
                    "SELECT topics.name, topics.type, count(messages.id), "
                    "min(messages.timestamp), max(messages.timestamp) FROM topics "
                    "LEFT JOIN messages ON messages.topic_id = topics.id "
                    "GROUP BY topics.id"
                ).fetchall()
            db.close()
        except sqlite3.Error as exc:
            raise BagReadError(
                f"{str(file)!r}: not a readable rosbag2 sqlite3 bag ({exc})"
            ) from exc
        for name, type_name, n, first, last in rows:
            types.setdefault(name, type_name)
            counts[name] = counts.get(name, 0) + n
            if n:
                start = first if start is None else min(start, first)
                end = last if end is None else max(end, last)
    return counts, types, start, end


def catalogue_row(bag: str | Path) -> dict[str, Any]:
    """The catalogue's row of one bag (see the module docstring); never raises for the bag."""
    row: dict[str, Any] = {
        "bag": str(bag),
        "storage": None,
        "source": None,
        "files": [],
        "size_bytes": None,
        "messages": None,
        "counts": {},
        "topics": {},
        "start_ns": None,
        "duration_s": math.nan,
        "ros_distro": None,
        "error": None,
        "nodes": [],
    }
    try:
        found = resolve(bag, require_metadata=False)
        row["storage"] = found.storage
        row["files"] = [f.name for f in found.files]
        row["size_bytes"] = sum(f.stat().st_size for f in found.files)
        meta = found.metadata
        if meta is not None:  # checked by the resolver (read_metadata)
            counts: dict[str, int] = {}
            types: dict[str, str] = {}
            for t in meta["topics_with_message_count"]:
                name = t["topic_metadata"]["name"]
                counts[name] = counts.get(name, 0) + t["message_count"]
                types.setdefault(name, t["topic_metadata"]["type"])
            start = meta["starting_time"]["nanoseconds_since_epoch"]
            end = start + meta["duration"]["nanoseconds"]
            row["source"], row["ros_distro"] = "metadata.yaml", meta.get("ros_distro")
        elif found.storage == "sqlite3":
            counts, types, start, end = _sqlite_summary(found)
            row["source"] = "sqlite3 tables"
        else:
            counts, types, start, end = _mcap_summary(found.files)
            row["source"] = "MCAP summary"
        row.update(fleet.count_columns(counts, start, end, False))
        del row["recovered"]
        row["topics"] = types
        row["nodes"] = [node.name for node in bag_nodes(found)]
    except (BagReadError, OSError) as exc:
        row["error"] = str(exc)
    return row


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("bag", nargs="+", help="directories searched for bags, bags, or globs")
    ap.add_argument(
        "-o", "--output", required=True, type=output_path, help="the catalogue, a .parquet file"
    )


def run(args: argparse.Namespace, prog: str = "drs-bag index") -> int:
    """Catalogue the bags; the exit status (see the module docstring)."""
    try:
        if not str(args.output).endswith(".parquet"):
            raise fleet.FleetError(f"-o {args.output!r}: the catalogue is a .parquet file")
        bags = fleet.find_bags(args.bag)
        if not bags:
            raise fleet.FleetError(f"no bag under {', '.join(map(repr, args.bag))}")
        rows = [catalogue_row(b) for b in _progress(bags)]
        import pyarrow.parquet as pq

        try:
            pq.write_table(fleet.to_table(rows), args.output)
        except OSError as exc:
            raise fleet.FleetError(f"cannot write the catalogue {args.output!r}: {exc}") from exc
    except fleet.FleetError as exc:  # -o, no bag found, or the catalogue cannot be written
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    bad = [r for r in rows if r["error"]]
    for r in bad:
        print(f"{r['bag']}: {r['error']}", file=sys.stderr)
    print(
        f"catalogued {len(rows)} bags ({sum(r['messages'] or 0 for r in rows)} messages, "
        f"{len(bad)} with an error) into {args.output}"
    )
    return EXIT_FAILED if bad else EXIT_OK


def _progress(items):
    """A tqdm bar over ``items`` on a terminal."""
    if not sys.stderr.isatty():
        return items
    from tqdm import tqdm

    return tqdm(items, desc="bags indexed", unit="bag", file=sys.stderr)


__all__ = ["add_arguments", "catalogue_row", "run"]
