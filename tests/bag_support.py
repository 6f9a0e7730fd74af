"""Bags made from other bags for tests: a copy with some messages changed (a tampered bag), and
several real bags merged into one (two drs nodes in one bag), written as rosbag2 writes a bag
(drs's MCAP recorder: one MCAP file with its summary, and metadata.yaml).

Every source is read verified (:func:`drs_ros.bag.read.reader.scan`); channels keep their schema and
metadata (the first source's, for a topic two sources share); messages keep their bytes, times
and sequence numbers, in the order ``drs-bag merge`` writes them
(:func:`drs_ros.bag.merge.merged_messages`: each source's in its recorded order, interleaved by
log time). Bags merged as they are: ``drs-bag merge`` itself.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path


def copy_bags(
    sources: Sequence[str | Path],
    out: str | Path,
    change: Callable[[str, str, bytes], bytes] | None = None,
    leave_out: Sequence[str] = (),
    rename: dict[str, str] | None = None,
) -> Path:
    """Write the messages of ``sources`` into the new bag directory ``out``, but the topics of
    ``leave_out``, and those of ``rename``'s keys on its values (as a remapping would have named
    them); ``change(topic, type_name, data) -> data`` may replace a message's bytes. Returns
    ``out``."""
    rename = rename or {}
    from drs_ros.bag.merge import merged_messages
    from drs_ros.bag.read.reader import scan
    from drs_ros.recording.mcap_recorder import McapRecorder
    from drs_ros.recording.qos import parse_qos_yaml

    channels: dict[str, object] = {}
    for source in sources:  # verified, every byte
        for channel in scan(source).channels.values():
            if channel.topic not in leave_out:
                channels.setdefault(channel.topic, channel)
    with McapRecorder(out, flush_thread=False) as rec:
        for channel in channels.values():
            rec.register_recorded_topic(
                rename.get(channel.topic, channel.topic),
                channel.type_name,
                channel.schema_data,
                channel.schema_encoding or "ros2msg",
                parse_qos_yaml(channel.metadata.get("offered_qos_profiles", "")),
                channel.metadata.get("topic_type_hash", ""),
            )
        for m in merged_messages(sources):
            if m.topic in leave_out:
                continue
            data = m.data if change is None else change(m.topic, m.type_name, m.data)
            rec.write(
                rename.get(m.topic, m.topic), data, m.log_time, m.publish_time, sequence=m.sequence
            )
    return Path(out)


def message_editor(
    type_name: str, edit: Callable[[object], bool], topic: str | None = None
) -> Callable:
    """A ``change`` for :func:`copy_bags`: each message of ``type_name`` (on ``topic``, if
    given) decoded, passed to ``edit(msg)`` (which changes it in place and returns True, or
    returns False to keep it as it was) and written as its exact CDR again."""
    from rclpy.serialization import deserialize_message

    from drs_ros.recording import cdr, msgdefs

    cls = msgdefs.message_class(type_name)
    serialize = cdr.serializer(cls)

    def change(topic_of: str, type_of: str, data: bytes) -> bytes:
        if type_of != type_name or topic not in (None, topic_of):
            return data
        msg = deserialize_message(data, cls)
        return serialize(msg) if edit(msg) else data

    return change
