"""A bag's messages as recorded (their exact bytes and channels, :class:`RecordedMessage`,
:class:`ChannelInfo`), what a scan of a bag read (:class:`BagScan`), and the failure of a
scan's caller (:class:`MessageCallbackError`): the types :mod:`drs_ros.bag.read.reader` produces.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drs_ros.errors import DRSRosError


class MessageCallbackError(DRSRosError):
    """The caller's ``on_message`` callback of :func:`.reader.scan` raised on a message that
    passed every check of the file: a failure of the caller (a bug, a type it cannot handle, its
    output that cannot be written), not of the bag. Never a :class:`BagReadError`;
    ``__cause__`` is the callback's exception.

    Attributes
    ----------
    path : Path
        The ``.mcap`` file being read.
    topic : str
    index : int
        1-based number of the message on its topic in that file.
    offset : int
        File offset of the message (of its chunk) [bytes].
    """

    def __init__(self, message: str, path: Path, topic: str, index: int, offset: int):
        super().__init__(message)
        self.path, self.topic, self.index, self.offset = path, topic, index, offset


@dataclass(frozen=True)
class RecordedMessage:
    """One message as recorded: topic, type, times [ns], sequence, exact bytes, the file offset
    of the record (of its chunk, for a chunked message) [bytes], and its channel as declared in
    the file (schema and metadata: what a copy of the message needs)."""

    topic: str
    type_name: str
    log_time: int
    publish_time: int
    sequence: int
    data: bytes
    offset: int
    channel: ChannelInfo | None = field(default=None, compare=False, repr=False)

    @classmethod
    def of_record(cls, channel: ChannelInfo, record: Any, offset: int) -> RecordedMessage:
        """The message ``record`` on ``channel`` (an ``mcap.records.Message``, or a row of
        :func:`drs_ros.bag.read.sqlite.iter_rows`: the same fields), at ``offset`` (the file
        offset [bytes]; for a sqlite3 row, its number)."""
        return cls(
            channel.topic,
            channel.type_name,
            record.log_time,
            record.publish_time,
            record.sequence,
            bytes(record.data),
            offset,
            channel,
        )


@dataclass
class ChannelInfo:
    """A channel as recorded: topic, schema (name, encoding, data), metadata."""

    id: int
    topic: str
    type_name: str
    schema_encoding: str
    schema_data: bytes
    message_encoding: str
    metadata: dict[str, str]

    @classmethod
    def of_record(cls, record: Any, schema: Any | None) -> ChannelInfo:
        """The MCAP channel ``record`` (an ``mcap.records.Channel``) with its ``schema`` (an
        ``mcap.records.Schema``; None: the channel has none, schema id 0)."""
        return cls(
            record.id,
            record.topic,
            schema.name if schema else "",
            schema.encoding if schema else "",
            bytes(schema.data) if schema else b"",
            record.message_encoding,
            dict(record.metadata),
        )


@dataclass
class BagScan:
    """What :func:`.reader.scan` read.

    Attributes
    ----------
    path : Path
        The ``.mcap`` file; for a bag split into several files, the bag directory.
    bag_dir : Path or None
        The bag directory (None for a bare file).
    channels : dict
        channel id -> :class:`ChannelInfo`, in the order they appear (for a split bag: the first
        channel of each topic, numbered from 1 in order of appearance).
    counts : dict
        topic -> messages read (every topic; summed over the files of a split bag).
    complete : bool
        The whole bag was read and verified (footer, summary, magic of every file).
    stopped_at : int or None
        With ``recover``: the offset [bytes] where reading stopped (of the first file that
        stopped early, for a split bag).
    reason : str
        With ``recover``: why it stopped ('' when complete; for a split bag, every file that
        stopped early, by name).
    last_good_offset : int
        End of the last record read completely [bytes] (of a single file).
    file_size : int
        [bytes] (the sum over the files of a split bag).
    start_ns, end_ns : int or None
        Earliest and latest ``log_time`` read.
    metadata : dict or None
        ``rosbag2_bagfile_information`` of ``metadata.yaml``, if there is one.
    notes : list of str
    parts : list of BagScan
        A split bag's scans, one per file in order (empty for a single file).
    """

    path: Path
    bag_dir: Path | None
    channels: dict[int, ChannelInfo] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    complete: bool = False
    stopped_at: int | None = None
    reason: str = ""
    last_good_offset: int = 0
    file_size: int = 0
    start_ns: int | None = None
    end_ns: int | None = None
    metadata: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    parts: list[BagScan] = field(default_factory=list)

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    @property
    def file_scans(self) -> list[BagScan]:
        """One scan per file, in order: ``parts``, or this scan for a single file."""
        return self.parts or [self]


__all__ = ["BagScan", "ChannelInfo", "MessageCallbackError", "RecordedMessage"]
