"""The deadline loop's ticks and the executor thread's callbacks kept apart: a part of
:class:`drs_ros.node.adapter.DRSNode` that the deadline loop (:func:`drs_ros.node.runner.
run_deadline_loop`) runs each tick through and that the executor asks.

Both threads run Python under one GIL. The executor waits for a running tick to end before it
takes the next event (:meth:`TickGate.wait_for_tick_end`): a flood of callbacks does not share
the GIL with the whole tick (an event taken while it waited for work may still start during a
tick). A callback that starts between two ticks runs on over the next deadline if it is long:
the tick then waits for the GIL (0.2-0.9 ms) and for the node's lock. A ``~/drs`` call is such
a callback (0.3-0.8 ms of Python, woken cold: the move planned, the effect record): under the
goal's command load at 1 kHz, 38 of 39 missed deadlines in a run came while one ran over the
deadline (benchmarks/results/node_rate.md, 2026-11-29). Such a callback first asks
:meth:`TickGate.clear_of_ticks`: when the next tick is due sooner than it needs, it runs just
after that tick instead (at 1 kHz always: a tick is always due within 1 ms).

The handshake between the two threads takes no lock: the tick's thread publishes its count and
the next deadline as one tuple, then reads the waiter; the waiter publishes itself, then reads
the count again. Each of these is one attribute read or write, atomic under the GIL; a Python
without one would need a lock around both.
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
        # (ticks run so far, steady time [ns] the next one is due or None): one tuple, read once
        self._state: tuple[int, int | None] = (0, None)
        self._waiter: threading.Event | None = None

    @property
    def ticks(self) -> int:
        """Ticks run so far."""
        return self._state[0]

    @property
    def next_deadline_ns(self) -> int | None:
        """Steady time [ns] the next tick is due (None: no tick is scheduled)."""
        return self._state[1]

    @property
    def waiting(self) -> bool:
        """Whether a callback waits for a tick now."""
        return self._waiter is not None

    def run(self, tick, next_deadline_ns: int) -> None:
        """Run ``tick()`` holding the gate; the next tick is due at ``next_deadline_ns`` [ns of
        ``time.monotonic_ns``]. A callback waiting for a tick to end then goes on."""
        try:
            with self._running:
                tick()
        finally:
            self._publish(self._state[0] + 1, next_deadline_ns)

    def stopped(self) -> None:
        """No tick is due any more (the loop ended): nothing waits for one."""
        self._publish(self._state[0], None)

    def _publish(self, ticks: int, next_deadline_ns: int | None) -> None:
        self._state = (ticks, next_deadline_ns)  # before the waiter is read (module docstring)
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
        than that (or none is scheduled), else once that tick has run (or the loop stopped), or
        after ``timeout_s`` [s] (by default the gate's :attr:`long_callback_s` and
        :attr:`max_wait_s`). Whether it waited. One thread asks (the executor's)."""
        needed_s = self.long_callback_s if needed_s is None else needed_s
        timeout_s = self.max_wait_s if timeout_s is None else timeout_s
        state = self._state
        due = state[1]
        if due is None or due - time.monotonic_ns() >= needed_s * 1e9:
            return False
        ended = threading.Event()
        self._waiter = ended  # published before the state is read again (module docstring)
        if self._state is state:
            ended.wait(timeout_s)
        self._waiter = None
        return True


__all__ = ["LONG_CALLBACK_S", "MAX_WAIT_S", "TickGate"]
