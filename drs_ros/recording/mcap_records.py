"""The MCAP record layout, where drs packs or unpacks records itself rather than through
mcap-python's record classes: the magic, the opcodes, a record's head, the message record's fixed
fields, the chunk record, the message index record and the footer (the MCAP specification,
https://mcap.dev/spec: little-endian, no padding).

The writers (:mod:`drs_ros.recording.mcap_append`, :mod:`drs_ros.recording.mcap_chunks`) pack
with these; the readers (:mod:`drs_ros.bag.read.mcap_file`, :mod:`drs_ros.bag.read.look_ahead`,
:mod:`drs_ros.bag.replay.play.index`) check and skip with them. No other module spells a field's
size.
"""

from __future__ import annotations

import itertools
import struct

from mcap.opcode import Opcode

#: The MCAP magic: 8 bytes at both ends of a file.
MAGIC = b"\x89MCAP0\r\n"
#: Every record's head: its opcode and the length of what follows it [bytes].
RECORD_HEAD = struct.Struct("<BQ")
#: A message record's fixed fields, which its length counts: channel id, sequence, log time and
#: publish time [ns]; the data follows them.
MESSAGE_FIELDS = struct.Struct("<HIQQ")
#: A message record's head and fixed fields at once: what the writer packs before the data.
MESSAGE_HEAD = struct.Struct(RECORD_HEAD.format + MESSAGE_FIELDS.format[1:])
#: :data:`Opcode.MESSAGE` as the plain int :data:`MESSAGE_HEAD` packs fastest.
MESSAGE_OPCODE = int(Opcode.MESSAGE)
#: A chunk record's fields before its compression name: message start and end time [ns],
#: uncompressed size [bytes], uncompressed CRC-32.
CHUNK_FIELDS = struct.Struct("<QQQI")
#: A string's or a byte array's length prefix (uint32) and a chunk's records' length (uint64).
_STRING_LENGTH = struct.Struct("<I")
_RECORDS_LENGTH = struct.Struct("<Q")
#: A message index record's fields before its entries: channel id, byte length of the entries.
_MESSAGE_INDEX_FIELDS = struct.Struct("<HI")
#: A message index record's head and fields before its entries.
MESSAGE_INDEX_HEAD = struct.Struct(RECORD_HEAD.format + _MESSAGE_INDEX_FIELDS.format[1:])
#: The footer record: its head, summary start, summary offset start [bytes from the file's
#: start], summary CRC-32.
FOOTER = struct.Struct(RECORD_HEAD.format + "QQI")
#: The footer's bytes its summary CRC covers: all but the CRC itself.
FOOTER_CRC_COVERED = FOOTER.size - 4
#: Message index entries packed per call. A call holds the GIL throughout (~10 us for this
#: many): between calls the node's tick, which wakes every millisecond, can take it. One
#: conversion of a chunk's ~2,500 entries held it ~2 ms, a missed deadline.
ENTRIES_PER_PACK = 128


def packed_entries(entries) -> bytes:
    """``[(log time, offset), ...]`` as a message index's entries: uint64 pairs, little-endian."""
    parts = []
    for start in range(0, len(entries), ENTRIES_PER_PACK):
        piece = entries[start : start + ENTRIES_PER_PACK]
        parts.append(struct.pack(f"<{2 * len(piece)}Q", *itertools.chain.from_iterable(piece)))
    return b"".join(parts)


def chunk_record(
    message_start_time: int,
    message_end_time: int,
    uncompressed: bytes,
    crc: int,
    compression: str,
    body: bytes,
) -> bytes:
    """A chunk record of ``body`` (``uncompressed`` as compressed by ``compression``: "", "lz4"
    or "zstd"), its messages' first and last log time [ns] and ``crc``, the uncompressed
    records' CRC-32 (0: none)."""
    name = compression.encode()
    fields = b"".join(
        (
            CHUNK_FIELDS.pack(message_start_time, message_end_time, len(uncompressed), crc),
            _STRING_LENGTH.pack(len(name)),
            name,
            _RECORDS_LENGTH.pack(len(body)),
        )
    )
    return RECORD_HEAD.pack(Opcode.CHUNK, len(fields) + len(body)) + fields + body


def message_index_record(channel_id: int, entries) -> bytes:
    """The message index record of channel ``channel_id`` in a chunk: its ``entries``
    ``[(log time [ns], offset in the chunk's records [bytes]), ...]``."""
    packed = packed_entries(entries)
    length = _MESSAGE_INDEX_FIELDS.size + len(packed)
    head = MESSAGE_INDEX_HEAD.pack(Opcode.MESSAGE_INDEX, length, channel_id, len(packed))
    return head + packed


__all__ = [
    "CHUNK_FIELDS",
    "ENTRIES_PER_PACK",
    "FOOTER",
    "FOOTER_CRC_COVERED",
    "MAGIC",
    "MESSAGE_FIELDS",
    "MESSAGE_HEAD",
    "MESSAGE_INDEX_HEAD",
    "MESSAGE_OPCODE",
    "RECORD_HEAD",
    "Opcode",
    "chunk_record",
    "message_index_record",
    "packed_entries",
]
