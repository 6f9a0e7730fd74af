"""A log line written at most once per period, decided before rclpy is asked.

rclpy's own throttle (``logger.warning(text, throttle_duration_sec=1.0)``) decides after it
has identified its caller: ``inspect.getframeinfo`` and ``os.path.realpath`` on each calling
frame (four or five a call), suppressed or not. That is ~160 us of CPU a call in a warm loop,
and 0.4-0.75 ms on the node's tick under a flood of refused commands, where such ticks were
among those that missed their deadline (measured 2026-11-29, benchmarks/results/node_rate.md).
:class:`LogThrottle` keeps the decision to itself: a suppressed line costs a clock read and a
comparison, and the next line written says how many were left out.

rclpy keys a logger's state on the calling location and refuses one location logging at two
severities; this module is therefore skipped when rclpy identifies a line's caller
(:func:`drs_ros.rclpy_private.log_for_callers`): a line comes from where the throttle was
called, as it did before.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from .rclpy_private import log_for_callers

log_for_callers(__file__)


class LogThrottle:
    """``throttle(text)``: ``log(text)`` if ``period_s`` [s] of ``clock`` (steady time by
    default: a stepped wall clock neither floods nor silences the log) have passed since the
    last line it wrote, else the line is only counted. A line written after suppressed ones
    ends with how many were not written. Returns whether the line was written. Thread-safe
    (the executor thread and the tick may both report); each call site owns one."""

    def __init__(
        self,
        log: Callable[[str], object],
        period_s: float = 1.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if not period_s >= 0.0:
            raise ValueError(f"a log throttle's period must be >= 0 s, got {period_s!r}")
        self._log, self.period_s, self._clock = log, period_s, clock
        self._last: float | None = None
        self._lock = threading.Lock()
        #: Lines not written since the last one written.
        self.suppressed = 0

    def __call__(self, text: str) -> bool:
        with self._lock:
            now = self._clock()
            if self._last is not None and now - self._last < self.period_s:
                self.suppressed += 1
                return False
            left_out, self._last, self.suppressed = self.suppressed, now, 0
        if left_out:
            s = "s" if left_out > 1 else ""
            text = f"{text} ({left_out} more line{s} like it not logged since the last)"
        self._log(text)
        return True


__all__ = ["LogThrottle"]
