"""When a recorder's chunks close and who writes them to the file: a part of
:class:`drs_ros.recording.mcap_recorder.McapRecorder` (:class:`ChunkFlusher`).

A chunk closes when it outgrows the chunk size, every ``flush_period`` seconds and every
``flush_messages`` messages (:class:`~drs_ros.recording.flush_schedule.FlushSchedule`), and when
writes stop for a period. Closing takes the chunk out of the writer in the writing thread; the
flush thread compresses and writes it (:mod:`drs_ros.recording.mcap_chunks`), so that the
thread that writes messages (the node's tick) never waits for a file. Without a flush thread,
or when the writer lacks the state the hand-off uses, the chunk is written where it closed.
"""

from __future__ import annotations

import errno
import os
import threading
from collections.abc import Callable
from pathlib import Path

from ..threads import NamedThread
from .flush_schedule import FlushSchedule
from .mcap_chunks import handoff_for


class ChunkFlusher:
    """The chunks of ``writer`` (an ``mcap.writer.Writer`` on ``stream``, the file ``path``),
    closed on ``schedule`` and written under ``lock`` (the recorder's). ``failed(exc)``: the
    recorder keeps the first ``OSError`` (a full disk, the file removed). ``flush_thread``: a
    daemon thread writes the closed chunks and closes the chunk of a recorder whose writes
    stopped for a period."""

    def __init__(
        self,
        writer,
        stream,
        path: Path,
        lock: threading.Lock,
        schedule: FlushSchedule,
        failed: Callable[[OSError], None],
        flush_thread: bool,
    ) -> None:
        self._writer, self._stream, self._path, self._lock = writer, stream, path, lock
        self.schedule, self._failed = schedule, failed
        #: Bytes in the file after the last chunk written [bytes].
        self.file_bytes = stream.tell()
        self._handoff = handoff_for(writer, lock, self._written)
        self._stop = threading.Event()
        self._wake = threading.Event()  # a chunk closed: the flush thread writes it
        self._thread: threading.Thread | None = None
        if flush_thread:
            self._thread = NamedThread(target=self._loop, name="mcap-recorder-flush", daemon=True)
            self._thread.start()

    def on_full(self) -> Callable[[], None] | None:
        """What closes a chunk that outgrew the chunk size (``lock`` held), for
        :class:`~drs_ros.recording.mcap_append.MessageAppender`; None: the writer's own."""
        return None if self._handoff is None else lambda: self.close_locked(0)

    def wrote_locked(self, message_count: int, new: int = 1) -> bool:
        """``new`` messages more (``lock`` held): close the chunk when the schedule says so.
        True when closed chunks wait: call :meth:`write_closed` once the lock is released."""
        self.schedule.wrote(new)
        if self.schedule.due():
            self.close_locked(message_count)
        return self._handoff is not None and self._handoff.pending > 0

    def close_locked(self, message_count: int) -> None:
        """Close the chunk in progress (``lock`` held): queued for writing, or, without the
        hand-off, compressed and written here by the writer (``message_count``: the recorder's
        messages in all, then all in the file)."""
        if self._handoff is None:
            try:
                self._writer.flush()
                self.check_file()
            except OSError as exc:
                self._failed(exc)
                raise
            self.file_bytes = self._stream.tell()
            self.schedule.flushed(message_count)
        elif self._handoff.close():
            self.schedule.closed()

    def write_closed(self) -> None:
        """The chunks closed so far into the file: by the flush thread (woken), or here."""
        if self._thread is not None:
            self._wake.set()
        else:
            self.drain()

    def drain(self) -> None:
        """Write every closed chunk now, in order (``lock`` not held); an ``OSError`` is kept by
        the recorder and raised."""
        if self._handoff is None:
            return
        try:
            self._handoff.drain()
        except OSError as exc:
            with self._lock:
                self._failed(exc)
            raise

    def _written(self, message_count: int) -> None:
        """A closed chunk of ``message_count`` messages reached the file (``lock`` held)."""
        self.check_file()
        self.file_bytes = self._stream.tell()
        self.schedule.written(self.schedule.messages_flushed + message_count)

    def check_file(self) -> None:
        """Raise if the bag file was removed: an unlinked file takes every write and vanishes."""
        if os.fstat(self._stream.fileno()).st_nlink == 0:
            raise FileNotFoundError(
                errno.ENOENT, "the bag file was removed while recording", str(self._path)
            )

    def stop(self) -> None:
        """No more closing by the flush thread (the recorder finishes or is abandoned)."""
        self._stop.set()
        self._wake.set()

    def join(self) -> None:
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)

    def _loop(self) -> None:
        while not self._stop.is_set():
            self._wake.wait(self.schedule.period / 2.0)
            self._wake.clear()
            try:
                with self._lock:
                    if self._stop.is_set():
                        return
                    if self.schedule.idle_due():
                        self.close_locked(0)
                self.drain()
            except OSError:
                return  # kept by the recorder: its next write raises it


__all__ = ["ChunkFlusher"]
