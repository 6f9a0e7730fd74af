"""Small MCAP bags for the writer tests: messages drawn on three channels (hypothesis), a writer
with those channels, and the bag mcap's own ``Writer.add_message`` (or
:class:`~drs_ros.recording.mcap_append.MessageAppender`) makes of them."""

from __future__ import annotations

import io

from hypothesis import strategies as st
from mcap.writer import Writer

from drs_ros.recording.mcap_append import MessageAppender

#: ``(channel 1..3, log time [ns], payload, sequence, flush after it)`` of each message.
MESSAGES = st.lists(
    st.tuples(
        st.integers(1, 3),
        st.integers(0, 2**40),
        st.binary(max_size=300),
        st.integers(0, 2**32 - 1),
        st.booleans(),
    ),
    max_size=60,
)


def three_channel_writer(out, chunk_size: int, compression, chunking=True) -> Writer:
    """A started writer into ``out`` with the channels 1, 2, 3 (``/t1`` .. ``/t3``)."""
    writer = Writer(out, chunk_size=chunk_size, compression=compression, use_chunking=chunking)
    writer.start(profile="ros2", library="test")
    schema = writer.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
    for k in (1, 2, 3):
        assert writer.register_channel(f"/t{k}", "cdr", schema, {"k": str(k)}) == k
    return writer


def write_bag(messages, *, direct: bool, chunk_size: int, compression, chunking=True) -> bytes:
    """A small bag of three channels; ``direct``: through MessageAppender, else add_message.
    A message whose flag is set is followed by a flush (the recorder's chunk closes)."""
    out = io.BytesIO()
    writer = three_channel_writer(out, chunk_size, compression, chunking)
    add = MessageAppender(writer).append if direct else writer.add_message
    for channel, log_time, data, sequence, flush in messages:
        add(channel, log_time, data, log_time + 7, sequence)
        if flush:
            writer.flush()
    writer.finish()
    return out.getvalue()
