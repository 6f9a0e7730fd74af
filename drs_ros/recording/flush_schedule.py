"""When a recorder hands its chunk in progress to the OS (:class:`FlushSchedule`): every
``period`` seconds and every ``messages`` messages since the last flush, so that a process killed
with SIGKILL loses at most the last period (:mod:`drs_ros.recording.mcap_recorder`).
"""

from __future__ import annotations

import math
import time

from .errors import RecordingError


class FlushSchedule:
    """The flush period [s] and message count of a recorder, and its flushes so far.

    Parameters
    ----------
    period : float
        Maximum time between flushes [s] (finite, > 0).
    messages : int or None
        Also flush after this many messages since the last flush (>= 1; None: time only).

    Raises
    ------
    RecordingError
        ``period`` or ``messages`` out of range, naming the value.
    """

    def __init__(self, period: float, messages: int | None):
        if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0):
            raise RecordingError(f"flush_period must be a finite number > 0 s, got {period!r}")
        if messages is not None and (
            isinstance(messages, bool) or not isinstance(messages, int) or messages < 1
        ):
            raise RecordingError(f"flush_messages must be an int >= 1 or None, got {messages!r}")
        self.period = float(period)
        self.messages = messages
        self.count = 0  # flushes so far
        self.messages_flushed = 0  # messages in the file at the last flush
        self.since = 0  # messages written since the last flush
        self.last = time.monotonic()  # monotonic time of the last flush (or of the start) [s]

    def wrote(self, n: int = 1) -> None:
        """``n`` more messages written since the last flush."""
        self.since += n

    def due(self) -> bool:
        """A write's flush is due: ``messages`` since the last flush, or ``period`` passed."""
        if self.messages is not None and self.since >= self.messages:
            return True
        return time.monotonic() - self.last >= self.period

    def idle_due(self) -> bool:
        """The background flush is due: messages wait and ``period`` passed since the last."""
        return bool(self.since) and time.monotonic() - self.last >= self.period

    def flushed(self, message_count: int) -> None:
        """A flush happened with ``message_count`` messages written in all."""
        self.closed()
        self.written(message_count)

    def closed(self) -> None:
        """The chunk in progress closed (its writing may follow in another thread)."""
        self.count += 1
        self.since = 0
        self.last = time.monotonic()

    def written(self, message_count: int) -> None:
        """A closed chunk reached the file, with ``message_count`` messages in it in all."""
        self.messages_flushed = max(self.messages_flushed, message_count)

    def age_s(self) -> float:
        """Time since the last flush (or the start) [s]."""
        return time.monotonic() - self.last


__all__ = ["FlushSchedule"]
