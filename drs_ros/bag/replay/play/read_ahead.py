"""rosbag2's read-ahead queue: a reader thread that stays a bounded number of messages ahead of
the player.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator

from drs_ros.stop_request import StopRequest
from drs_ros.threads import NamedThread

_END = object()


class ReadAhead:
    """A reader thread that keeps at most ``size`` messages of ``source`` ready (rosbag2's
    read-ahead queue). Iterating yields them; a reader error is raised in the consumer.
    A stop requested (``stop``, a :class:`~drs_ros.stop_request.StopRequest`) or :meth:`close`
    ends both sides within 0.1 s."""

    def __init__(self, source: Iterator, size: int, stop: StopRequest | None = None):
        self._queue: queue.Queue = queue.Queue(maxsize=size)
        self._stop = stop if stop is not None else StopRequest()
        self._closed = threading.Event()
        self._thread = NamedThread(
            target=self._fill, args=(source,), name="drs-bag-read-ahead", daemon=True
        )
        self._thread.start()

    def _put(self, item) -> bool:
        while not self._halted():
            try:
                self._queue.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def _fill(self, source: Iterator) -> None:
        try:
            for item in source:
                if not self._put(item):
                    return
            self._put(_END)
        except BaseException as exc:  # handed to the consumer, which reports it
            self._put(exc)
        finally:
            close = getattr(source, "close", None)
            if close is not None:
                close()

    def __iter__(self):
        while True:
            try:
                item = self._queue.get(timeout=0.1)
            except queue.Empty:
                if self._halted():
                    return
                continue
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            yield item

    def _halted(self) -> bool:
        return self._stop.requested or self._closed.is_set()

    def close(self) -> None:
        """Stop the reader thread (waits up to 1 s for it)."""
        self._closed.set()
        self._thread.join(timeout=1.0)
