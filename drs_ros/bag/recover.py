"""``drs-bag recover BAG -o OUT``: a SIGKILLed or truncated recording made whole again.

Reads the damaged bag sequentially (:func:`drs_ros.bag.read.reader.scan` with ``recover``: chunk
CRCs
checked, exact CDR bytes checked), every file of a split bag in order, each up to its first
truncated or corrupt record, and copies every complete message into a new rosbag2 bag directory
``OUT`` (one MCAP file with its summary, plus ``metadata.yaml`` counting what was written):
schemas, channel metadata, times and sequence numbers copied as they were. It then reports what
was kept and what was lost, per file, and the drs nodes whose records it holds
(:mod:`drs_ros.bag.read.nodes`: their names and topics). Readers that need the summary (rosbags,
mcap_ros2's seeking reader, ``ros2 bag``) read the result.

Exit status: 0 the result holds every message of a bag that was complete; 3 the bag was damaged
and the result holds its readable part (the report says what was lost); 2 nothing was readable,
the bag's ``metadata.yaml`` is malformed, or OUT exists or cannot be written (one line on
stderr, OUT not created); 4 copying a message that passed every check failed for another reason
(one line ``internal error``, OUT not created). OUT is never left holding part of what was read.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from drs_model.cli._common import output_path
from drs_model.cli.exit_status import EXIT_INTERNAL, EXIT_OK, EXIT_RECOVERED, EXIT_UNREADABLE
from drs_ros.bag.new_bag import new_bag
from drs_ros.bag.read.files import BagReadError
from drs_ros.bag.read.nodes import bag_nodes, nodes_text
from drs_ros.bag.read.reader import scan
from drs_ros.bag.read.recorded import ChannelInfo, MessageCallbackError, RecordedMessage
from drs_ros.recording.destinations import check_new_bag
from drs_ros.recording.errors import RecordingError
from drs_ros.recording.mcap_recorder import McapRecorder
from drs_ros.recording.qos import parse_qos_yaml
from drs_ros.timestamps import split_ns


def _register(rec: McapRecorder, channel: ChannelInfo) -> None:
    rec.register_recorded_topic(
        channel.topic,
        channel.type_name,
        channel.schema_data,
        channel.schema_encoding or "ros2msg",
        parse_qos_yaml(channel.metadata.get("offered_qos_profiles", "")),
        channel.metadata.get("topic_type_hash", ""),
    )


def _unwritable(out: str | Path, cause: BaseException) -> RecordingError:
    return RecordingError(
        f"cannot write the recovered bag {str(out)!r} ({type(cause).__name__}: {cause}); "
        "nothing of it was kept"
    )


def recover(bag: str | Path, out: str | Path) -> dict:
    """Copy every complete message of ``bag`` (every file of a split bag, in order) into the new
    bag directory ``out``; a report (JSON-ready), with one entry per source file in ``files``.

    Raises
    ------
    BagReadError
        Nothing of ``bag`` is readable, or its ``metadata.yaml`` is malformed.
    RecordingError
        ``out`` exists with files, or cannot be written (nothing of it is left).
    MessageCallbackError
        Copying a message failed for a reason other than writing ``out`` (nothing is left).
    """
    check_new_bag(out)
    last: list[int] = []

    def copy(m: RecordedMessage) -> None:
        if m.topic not in rec.topics:
            _register(rec, m.channel)
        rec.write(m.topic, m.data, m.log_time, m.publish_time, sequence=m.sequence)
        last[:] = [max(last[0], m.log_time)] if last else [m.log_time]

    with new_bag(out) as rec:
        try:
            result = scan(bag, copy, recover=True)
            for channel in result.channels.values():  # topics without a message too
                if channel.topic not in rec.topics:
                    _register(rec, channel)
        except MessageCallbackError as exc:  # copying failed: OUT's fault, never the source's
            if isinstance(exc.__cause__, (OSError, RecordingError)):
                raise _unwritable(out, exc.__cause__) from exc
            raise
        try:
            rec.finish()
        except OSError as exc:
            raise _unwritable(out, exc) from exc
    files = [
        {
            "file": str(part.path),
            "complete": part.complete,
            "messages": part.message_count,
            "per_topic": dict(part.counts),
            "stopped_at_offset": part.stopped_at,
            "file_size": part.file_size,
            "bytes_lost": 0 if part.complete else part.file_size - part.last_good_offset,
            "reason": part.reason,
        }
        for part in result.file_scans
    ]
    return {
        "source": str(result.path),
        "output": str(out),
        "complete_source": result.complete,
        "messages": result.message_count,
        "per_topic": dict(result.counts),
        "last_log_time_ns": last[0] if last else None,
        "stopped_at_offset": result.stopped_at,
        "file_size": result.file_size,
        "bytes_lost": sum(f["bytes_lost"] for f in files),
        "reason": result.reason,
        "files": files,
        "nodes": [node.summary() for node in bag_nodes(out)],
    }


def format_report(rep: dict) -> str:
    lines = [f"recovered {rep['messages']} messages from {rep['source']} into {rep['output']}"]
    for topic, n in sorted(rep["per_topic"].items()):
        lines.append(f"  {topic:<34} {n:>8}")
    files = rep.get("files", [])
    if rep["complete_source"]:
        lines.append("the source was complete: nothing was lost")
    elif len(files) <= 1:
        lines.append(
            f"lost: everything after offset {rep['stopped_at_offset']} of {rep['file_size']} "
            f"({rep['bytes_lost']} bytes): {rep['reason']}"
        )
    else:
        lines.append(f"lost: {rep['bytes_lost']} bytes of {len(files)} files")
        for f in files:
            name = Path(f["file"]).name
            if f["complete"]:
                lines.append(f"  {name}: complete, {f['messages']} messages, nothing lost")
            else:
                lines.append(
                    f"  {name}: {f['messages']} messages kept; everything after offset "
                    f"{f['stopped_at_offset']} of {f['file_size']} lost ({f['bytes_lost']} "
                    f"bytes): {f['reason']}"
                )
    last = rep["last_log_time_ns"]
    if not rep["complete_source"] and last is not None:
        sec, nanosec = split_ns(last)  # exact: a float of epoch seconds keeps ~0.2 us
        lines.append(f"last recovered message logged at {sec}.{nanosec:09d} s")
    nodes = rep.get("nodes", [])
    lines.append(f"drs nodes: {len(nodes) or 'none named by the bag'}")
    lines += [f"  {line}" for line in nodes_text(nodes, rep["per_topic"])]
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("bag", help="the damaged bag directory (split or not) or .mcap file")
    ap.add_argument(
        "-o", "--output", required=True, type=output_path, help="the new bag directory to write"
    )
    ap.add_argument("--json", action="store_true", help="print the report as JSON")


def run(args: argparse.Namespace, prog: str = "drs-bag recover") -> int:
    try:
        rep = recover(args.bag, args.output)
    except MessageCallbackError as exc:  # our own failure on an intact message
        print(f"{prog}: internal error (not a verdict on the bag): {exc}", file=sys.stderr)
        return EXIT_INTERNAL
    except (BagReadError, RecordingError) as exc:  # nothing readable, or OUT cannot be written
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_UNREADABLE
    print(json.dumps(rep, indent=2) if args.json else format_report(rep))
    return EXIT_OK if rep["complete_source"] else EXIT_RECOVERED


__all__ = ["add_arguments", "format_report", "recover", "run"]
