"""One ``.mcap`` file read record by record and verified (:func:`scan_file`): its magic at both
ends, every chunk's CRC, the summary (its CRC, its chunk indexes and statistics against what was
read); what reading damaged MCAP bytes raises (:func:`mcap_read_errors`).
"""

from __future__ import annotations

import io
import struct
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path

from drs_ros.bag.read.files import BagReadError
from drs_ros.bag.read.recorded import BagScan, ChannelInfo
from drs_ros.recording.mcap_private import record_stream
from drs_ros.recording.mcap_records import (
    FOOTER,
    FOOTER_CRC_COVERED,
    MAGIC,
    MESSAGE_FIELDS,
    RECORD_HEAD,
    Opcode,
)


def scan_file(
    mcap_path: Path,
    bag_dir: Path | None,
    take_message: Callable[[BagScan, object, int, Path], None],
    recover: bool,
) -> BagScan:
    """Read and verify one ``.mcap`` file (everything of :func:`.reader.scan` but
    ``metadata.yaml``); ``take_message(out, record, offset, path)`` checks, counts and hands on
    each message record."""
    file = _McapFileScan(mcap_path, bag_dir, take_message)
    out = file.out
    try:
        file.read()
    except BagReadError as exc:
        if not recover or out.message_count == 0:
            raise
        return file.stopped(str(exc).split(": ", 1)[-1])
    except mcap_read_errors() as exc:
        reason = _describe(exc, file.where)
        if not recover:
            raise BagReadError(
                f"{str(mcap_path)!r}: {reason}; {out.message_count} messages were readable "
                f"before it (drs-bag recover salvages them)"
            ) from exc
        if out.message_count == 0:
            raise BagReadError(
                f"{str(mcap_path)!r}: nothing recoverable: {reason} before any complete message"
            ) from exc
        return file.stopped(reason)
    file.check_summary_counts()
    out.complete = True
    return out


class _McapFileScan:
    """One file's scan as it goes: the result so far (``out``), the schemas, the chunks read
    (offset -> length [bytes]), the summary's statistics, chunk indexes and footer, the offset of
    the next record and ``where`` reading is (what an error names)."""

    def __init__(self, mcap_path: Path, bag_dir: Path | None, take_message: Callable):
        self.path, self.take_message = mcap_path, take_message
        self.out = BagScan(mcap_path, bag_dir, file_size=mcap_path.stat().st_size)
        self.schemas: dict[int, object] = {}
        self.chunk_offsets: dict[int, int] = {}
        self.stats = None
        self.chunk_indexes: list = []
        self.footer = None
        self.offset = len(MAGIC)
        self.where = "the header"

    def fail(self, msg: str) -> None:
        raise BagReadError(f"{str(self.path)!r}: {msg}")

    def read(self) -> None:
        """Every record, in file order, then nothing after the closing magic and the summary's
        CRC; raises what the file or the mcap library raises."""
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
        from mcap.stream_reader import StreamReader

        with open(self.path, "rb") as f:
            head = f.read(len(MAGIC))
            if head != MAGIC:
                self.fail("not an MCAP file (no MCAP magic at the start)" if head else "empty file")
            f.seek(0)
            reader = StreamReader(f, validate_crcs=True, emit_chunks=True)
            stream = record_stream(reader)  # its byte count is the offset of the next record
            for record in reader.records:
                end, offset = stream.count, self.offset
                if isinstance(record, Chunk):
                    self.where = f"the chunk at offset {offset}"
                    self.chunk_offsets[offset] = end - offset
                    for inner in chunk_records(record):
                        self.data_record(inner, offset)
                elif isinstance(record, (Message, Schema, Channel)):
                    self.data_record(record, offset)
                elif isinstance(record, Statistics):
                    self.stats = record
                elif isinstance(record, ChunkIndex):
                    self.chunk_indexes.append(record)
                elif isinstance(record, DataEnd):
                    self.where = f"the summary after offset {end}"
                elif isinstance(record, Footer):
                    self.footer = record
                self.out.last_good_offset = end
                self.offset = end
                if self.footer is None:
                    self.where = f"the record at offset {end}"
            if self.footer is None:
                self.fail(f"ends at offset {self.offset} without a footer (truncated)")
            end_of_file = stream.count
            f.seek(0, 2)
            size = f.tell()
            if size != end_of_file:
                self.fail(
                    f"{size - end_of_file} unread bytes after the closing magic at offset "
                    f"{end_of_file}"
                )
            _check_summary(f, self.footer, size, self.fail)

    def data_record(self, rec, at: int) -> None:
        """A message, schema or channel, in a chunk or not (``at``: the offset to report)."""
        from mcap.records import Channel, Message, Schema

        if isinstance(rec, Message):
            self.take_message(self.out, rec, at, self.path)
        elif isinstance(rec, Schema):
            self.schemas[rec.id] = rec
        elif isinstance(rec, Channel):
            _add_channel(self.out, self.schemas, rec, self.fail)

    def check_summary_counts(self) -> None:
        """The statistics' message counts and the chunk indexes against what was read."""
        out, path = self.out, self.path
        if self.stats is None:
            raise BagReadError(f"{str(path)!r}: no statistics record in the summary")
        for cid, n in self.stats.channel_message_counts.items():
            topic = out.channels[cid].topic if cid in out.channels else f"channel {cid}"
            if out.counts.get(topic, 0) != n:
                raise BagReadError(
                    f"{str(path)!r}: the summary counts {n} messages on {topic}, "
                    f"{out.counts.get(topic, 0)} were read ({n - out.counts.get(topic, 0)} missing)"
                )
        for index in self.chunk_indexes:
            if self.chunk_offsets.get(index.chunk_start_offset) != index.chunk_length:
                raise BagReadError(
                    f"{str(path)!r}: the summary indexes a chunk at offset "
                    f"{index.chunk_start_offset} ({index.chunk_length} bytes) that is not in "
                    "the file"
                )
        if len(self.chunk_indexes) != len(self.chunk_offsets):
            raise BagReadError(
                f"{str(path)!r}: {len(self.chunk_offsets)} chunks were read, the summary indexes "
                f"{len(self.chunk_indexes)}"
            )

    def stopped(self, reason: str) -> BagScan:
        """The result of a recovering scan that stopped at the current offset for ``reason``."""
        self.out.stopped_at, self.out.reason = self.offset, reason
        _recovered_note(self.out)
        return self.out


def mcap_read_errors() -> tuple[type[BaseException], ...]:
    """What reading damaged MCAP bytes raises, from the mcap library, the decompressors and the
    file: the errors a reader of a bag means to catch (and no other)."""
    from mcap.exceptions import McapError

    return (
        McapError,
        ValueError,
        EOFError,
        OSError,
        struct.error,
        KeyError,
        IndexError,
        UnicodeDecodeError,
        *_decompression_errors(),
    )


def _decompression_errors() -> tuple[type[BaseException], ...]:
    """What the chunk decompressors raise on corrupt data: zstandard's ``ZstdError``, lz4's
    ``RuntimeError`` (both are dependencies of the ros extra, as mcap reads through them)."""
    import zstandard

    return (zstandard.ZstdError, RuntimeError)


def _add_channel(out: BagScan, schemas, record, fail) -> None:
    schema = schemas.get(record.schema_id)
    if schema is None and record.schema_id != 0:
        fail(f"channel {record.topic} names schema {record.schema_id}, never declared")
    out.channels[record.id] = ChannelInfo.of_record(record, schema)
    out.counts.setdefault(record.topic, 0)


def chunk_records(chunk) -> Iterator[object]:
    """The Schema, Channel and Message records of an MCAP ``chunk``, in order, made one at a time
    (mcap's ``breakup_chunk`` makes the list of all of them first: a 1 MiB chunk of small
    messages is ~3 MB of objects at once). The chunk's CRC and the framing of every record in it
    (opcode, length, within the chunk) are checked before the first is made, so a damaged chunk
    gives none."""
    from mcap.data_stream import ReadDataStream
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import get_chunk_data_stream

    stream, length = get_chunk_data_stream(chunk, validate_crc=True)
    # the whole of the BytesIO it wraps: CPython hands back the same bytes object, no copy
    data = stream.read(length)
    at, head, fixed = 0, RECORD_HEAD.size, MESSAGE_FIELDS.size
    while at < length:
        if at + head > length:
            raise EOFError(f"a record header cut at byte {at} of a {length}-byte chunk")
        opcode, record_len = RECORD_HEAD.unpack_from(data, at)
        if opcode == Opcode.MESSAGE and record_len < fixed:
            raise EOFError(
                f"a message record of {record_len} bytes at byte {at} of its chunk "
                f"(its fixed fields alone take {fixed})"
            )
        at += head + record_len
        if at > length:
            raise EOFError(f"a record of {record_len} bytes overruns its {length}-byte chunk")
    stream = ReadDataStream(io.BytesIO(data))
    read = {Opcode.SCHEMA: Schema.read, Opcode.CHANNEL: Channel.read}
    while stream.count < length:
        opcode, record_len = stream.read1(), stream.read8()
        if opcode == Opcode.MESSAGE:
            yield Message.read(stream, record_len)
        elif opcode in read:
            yield read[opcode](stream)
        else:
            stream.read(record_len)  # a record type a chunk may hold that no check reads


def _check_summary(f, footer, size: int, fail) -> None:
    """The footer's summary CRC: bytes from the summary start through summary_offset_start."""
    if footer.summary_start == 0 or footer.summary_crc == 0:
        return
    footer_at = size - len(MAGIC) - FOOTER.size
    f.seek(footer.summary_start)
    data = f.read(footer_at + FOOTER_CRC_COVERED - footer.summary_start)
    crc = zlib.crc32(data)
    if crc != footer.summary_crc:
        fail(
            f"summary CRC mismatch (footer says {footer.summary_crc:#010x}, the bytes from "
            f"offset {footer.summary_start} give {crc:#010x})"
        )


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


__all__ = ["chunk_records", "mcap_read_errors", "scan_file"]
