"""Message records appended to an ``mcap.writer.Writer``'s open chunk in one step each.

``Writer.add_message`` builds a ``Message`` record object, writes its five fields through six
calls of a ``RecordBuilder`` (a ``struct.pack`` and a ``BytesIO.write`` each), then updates the
chunk's message index and the file's statistics: ~10-15 us per message, the largest part of
a bag write, paid for every message of every tick. :class:`MessageAppender` writes the same
record (its 31-byte head packed by one ``struct.pack``, then the data) into the chunk's buffer
and updates the same index and statistics, so that the file holds exactly the bytes
``add_message`` would have written (tests/test_mcap_append.py compares them).

It works on the writer's private state (:mod:`drs_ros.recording.mcap_private`: the statistics,
the open chunk, the chunk size, the chunk's ``RecordBuilder`` buffer); an mcap without it is an
error that names what is missing. A writer without chunks is given its own ``add_message``. The
record's layout is :mod:`drs_ros.recording.mcap_records`'.
"""

from __future__ import annotations

from mcap.records import MessageIndex

from .mcap_private import chunk_buffer, writer_state
from .mcap_records import MESSAGE_FIELDS, MESSAGE_HEAD, MESSAGE_OPCODE

#: The record length counts the fixed fields after the length, then the data [bytes].
_FIELDS_BYTES = MESSAGE_FIELDS.size


class MessageAppender:
    """``append(channel_id, log_time, data, publish_time, sequence)``: one message into
    ``writer`` (an ``mcap.writer.Writer`` that has started), as ``writer.add_message`` with the
    same arguments would add it. ``on_full()``: what closes a chunk that outgrew the writer's
    chunk size (by default the writer's own closing, as ``add_message`` does; the recorder hands
    it to another thread, :mod:`drs_ros.recording.mcap_chunks`)."""

    def __init__(self, writer, on_full=None) -> None:
        self._writer = writer
        state = writer_state(writer)
        self._stats = state.statistics
        self._chunk = state.chunk_builder  # None: the writer writes no chunks
        self._chunk_size = state.chunk_size
        self._on_full = on_full or state.maybe_finalize_chunk
        #: Whether records go straight into the chunk (False: through ``add_message``).
        self.direct = self._chunk is not None
        if not self.direct:
            self.append = writer.add_message

    def append(
        self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int
    ) -> None:
        """Add one message record (``data``: its payload) to the open chunk; the chunk is
        closed and written when it outgrows the writer's chunk size, as ``add_message`` does."""
        self._file_statistics(log_time, 1)
        self._stats.channel_message_counts[channel_id] += 1
        self._into_chunk(channel_id, log_time, data, publish_time, sequence)

    def append_many(self, log_time: int, records) -> None:
        """Add the records ``(channel_id, data, sequence)`` of one log time [ns], which is also
        their publish time (a tick's states), in order: the same bytes as :meth:`append` of
        each, the file's statistics updated once."""
        if not self.direct:
            for channel_id, data, sequence in records:
                self.append(channel_id, log_time, data, log_time, sequence)
            return
        self._file_statistics(log_time, len(records))
        counts = self._stats.channel_message_counts
        for channel_id, data, sequence in records:
            counts[channel_id] += 1
            self._into_chunk(channel_id, log_time, data, log_time, sequence)

    def _file_statistics(self, log_time: int, count: int) -> None:
        """``count`` messages more, logged at ``log_time`` [ns], in the file's statistics."""
        if count == 0:
            return
        stats = self._stats
        if stats.message_count == 0 or log_time < stats.message_start_time:
            stats.message_start_time = log_time
        if log_time > stats.message_end_time:
            stats.message_end_time = log_time
        stats.message_count += count

    def _into_chunk(
        self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int
    ) -> None:
        """The record into the open chunk, its index and time bounds; the chunk closed when it
        outgrows the writer's chunk size."""
        chunk = self._chunk
        if chunk.num_messages == 0 or log_time < chunk.message_start_time:
            chunk.message_start_time = log_time
        if log_time > chunk.message_end_time:
            chunk.message_end_time = log_time
        buffer = chunk_buffer(chunk)  # a new one after each chunk: looked up each time
        index = chunk.message_indices.get(channel_id)
        if index is None:
            index = chunk.message_indices[channel_id] = MessageIndex(channel_id, [])
        index.records.append((log_time, buffer.tell()))
        chunk.num_messages += 1
        buffer.write(
            MESSAGE_HEAD.pack(
                MESSAGE_OPCODE,
                _FIELDS_BYTES + len(data),
                channel_id,
                sequence,
                log_time,
                publish_time,
            )
        )
        buffer.write(data)
        if buffer.tell() > self._chunk_size:
            self._on_full()


__all__ = ["MessageAppender"]
