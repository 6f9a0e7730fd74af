"""The tick gate (``drs_ros.node.tick_gate``): a long callback waits for a tick that is due
sooner than the room it asks for, and only then; no tick's end is missed by a waiter; the
node's ``~/drs`` call asks for room before its work."""

from __future__ import annotations

import threading
import time
import types

import pytest
from node_support import ros_context  # noqa: F401

from drs_ros.node.tick_gate import TickGate

MS = 1_000_000  # [ns]


def _tick_later(gate: TickGate, after_s: float, next_deadline_ns: int) -> threading.Thread:
    """A tick run through ``gate`` by another thread ``after_s`` [s] from now."""

    def run():
        time.sleep(after_s)
        gate.run(lambda: None, next_deadline_ns)

    thread = threading.Thread(target=run)
    thread.start()
    return thread


def _until(condition, timeout_s: float = 30.0) -> None:
    give_up = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < give_up, "the condition never held"
        time.sleep(0.001)


def test_no_tick_scheduled_or_one_due_later_than_the_room_asked_means_no_wait():
    gate = TickGate()
    assert gate.clear_of_ticks(0.001, timeout_s=5.0) is False  # no tick scheduled yet
    gate.run(lambda: None, time.monotonic_ns() + 200 * MS)  # the next one in 0.2 s
    assert gate.clear_of_ticks(0.001, timeout_s=5.0) is False
    assert gate.ticks == 1


def test_a_tick_due_sooner_than_the_room_asked_is_waited_for_until_it_has_run():
    gate = TickGate()
    gate.run(lambda: None, time.monotonic_ns() + 50 * MS)  # due in 50 ms: sooner than 1 s
    thread = _tick_later(gate, 0.05, time.monotonic_ns() + 10_000 * MS)
    try:
        assert gate.clear_of_ticks(1.0, timeout_s=30.0) is True
        assert gate.ticks == 2  # it returned after the tick, not before
    finally:
        thread.join(timeout=30.0)


def test_a_running_tick_is_waited_for():
    """While a tick runs, the deadline the gate knows has passed: the callback waits for the
    end of that tick."""
    gate, release, started = TickGate(), threading.Event(), threading.Event()
    gate.run(lambda: None, time.monotonic_ns())  # the next tick is due now

    def long_tick():
        started.set()
        release.wait(30.0)

    thread = threading.Thread(target=gate.run, args=(long_tick, time.monotonic_ns() + 10 * MS))
    thread.start()
    assert started.wait(30.0)
    seen = []
    waiter = threading.Thread(
        target=lambda: seen.append((gate.clear_of_ticks(0.001, 30.0), gate.ticks))
    )
    waiter.start()
    _until(lambda: gate.waiting)
    assert not seen  # still waiting: the tick runs
    release.set()
    waiter.join(timeout=30.0)
    thread.join(timeout=30.0)
    assert seen == [(True, 2)]


def test_a_wait_ends_at_the_timeout_when_no_tick_comes_and_at_once_when_the_loop_stops():
    gate = TickGate()
    gate.run(lambda: None, time.monotonic_ns())  # due now, and never run
    assert gate.clear_of_ticks(0.001, timeout_s=0.01) is True
    assert gate.ticks == 1
    done = []
    waiter = threading.Thread(target=lambda: done.append(gate.clear_of_ticks(0.001, 30.0)))
    waiter.start()
    _until(lambda: gate.waiting)
    gate.stopped()  # the loop ended: nothing will tick
    waiter.join(timeout=30.0)
    assert done == [True]
    assert gate.next_deadline_ns is None
    assert gate.clear_of_ticks(0.001, timeout_s=30.0) is False  # no tick is scheduled


@pytest.mark.parametrize("period_ms", [1.0, 0.1])
def test_every_wait_ends_after_a_tick_that_ran_since_it_began(period_ms):
    """Ticks every ``period_ms`` from one thread, a waiter asking for more room than a period
    from another, 2,000 times: each waits (a tick is always due within two periods) and ends
    once a tick has run since it began, well within its timeout."""
    gate, stop = TickGate(), threading.Event()
    period_ns = int(period_ms * MS)

    def loop():
        deadline = time.monotonic_ns()
        while not stop.is_set():
            deadline += period_ns
            time.sleep(max(deadline - time.monotonic_ns(), 0) / 1e9)
            gate.run(lambda: None, deadline + period_ns)
        gate.stopped()

    ticker = threading.Thread(target=loop)
    ticker.start()
    longest, waited = 0.0, 0
    try:
        while gate.ticks == 0:
            time.sleep(0.001)
        for _ in range(2000):
            before = gate.ticks
            t0 = time.monotonic()
            if gate.clear_of_ticks(2 * period_ms * 1e-3, timeout_s=20.0):
                waited += 1
                assert gate.ticks > before
            longest = max(longest, time.monotonic() - t0)
            assert longest < 10.0, f"a wait lasted {longest:.3f} s"
    finally:
        stop.set()
        ticker.join(timeout=30.0)
    assert waited == 2000  # the next tick is always due within two periods


def test_a_tick_that_ends_while_the_waiter_gets_ready_is_not_waited_past(monkeypatch):
    """A tick that ends between the waiter's reading of the gate and its waiting (here: while
    its Event is made) is seen: the callback goes on at once instead of waiting for a tick that
    already ran (until the next one, or its timeout)."""
    from drs_ros.node import tick_gate

    gate = TickGate()
    gate.run(lambda: None, time.monotonic_ns())  # due now
    real_event = threading.Event

    def event_after_a_tick():
        gate.run(lambda: None, time.monotonic_ns() + 10_000 * MS)  # the next due in 10 s
        return real_event()

    # the gate module's own name only: threading.Thread makes Events of its own
    monkeypatch.setattr(
        tick_gate, "threading", types.SimpleNamespace(Event=event_after_a_tick, Lock=threading.Lock)
    )
    t0 = time.monotonic()
    assert gate.clear_of_ticks(1.0, timeout_s=30.0) is True
    assert time.monotonic() - t0 < 10.0, "it waited for a tick after the one that had run"
    assert gate.ticks == 2


@pytest.mark.ros
def test_a_drs_call_made_just_before_a_tick_does_its_work_after_that_tick(ros_context):  # noqa: F811
    """The node's ``~/drs`` callback asks the gate for room first: with the next tick due now,
    the call's move is planned and applied once that tick has run, not over it."""
    from std_srvs.srv import SetBool

    from drs_ros.node import DRSNode

    node = DRSNode(context=ros_context, tick_timer=False)
    try:
        gate = node.tick_gate
        gate.max_wait_s = 30.0  # the next tick below comes 50 ms on: wait for it, however late
        gate.run(node.tick, time.monotonic_ns())  # the first tick; the next one due now
        seen, on_drs = [], node.intake.on_drs

        def watched(request, response, now_ns):
            seen.append(gate.ticks)
            return on_drs(request, response, now_ns)

        node.intake.on_drs = watched

        def next_tick():
            time.sleep(0.05)
            gate.run(node.tick, time.monotonic_ns() + 10_000 * MS)

        thread = threading.Thread(target=next_tick)
        thread.start()
        response = node._on_drs(SetBool.Request(data=True), SetBool.Response())
        thread.join(timeout=30.0)
    finally:
        node.close_recordings()
        node.destroy_node()
    assert response.success, response.message
    assert seen == [2]
