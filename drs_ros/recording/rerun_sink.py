"""The health of a rerun recording's file sink (:class:`FileSinkWatch`).

rerun-sdk 0.41 writes an ``.rrd`` file from a thread of its own (``re_log_encoding``'s
``FileSink``). When a write fails (``No space left on device``), that thread logs the error to
stderr and ends; ``log`` and ``send_columns`` go on taking data, which no longer reaches the file,
and nothing is raised in Python until the stream is flushed: a flush then raises
``RuntimeError("File-writer thread shut down prematurely")`` (measured with a 300 KB tmpfs). A
file removed while recording fails no write at all: the writer goes on into the unlinked file.

The watch therefore flushes the stream every :data:`SINK_CHECK_PERIOD_S` with a timeout (the
flush releases the GIL: the logging thread goes on meanwhile) and checks that the path still names
the file it opened; it keeps the first failure, with the free space of the file system.
"""

from __future__ import annotations

import os
import shutil
import threading
from pathlib import Path

from ..threads import NamedThread
from .errors import RecordingError

#: How often [s] the watch checks that the file sink still writes.
SINK_CHECK_PERIOD_S = 0.5
#: How long [s] a check's flush may take before the sink counts as failed (a stalled disk).
SINK_FLUSH_TIMEOUT_S = 10.0


class RerunSinkError(RecordingError):
    """The ``.rrd`` file is incomplete: rerun's file writer stopped (a full disk), or the file
    was removed; the message says which and what the file lacks."""


class FileSinkWatch:
    """A thread that checks, every ``period`` [s], that the file sink of ``rec`` (a
    ``rr.RecordingStream`` writing ``path``) still writes; :attr:`failure` is its first finding.

    With a live stream too (``live``), a flush also waits for the viewer, whose failures are not
    the file's: only the file's identity is then checked while recording, and the flush at
    :meth:`check` ``(math.inf)`` (the recorder's close) judges the rest."""

    def __init__(self, rec, path: Path, *, live: bool, period: float = SINK_CHECK_PERIOD_S):
        self.rec, self.path, self.live = rec, Path(path), live
        #: Why the file sink no longer writes (None: it writes).
        self.failure: str | None = None
        self._identity = _identity(self.path)
        self._stop = threading.Event()
        self._thread = NamedThread(
            target=self._run, args=(period,), name="rerun-sink-watch", daemon=True
        )
        self._thread.start()

    def _run(self, period: float) -> None:
        while not self._stop.wait(period) and self.failure is None:
            self.check(SINK_FLUSH_TIMEOUT_S, flush=not self.live)

    def check(self, timeout_s: float, flush: bool = True) -> str | None:
        """Check the sink now (flushing the stream within ``timeout_s`` [s] if ``flush``); the
        first failure found is kept in :attr:`failure` and returned."""
        if self.failure is None:
            self.failure = self._find_failure(timeout_s, flush)
        return self.failure

    def _find_failure(self, timeout_s: float, flush: bool) -> str | None:
        if _identity(self.path) != self._identity:
            return f"the file {str(self.path)!r} was removed while recording"
        if not flush:
            return None
        try:
            self.rec.flush(timeout_sec=timeout_s)
        except RuntimeError as exc:
            free = shutil.disk_usage(self.path.parent).free
            return (
                f"rerun's file writer stopped ({exc}; rerun logs the cause on stderr); "
                f"{free} bytes are free on the file system of {str(self.path.parent)!r}"
            )
        return None

    def stop(self) -> None:
        """End the thread (idempotent); :meth:`check` still works."""
        self._stop.set()
        if self._thread is not threading.current_thread():
            self._thread.join()


def _identity(path: Path) -> tuple[int, int] | None:
    """``(device, inode)`` of the file at ``path`` (None: there is none)."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


__all__ = ["SINK_CHECK_PERIOD_S", "SINK_FLUSH_TIMEOUT_S", "FileSinkWatch", "RerunSinkError"]
