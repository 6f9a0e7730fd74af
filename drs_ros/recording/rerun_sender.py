"""The sender thread of a rerun recording (:class:`BatchSender`): it sends, in order, the batches
of states the logging thread hands it, so that ``send_columns`` never runs in that thread.

Why: the node logs a state at every tick (up to 1 kHz, on a real-time thread whose tick is late
after 1.5 periods). Sending a batch (the series, the drawings, nine ``send_columns``) takes
milliseconds at once; done in the tick, it was ~9 % of the tick thread's time in one burst per
simulated second, a missed deadline every second at 1 kHz. The logging thread now only appends a
batch to a ``queue.SimpleQueue`` (a C queue: ``put`` never waits for this thread).

This thread runs Python too and shares the GIL with the tick: what it does per batch is numpy
over whole arrays and the rerun calls, so it holds the GIL in short pieces that CPython's switch
interval hands back to the tick; it runs under ``SCHED_OTHER`` whoever starts it.

A batch that fails (any exception of ``send``) is lost, not the thread: its exception and its
number of states are kept, in order, until the owner takes them (:meth:`take_failures`).
:meth:`drain` waits until every batch handed so far is sent; :meth:`close` sends every batch
handed before it and joins the thread; :meth:`abandon` drops what is queued and joins.
"""

from __future__ import annotations

import os
import queue
import threading
import traceback
from collections import deque
from collections.abc import Callable
from typing import NamedTuple

from ..threads import NamedThread

#: How often [s] a waiting :meth:`BatchSender.drain` checks that the thread still runs.
ALIVE_CHECK_S = 0.1


class SendFailure(NamedTuple):
    """A batch the sender could not send: the exception ``send`` raised and the ``states`` the
    batch held (all lost)."""

    error: Exception
    states: int


class _Stop:
    """The last item of the queue: the thread ends when it takes it."""


class BatchSender:
    """A thread that calls ``send(*batch)`` for each batch given to :meth:`put`, in order.

    Parameters
    ----------
    send : callable
        Sends one batch; its first argument is an array whose length is the batch's number of
        states.
    name : str
        The thread's name.
    """

    def __init__(self, send: Callable[..., None], name: str) -> None:
        self._send = send
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._failures: deque[SendFailure] = deque()
        self._abandoned = False
        self._thread = NamedThread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def put(self, *batch) -> None:
        """Queue ``send(*batch)``; never waits for the thread."""
        self._queue.put(batch)

    @property
    def failed(self) -> bool:
        """Whether failures wait to be taken (cheap: for the logging thread)."""
        return bool(self._failures)

    def take_failures(self) -> list[SendFailure]:
        """The failures met since the last call, in order (each is returned once)."""
        taken = []
        while self._failures:
            taken.append(self._failures.popleft())
        return taken

    def _run(self) -> None:
        _leave_real_time()
        while True:
            item = self._queue.get()
            if isinstance(item, _Stop):
                return
            if isinstance(item, threading.Event):  # a drain's mark: all before it is sent
                item.set()
            elif not self._abandoned:
                try:
                    self._send(*item)
                except Exception as exc:  # noqa: BLE001 - one batch lost, kept for the owner
                    traceback.clear_frames(exc.__traceback__)  # keep the lines, not the arrays
                    self._failures.append(SendFailure(exc, len(item[0])))

    def drain(self) -> None:
        """Wait until every batch put before this call is sent (or failed)."""
        done = threading.Event()
        self._queue.put(done)
        while not done.wait(ALIVE_CHECK_S) and self._thread.is_alive():
            pass

    def close(self) -> None:
        """Send every batch put before this call, then end and join the thread (idempotent)."""
        self._queue.put(_Stop())
        if self._thread is not threading.current_thread():
            self._thread.join()

    def abandon(self) -> None:
        """Drop the batches not yet sent, then end and join the thread (idempotent)."""
        self._abandoned = True
        self.close()


def _leave_real_time() -> None:
    """Run the calling thread under ``SCHED_OTHER``: a thread inherits its starter's policy, and
    under the tick's ``SCHED_FIFO`` this one would compete with the tick for the core."""
    try:
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (AttributeError, OSError):  # no such call here, or not allowed: nothing to leave
        pass


__all__ = ["BatchSender", "SendFailure"]
