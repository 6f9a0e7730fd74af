"""MessageAppender writes exactly what mcap's Writer.add_message writes, chunk for chunk."""

from __future__ import annotations

import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer
from mcap_support import MESSAGES, three_channel_writer, write_bag

from drs_ros.recording.mcap_append import MessageAppender

#: Chunks closed by size after every message or two, now and then, or only by flushes.
CHUNK_SIZES = st.sampled_from([64, 1000, 1 << 20])
COMPRESSIONS = st.sampled_from([CompressionType.NONE, CompressionType.LZ4])


@settings(max_examples=60, deadline=None)
@given(messages=MESSAGES, chunk_size=CHUNK_SIZES, compression=COMPRESSIONS)
def test_the_file_is_byte_for_byte_what_add_message_writes(messages, chunk_size, compression):
    # log times in any order (the statistics' and chunks' start and end), chunks closed by
    # size and by flushes, empty payloads: every byte of the file the same
    direct = write_bag(messages, direct=True, chunk_size=chunk_size, compression=compression)
    assert direct == write_bag(
        messages, direct=False, chunk_size=chunk_size, compression=compression
    )


BATCHES = st.lists(
    st.tuples(
        st.integers(0, 2**40),
        st.lists(
            st.tuples(st.integers(1, 3), st.binary(max_size=300), st.integers(0, 2**32 - 1)),
            max_size=6,
        ),
        st.booleans(),
    ),
    max_size=20,
)


def write_batches(batches, *, many: bool, chunk_size: int, compression) -> bytes:
    """A small bag of three channels from batches of one log time each (a tick's states):
    through ``append_many``, or ``add_message`` for each message (publish time = log time)."""
    out = io.BytesIO()
    writer = three_channel_writer(out, chunk_size, compression)
    appender = MessageAppender(writer)
    for log_time, records, flush in batches:
        if many:
            appender.append_many(log_time, records)
        else:
            for channel, data, sequence in records:
                writer.add_message(channel, log_time, data, log_time, sequence)
        if flush:
            writer.flush()
    writer.finish()
    return out.getvalue()


@settings(max_examples=60, deadline=None)
@given(batches=BATCHES, chunk_size=CHUNK_SIZES, compression=COMPRESSIONS)
def test_a_batch_of_one_log_time_is_byte_for_byte_what_add_message_writes(
    batches, chunk_size, compression
):
    # empty batches, chunks closed by size in the middle of a batch and by flushes between them
    many = write_batches(batches, many=True, chunk_size=chunk_size, compression=compression)
    assert many == write_batches(
        batches, many=False, chunk_size=chunk_size, compression=compression
    )


def test_the_messages_read_back_in_order_with_their_fields():
    messages = [(1 + k % 3, 10_000 - k, bytes([k]) * k, k, k % 7 == 0) for k in range(50)]
    data = write_bag(messages, direct=True, chunk_size=200, compression=CompressionType.NONE)
    reader = make_reader(io.BytesIO(data))
    read = [
        (c.id, m.log_time, m.data, m.sequence, m.publish_time)
        for _s, c, m in reader.iter_messages(log_time_order=False)
    ]
    assert read == [(c, t, d, s, t + 7) for c, t, d, s, _f in messages]
    summary = make_reader(io.BytesIO(data)).get_summary()
    assert summary.statistics.message_count == 50
    assert summary.statistics.message_start_time == 10_000 - 49
    assert summary.statistics.message_end_time == 10_000


def test_a_writer_without_chunks_gets_add_message_itself():
    out = io.BytesIO()
    writer = Writer(out, use_chunking=False)
    appender = MessageAppender(writer)
    assert not appender.direct
    assert appender.append == writer.add_message
    messages = [(2, 5, b"abc", 1, False), (1, 3, b"", 2, False)]
    assert write_bag(
        messages, direct=True, chunk_size=64, compression=CompressionType.NONE, chunking=False
    ) == write_bag(
        messages, direct=False, chunk_size=64, compression=CompressionType.NONE, chunking=False
    )


def test_a_sequence_beyond_32_bits_is_refused_as_add_message_refuses_it():
    out = io.BytesIO()
    writer = Writer(out)
    writer.start()
    with pytest.raises(Exception) as direct:
        MessageAppender(writer).append(1, 0, b"", 0, 2**32)
    with pytest.raises(Exception) as library:
        writer.add_message(1, 0, b"", 0, 2**32)
    assert type(direct.value) is type(library.value)
