"""drs_ros.recording.mcap_records packs and unpacks the bytes mcap-python's own record classes
write (the reference: ``Message``, ``Chunk``, ``MessageIndex``, ``Footer`` through a
``RecordBuilder``)."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st
from mcap.data_stream import RecordBuilder
from mcap.records import Chunk, Footer, Message, MessageIndex
from mcap.writer import MCAP0_MAGIC

from drs_ros.recording import mcap_records as records

U16, U32, U64 = (st.integers(0, 2**n - 1) for n in (16, 32, 64))
ENTRIES = st.lists(st.tuples(U64, U64), max_size=300)


def written(record) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return builder.end()


def test_the_magic_is_the_writers():
    assert records.MAGIC == MCAP0_MAGIC


@given(U16, U32, U64, U64, st.binary(max_size=40))
def test_a_message_head_and_its_data_are_the_message_record(channel, sequence, log, publish, data):
    head = records.MESSAGE_HEAD.pack(
        records.MESSAGE_OPCODE,
        records.MESSAGE_FIELDS.size + len(data),
        channel,
        sequence,
        log,
        publish,
    )
    record = written(Message(channel, log, data, publish, sequence))
    assert head + data == record
    opcode, length = records.RECORD_HEAD.unpack_from(record)
    assert (opcode, length) == (records.Opcode.MESSAGE, len(record) - records.RECORD_HEAD.size)
    fields = records.MESSAGE_FIELDS.unpack_from(record, records.RECORD_HEAD.size)
    assert fields == (channel, sequence, log, publish)


@given(
    U64,
    U64,
    st.binary(max_size=200),
    U32,
    st.sampled_from(["", "lz4", "zstd"]),
    st.binary(max_size=200),
)
def test_a_chunk_record_is_the_chunk_writers(start, end, uncompressed, crc, compression, body):
    chunk = Chunk(
        compression=compression,
        data=body,
        message_start_time=start,
        message_end_time=end,
        uncompressed_crc=crc,
        uncompressed_size=len(uncompressed),
    )
    packed = records.chunk_record(start, end, uncompressed, crc, compression, body)
    assert packed == written(chunk)


@given(U16, ENTRIES)
def test_a_message_index_record_is_the_index_writers(channel, entries):
    assert records.message_index_record(channel, entries) == written(MessageIndex(channel, entries))


@given(U64, U64, U32)
def test_the_footer_layout_and_what_its_crc_covers(summary_start, offset_start, crc):
    record = written(Footer(summary_start, offset_start, crc))
    assert len(record) == records.FOOTER.size
    assert records.FOOTER.unpack(record) == (
        records.Opcode.FOOTER,
        len(record) - 9,
        summary_start,
        offset_start,
        crc,
    )
    # the summary CRC covers every footer byte before the CRC itself
    assert record[: records.FOOTER_CRC_COVERED] + crc.to_bytes(4, "little") == record
