"""ChunkHandoff: chunks closed in one thread and written from another make the file that mcap's
Writer makes when it closes the same chunks itself; the recorder's tick-side writes never
compress or write a chunk."""

from __future__ import annotations

import io
import threading
import time

from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap_support import MESSAGES, three_channel_writer, write_bag

from drs_ros.recording.mcap_append import MessageAppender
from drs_ros.recording.mcap_chunks import handoff_for

COMPRESSIONS = st.sampled_from([CompressionType.NONE, CompressionType.LZ4, CompressionType.ZSTD])


def library_bag(messages, chunk_size: int, compression) -> bytes:
    """The reference: add_message, the writer closing its chunks (by size and at flushes)."""
    return write_bag(messages, direct=False, chunk_size=chunk_size, compression=compression)


def handoff_bag(messages, chunk_size: int, compression, concurrent: bool) -> bytes:
    """The same messages through MessageAppender and ChunkHandoff: chunks closed where they are
    written, written by ``drain`` (``concurrent``: by another thread, all along)."""
    out = io.BytesIO()
    writer = three_channel_writer(out, chunk_size, compression)
    lock = threading.Lock()
    handoff = handoff_for(writer, lock, lambda n: None)
    append = MessageAppender(writer, handoff.close).append
    done = threading.Event()

    def drain_all():
        while not done.is_set():
            handoff.drain()
        handoff.drain()

    drainer = threading.Thread(target=drain_all) if concurrent else None
    if drainer:
        drainer.start()
    for channel, log_time, data, sequence, flush in messages:
        with lock:
            append(channel, log_time, data, log_time + 7, sequence)
            if flush:
                handoff.close()
        if not concurrent:
            handoff.drain()
    done.set()
    if drainer:
        drainer.join()
    with lock:
        handoff.close()
    handoff.drain()
    writer.finish()
    return out.getvalue()


@settings(max_examples=60, deadline=None)
@given(
    messages=MESSAGES,
    chunk_size=st.sampled_from([64, 1000, 1 << 20]),
    compression=COMPRESSIONS,
    concurrent=st.booleans(),
)
def test_the_file_is_byte_for_byte_what_the_writer_makes(
    messages, chunk_size, compression, concurrent
):
    # chunks closed by size and by flushes, written at once or by another thread meanwhile,
    # log times in any order, empty payloads, three compressions: every byte the same
    assert handoff_bag(messages, chunk_size, compression, concurrent) == library_bag(
        messages, chunk_size, compression
    )


def test_a_closed_chunk_reads_back_with_its_index_and_statistics():
    messages = [(1 + k % 3, 10_000 - k, bytes([k]) * k, k, k % 7 == 0) for k in range(50)]
    data = handoff_bag(messages, 200, CompressionType.LZ4, concurrent=True)
    reader = make_reader(io.BytesIO(data))
    summary = reader.get_summary()
    assert summary.statistics.message_count == 50
    assert summary.statistics.chunk_count == len(summary.chunk_indexes) > 7
    # the indexed reader seeks through the chunk and message indexes written by the hand-off
    read = [(c.id, m.log_time, m.data) for _s, c, m in reader.iter_messages()]
    assert read == sorted(((c, t, d) for c, t, d, _s, _f in messages), key=lambda r: r[1])


def test_the_writing_thread_never_encodes_a_chunk(tmp_path, monkeypatch):
    """The recorder's writes (the node's tick) close chunks; only the flush thread compresses
    and writes them."""
    from std_msgs.msg import Float64

    from drs_ros.recording import mcap_chunks
    from drs_ros.recording.mcap_recorder import McapRecorder

    threads = []
    encode = mcap_chunks.ChunkHandoff.encode

    def spy(self, closed):
        threads.append(threading.current_thread().name)
        return encode(self, closed)

    monkeypatch.setattr(mcap_chunks.ChunkHandoff, "encode", spy)
    with McapRecorder(tmp_path / "b", flush_messages=20, chunk_size=512, compression="zstd") as rec:
        rec.register_topic("/x", Float64)
        for k in range(500):
            rec.write("/x", Float64(data=float(k)), k)
        # the flush thread writes what the writes closed, when it gets the GIL (a busy machine
        # delays it): wait for it, then only then look (finish drains in the caller)
        deadline = time.monotonic() + 30.0
        while rec._flusher._handoff.pending and time.monotonic() < deadline:
            time.sleep(0.01)
        writer_threads = set(threads)
    assert writer_threads == {"mcap-recorder-flush"}
    with open(rec.path, "rb") as f:
        read = [m.log_time for _s, _c, m in make_reader(f).iter_messages()]
    assert read == list(range(500))


def test_a_recorder_whose_writes_stop_has_its_chunk_in_the_file(tmp_path):
    from std_msgs.msg import Float64

    from drs_ros.recording.mcap_recorder import McapRecorder

    rec = McapRecorder(tmp_path / "b", flush_period=0.05)
    rec.register_topic("/x", Float64)
    for k in range(30):
        rec.write("/x", Float64(data=float(k)), k)
    deadline = threading.Event()
    for _ in range(100):  # the flush thread closes and writes it within a few periods
        if rec.stats().messages_flushed == 30:
            break
        deadline.wait(0.05)
    assert rec.stats().messages_flushed == 30
    assert rec.stats().file_bytes == rec.path.stat().st_size
    rec.finish()


@given(st.lists(st.tuples(st.integers(0, 2**64 - 1), st.integers(0, 2**64 - 1)), max_size=600))
def test_index_entries_packed_in_pieces_are_the_uint64_pairs(entries):
    # across the piece boundaries (0, 1, 128, 129... entries), the extremes of uint64
    import numpy as np

    from drs_ros.recording.mcap_chunks import packed_entries

    expected = np.array(entries, dtype="<u8").reshape(-1, 2).tobytes()
    assert packed_entries(entries) == expected
