"""``drs-bag recover BAG -o OUT``: a SIGKILLed or truncated recording made whole again.

Reads the damaged bag sequentially (:func:`drs_ros.bag.reader.scan` with ``recover``: chunk CRCs
checked, exact CDR bytes checked) up to its first truncated or corrupt record, and writes every
complete message before it into a new rosbag2 bag directory ``OUT`` (MCAP with its summary, plus
``metadata.yaml``): schemas, channel metadata, times and sequence numbers copied as they were.
It then reports what was kept and what was lost. Readers that need the summary (rosbags,
mcap_ros2's seeking reader, ``ros2 bag``) read the result.

Exit status: 0 the result holds every message of a bag that was complete; 3 the bag was damaged
and the result holds its readable part (the report says what was lost); 2 nothing was readable,
or OUT cannot be written (one line on stderr, OUT not created).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from drs_model.errors import DRSError

from ..recording import McapRecorder, check_new_bag, parse_qos_yaml
from .reader import scan


def recover(bag: str | Path, out: str | Path) -> dict:
    """Copy every complete message of ``bag`` into the new bag directory ``out``; a report.

    Raises
    ------
    BagReadError
        Nothing of ``bag`` is readable.
    RecordingError
        ``out`` exists with files, or cannot be written.
    """
    check_new_bag(out)
    messages: list = []
    result = scan(bag, messages.append, recover=True)
    made = not Path(out).exists()
    try:
        with McapRecorder(out, flush_thread=False) as rec:
            for channel in result.channels.values():
                rec.register_recorded_topic(
                    channel.topic, channel.type_name, channel.schema_data,
                    channel.schema_encoding or "ros2msg",
                    parse_qos_yaml(channel.metadata.get("offered_qos_profiles", "")),
                    channel.metadata.get("topic_type_hash", ""),
                )  # fmt: skip
            for m in messages:
                rec.write(m.topic, m.data, m.log_time, m.publish_time, sequence=m.sequence)
    except Exception:
        if made:
            shutil.rmtree(out, ignore_errors=True)
        raise
    last = max((m.log_time for m in messages), default=None)
    return {
        "source": str(result.path),
        "output": str(out),
        "complete_source": result.complete,
        "messages": result.message_count,
        "per_topic": dict(result.counts),
        "last_log_time_ns": last,
        "stopped_at_offset": result.stopped_at,
        "file_size": result.file_size,
        "bytes_lost": result.file_size - result.last_good_offset if not result.complete else 0,
        "reason": result.reason,
    }


def format_report(rep: dict) -> str:
    lines = [f"recovered {rep['messages']} messages from {rep['source']} into {rep['output']}"]
    for topic, n in sorted(rep["per_topic"].items()):
        lines.append(f"  {topic:<34} {n:>8}")
    if rep["complete_source"]:
        lines.append("the source was complete: nothing was lost")
    else:
        last = rep["last_log_time_ns"]
        lines.append(
            f"lost: everything after offset {rep['stopped_at_offset']} of {rep['file_size']} "
            f"({rep['bytes_lost']} bytes): {rep['reason']}"
        )
        if last is not None:
            lines.append(f"last recovered message logged at {last * 1e-9:.9f} s")
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("bag", help="the damaged bag directory or .mcap file")
    ap.add_argument("-o", "--output", required=True, help="the new bag directory to write")
    ap.add_argument("--json", action="store_true", help="print the report as JSON")


def run(args: argparse.Namespace, prog: str = "drs-bag recover") -> int:
    try:
        rep = recover(args.bag, args.output)
    except DRSError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(rep, indent=2) if args.json else format_report(rep))
    return 0 if rep["complete_source"] else 3


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="drs-bag recover", description=__doc__.splitlines()[0])
    add_arguments(ap)
    return run(ap.parse_args(argv))


__all__ = ["add_arguments", "format_report", "main", "recover", "run"]
