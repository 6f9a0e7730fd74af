"""A bag as the player reads it: the summaries of its files (channels, time range, count), and its
messages streamed in log-time order, a chunk at a time (an MCAP bag), or a database cursor at a
time (a sqlite3 bag, through rosbags).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from drs_ros.bag.read.files import BagReadError, resolve
from drs_ros.recording.mcap_records import MAGIC


@dataclass(frozen=True)
class Channel:
    """A recorded topic: name, ``pkg/msg/Type``, message encoding, QoS metadata."""

    topic: str
    type_name: str
    encoding: str
    offered_qos: str | None


@dataclass(frozen=True)
class BagIndex:
    """What the summaries of a bag's files say: files, channels, time range [ns], count."""

    files: tuple[Path, ...]
    channels: dict[str, Channel]
    start_ns: int
    end_ns: int
    message_count: int
    storage: str = "mcap"


def _read_failure(path: Path, exc: Exception) -> BagReadError:
    return BagReadError(
        f"{str(path)!r}: not MCAP, truncated or corrupt ({type(exc).__name__}: "
        f"{str(exc) or 'end of file'})"
    )


def _summary(f, path: Path):
    """The summary of an open MCAP file (a seeking reader validating chunk CRCs)."""
    from mcap.reader import make_reader

    if f.read(len(MAGIC)) != MAGIC:
        raise BagReadError(f"{str(path)!r}: not an MCAP file (no MCAP magic at its start)")
    f.seek(0)
    try:
        reader = make_reader(f, validate_crcs=True)
        reader.get_header()
        summary = reader.get_summary()
    except Exception as exc:  # any failure of the mcap library is a bad file, never a traceback
        raise _read_failure(path, exc) from exc
    if summary is None:
        raise BagReadError(
            f"{str(path)!r}: truncated or unfinished MCAP file (no summary); "
            "its readable prefix can be recovered (drs-bag recover)"
        )
    return reader, summary


def index_bag(path: str | Path) -> BagIndex:
    """Read the summaries of a bag's files: channels (first type wins), time range, count.

    Raises
    ------
    BagReadError
        Missing path, not MCAP, truncated (no summary) or corrupt.
    """
    bag = resolve(path, require_metadata=False)
    if bag.storage == "sqlite3":
        return _index_sqlite(bag)
    files = bag.files
    channels: dict[str, Channel] = {}
    start, end, count = math.inf, -1, 0  # no message yet
    for file in files:
        with open(file, "rb") as f:
            _reader, summary = _summary(f, file)
        for ch in summary.channels.values():
            schema = summary.schemas.get(ch.schema_id)
            channels.setdefault(
                ch.topic,
                Channel(
                    ch.topic,
                    schema.name if schema is not None else "",
                    ch.message_encoding,
                    ch.metadata.get("offered_qos_profiles"),
                ),
            )
        stats = summary.statistics
        if stats is not None and stats.message_count:
            start = min(start, stats.message_start_time)
            end = max(end, stats.message_end_time)
            count += stats.message_count
        for ci in summary.chunk_indexes:
            start = min(start, ci.message_start_time)
            end = max(end, ci.message_end_time)
    if end < 0:
        start = end = 0
    return BagIndex(files, channels, start, end, count)


def _index_sqlite(bag) -> BagIndex:
    """:func:`index_bag` of a sqlite3 bag: its topics (:mod:`drs_ros.bag.read.sqlite`), and its time
    range and count from the ``messages`` table (its timestamp index, no row read)."""
    import sqlite3

    from drs_ros.bag.read import sqlite

    channels = {
        c["topic"]: Channel(
            c["topic"],
            c["type_name"],
            c["message_encoding"],
            c["metadata"].get("offered_qos_profiles") or None,
        )
        for c in sqlite.channels(bag)
    }
    start, end, count = math.inf, -1, 0
    for file in bag.files:
        try:
            with sqlite3.connect(f"file:{file}?mode=ro&immutable=1", uri=True) as db:
                first, last, n = db.execute(
                    "SELECT min(timestamp), max(timestamp), count(*) FROM messages"
                ).fetchone()
            db.close()
        except sqlite3.Error as exc:
            raise _read_failure(file, exc) from exc
        if n:
            start, end, count = min(start, first), max(end, last), count + n
    if end < 0:
        start = end = 0
    return BagIndex(bag.files, channels, int(start), int(end), count, "sqlite3")


def _iter_sqlite(index: BagIndex, topics: Sequence[str], starting_at: int | None):
    """:func:`iter_bag` of a sqlite3 bag: rosbags' reader, file by file, in time order."""
    from rosbags.rosbag2 import Reader

    for file in index.files:
        try:
            with Reader(file) as reader:
                wanted = [c for c in reader.connections if c.topic in set(topics)]
                if not wanted:
                    continue
                for conn, timestamp, data in reader.messages(wanted, start=starting_at):
                    yield conn.topic, timestamp, bytes(data)
        except BagReadError:  # ours, already naming the file
            raise
        except Exception as exc:  # rosbags' or apsw's error on a damaged database
            raise _read_failure(file, exc) from exc


def iter_bag(
    index: BagIndex, topics: Sequence[str], starting_at: int | None = None
) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, log_time_ns, serialised bytes)`` of ``topics``, in log-time order per file.

    Streams: ``iter_messages(log_time_order=True)`` of the seeking reader decompresses a chunk
    only when its first message is the next one due, so memory holds the chunks overlapping in
    time, not the file. Without chunk indexes the file order is kept (no in-memory sort).
    """
    from mcap.reader import make_reader

    if index.storage == "sqlite3":
        yield from _iter_sqlite(index, topics, starting_at)
        return
    wanted = sorted(topics)
    for file in index.files:
        try:
            with open(file, "rb") as f:
                reader = make_reader(f, validate_crcs=True)
                summary = reader.get_summary()
                if summary is None:
                    raise BagReadError(f"{str(file)!r}: truncated or unfinished MCAP file")
                ordered = bool(summary.chunk_indexes)
                for _schema, channel, message in reader.iter_messages(
                    wanted, log_time_order=ordered, starting_at=starting_at
                ):
                    data = message.data
                    yield (
                        channel.topic,
                        message.log_time,
                        (data if isinstance(data, bytes) else bytes(data)),
                    )
        except BagReadError:  # ours, already naming the file
            raise
        except Exception as exc:  # a corrupt chunk, found while playing
            raise _read_failure(file, exc) from exc
