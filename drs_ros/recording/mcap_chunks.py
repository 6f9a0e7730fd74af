"""The bag's chunks closed where the messages are written, and compressed and written elsewhere.

``mcap.writer.Writer`` closes a chunk in the thread that adds the message which fills it, or that
calls ``flush``: it compresses the chunk, writes its message index record by record (two
``struct.pack`` calls and two buffer writes per message) and writes both to the file. At 1 kHz
the node's flush every 0.5 s closes a chunk of ~2,500 messages: 5-10 ms on the tick thread, a
missed deadline each time.

:class:`ChunkHandoff` splits the closing in two. :meth:`ChunkHandoff.close` takes the open chunk
out of the writer (its records, times and index: a few microseconds) and queues it;
:meth:`ChunkHandoff.drain`, run by another thread, encodes each queued chunk (compression, CRC,
the chunk record and its message index records packed at once) without the recorder's lock, then
writes it under the lock as ``Writer`` would have written it, where it would have written it.
The file is byte for byte what ``Writer.flush`` gives at the same closings
(tests/test_mcap_chunks.py).

Like :mod:`drs_ros.recording.mcap_append`, it works on the writer's private state
(:mod:`drs_ros.recording.mcap_private`: the chunk builder, the record builder and ``__flush``,
the statistics and the chunk indices); an mcap without it is an error that names what is
missing. :func:`handoff_for` gives None for a writer without chunks, and the recorder then
closes its chunks through ``Writer.flush``. The records' layout is
:mod:`drs_ros.recording.mcap_records`'.
"""

from __future__ import annotations

import collections
import threading
import zlib
from collections.abc import Callable
from dataclasses import dataclass

from mcap.records import ChunkIndex
from mcap.writer import CompressionType, IndexType

from .mcap_private import writer_state
from .mcap_records import (
    chunk_record,
    message_index_record,
    packed_entries,  # offered here too: the entries a chunk indexes
)


@dataclass(frozen=True)
class ClosedChunk:
    """A chunk taken out of the writer: its ``records`` (uncompressed bytes), the first and last
    log time [ns] of its messages, its message index (channel id -> ``[(log time, offset)]``, in
    the order the channels first appeared) and its ``message_count``."""

    records: bytes
    message_start_time: int
    message_end_time: int
    indices: dict
    message_count: int


@dataclass(frozen=True)
class EncodedChunk:
    """A closed chunk as the bytes of its chunk record and of its message index records."""

    closed: ClosedChunk
    compression: str
    compressed_size: int
    chunk_record: bytes
    index_records: tuple


class ChunkHandoff:
    """Close ``writer``'s chunks in one thread and write them from another, in order.

    ``lock`` is the lock under which the writer is used (the recorder's); ``close`` is called
    with it held, ``drain`` without. ``written(message_count)`` is called under ``lock`` after
    each chunk reached the file, with its messages (the recorder checks the file and counts)."""

    def __init__(self, writer, lock: threading.Lock, written: Callable) -> None:
        self._writer, self._lock, self._written = writer, lock, written
        state = writer_state(writer)
        self._builder = state.chunk_builder
        self._records = state.record_builder
        self._flush_records = state.flush
        self._stream = state.stream
        self._stats = state.statistics
        self._chunk_indices = state.chunk_indices
        self._compression = state.compression
        self._crcs = state.enable_crcs
        self._indexed = bool(state.index_types & IndexType.MESSAGE)
        self._pending: collections.deque[ClosedChunk] = collections.deque()
        self._drain_lock = threading.Lock()  # one writer of chunks at a time: the file's order

    @property
    def pending(self) -> int:
        """Chunks closed and not yet written."""
        return len(self._pending)

    def close(self) -> bool:
        """Take the open chunk out of the writer and queue it (``lock`` held). False when it
        holds no message: like ``Writer.flush``, a chunk of schemas and channels only stays."""
        chunk = self._builder
        if chunk.num_messages == 0:
            return False
        indices = {cid: index.records for cid, index in chunk.message_indices.items()}
        self._pending.append(
            ClosedChunk(
                chunk.end(),
                chunk.message_start_time,
                chunk.message_end_time,
                indices,
                chunk.num_messages,
            )
        )
        chunk.reset()  # a new index dict's lists: the closed chunk keeps its own
        return True

    def drain(self) -> None:
        """Encode and write every queued chunk, in the order they closed (``lock`` not held).
        An ``OSError`` of the file is raised; the chunks not yet written stay queued."""
        with self._drain_lock:
            while True:
                with self._lock:
                    if not self._pending or self._stream.closed:
                        return
                    closed = self._pending[0]
                encoded = self.encode(closed)  # compression and packing off the lock
                with self._lock:
                    if self._stream.closed:  # abandoned or discarded meanwhile
                        return
                    self._write(encoded)
                    self._pending.popleft()
                    self._written(closed.message_count)

    def encode(self, closed: ClosedChunk) -> EncodedChunk:
        """The chunk record and message index records of ``closed``, as ``Writer`` writes them."""
        data = closed.records
        if self._compression == CompressionType.LZ4:
            import lz4.frame

            compression, body = "lz4", lz4.frame.compress(data)
        elif self._compression == CompressionType.ZSTD:
            import zstandard

            compression, body = "zstd", zstandard.compress(data)
        else:
            compression, body = "", data
        crc = zlib.crc32(data) if self._crcs else 0
        record = chunk_record(
            closed.message_start_time, closed.message_end_time, data, crc, compression, body
        )
        index_records = []
        if self._indexed:
            for channel_id, entries in closed.indices.items():
                index_records.append((channel_id, message_index_record(channel_id, entries)))
        return EncodedChunk(closed, compression, len(body), record, tuple(index_records))

    def _write(self, encoded: EncodedChunk) -> None:
        """``encoded`` into the file where ``Writer`` would put it, with its chunk index."""
        self._stats.chunk_count += 1
        self._flush_records()  # what the writer holds (a metadata record) goes first
        start = self._stream.tell()
        self._records.write(encoded.chunk_record)
        self._flush_records()
        index_start = self._stream.tell()
        offsets, length = {}, 0
        for channel_id, record in encoded.index_records:
            offsets[channel_id] = index_start + length
            self._records.write(record)
            length += len(record)
        self._flush_records()
        closed = encoded.closed
        self._chunk_indices.append(
            ChunkIndex(
                message_start_time=closed.message_start_time,
                message_end_time=closed.message_end_time,
                chunk_start_offset=start,
                chunk_length=len(encoded.chunk_record),
                message_index_offsets=offsets,
                message_index_length=length,
                compression=encoded.compression,
                compressed_size=encoded.compressed_size,
                uncompressed_size=len(closed.records),
            )
        )
        self._stream.flush()


def handoff_for(writer, lock: threading.Lock, written: Callable) -> ChunkHandoff | None:
    """A :class:`ChunkHandoff` of ``writer`` (a started ``mcap.writer.Writer`` with chunks), or
    None when the writer writes no chunks. An mcap without the private state it uses:
    :class:`~drs_ros.recording.mcap_private.McapPrivateMissing`."""
    if writer_state(writer).chunk_builder is None:
        return None
    return ChunkHandoff(writer, lock, written)


__all__ = ["ChunkHandoff", "ClosedChunk", "EncodedChunk", "handoff_for", "packed_entries"]
