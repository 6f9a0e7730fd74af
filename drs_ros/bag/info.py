"""``drs-bag info BAG``: what a bag holds, printed as ``ros2 bag info`` prints it, then the drs
nodes it holds, each with its topics by role (:mod:`drs_ros.bag.read.nodes`).

From ``metadata.yaml`` when the bag directory has one (as ``ros2 bag info`` does), else from a
scan of the files (a bare ``.mcap``, or an unfinished recording, split or not: then said so).
A malformed ``metadata.yaml`` is an error (exit status 2, one line naming the file and the field).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from drs_model.cli.exit_status import EXIT_OK, EXIT_UNREADABLE
from drs_ros.bag.read.files import BagReadError, resolve
from drs_ros.bag.read.nodes import bag_nodes, nodes_text
from drs_ros.bag.read.reader import scan
from drs_ros.recording import msgdefs
from drs_ros.timestamps import split_ns

_INDENT = " " * 19
SERVICE_EVENT_TOPIC_SUFFIX = "/_service_event"


def _size(n: int) -> str:
    units = ["B", "KiB", "MiB", "GiB", "TiB"]
    size, i = float(n), 0
    while size >= 1024 and i < 4:
        size /= 1024
        i += 1
    return f"{size:.0f} {units[i]}" if i == 0 else f"{size:.1f} {units[i]}"


def _point(ns: int) -> str:
    sec, frac = split_ns(ns)
    tm = time.localtime(sec)
    return f"{time.strftime('%b %e %Y %H:%M:%S', tm)}.{frac:09d} ({sec}.{frac:09d})"


def _is_service_event(topic: str, type_name: str) -> bool:
    try:
        return topic.endswith(SERVICE_EVENT_TOPIC_SUFFIX) and msgdefs.is_service_event(type_name)
    except msgdefs.MessageDefinitionError:  # a type that is not installed: not a service event
        return False


def bag_summary(path: str | Path) -> dict:
    """Files, size, storage, distro, start [ns], duration [ns], topics with type and count, and
    the drs nodes (``nodes``: name, topics by role, where they come from).

    Raises
    ------
    BagReadError
        The bag cannot be found or read, or its ``metadata.yaml`` is malformed.
    """
    info = _files_summary(path)
    info["nodes"] = [node.summary() for node in bag_nodes(path)]
    return info


def _files_summary(path: str | Path) -> dict:
    """:func:`bag_summary` but the nodes."""
    bag = resolve(path, require_metadata=False)
    meta = bag.metadata
    if meta is not None:  # checked by the resolver (drs_ros.bag.read.files.read_metadata)
        topics = [
            (
                t["topic_metadata"]["name"],
                t["topic_metadata"]["type"],
                t["message_count"],
                t["topic_metadata"].get("serialization_format", "cdr"),
            )
            for t in meta["topics_with_message_count"]
        ]
        return {
            "files": [f.name for f in bag.files],
            "size": sum(f.stat().st_size for f in bag.files),
            "storage": meta.get("storage_identifier", "mcap"),
            "distro": meta.get("ros_distro") or "unknown",
            "start_ns": meta["starting_time"]["nanoseconds_since_epoch"],
            "duration_ns": meta["duration"]["nanoseconds"],
            "topics": topics,
            "source": "metadata.yaml",
        }
    result = scan(path, recover=True, exact=False)
    topics = [
        (c.topic, c.type_name, result.counts.get(c.topic, 0), c.message_encoding)
        for c in result.channels.values()
    ]
    start = result.start_ns or 0
    source = "the files" if result.parts else "the file"
    return {
        "files": [f.name for f in bag.files],
        "size": result.file_size,
        "storage": bag.storage,
        "distro": "unknown",
        "start_ns": start,
        "duration_ns": (result.end_ns or start) - start,
        "topics": topics,
        "source": source + ("" if result.complete else f" (incomplete: {result.reason})"),
    }


def format_info(info: dict) -> str:
    """The ``ros2 bag info`` text of :func:`bag_summary`."""
    plain = [t for t in info["topics"] if not _is_service_event(t[0], t[1])]
    services = [t for t in info["topics"] if _is_service_event(t[0], t[1])]
    end = info["start_ns"] + info["duration_ns"]
    sec, frac = split_ns(info["duration_ns"])
    lines = [
        "",
        "Files:             " + f"\n{_INDENT}".join(info["files"]),
        f"Bag size:          {_size(info['size'])}",
        f"Storage id:        {info['storage']}",
        f"ROS Distro:        {info['distro']}",
        f"Duration:          {sec}.{frac:09d}s",
        f"Start:             {_point(info['start_ns'])}",
        f"End:               {_point(end)}",
        f"Messages:          {sum(t[2] for t in plain)}",
    ]
    rows = [
        f"Topic: {n} | Type: {t} | Count: {c} | Serialization Format: {f}" for n, t, c, f in plain
    ]
    lines.append("Topic information: " + f"\n{_INDENT}".join(rows))
    lines.append(f"Service:           {len(services)}")
    rows = [
        f"Service: {n.removesuffix(SERVICE_EVENT_TOPIC_SUFFIX)} | "
        f"Type: {t.removesuffix(msgdefs.SERVICE_EVENT_SUFFIX)} | Event Count: {c} | "
        f"Serialization Format: {f}"
        for n, t, c, f in services
    ]
    lines.append("Service information: " + f"\n{_INDENT}  ".join(rows))
    if info["source"] != "metadata.yaml":
        lines.append(f"(read from {info['source']}: no metadata.yaml)")
    nodes = info.get("nodes", [])
    lines.append(f"DRS nodes:         {len(nodes) or 'none named by the bag'}")
    held = [t[0] for t in info["topics"]]
    lines += [f"{_INDENT}{line}" for line in nodes_text(nodes, held)]
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("bag", help="bag directory or .mcap file")
    ap.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args: argparse.Namespace, prog: str = "drs-bag info") -> int:
    try:
        info = bag_summary(args.bag)
    except (BagReadError, OSError) as exc:
        msg = str(exc) if isinstance(exc, BagReadError) else f"{args.bag}: {exc}"
        print(f"{prog}: error: {msg}", file=sys.stderr)
        return EXIT_UNREADABLE
    print(json.dumps(info, indent=2) if args.json else format_info(info))
    return EXIT_OK


__all__ = ["add_arguments", "bag_summary", "format_info", "run"]
