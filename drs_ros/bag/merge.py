"""``drs-bag merge A B ... -o OUT``: several bags in one new rosbag2 bag, byte for byte.

What two actuators recorded into their own bags (two nodes, under different names or
namespaces) becomes one bag, as ``mcap merge`` makes one: every message keeps its bytes, its log
and publish times and its sequence number; a topic that several bags hold is one channel when its
type and schema are the same in each (its offered QoS profiles are those of every bag, each
once), and a schema is written once. The messages are written in log-time order: each bag's in
the order it recorded them (a record written before the states of its tick stays before them,
which ``resimulate`` needs), the bags interleaved by log time (a tie goes to the bag named
first). OUT is drs's MCAP recorder's bag: one MCAP file with its summary, and ``metadata.yaml``
in rosbag2's layout (:mod:`drs_ros.recording.bag_metadata`). ``check``, ``resimulate``, ``fit``
and ``play`` then pick a node with ``--node``.

Every source is verified first (:func:`drs_ros.bag.read.reader.scan`: every byte) and refused whole
if anything of it is wrong. Refused too, before OUT is made: fewer than two bags, one bag named
twice, a topic whose type or schema differs between two bags, and one drs node in two bags (the
merged bag could not tell their runs apart).

Exit status (docs/cli.md): 0 written; 2 a bad option, a source unreadable or refused (above), or
OUT exists or cannot be written (one line on stderr, OUT not created).
"""

from __future__ import annotations

import argparse
import heapq
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import EXIT_OK, EXIT_UNREADABLE
from drs_ros.bag.new_bag import new_bag
from drs_ros.bag.read.files import BagReadError, resolve
from drs_ros.bag.read.recorded import ChannelInfo, RecordedMessage
from drs_ros.errors import DRSRosError
from drs_ros.recording.destinations import check_new_bag
from drs_ros.recording.errors import RecordingError
from drs_ros.recording.qos import parse_qos_yaml


class MergeError(DRSRosError, ValueError):
    """Bags that cannot be merged into one: fewer than two, one named twice, or what they hold
    conflicts (the message names both bags). Exit status 2."""


def bag_messages(path: str | Path) -> Iterator[RecordedMessage]:
    """Every message of a bag in the order it was recorded, file after file, each with its
    channel. Nothing is verified here (:func:`drs_ros.bag.read.reader.scan` does)."""
    bag = resolve(path)
    if bag.storage == "sqlite3":
        from drs_ros.bag.read import sqlite

        channels = {c["id"]: ChannelInfo(**c) for c in sqlite.channels(bag)}
        for row, rec in enumerate(sqlite.iter_rows(bag), start=1):
            yield RecordedMessage.of_record(channels[rec.channel_id], rec, row)
        return
    for file in bag.files:
        yield from _mcap_messages(file)


def _mcap_messages(file: Path) -> Iterator[RecordedMessage]:
    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import StreamReader

    from drs_ros.bag.read.mcap_file import chunk_records
    from drs_ros.recording.mcap_private import record_stream
    from drs_ros.recording.mcap_records import MAGIC

    schemas: dict[int, Schema] = {}
    channels: dict[int, ChannelInfo] = {}
    with open(file, "rb") as f:
        reader = StreamReader(f, emit_chunks=True)
        stream = record_stream(reader)  # its byte count is the offset of the next record
        at = len(MAGIC)
        for record in reader.records:
            for rec in chunk_records(record) if isinstance(record, Chunk) else (record,):
                if isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    channels[rec.id] = ChannelInfo.of_record(rec, schemas.get(rec.schema_id))
                elif isinstance(rec, Message):
                    yield RecordedMessage.of_record(channels[rec.channel_id], rec, at)
            at = stream.count


def merged_messages(sources: Sequence[str | Path]) -> Iterator[RecordedMessage]:
    """The messages of ``sources``, each bag's in its recorded order, interleaved by log time
    (ties: the bag named first)."""
    return heapq.merge(*(bag_messages(s) for s in sources), key=lambda m: m.log_time)


def merged_channels(scans: Sequence) -> dict[str, tuple[ChannelInfo, list[dict]]]:
    """topic -> (its channel, the offered QoS profiles of every bag, each once), from the
    :class:`~drs_ros.bag.read.recorded.BagScan` of each source.

    Raises
    ------
    MergeError
        A topic whose type or schema differs between two bags.
    """
    out: dict[str, tuple[ChannelInfo, list[dict]]] = {}
    first: dict[str, Path] = {}
    for scan in scans:
        for channel in scan.channels.values():
            profiles = parse_qos_yaml(channel.metadata.get("offered_qos_profiles", ""))
            known = out.get(channel.topic)
            if known is None:
                out[channel.topic], first[channel.topic] = (channel, profiles), scan.path
                continue
            kept, held = known
            if (kept.type_name, kept.schema_data) != (channel.type_name, channel.schema_data):
                what = (
                    "is " + kept.type_name
                    if kept.type_name != channel.type_name
                    else "has another definition of " + kept.type_name
                )
                raise MergeError(
                    f"{channel.topic} {what} in {str(first[channel.topic])!r} than "
                    f"{channel.type_name} in {str(scan.path)!r}"
                )
            held += [p for p in profiles if p not in held]
    return out


def _verify(sources: Sequence[str | Path]) -> list:
    """Each source's verified scan; its drs nodes, each in one bag only."""
    from drs_ros.bag.read.nodes import bag_nodes
    from drs_ros.bag.read.reader import scan

    if len(sources) < 2:
        raise MergeError(f"merge takes two bags or more, got {len(sources)}")
    seen: dict[Path, str] = {}
    for source in sources:
        real = Path(source).resolve()
        if real in seen:
            raise MergeError(f"{str(source)!r} and {seen[real]!r} are the same bag")
        seen[real] = str(source)
    scans, owner = [], {}
    for source in sources:
        scans.append(scan(source))
        for node in bag_nodes(source):
            if node.name in owner:
                raise MergeError(
                    f"the drs node {node.name} is in {owner[node.name]!r} and {str(source)!r}: "
                    "the merged bag could not tell their runs apart (record each node under its "
                    "own name or namespace)"
                )
            owner[node.name] = str(source)
    return scans


def merge(sources: Sequence[str | Path], out: str | Path) -> dict:
    """Write the messages of ``sources`` into the new bag directory ``out`` (module docstring);
    a report: the output, each source's and the total messages per topic.

    Raises
    ------
    BagReadError
        A source cannot be read, or fails its verification.
    MergeError
        The sources cannot be merged (module docstring).
    RecordingError
        ``out`` exists with files, or cannot be written (nothing of it is left).
    """
    check_new_bag(out)
    scans = _verify(sources)
    channels = merged_channels(scans)
    with new_bag(out) as rec:
        for channel, profiles in channels.values():
            rec.register_recorded_topic(
                channel.topic,
                channel.type_name,
                channel.schema_data,
                channel.schema_encoding or "ros2msg",
                profiles,
                channel.metadata.get("topic_type_hash", ""),
            )
        counts: dict[str, int] = {}
        for m in merged_messages(sources):
            rec.write(m.topic, m.data, m.log_time, m.publish_time, sequence=m.sequence)
            counts[m.topic] = counts.get(m.topic, 0) + 1
        rec.finish()
    return {
        "output": str(out),
        "sources": [
            {"bag": str(source), "messages": s.message_count}
            for source, s in zip(sources, scans, strict=True)
        ],
        "messages": sum(counts.values()),
        "per_topic": counts,
    }


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument(
        "bags",
        nargs="+",
        metavar="BAG",
        help="the bags to merge (directories, .mcap or .db3 files), two or more",
    )
    ap.add_argument(
        "-o", "--output", required=True, type=output_path, help="the new bag directory to write"
    )


def run(args: argparse.Namespace, prog: str = "drs-bag merge") -> int:
    try:
        rep = merge(args.bags, args.output)
    except (BagReadError, MergeError, RecordingError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_UNREADABLE
    print(f"merged {rep['messages']} messages of {len(rep['sources'])} bags into {rep['output']}")
    for source in rep["sources"]:
        print(f"  {source['bag']}: {source['messages']} messages")
    return EXIT_OK


__all__ = [
    "MergeError",
    "add_arguments",
    "bag_messages",
    "merge",
    "merged_channels",
    "merged_messages",
    "run",
]
