"""``drs_ros.bag.read.mcap_file.chunk_records``: a chunk's records one at a time, the same records
as
the mcap library's own ``breakup_chunk`` (the reference), and none from a chunk whose framing
is damaged."""

from __future__ import annotations

import io
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drs_ros.bag.read.mcap_file import chunk_records


def _chunks(payloads: list[bytes], compression: str) -> list:
    """The Chunk records of an MCAP file that the mcap library writes: two channels, the
    payloads alternating between them, chunks of 256 bytes."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader
    from mcap.writer import CompressionType, Writer

    buf = io.BytesIO()
    writer = Writer(buf, chunk_size=256, compression=CompressionType[compression.upper()])
    writer.start()
    schema = writer.register_schema("s", "raw", b"")
    channels = [writer.register_channel(f"/t{i}", "cdr", schema) for i in range(2)]
    for k, data in enumerate(payloads):
        writer.add_message(channels[k % 2], log_time=k, data=data, publish_time=k + 1, sequence=k)
    writer.finish()
    buf.seek(0)
    records = StreamReader(buf, validate_crcs=True, emit_chunks=True).records
    return [r for r in records if isinstance(r, Chunk)]


@settings(max_examples=30, deadline=None)
@given(
    payloads=st.lists(st.binary(max_size=300), min_size=1, max_size=40),
    compression=st.sampled_from(["none", "zstd", "lz4"]),
)
def test_the_records_are_the_mcap_librarys(payloads, compression):
    from mcap.stream_reader import breakup_chunk

    chunks = _chunks(payloads, compression)
    assert chunks
    for chunk in chunks:
        assert list(chunk_records(chunk)) == breakup_chunk(chunk, validate_crc=True)


@pytest.mark.parametrize("damage", ["overrun", "short message", "cut header"])
def test_a_chunk_with_damaged_framing_gives_no_record(damage):
    from dataclasses import replace

    (chunk,) = _chunks([b"abc", b"defg", b"hi"], "none")[:1]
    data = bytearray(chunk.data)
    at = 0  # the first message record (after the schema and the channels)
    while data[at] != 0x05:
        at += 9 + struct.unpack_from("<Q", data, at + 1)[0]
    assert at > 0  # records come before it: none of them may be given either
    if damage == "overrun":
        struct.pack_into("<Q", data, at + 1, len(data))
    elif damage == "short message":
        struct.pack_into("<Q", data, at + 1, 3)
    else:
        data = data[: at + 4]
    # uncompressed_crc 0: no CRC to catch it, the framing check alone does
    damaged = replace(chunk, data=bytes(data), uncompressed_size=len(data), uncompressed_crc=0)
    records = chunk_records(damaged)
    with pytest.raises(EOFError):
        next(records)
