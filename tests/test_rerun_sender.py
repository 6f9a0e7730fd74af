"""BatchSender: the batches handed to it are sent in order by its own thread, a failing batch is
kept (not lost, not the thread's end), close sends what is queued and joins, abandon drops it,
and the thread leaves the real-time policy of the thread that started it."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

from drs_ros.recording.rerun_sender import BatchSender


class Recorded:
    """A ``send`` that keeps what it was given, the thread it ran in, and can be held."""

    def __init__(self, fail_on=()):
        self.batches: list[np.ndarray] = []
        self.threads: set[str] = set()
        self.release = threading.Event()
        self.release.set()
        self.fail_on = set(fail_on)

    def __call__(self, t, tag):
        self.release.wait()
        self.threads.add(threading.current_thread().name)
        if tag in self.fail_on:
            raise ValueError(f"batch {tag} refused on purpose")
        self.batches.append(t.copy())


def test_batches_are_sent_in_order_by_the_thread_and_close_sends_the_queue():
    send = Recorded()
    send.release.clear()  # the thread holds the first batch: the rest wait in the queue
    sender = BatchSender(send, name="test-sender")
    batches = [np.arange(k, k + 5, dtype=float) for k in range(0, 200, 5)]
    for i, t in enumerate(batches):
        sender.put(t, i)
    assert send.batches == []  # none sent yet: the queue holds them all
    send.release.set()
    sender.close()
    assert not any(th.name == "test-sender" for th in threading.enumerate())  # joined
    np.testing.assert_array_equal(np.concatenate(send.batches), np.arange(200.0))
    assert send.threads == {"test-sender"}
    sender.close()  # idempotent
    assert sender.take_failures() == []


def test_a_failing_batch_is_kept_and_the_next_ones_are_sent():
    send = Recorded(fail_on={1, 3})
    sender = BatchSender(send, name="test-sender")
    for i in range(5):
        sender.put(np.full(10 + i, float(i)), i)  # batch i holds 10 + i states
    sender.drain()
    failures = sender.take_failures()
    assert [str(f.error) for f in failures] == [
        "batch 1 refused on purpose",
        "batch 3 refused on purpose",
    ]
    assert [f.states for f in failures] == [11, 13]
    assert [b[0] for b in send.batches] == [0.0, 2.0, 4.0]
    assert sender.take_failures() == [] and not sender.failed  # each taken once
    sender.put(np.zeros(3), 1)  # the thread still runs after failures
    sender.close()
    (again,) = sender.take_failures()
    assert again.states == 3 and isinstance(again.error, ValueError)


def test_drain_waits_for_what_was_put_before():
    send = Recorded()
    sender = BatchSender(send, name="test-sender")
    for i in range(20):
        sender.put(np.full(4, float(i)), i)
    sender.drain()
    assert len(send.batches) == 20
    sender.close()


def test_abandon_drops_the_queue_and_joins():
    send = Recorded()
    send.release.clear()
    sender = BatchSender(send, name="test-sender")
    for i in range(10):
        sender.put(np.full(2, float(i)), i)
    threading.Timer(0.2, send.release.set).start()  # the batch in hand ends; the rest are dropped
    sender.abandon()
    assert len(send.batches) <= 1
    assert not any(th.name == "test-sender" for th in threading.enumerate())


@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="Linux scheduling calls")
def test_the_thread_leaves_the_real_time_policy_of_its_starter():
    """Started from a SCHED_FIFO thread (when this process may use it), the sender runs under
    SCHED_OTHER: it must not compete with the tick for the core."""
    seen = {}

    def send(t):
        seen["policy"] = os.sched_getscheduler(0)

    def starter():
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))
            seen["starter"] = os.sched_getscheduler(0)
        except PermissionError:
            seen["starter"] = os.SCHED_OTHER
        seen["sender"] = BatchSender(send, name="test-sender")

    th = threading.Thread(target=starter)
    th.start()
    th.join()
    sender = seen["sender"]
    sender.put(np.zeros(1))
    sender.close()
    assert seen["policy"] == os.SCHED_OTHER
    if os.geteuid() == 0:  # root may use SCHED_FIFO: the test did start from a real-time thread
        assert seen["starter"] == os.SCHED_FIFO
