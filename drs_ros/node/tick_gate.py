"""The deadline loop's ticks and the executor thread's callbacks kept apart: a part of
:class:`drs_ros.node.adapter.DRSNode` that the deadline loop (:func:`drs_ros.node.runner.
run_deadline_loop`) runs each tick through and that the executor asks.

Both threads run Python under one GIL. The executor waits for a running tick to end before each
callback (:meth:`TickGate.wait_for_tick_end`): a flood of callbacks does not share the GIL with
the whole tick. A callback that starts between two ticks still runs on over the next deadline
if it is long: the tick then waits for the GIL (0.2-0.9 ms) and for the node's lock. A ``~/drs``
call is such a callback (0.3-0.8 ms of Python, woken cold: the move planned, the effect
record): under the goal's command load at 1 kHz, 38 of 39 missed deadlines in a run came while
one ran over the deadline (benchmarks/results/node_rate.md, 2026-11-29). Such a callback first
asks :meth:`TickGate.clear_of_ticks`: when the next tick is due sooner than it needs, it runs
just after that tick instead.
"""

from __future__ import annotations

import threading
import time

#: The room [s] a long callback asks for: a ``~/drs`` call's callbacks take 0.3-0.8 ms woken cold.
LONG_CALLBACK_S = 0.001
#: The longest a callback waits for the tick it makes room for [s] (a tick that stalls, a loop
#: that ends meanwhile).
MAX_WAIT_S = 0.01


class TickGate:
    """Where the ticks run (:meth:`run`, from the deadline loop's thread) and what the executor's
    thread asks of them (:meth:`wait_for_tick_end`, :meth:`clear_of_ticks`; one thread asks)."""

    def __init__(self, long_callback_s: float = LONG_CALLBACK_S, max_wait_s: float = MAX_WAIT_S):
        #: The room [s] :meth:`clear_of_ticks` asks for, and the longest it waits [s].
        self.long_callback_s, self.max_wait_s = long_callback_s, max_wait_s
        self._running = threading.Lock()  # held while a tick runs
        #: Ticks run so far.
        self.ticks = 0
        #: Steady time [ns] the next tick is due (None: no tick is scheduled).
        self.next_deadline_ns: int | None = None
        self._waiter: threading.Event | None = None

    def run(self, tick, next_deadline_ns: int) -> None:
        """Run ``tick()`` holding the gate; the next tick is due at ``next_deadline_ns`` [ns of
        ``time.monotonic_ns``]. A callback waiting for a tick to end then goes on."""
        try:
            with self._running:
                tick()
        finally:
            self._ended(next_deadline_ns)

    def stopped(self) -> None:
        """No tick is due any more (the loop ended): nothing waits for one."""
        self._ended(None)

    def _ended(self, next_deadline_ns: int | None) -> None:
        # the count before the waiter is read: clear_of_ticks checks it after publishing its
        # waiter, so a tick that ends in between is seen one way or the other (GIL-atomic ops)
        self.next_deadline_ns = next_deadline_ns
        self.ticks += 1
        waiter = self._waiter
        if waiter is not None:
            waiter.set()

    def wait_for_tick_end(self, timeout_s: float) -> None:
        """Return once no tick runs, or after ``timeout_s`` [s] (a tick that stalls does not
        stall the executor)."""
        if self._running.acquire(timeout=timeout_s):
            self._running.release()

    def clear_of_ticks(self, needed_s: float | None = None, timeout_s: float | None = None) -> bool:
        """Make room for ``needed_s`` [s] of work: return at once if the next tick is due later
        than that (or none is scheduled), else once that tick has run, or after ``timeout_s``
        [s] (by default the gate's :attr:`long_callback_s` and :attr:`max_wait_s`). Whether it
        waited."""
        needed_s = self.long_callback_s if needed_s is None else needed_s
        timeout_s = self.max_wait_s if timeout_s is None else timeout_s
        due = self.next_deadline_ns
        if due is None or due - time.monotonic_ns() >= needed_s * 1e9:
            return False
        ticks, ended = self.ticks, threading.Event()
        self._waiter = ended
        if self.ticks == ticks:
            ended.wait(timeout_s)
        self._waiter = None
        return True


__all__ = ["LONG_CALLBACK_S", "MAX_WAIT_S", "TickGate"]
