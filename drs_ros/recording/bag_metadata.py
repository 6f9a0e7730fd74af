"""What rosbag2 records about a bag beside its messages: a topic as its channel declares it
(:class:`TopicInfo`: name, type, offered QoS profiles, type hash) and the ``BagMetadata``
document (:func:`bag_metadata`) that ``metadata.yaml`` and the MCAP metadata record ``rosbag2``
hold (version 9, ROS 2 Jazzy).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

#: rosbag2 metadata version of ROS 2 Jazzy.
ROSBAG2_METADATA_VERSION = 9


@dataclass(frozen=True)
class TopicInfo:
    """A registered topic: name, ``pkg/msg/Type``, message class (None for a topic copied from
    another bag, which only takes bytes), channel id, QoS, type hash (``""`` when not stored)."""

    name: str
    type_name: str
    msg_class: type | None = field(repr=False)
    channel_id: int
    qos_profiles: tuple[dict[str, Any], ...] = field(repr=False)
    type_hash: str


def bag_metadata(
    topics: Iterable[TopicInfo],
    counts: Mapping[str, int],
    message_count: int,
    t_min: int | None,
    t_max: int | None,
    file_name: str,
    custom_data: Mapping[str, str],
    ros_distro: str,
) -> dict[str, Any]:
    """rosbag2's ``BagMetadata`` (version :data:`ROSBAG2_METADATA_VERSION`) of a bag of one
    file ``file_name``, as a dict: ``topics`` with their message ``counts`` (topic -> count),
    ``message_count`` in all, the earliest and latest log times ``t_min``, ``t_max`` [ns] (None:
    no message), rosbag2's ``custom_data`` and the ROS distribution."""
    start = t_min or 0
    duration = (t_max - t_min) if t_min is not None else 0
    entries = [
        {
            "topic_metadata": {
                "name": info.name,
                "type": info.type_name,
                "serialization_format": "cdr",
                "offered_qos_profiles": [dict(p) for p in info.qos_profiles],
                "type_description_hash": info.type_hash,
            },
            "message_count": counts[info.name],
        }
        for info in topics
    ]
    return {
        "version": ROSBAG2_METADATA_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": message_count,
        "topics_with_message_count": entries,
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [
            {
                "path": file_name,
                "starting_time": {"nanoseconds_since_epoch": start},
                "duration": {"nanoseconds": duration},
                "message_count": message_count,
            }
        ],
        "custom_data": dict(custom_data) or None,
        "ros_distro": ros_distro,
    }


__all__ = ["ROSBAG2_METADATA_VERSION", "TopicInfo", "bag_metadata"]
