"""drs_ros.recording.mcap_private, the only module that touches mcap-python's private names: each
helper gives what the writers and readers rely on, on the installed mcap. A failure here means an
mcap upgrade changed one of them (the module docstring says what each is for)."""

from __future__ import annotations

import io
import re
import threading
from pathlib import Path
from types import SimpleNamespace

import mcap
import pytest
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, IndexType, Writer

from drs_ros.recording import mcap_private
from drs_ros.recording.mcap_append import MessageAppender
from drs_ros.recording.mcap_chunks import handoff_for

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def started_writer(out, **options) -> Writer:
    writer = Writer(out, **options)
    writer.start(profile="ros2", library="test")
    schema = writer.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
    writer.register_channel("/x", "cdr", schema)
    return writer


def test_the_installed_mcap_is_the_pinned_one():
    assert mcap.__version__ == mcap_private.MCAP_VERSION
    pins = re.findall(r'"mcap([=<>!~][^"]*)"', PYPROJECT.read_text())
    assert pins == [f"=={mcap_private.MCAP_VERSION}"]


def test_the_writer_state_is_the_writers_own():
    """Each field is the object the writer itself updates and uses, with the options given."""
    out = io.BytesIO()
    writer = started_writer(
        out,
        chunk_size=200,
        compression=CompressionType.NONE,
        enable_crcs=False,
        index_types=IndexType.CHUNK,
    )
    state = mcap_private.writer_state(writer)
    assert set(mcap_private.WRITER_PRIVATE_NAMES) == {
        "statistics",
        "chunk_builder",
        "chunk_size",
        "maybe_finalize_chunk",
        "record_builder",
        "flush",
        "stream",
        "chunk_indices",
        "compression",
        "enable_crcs",
        "index_types",
    }
    assert (state.chunk_size, state.compression, state.enable_crcs, state.index_types) == (
        200,
        CompressionType.NONE,
        False,
        IndexType.CHUNK,
    )
    chunk = state.chunk_builder
    writer.add_message(1, 5, b"abc", 5)
    assert state.statistics.message_count == 1
    assert state.statistics.channel_message_counts[1] == 1
    assert chunk.num_messages == 1
    assert (chunk.message_start_time, chunk.message_end_time) == (5, 5)
    # the message record (9-byte head, 22 bytes of fields, its data) ends the chunk's buffer
    message_at = mcap_private.chunk_buffer(chunk).tell() - (9 + 22 + 3)
    assert chunk.message_indices[1].records == [(5, message_at)]
    assert state.chunk_indices == []
    writer.add_message(1, 6, bytes(300), 6)  # past the chunk size: the writer closes the chunk
    assert len(state.chunk_indices) == 1 and chunk.num_messages == 0
    assert mcap_private.chunk_buffer(chunk).tell() == 0  # the new chunk's buffer
    at = state.stream.tell()
    state.record_builder.write(b"xyz")
    state.flush()  # the record builder into the stream: the writer's output
    assert state.stream.tell() == at + 3
    writer.add_message(1, 7, bytes(300), 7)
    state.maybe_finalize_chunk()
    assert len(state.chunk_indices) == 2
    writer.finish()
    assert out.getvalue()[at : at + 3] == b"xyz"


def test_a_writer_without_chunks_has_no_chunk_builder():
    state = mcap_private.writer_state(started_writer(io.BytesIO(), use_chunking=False))
    assert state.chunk_builder is None


def test_the_record_streams_count_is_the_offset_of_the_next_record():
    out = io.BytesIO()
    writer = started_writer(out, use_chunking=False)
    writer.add_message(1, 5, b"abc", 5)
    writer.finish()
    data = out.getvalue()
    reader = StreamReader(io.BytesIO(data), emit_chunks=True)
    stream = mcap_private.record_stream(reader)
    offsets = [stream.count for _record in reader.records]
    # the records' ends, walked through the bytes: a record is its opcode, its length (uint64)
    # and that many bytes; the footer (opcode 2) is the last, the closing magic after it
    ends, at = [], 8
    while True:
        opcode, length = data[at], int.from_bytes(data[at + 1 : at + 9], "little")
        at += 9 + length
        ends.append(at)
        if opcode == 2:
            break
    assert offsets == ends


@pytest.mark.parametrize("name", mcap_private.WRITER_PRIVATE_NAMES)
def test_a_writer_missing_a_private_name_is_an_error_naming_it(name):
    writer = started_writer(io.BytesIO())
    values = {n: getattr(writer, f"_Writer__{n}") for n in mcap_private.WRITER_PRIVATE_NAMES}
    values.pop(name)
    other = SimpleNamespace(**{f"_Writer__{n}": v for n, v in values.items()})
    for make in (
        mcap_private.writer_state,
        MessageAppender,
        lambda w: handoff_for(w, threading.Lock(), lambda n: None),
    ):
        with pytest.raises(mcap_private.McapPrivateMissing, match=f"_Writer__{name}"):
            make(other)


@pytest.mark.parametrize("name", mcap_private.CHUNK_BUILDER_NAMES)
def test_a_chunk_builder_missing_a_name_is_an_error_naming_it(name):
    writer = started_writer(io.BytesIO())
    chunk = writer._Writer__chunk_builder
    fake = SimpleNamespace(
        **{n: getattr(chunk, n) for n in mcap_private.CHUNK_BUILDER_NAMES if n != name}
    )
    writer._Writer__chunk_builder = fake
    with pytest.raises(mcap_private.McapPrivateMissing, match=f"ChunkBuilder has no '{name}'"):
        MessageAppender(writer)


def test_a_record_builder_without_its_buffer_is_an_error_naming_it():
    writer = started_writer(io.BytesIO())
    writer._Writer__chunk_builder.record_writer = SimpleNamespace()
    for make in (
        mcap_private.writer_state,
        MessageAppender,
        lambda w: handoff_for(w, threading.Lock(), lambda n: None),
    ):
        with pytest.raises(mcap_private.McapPrivateMissing, match="RecordBuilder has no '_buffer'"):
            make(writer)


def test_a_stream_reader_without_its_stream_is_an_error_naming_it():
    with pytest.raises(mcap_private.McapPrivateMissing, match="StreamReader has no '_stream'"):
        mcap_private.record_stream(SimpleNamespace())
