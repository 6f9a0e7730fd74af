"""The private parts of mcap-python (1.6.0, pinned in pyproject.toml) drs uses, where mcap has no
public API.

Every use of a private mcap name is here, so that an mcap upgrade that changes one breaks one
module with an error naming it (:class:`McapPrivateMissing`), never a file written another way,
and ``tests/test_mcap_private.py`` says which:

* :func:`writer_state`: an ``mcap.writer.Writer``'s private state (its statistics, open chunk,
  chunk size, record builder and output stream, chunk indexes, compression, CRC and index
  settings, and the methods that close a chunk and write the record builder out).
  :mod:`drs_ros.recording.mcap_append` adds message records to the open chunk without building a
  ``Message`` each; :mod:`drs_ros.recording.mcap_chunks` closes chunks in one thread and writes
  them from another. ``Writer`` offers neither.
* :data:`chunk_buffer`: the ``BytesIO`` of the open chunk's ``RecordBuilder``, where a message
  record goes.
* :func:`record_stream`: the data stream of an ``mcap.stream_reader.StreamReader``, whose byte
  count is the file offset of the next record (what a reader of a damaged file reports).
"""

from __future__ import annotations

import operator
from dataclasses import dataclass

from ..errors import DRSRosError

#: The mcap-python version whose private state this module reads (pyproject.toml pins it).
MCAP_VERSION = "1.6.0"


class McapPrivateMissing(DRSRosError):
    """The installed mcap-python lacks a private name drs uses: an mcap other than
    :data:`MCAP_VERSION`."""


def _private(obj, name: str, owner: str):
    """``obj``'s attribute ``name`` (of mcap's class ``owner``), or :class:`McapPrivateMissing`."""
    try:
        return getattr(obj, name)
    except AttributeError:
        raise McapPrivateMissing(
            f"{owner} has no {name!r} in the installed mcap {_installed()}; drs reads it as "
            f"mcap {MCAP_VERSION} defines it (drs_ros/recording/mcap_private.py)"
        ) from None


def _installed() -> str:
    import mcap

    return mcap.__version__


@dataclass(frozen=True)
class WriterState:
    """An ``mcap.writer.Writer``'s private state: the objects themselves, shared with the writer
    (a change made through them is the writer's). ``chunk_builder`` is None for a writer that
    writes no chunks."""

    statistics: object
    chunk_builder: object
    chunk_size: int
    maybe_finalize_chunk: object
    record_builder: object
    flush: object
    stream: object
    chunk_indices: list
    compression: object
    enable_crcs: bool
    index_types: object


#: The ``Writer.__name`` attributes :class:`WriterState` holds, in its fields' order.
WRITER_PRIVATE_NAMES = tuple(WriterState.__dataclass_fields__)


#: What drs uses of the writer's open chunk, an ``mcap._chunk_builder.ChunkBuilder`` (a class
#: of a private module): its message count and time bounds, its message index (channel id ->
#: ``MessageIndex``), its ``RecordBuilder``, ``end()`` (its records' bytes) and ``reset()``.
CHUNK_BUILDER_NAMES = (
    "num_messages",
    "message_start_time",
    "message_end_time",
    "message_indices",
    "record_writer",
    "end",
    "reset",
)


def writer_state(writer) -> WriterState:
    """The private state of ``writer`` (an ``mcap.writer.Writer``), its open chunk's checked
    too; raises :class:`McapPrivateMissing` naming the first name the installed mcap lacks."""
    values = {}
    for name in WRITER_PRIVATE_NAMES:
        values[name] = _private(writer, f"_Writer__{name}", "mcap.writer.Writer")
    chunk = values["chunk_builder"]
    if chunk is not None:
        for name in CHUNK_BUILDER_NAMES:
            _private(chunk, name, "mcap._chunk_builder.ChunkBuilder")
        _private(chunk.record_writer, "_buffer", "mcap.data_stream.RecordBuilder")
    return WriterState(**values)


#: ``chunk_buffer(chunk_builder)``: the ``BytesIO`` the open chunk's records are written into
#: (its ``RecordBuilder``'s; a new one after each chunk closes: looked up again for each
#: message). A C getter: it runs once per message, ~50 ns less than a Python function, and
#: :func:`writer_state` has already checked that the name exists.
chunk_buffer = operator.attrgetter("record_writer._buffer")


def record_stream(reader):
    """The ``ReadDataStream`` of ``reader`` (an ``mcap.stream_reader.StreamReader``): its
    ``count`` is the offset [bytes] of the next record in the file."""
    return _private(reader, "_stream", "mcap.stream_reader.StreamReader")


__all__ = [
    "CHUNK_BUILDER_NAMES",
    "MCAP_VERSION",
    "WRITER_PRIVATE_NAMES",
    "McapPrivateMissing",
    "WriterState",
    "chunk_buffer",
    "record_stream",
    "writer_state",
]
