"""rosbag2's sqlite3 storage (``.db3``), read through ``rosbags``: the channels and the message
rows of a bag, streamed in time order (a database cursor, not the bag in memory).

The topics (types, definitions, hashes) are what rosbags reads of a bag directory with
``metadata.yaml`` (every file it lists), or of a bare ``.db3`` file, or of each file of a
directory without it. The message rows are read file after file in the order rosbag2 wrote
them, with a cursor (rosbags yields them sorted by time, which is not the order a recorder wrote
them in). A row carries what rosbag2's sqlite3 schema stores: topic, receive time
(``log_time``; the publish time is not stored, so it is the receive time too) and the
serialised bytes; a message's ``sequence`` is its number on its topic (1, 2, ...), as drs's
recorder numbers them.
:func:`check_integrity` has SQLite read every page of a file. Verification is
:func:`drs_ros.bag.read.reader.scan`'s, as for MCAP.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from drs_ros.bag.read.files import BagFiles, BagReadError


@dataclass(frozen=True)
class Row:
    """One message row, as :func:`drs_ros.bag.read.reader.scan` takes a record."""

    channel_id: int
    log_time: int
    publish_time: int
    sequence: int
    data: bytes


def _failure(path: Path, exc: BaseException) -> BagReadError:
    said = " ".join(str(exc).split()) or type(exc).__name__
    return BagReadError(
        f"{str(path)!r}: not a readable rosbag2 sqlite3 bag ({type(exc).__name__}: {said})"
    )


def check_integrity(path: Path) -> None:
    """SQLite's ``PRAGMA integrity_check`` of a ``.db3`` file (every page read; its first three
    problems named), opened read-only.

    Raises
    ------
    BagReadError
        Not an SQLite database, or a damaged one (the first problem SQLite names).
    """
    try:
        with sqlite3.connect(f"file:{path}?mode=ro&immutable=1", uri=True) as db:
            result = [row[0] for row in db.execute("PRAGMA integrity_check(3)")]
            tables = {row[0] for row in db.execute("SELECT name FROM sqlite_master")}
        db.close()
    except sqlite3.Error as exc:
        raise _failure(path, exc) from exc
    if result != ["ok"]:
        problems = "; ".join(" ".join(r.split()) for r in result)  # one line, the first three
        raise BagReadError(f"{str(path)!r}: the sqlite3 database is damaged ({problems})")
    if not {"messages", "topics"} <= tables:
        raise BagReadError(
            f"{str(path)!r}: an SQLite database without rosbag2's tables "
            f"'messages' and 'topics' (it has {sorted(tables)})"
        )


def _sources(bag: BagFiles) -> list[Path]:
    """What rosbags opens: the bag directory (with metadata.yaml), else each file."""
    return [bag.bag_dir] if bag.metadata is not None else list(bag.files)


def _qos_text(files) -> dict[str, str]:
    """topic -> ``offered_qos_profiles`` as stored (the YAML text rosbag2 writes), if any."""
    out: dict[str, str] = {}
    for file in files:
        try:
            with sqlite3.connect(f"file:{file}?mode=ro&immutable=1", uri=True) as db:
                for name, qos in db.execute("SELECT name, offered_qos_profiles FROM topics"):
                    out.setdefault(name, qos or "")
            db.close()
        except sqlite3.Error:  # an old schema without the column: no recorded offers
            continue
    return out


def channels(bag: BagFiles) -> list[dict]:
    """The bag's topics as :class:`drs_ros.bag.read.recorded.ChannelInfo` fields (numbered from 1 in
    order of appearance, one per topic).

    Raises
    ------
    BagReadError
        rosbags cannot open the bag.
    """
    from rosbags.rosbag2 import Reader

    qos = _qos_text(bag.files)
    out: dict[str, dict] = {}
    for source in _sources(bag):
        try:
            with Reader(source) as reader:
                connections = list(reader.connections)
        except Exception as exc:  # rosbags' ReaderError, apsw's errors: a bad bag, not a crash
            raise _failure(source, exc) from exc
        for conn in connections:
            if conn.topic in out:
                continue
            metadata = {"offered_qos_profiles": qos.get(conn.topic, "")}
            if conn.digest:
                metadata["topic_type_hash"] = conn.digest
            out[conn.topic] = {
                "id": len(out) + 1,
                "topic": conn.topic,
                "type_name": conn.msgtype,
                "schema_encoding": "ros2msg" if conn.msgdef.data else "",
                "schema_data": conn.msgdef.data.encode(),
                "message_encoding": conn.ext.serialization_format,
                "metadata": metadata,
            }
    return list(out.values())


def iter_rows(bag: BagFiles, topics=None) -> Iterator[Row]:
    """The message rows of the bag, file after file, each in the order rosbag2 wrote them (row
    id: its arrival order, as an MCAP file's order; not sorted by time, which would put a record
    after states it was written before), as :class:`Row` (channel ids as :func:`channels`
    numbers them); only ``topics`` if given. A cursor streams the rows.

    Raises
    ------
    BagReadError
        A row cannot be read (a damaged database).
    """
    ids = {c["topic"]: c["id"] for c in channels(bag)}
    sequence: dict[str, int] = {}
    for file in bag.files:
        db = None
        try:
            db = sqlite3.connect(f"file:{file}?mode=ro&immutable=1", uri=True)
            names = dict(db.execute("SELECT id, name FROM topics"))
            for topic_id, timestamp, data in db.execute(
                "SELECT topic_id, timestamp, data FROM messages ORDER BY id"
            ):
                topic = names.get(topic_id)
                if topic is None:
                    raise BagReadError(
                        f"{str(file)!r}: a message names topic id {topic_id}, "
                        "which the topics table does not hold"
                    )
                if topics is not None and topic not in topics:
                    continue
                n = sequence[topic] = sequence.get(topic, 0) + 1
                yield Row(ids[topic], int(timestamp), int(timestamp), n, bytes(data))
        except sqlite3.Error as exc:
            raise _failure(file, exc) from exc
        finally:
            if db is not None:
                db.close()


__all__ = ["Row", "channels", "check_integrity", "iter_rows"]
