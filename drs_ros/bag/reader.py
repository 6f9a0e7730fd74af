"""Read a rosbag2 MCAP bag and verify every byte of it (what ``drs-bag check`` trusts).

:func:`scan` reads the file sequentially, record by record, and stops at the first problem with a
:class:`BagReadError` naming the offset, the record and, where there is one, the topic:

* the magic bytes at both ends, and nothing after the closing magic;
* every chunk's CRC (the uncompressed data) and the data section CRC, as written;
* the summary: its CRC (footer ``summary_crc``, computed here: the mcap reader does not), every
  chunk index pointing at a chunk that was read at that offset, and the statistics' message
  counts per channel against the messages actually read;
* every message: its channel is known, and its bytes are exactly its CDR serialisation: it is
  decoded by the installed type support (``rclpy.serialization.deserialize_message``) and
  serialised again by :mod:`drs_ros.recording.cdr`; trailing bytes or non-zero padding are an error;
* a bag directory's ``metadata.yaml``: present, well formed
  (:func:`drs_ros.bag.files.read_metadata`), naming files that exist, and its per-topic counts
  equal to what was read from all of them.

A bag split into several files (``name_0.mcap``, ``name_1.mcap``... as rosbag2 splits) is read
file by file, in order (:func:`drs_ros.bag.files.resolve` is the one place that finds a bag's
files).

A sqlite3 bag (rosbag2's ``.db3`` storage, :mod:`drs_ros.bag.sqlite`) is read row by row in
the order rosbag2 wrote it, after SQLite's integrity check of every page, with the same message
checks and the same ``metadata.yaml`` counts.

With ``recover=True`` the scan keeps what it read before a truncation or a corrupt record and
reports where and why it stopped, instead of raising; in a split bag each file is read up to its
own first problem.

Only the file decides a :class:`BagReadError`. An exception raised by the caller's ``on_message``
callback says nothing about the file: it is raised as :class:`MessageCallbackError` (its cause is
the callback's exception), with or without ``recover``, and never ends a scan as a truncation.

No state beyond the scan's own result; rclpy is used only for its type support.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..errors import DRSRosError
from .files import BagFiles, BagReadError, resolve

#: The MCAP magic (8 bytes at both ends of a file).
MCAP_MAGIC = b"\x89MCAP0\r\n"
_FOOTER_LEN = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, crc


class MessageCallbackError(DRSRosError):
    """The caller's ``on_message`` callback of :func:`scan` raised on a message that passed every
    check of the file: a failure of the caller (a bug, a type it cannot handle, its output that
    cannot be written), not of the bag. Never a :class:`BagReadError`; ``__cause__`` is the
    callback's exception.

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


@dataclass
class BagScan:
    """What :func:`scan` read.

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


def _exact_checker(padded: dict[str, int]) -> Callable[[str, bytes], str | None]:
    """``check(type_name, data) -> problem, '' (exact) or None (type not installed)``: decode
    with the installed type support and serialise again exactly. Up to 3 zero bytes after the
    exact CDR are the DDS transport's padding (:func:`drs_ros.recording.cdr.exact_bytes`):
    rosbag2 records them as they arrive; they are counted in ``padded`` per type, not refused."""
    from rclpy.serialization import deserialize_message

    from drs_ros.recording import cdr, msgdefs

    classes: dict[str, Any] = {}

    def check(type_name: str, data: bytes) -> str | None:
        cls = classes.get(type_name)
        if cls is None:
            try:
                cls = msgdefs.message_class(type_name)
            except msgdefs.MessageDefinitionError:
                cls = False
            classes[type_name] = cls
        if cls is False:
            return None  # not installed: counted, not verified (noted by the caller)
        try:
            again = cdr.serializer(cls)(deserialize_message(data, cls))
        except Exception as exc:  # noqa: BLE001 - any decode failure is the bag's problem
            return f"does not decode as {type_name} ({type(exc).__name__}: {exc})"
        if again == data:
            return ""
        tail = data[len(again) :]
        if data.startswith(again) and cdr.is_transport_padding(tail):
            padded[type_name] = padded.get(type_name, 0) + 1  # DDS's padding, not a leak
            return ""
        if len(data) != len(again):
            return (f"is {len(data)} bytes where its CDR serialisation is {len(again)} "
                    f"({len(data) - len(again):+d} bytes)")  # fmt: skip
        first = next(i for i, (a, b) in enumerate(zip(data, again, strict=True)) if a != b)
        return f"differs from its CDR serialisation at byte {first} (non-zero padding?)"

    return check


def scan(
    path: str | Path,
    on_message: Callable[[RecordedMessage], None] | None = None,
    *,
    recover: bool = False,
    exact: bool = True,
    topics: Iterable[str] | None = None,
) -> BagScan:
    """Read and verify a bag (see the module docstring); call ``on_message`` for each message.

    Parameters
    ----------
    path : str or Path
        Bag directory or ``.mcap`` file.
    on_message : callable, optional
        Called with each :class:`RecordedMessage` of ``topics`` (all topics by default), in file
        order, file after file, once the message passed its checks.
    recover : bool
        Keep what was read before a truncation or corruption instead of raising (a directory
        without ``metadata.yaml`` is then accepted too). In a split bag every file is read up to
        its own first problem; a file with nothing readable is reported in ``reason``.
    exact : bool
        Verify that every message's bytes are its exact CDR serialisation.
    topics : iterable of str, optional
        Topics passed to ``on_message``; every message is verified regardless.

    Raises
    ------
    BagReadError
        Without ``recover``: any problem of the bag; with it: nothing readable at all.
    BagMetadataError
        ``metadata.yaml`` is malformed (a :class:`BagReadError`).
    MessageCallbackError
        ``on_message`` raised (with or without ``recover``): the scan ends there, and nothing is
        said about the rest of the bag.
    """
    bag = resolve(path, require_metadata=not recover)
    wanted = None if topics is None else set(topics)
    padded: dict[str, int] = {}
    check = _exact_checker(padded) if exact else None
    unverified: set[str] = set()
    parts: list[BagScan] = []
    if bag.storage == "sqlite3":  # one result for the bag (its files are one database to rosbags)
        parts.append(_scan_sqlite(bag, on_message, check, wanted, unverified))
    for file in bag.files if bag.storage == "mcap" else ():
        try:
            part = _scan_file(file, bag.bag_dir, on_message, recover, check, wanted, unverified)
        except BagReadError as exc:
            if not recover or len(bag.files) == 1:
                raise
            reason = str(exc).split(": ", 1)[-1]
            part = BagScan(file, bag.bag_dir, stopped_at=0, file_size=file.stat().st_size,
                           reason=reason, notes=[f"nothing readable: {reason}"])  # fmt: skip
        parts.append(part)
    out = parts[0] if len(parts) == 1 else _combine(bag, parts)
    if recover and out.message_count == 0 and not out.complete:
        raise BagReadError(f"{str(out.path)!r}: nothing recoverable in any file: {out.reason}")
    out.metadata = bag.metadata
    if bag.metadata is not None and out.complete:
        _check_metadata(out, bag.metadata, bag.bag_dir / "metadata.yaml")
    if out.complete and unverified:
        out.notes.append(f"types not installed, bytes not verified: {sorted(unverified)}")
    if out.complete and padded:
        out.notes.append(f"messages carrying the DDS transport's zero padding (<= 3 bytes) after "
                         f"their exact CDR: {padded}")  # fmt: skip
    return out


def _combine(bag: BagFiles, parts: list[BagScan]) -> BagScan:
    """One result of a split bag's per-file scans (see :class:`BagScan`)."""
    out = BagScan(bag.bag_dir, bag.bag_dir, parts=parts)
    first: dict[str, tuple[ChannelInfo, Path]] = {}
    for part in parts:
        for channel in part.channels.values():
            known = first.get(channel.topic)
            if known is None:
                first[channel.topic] = (channel, part.path)
                out.channels[len(first)] = replace(channel, id=len(first))
            elif known[0].type_name != channel.type_name:
                raise BagReadError(
                    f"{str(bag.bag_dir)!r}: {channel.topic} is {known[0].type_name} in "
                    f"{known[1].name} and {channel.type_name} in {part.path.name}"
                )
        for topic, n in part.counts.items():
            out.counts[topic] = out.counts.get(topic, 0) + n
        for t in (part.start_ns, part.end_ns):
            if t is not None:
                out.start_ns = t if out.start_ns is None else min(out.start_ns, t)
                out.end_ns = t if out.end_ns is None else max(out.end_ns, t)
        out.file_size += part.file_size
        out.notes += [f"{part.path.name}: {note}" for note in part.notes]
    stopped = [part for part in parts if not part.complete]
    out.complete = not stopped
    if stopped:
        out.stopped_at, out.last_good_offset = stopped[0].stopped_at, stopped[0].last_good_offset
        out.reason = "; ".join(f"{part.path.name}: {part.reason}" for part in stopped)
    return out


def _scan_file(
    mcap_path: Path,
    bag_dir: Path | None,
    on_message: Callable[[RecordedMessage], None] | None,
    recover: bool,
    check: Callable[[str, bytes], str | None] | None,
    wanted: set[str] | None,
    unverified: set[str],
) -> BagScan:
    """Read and verify one ``.mcap`` file (everything of :func:`scan` but ``metadata.yaml``)."""
    from mcap.exceptions import McapError
    from mcap.records import (
        Channel,
        Chunk,
        ChunkIndex,
        DataEnd,
        Footer,
        Message,
        Schema,
        Statistics,
    )
    from mcap.stream_reader import StreamReader, breakup_chunk

    out = BagScan(mcap_path, bag_dir, file_size=mcap_path.stat().st_size)
    schemas: dict[int, Schema] = {}
    chunk_offsets: dict[int, int] = {}
    stats: Statistics | None = None
    chunk_indexes: list[ChunkIndex] = []
    footer: Footer | None = None
    offset = 8
    where = "the header"

    def fail(msg: str) -> None:
        raise BagReadError(f"{str(mcap_path)!r}: {msg}")

    def take(rec, at: int) -> None:
        _take(out, rec, at, mcap_path, check, unverified, on_message, wanted)

    def data_record(rec, at: int) -> None:
        """A message, schema or channel, in a chunk or not (``at``: the offset to report)."""
        if isinstance(rec, Message):
            take(rec, at)
        elif isinstance(rec, Schema):
            schemas[rec.id] = rec
        elif isinstance(rec, Channel):
            _add_channel(out, schemas, rec, fail)

    errors = (McapError, ValueError, EOFError, OSError, struct.error, KeyError, IndexError,
              UnicodeDecodeError, *_decompression_errors())  # fmt: skip
    try:
        with open(mcap_path, "rb") as f:
            head = f.read(8)
            if head != MCAP_MAGIC:
                fail("not an MCAP file (no MCAP magic at the start)" if head else "empty file")
            f.seek(0)
            reader = StreamReader(f, validate_crcs=True, emit_chunks=True)
            stream = reader._stream  # its byte count is the offset of the next record
            for record in reader.records:
                end = stream.count
                if isinstance(record, Chunk):
                    where = f"the chunk at offset {offset}"
                    chunk_offsets[offset] = end - offset
                    for inner in breakup_chunk(record, validate_crc=True):
                        data_record(inner, offset)
                elif isinstance(record, (Message, Schema, Channel)):
                    data_record(record, offset)
                elif isinstance(record, Statistics):
                    stats = record
                elif isinstance(record, ChunkIndex):
                    chunk_indexes.append(record)
                elif isinstance(record, DataEnd):
                    where = f"the summary after offset {end}"
                elif isinstance(record, Footer):
                    footer = record
                out.last_good_offset = end
                offset = end
                if footer is None:
                    where = f"the record at offset {offset}"
            if footer is None:
                fail(f"ends at offset {offset} without a footer (truncated)")
            end_of_file = stream.count
            f.seek(0, 2)
            size = f.tell()
            if size != end_of_file:
                fail(f"{size - end_of_file} unread bytes after the closing magic at offset "
                     f"{end_of_file}")  # fmt: skip
            _check_summary(f, footer, size, fail)
    except BagReadError as exc:
        if not recover or out.message_count == 0:
            raise
        out.stopped_at, out.reason = offset, str(exc).split(": ", 1)[-1]
        _recovered_note(out)
        return out
    except errors as exc:
        reason = _describe(exc, where)
        if not recover:
            raise BagReadError(
                f"{str(mcap_path)!r}: {reason}; {out.message_count} messages were readable "
                f"before it (drs-bag recover salvages them)"
            ) from exc
        if out.message_count == 0:
            raise BagReadError(
                f"{str(mcap_path)!r}: nothing recoverable: {reason} before any complete message"
            ) from exc
        out.stopped_at, out.reason = offset, reason
        _recovered_note(out)
        return out
    if stats is not None:
        for cid, n in stats.channel_message_counts.items():
            topic = out.channels[cid].topic if cid in out.channels else f"channel {cid}"
            if out.counts.get(topic, 0) != n:
                raise BagReadError(
                    f"{str(mcap_path)!r}: the summary counts {n} messages on {topic}, "
                    f"{out.counts.get(topic, 0)} were read ({n - out.counts.get(topic, 0)} missing)"
                )
    else:
        raise BagReadError(f"{str(mcap_path)!r}: no statistics record in the summary")
    for index in chunk_indexes:
        if chunk_offsets.get(index.chunk_start_offset) != index.chunk_length:
            raise BagReadError(
                f"{str(mcap_path)!r}: the summary indexes a chunk at offset "
                f"{index.chunk_start_offset} ({index.chunk_length} bytes) that is not in the file"
            )
    if len(chunk_indexes) != len(chunk_offsets):
        raise BagReadError(
            f"{str(mcap_path)!r}: {len(chunk_offsets)} chunks were read, the summary indexes "
            f"{len(chunk_indexes)}"
        )
    out.complete = True
    return out


def _decompression_errors() -> tuple[type[BaseException], ...]:
    """What the chunk decompressors raise on corrupt data: zstandard's ``ZstdError``, lz4's
    ``RuntimeError`` (both are dependencies of the ros extra, as mcap reads through them)."""
    import zstandard

    return (zstandard.ZstdError, RuntimeError)


def _take(
    out: BagScan,
    rec,
    at: int,
    path: Path,
    check: Callable[[str, bytes], str | None] | None,
    unverified: set[str],
    on_message: Callable[[RecordedMessage], None] | None,
    wanted: set[str] | None,
) -> None:
    """One message record (``channel_id``, ``log_time``, ``publish_time``, ``sequence``,
    ``data``) read at offset ``at`` of ``path``: its channel known, its bytes exact, counted, and
    handed to ``on_message`` (whose failure is a :class:`MessageCallbackError`)."""
    channel = out.channels.get(rec.channel_id)
    if channel is None:
        raise BagReadError(f"{str(path)!r}: a message at offset {at} names channel "
                           f"{rec.channel_id}, never declared")  # fmt: skip
    if check is not None:
        problem = check(channel.type_name, rec.data)
        if problem is None:
            unverified.add(channel.type_name)
        elif problem:
            raise BagReadError(f"{str(path)!r}: message {out.counts.get(channel.topic, 0) + 1} "
                               f"of {channel.topic} (chunk at offset {at}) {problem}")  # fmt: skip
    n = out.counts[channel.topic] = out.counts.get(channel.topic, 0) + 1
    out.start_ns = rec.log_time if out.start_ns is None else min(out.start_ns, rec.log_time)
    out.end_ns = rec.log_time if out.end_ns is None else max(out.end_ns, rec.log_time)
    if on_message is not None and (wanted is None or channel.topic in wanted):
        message = RecordedMessage(channel.topic, channel.type_name, rec.log_time,
                                  rec.publish_time, rec.sequence, bytes(rec.data), at,
                                  channel)  # fmt: skip
        try:
            on_message(message)
        except Exception as exc:  # the caller's failure, not the file's: never a verdict
            said = " ".join(str(exc).split()) or "(no message)"
            raise MessageCallbackError(
                f"{str(path)!r}: message {n} of {channel.topic} (offset {at}) passed "
                f"every check of the file, then the caller's on_message callback raised "
                f"{type(exc).__name__}: {said}",
                path, channel.topic, n, at,
            ) from exc  # fmt: skip


def _scan_sqlite(
    bag: BagFiles,
    on_message: Callable[[RecordedMessage], None] | None,
    check: Callable[[str, bytes], str | None] | None,
    wanted: set[str] | None,
    unverified: set[str],
) -> BagScan:
    """Read and verify a sqlite3 bag (:mod:`drs_ros.bag.sqlite`): every page of each database
    (SQLite's integrity check), then every message, in time order, as :func:`_scan_file` does
    (its row number in the file is its ``offset``)."""
    from . import sqlite

    path = bag.bag_dir if bag.bag_dir is not None else bag.files[0]
    out = BagScan(path, bag.bag_dir, file_size=sum(f.stat().st_size for f in bag.files))
    for file in bag.files:
        sqlite.check_integrity(file)
    for channel in sqlite.channels(bag):
        out.channels[channel["id"]] = ChannelInfo(**channel)
        out.counts.setdefault(channel["topic"], 0)
    for row, rec in enumerate(sqlite.iter_rows(bag), start=1):
        _take(out, rec, row, path, check, unverified, on_message, wanted)
    out.complete = True
    return out


def _add_channel(out: BagScan, schemas, record, fail) -> None:
    schema = schemas.get(record.schema_id)
    if schema is None and record.schema_id != 0:
        fail(f"channel {record.topic} names schema {record.schema_id}, never declared")
    out.channels[record.id] = ChannelInfo(
        record.id,
        record.topic,
        schema.name if schema else "",
        schema.encoding if schema else "",
        bytes(schema.data) if schema else b"",
        record.message_encoding,
        dict(record.metadata),
    )
    out.counts.setdefault(record.topic, 0)


def first_message(
    path: str | Path, topic: str, accept: Callable[[RecordedMessage], bool] = lambda m: True
) -> RecordedMessage | None:
    """The first message of ``topic`` that ``accept`` takes, reading the bag's files in order a
    chunk at a time and stopping there (a look-ahead, e.g. for the parameters a run recorded at
    its start). Nothing is verified: a damaged or unreadable file ends the search (None), and
    :func:`scan` says why. An exception of ``accept`` is the caller's failure, not the file's:
    it is raised as :class:`MessageCallbackError`, never taken for "no such message"."""
    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk

    try:
        bag = resolve(path, require_metadata=False)
        if bag.storage == "sqlite3":
            return _first_row(bag, topic, accept)
    except BagReadError:
        return None
    for file in bag.files:
        schemas: dict[int, Any] = {}
        channels: dict[int, Any] = {}
        try:
            with open(file, "rb") as f:
                if f.read(8) != MCAP_MAGIC:
                    return None
                f.seek(0)
                for record in StreamReader(f, validate_crcs=True, emit_chunks=True).records:
                    inner = breakup_chunk(record, True) if isinstance(record, Chunk) else [record]
                    for rec in inner:
                        if isinstance(rec, Schema):
                            schemas[rec.id] = rec
                        elif isinstance(rec, Channel):
                            channels[rec.id] = rec
                        elif isinstance(rec, Message):
                            channel = channels.get(rec.channel_id)
                            if channel is None or channel.topic != topic:
                                continue
                            schema = schemas.get(channel.schema_id)
                            message = RecordedMessage(
                                topic, schema.name if schema else "", rec.log_time,
                                rec.publish_time, rec.sequence, bytes(rec.data), 0,
                            )  # fmt: skip
                            if _accepts(accept, message, file):
                                return message
        except MessageCallbackError:
            raise
        except Exception:  # noqa: BLE001 - the mcap library's error on damage: scan reports it
            return None
    return None


def _accepts(accept, message: RecordedMessage, file: Path) -> bool:
    """``accept(message)``, its exception raised as :class:`MessageCallbackError`."""
    try:
        return bool(accept(message))
    except Exception as exc:  # the caller's failure: named, never a verdict on the file
        raise MessageCallbackError(
            f"{str(file)!r}: the look-ahead's callback raised on a message of {message.topic} "
            f"({type(exc).__name__}: {exc})", file, message.topic, 0, message.offset,
        ) from exc  # fmt: skip


def _first_row(bag: BagFiles, topic: str, accept) -> RecordedMessage | None:
    """:func:`first_message` of a sqlite3 bag."""
    from . import sqlite

    types = {c["id"]: c["type_name"] for c in sqlite.channels(bag)}
    for rec in sqlite.iter_rows(bag, topics={topic}):
        message = RecordedMessage(topic, types[rec.channel_id], rec.log_time, rec.publish_time,
                                  rec.sequence, rec.data, 0)  # fmt: skip
        if _accepts(accept, message, bag.bag_dir or bag.files[0]):
            return message
    return None


def _check_summary(f, footer, size: int, fail) -> None:
    """The footer's summary CRC: bytes from the summary start through summary_offset_start."""
    if footer.summary_start == 0 or footer.summary_crc == 0:
        return
    footer_at = size - 8 - _FOOTER_LEN
    f.seek(footer.summary_start)
    data = f.read(footer_at + 1 + 8 + 8 + 8 - footer.summary_start)
    crc = zlib.crc32(data)
    if crc != footer.summary_crc:
        fail(f"summary CRC mismatch (footer says {footer.summary_crc:#010x}, the bytes from "
             f"offset {footer.summary_start} give {crc:#010x})")  # fmt: skip


def _check_metadata(out: BagScan, meta: dict, meta_path: Path) -> None:
    """``metadata.yaml``'s counts (checked by :func:`~drs_ros.bag.files.read_metadata`) against
    what was read."""
    where = str(meta_path)
    held = "the file holds" if not out.parts else f"its {len(out.parts)} files hold"
    listed: dict[str, int] = {}
    for t in meta["topics_with_message_count"]:
        name = t["topic_metadata"]["name"]
        listed[name] = listed.get(name, 0) + t["message_count"]
    for topic, n in listed.items():
        if out.counts.get(topic) is None:
            raise BagReadError(f"{where!r}: lists {topic} ({n} messages); {held} no such topic")
        if out.counts[topic] != n:
            raise BagReadError(
                f"{where!r}: counts {n} messages on {topic}, {held} {out.counts[topic]} "
                f"({n - out.counts[topic]:+d})"
            )
    extra = sorted(set(out.counts) - set(listed))
    if extra:
        raise BagReadError(f"{where!r}: does not list the topics {extra} of the bag")
    total = meta["message_count"]
    if total != out.message_count:
        raise BagReadError(f"{where!r}: counts {total} messages, {held} {out.message_count}")


def _describe(exc: BaseException, where: str) -> str:
    name = type(exc).__name__
    text = str(exc) or "unexpected end of file"
    if name == "CRCValidationError":
        return f"{where} is corrupt ({text})"
    if isinstance(exc, (EOFError, struct.error)) or "end of" in text.lower():
        return f"the file ends inside {where} (truncated: {text})"
    return f"cannot read {where} ({name}: {text})"


def _recovered_note(out: BagScan) -> None:
    lost = out.file_size - out.last_good_offset
    out.notes.append(
        f"stopped at offset {out.stopped_at} of {out.file_size}: {out.reason}; kept "
        f"{out.message_count} messages, {lost} bytes after the last complete record are lost"
    )


__all__ = [
    "MCAP_MAGIC",
    "BagScan",
    "ChannelInfo",
    "MessageCallbackError",
    "RecordedMessage",
    "first_message",
    "scan",
]
