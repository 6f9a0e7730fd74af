"""A look-ahead into a bag: its channels and the messages of a few topics, read without the rest
and without verifying them.

What a tool wants to know before the verifying read (:func:`drs_ros.bag.read.reader.scan`), or
instead of one (``info``, ``index``, ``play``): which drs nodes a bag holds, with which
parameters and topics (:mod:`drs_ros.bag.read.nodes`). A finished MCAP file is read through its
summary: only the chunks its chunk indexes say hold a wanted topic are decompressed, each once,
and a topic asked for ``first_only`` is wanted until its first message. A file without a summary (an
unfinished recording) is read from its start; a sqlite3 bag row by row.

Nothing is verified. A file that cannot be read ends the look-ahead at that file, silently: the
verifying scan, when one follows, says why; a tool without one says what it did not find. Only
reading is guarded: what the caller does with a message runs outside, and its errors are its own
(:func:`messages` is a generator: an exception of the loop that consumes it never passes
through it).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Iterator
from pathlib import Path

from drs_ros.bag.read.files import BagFiles, BagReadError, resolve
from drs_ros.bag.read.mcap_file import chunk_records, mcap_read_errors
from drs_ros.bag.read.recorded import RecordedMessage
from drs_ros.recording.mcap_records import MAGIC, RECORD_HEAD, Opcode


def bag_files(path: str | Path | BagFiles) -> BagFiles | None:
    """The bag's files (:func:`drs_ros.bag.read.files.resolve`, once: a caller with several
    look-aheads passes its result on), None for a bag that cannot be found or read."""
    if isinstance(path, BagFiles):
        return path
    try:
        return resolve(path, require_metadata=False)
    except BagReadError:
        return None


def channels(path: str | Path | BagFiles) -> dict[str, str]:
    """``topic -> type`` of every channel of the bag (of the readable part of a damaged one;
    empty when nothing is readable)."""
    out: dict[str, str] = {}
    bag = bag_files(path)
    if bag is None:
        return out
    try:
        if bag.storage == "sqlite3":
            from drs_ros.bag.read import sqlite

            return {c["topic"]: c["type_name"] for c in sqlite.channels(bag)}
    except BagReadError:
        return out
    for file in bag.files:
        for topic, type_name in _mcap_channels(file):
            out.setdefault(topic, type_name)
    return out


def messages(
    path: str | Path | BagFiles, topics: Iterable[str], first_only: Iterable[str] = ()
) -> Iterator[RecordedMessage]:
    """The messages of ``topics``, file after file, each file in its order (a finished MCAP
    file: its chunks in the order of their first log time); of each topic in ``first_only``,
    only its first message of each file. ``offset`` is 0 (not looked up)."""
    topics, first_only = set(topics), set(first_only)
    bag = bag_files(path)
    if bag is None:
        return
    if bag.storage == "sqlite3":
        yield from _sqlite_messages(bag, topics, first_only)
        return
    for file in bag.files:
        yield from _mcap_messages(file, topics, first_only)


def _mcap_channels(file: Path) -> list[tuple[str, str]]:
    """(topic, type) of one MCAP file: from its summary, else from its records up to the first
    that cannot be read."""
    from mcap.records import Channel, Schema

    summary = _summary(file)
    if summary is not None:
        return [
            (c.topic, _type_name(summary.schemas.get(c.schema_id)))
            for c in summary.channels.values()
        ]
    out, schemas = [], {}
    for rec in _streamed_records(file):
        if isinstance(rec, Schema):
            schemas[rec.id] = rec
        elif isinstance(rec, Channel):
            out.append((rec.topic, _type_name(schemas.get(rec.schema_id))))
    return out


def _streamed_records(file: Path):
    """Every record of an MCAP file from its start, those of its chunks in their place, up to
    the first that cannot be read (the verifying scan says why it ends)."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    try:
        with open(file, "rb") as f:
            if f.read(len(MAGIC)) != MAGIC:
                return
            f.seek(0)
            for record in StreamReader(f, validate_crcs=True, emit_chunks=True).records:
                yield from chunk_records(record) if isinstance(record, Chunk) else [record]
    except mcap_read_errors():
        return


def _type_name(schema) -> str:
    return schema.name if schema is not None else ""


def _summary(file: Path):
    """The summary of a finished MCAP file with chunk indexes, else None (the last few files'
    kept while their size and modification time stay: one look-ahead reads it twice)."""
    try:
        stat = file.stat()
    except OSError:
        return None
    return _read_summary(file, stat.st_size, stat.st_mtime_ns)


@functools.lru_cache(maxsize=8)
def _read_summary(file: Path, _size: int, _mtime_ns: int):
    from mcap.reader import make_reader

    try:
        with open(file, "rb") as f:
            if f.read(len(MAGIC)) != MAGIC:
                return None
            f.seek(0)
            summary = make_reader(f).get_summary()
    except mcap_read_errors():
        return None
    return summary if summary is not None and summary.chunk_indexes else None


def _mcap_messages(file: Path, topics: set[str], first_only: set[str]):
    """:func:`messages` of one MCAP file: through its summary's chunk indexes, each chunk that
    holds a topic still wanted read once, and in it only the wanted messages its message
    indexes point at; without a summary, from the file's start."""
    summary = _summary(file)
    if summary is None:
        yield from _streamed_messages(file, topics, first_only)
        return
    by_id = {cid: c for cid, c in summary.channels.items() if c.topic in topics}
    done: set[str] = set()
    try:
        with open(file, "rb") as f:
            for index in sorted(summary.chunk_indexes, key=lambda i: i.message_start_time):
                held = index.message_index_offsets  # none: a chunk that must be read to know
                ids = [cid for cid in by_id if cid in held and by_id[cid].topic not in done]
                if held and not ids:
                    continue
                for rec in _chunk_messages(f, index, ids, first_only, by_id):
                    channel = by_id.get(rec.channel_id)
                    if channel is None or channel.topic in done:
                        continue
                    if channel.topic in first_only:
                        done.add(channel.topic)
                    yield _recorded(summary.schemas.get(channel.schema_id), channel, rec)
    except mcap_read_errors():
        return  # a damaged chunk ends the look-ahead here: the verifying scan says why


def _chunk_messages(f, index, ids: list[int], first_only: set[str], by_id: dict) -> list:
    """The messages of channels ``ids`` in the chunk ``index`` points at, in the chunk's order
    (of each channel in ``first_only`` its first only), read at the offsets its message indexes
    give: the other records are not parsed. A chunk without message indexes: every message."""
    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk, Message, MessageIndex
    from mcap.stream_reader import get_chunk_data_stream

    f.seek(index.chunk_start_offset + RECORD_HEAD.size)  # past the opcode and the length
    chunk = Chunk.read(ReadDataStream(f))
    if not index.message_index_offsets:
        return [r for r in chunk_records(chunk) if isinstance(r, Message)]
    offsets = []
    for cid in ids:
        f.seek(index.message_index_offsets[cid])
        opcode, _length = RECORD_HEAD.unpack(f.read(RECORD_HEAD.size))
        if opcode != Opcode.MESSAGE_INDEX:
            raise ValueError(f"no message index at offset {index.message_index_offsets[cid]}")
        entries = sorted(offset for _t, offset in MessageIndex.read(ReadDataStream(f)).records)
        offsets += entries[:1] if by_id[cid].topic in first_only else entries
    stream, _length = get_chunk_data_stream(chunk, validate_crc=True)
    out = []
    for offset in sorted(offsets):
        stream.read(offset - stream.count)  # to the record
        if stream.read1() != Opcode.MESSAGE:
            raise ValueError(f"no message at offset {offset} of the chunk")
        out.append(Message.read(stream, stream.read8()))
    return out


def _recorded(schema, channel, message) -> RecordedMessage:
    return RecordedMessage(
        channel.topic,
        _type_name(schema),
        message.log_time,
        message.publish_time,
        message.sequence,
        bytes(message.data),
        0,
    )


def _streamed_messages(file: Path, topics: set[str], first_only: set[str]):
    """:func:`messages` of an MCAP file without a summary: read from its start."""
    from mcap.records import Channel, Message, Schema

    schemas: dict[int, object] = {}
    chans: dict[int, object] = {}
    done: set[str] = set()
    for rec in _streamed_records(file):
        if isinstance(rec, Schema):
            schemas[rec.id] = rec
        elif isinstance(rec, Channel):
            chans[rec.id] = rec
        elif isinstance(rec, Message):
            channel = chans.get(rec.channel_id)
            if channel is None or channel.topic not in topics or channel.topic in done:
                continue
            if channel.topic in first_only:
                done.add(channel.topic)
            yield _recorded(schemas.get(channel.schema_id), channel, rec)


def _sqlite_messages(bag, topics: set[str], first_only: set[str]):
    """:func:`messages` of a sqlite3 bag (its rows in the order rosbag2 wrote them)."""
    from drs_ros.bag.read import sqlite

    done: set[str] = set()
    try:
        types = {c["id"]: (c["topic"], c["type_name"]) for c in sqlite.channels(bag)}
        for row in sqlite.iter_rows(bag, topics=topics):
            topic, type_name = types[row.channel_id]
            if topic in done:
                continue
            if topic in first_only:
                done.add(topic)
            yield RecordedMessage(
                topic, type_name, row.log_time, row.publish_time, row.sequence, row.data, 0
            )
    except BagReadError:
        return


__all__ = ["bag_files", "channels", "messages"]
