"""The deadline loop's pacing (:func:`drs_ros.node.tick_schedule.tick_at_deadlines`): ticks
shorter than the period keep their absolute deadlines, an overrunning tick under SCHED_FIFO
rests as long as it ran before the next one, and a real SCHED_FIFO thread whose every tick
overruns takes at most half a core of CPU."""

from __future__ import annotations

import os
import threading
import time
from itertools import pairwise

import pytest

from drs_ros.node import tick_schedule
from drs_ros.node.tick_schedule import (
    FIFO_REST_PER_TICK_CPU,
    LatenessHistogram,
    TickPolicy,
    apply_tick_policy,
    leave_tick_policy,
    rest_per_tick_cpu,
    tick_at_deadlines,
)

PERIOD_NS = 1_000_000


class FakeTime:
    """A steady clock and a thread CPU clock [ns] that move only when the loop sleeps (the
    steady one) or a tick runs (both): the loop's schedule, free of the machine's noise."""

    def __init__(self) -> None:
        self.mono = 10_000_000
        self.cpu = 0

    def monotonic_ns(self) -> int:
        return self.mono

    def thread_time_ns(self) -> int:
        return self.cpu

    def sleep(self, seconds: float) -> None:
        self.mono += max(int(seconds * 1e9), 1)

    def run(self, cost_ns: int) -> None:
        self.mono += cost_ns
        self.cpu += cost_ns


def schedule(monkeypatch, cost_ns: int, rest_per_cpu: float, ticks: int = 8):
    """The steady times [ns] the ticks of ``cost_ns`` each started at, from the loop's start,
    and the lateness histogram, with ``rest_per_cpu``."""
    fake = FakeTime()
    monkeypatch.setattr(tick_schedule, "time", fake)
    origin, starts = fake.mono, []

    def tick() -> None:
        starts.append(fake.mono - origin)
        fake.run(cost_ns)

    lateness = LatenessHistogram()
    tick_at_deadlines(tick, PERIOD_NS, lateness, lambda: len(starts) >= ticks, rest_per_cpu)
    return starts, lateness


@pytest.mark.parametrize("rest", [0.0, FIFO_REST_PER_TICK_CPU])
def test_ticks_shorter_than_the_period_keep_their_deadlines(monkeypatch, rest):
    """A tick of 0.4 period leaves 0.6 period to its deadline, more than its rest: every tick
    starts at its deadline under either policy (the rest changes nothing then)."""
    starts, lateness = schedule(monkeypatch, 400_000, rest)
    assert starts == [PERIOD_NS * (k + 1) for k in range(len(starts))]
    assert lateness.max_ns == 0 and lateness.skipped == 0


def test_an_overrunning_fifo_tick_rests_as_long_as_it_ran():
    """Under SCHED_FIFO the rest is the tick's own CPU time, under SCHED_OTHER none."""
    assert rest_per_tick_cpu(TickPolicy("SCHED_FIFO", 10)) == FIFO_REST_PER_TICK_CPU == 1.0
    assert rest_per_tick_cpu(TickPolicy("SCHED_OTHER", 0, "refused")) == 0.0


@pytest.mark.parametrize("cost_ns", [1_300_000, 2_500_000])
def test_overrunning_ticks_under_fifo_leave_the_core_half_the_time(monkeypatch, cost_ns):
    """Ticks of 1.3 and 2.5 periods: without a rest they run back to back (the core held all
    the time); with the FIFO rest each starts a tick's length after the last one ended, and the
    deadlines passed meanwhile are counted as skipped."""
    back_to_back, _ = schedule(monkeypatch, cost_ns, 0.0)
    assert [b - a for a, b in pairwise(back_to_back)] == [cost_ns] * 7
    rested, lateness = schedule(monkeypatch, cost_ns, FIFO_REST_PER_TICK_CPU)
    gaps = [b - a for a, b in pairwise(rested)]
    assert all(2 * cost_ns <= gap < 2 * cost_ns + PERIOD_NS for gap in gaps), gaps
    assert lateness.count == 8 and lateness.skipped >= 7
    held = 7 * cost_ns / (rested[-1] - rested[0])  # the core's share of the first 7 ticks
    assert held <= 1 / (1 + FIFO_REST_PER_TICK_CPU)


def test_a_stop_ends_the_rest_within_a_poll(monkeypatch):
    """A stop asked for half a second into the 2 s rest after a 2 s tick is seen within a poll
    (50 ms), not at the end of the rest: the loop returns without another tick."""
    fake = FakeTime()
    monkeypatch.setattr(tick_schedule, "time", fake)
    ticks = []

    def tick() -> None:
        ticks.append(fake.mono)
        fake.run(2_000_000_000)

    def should_stop() -> bool:
        return bool(ticks) and fake.mono >= ticks[0] + 2_500_000_000

    tick_at_deadlines(tick, PERIOD_NS, LatenessHistogram(), should_stop, 1.0, poll_s=0.05)
    assert len(ticks) == 1
    assert ticks[0] + 2_500_000_000 <= fake.mono <= ticks[0] + 2_550_000_000


@pytest.mark.skipif(not hasattr(os, "sched_setscheduler"), reason="Linux scheduling calls")
def test_a_fifo_thread_whose_ticks_all_overrun_takes_at_most_half_a_core():
    """A real thread under SCHED_FIFO (where granted) at 1 kHz whose every tick burns 3 ms of
    its own CPU: over the loop its CPU time is at most half the steady time that passed (the
    kernel's accounting, so the machine's load can only lower the share). Before the rest the
    same loop held its core for ~95 % (the kernel's real-time cap) and starved the process's
    ordinary threads."""
    seen = {"starts": []}  # (thread CPU, steady time) [ns] at each tick's start

    def burn_3_ms() -> None:
        seen["starts"].append((time.thread_time_ns(), time.monotonic_ns()))
        end = time.thread_time_ns() + 3_000_000
        while time.thread_time_ns() < end:
            pass

    def loop() -> None:
        policy = apply_tick_policy("fifo", 5)
        try:
            stop = lambda: len(seen["starts"]) >= 40  # noqa: E731
            tick_at_deadlines(burn_3_ms, PERIOD_NS, LatenessHistogram(), stop, 1.0)
        finally:
            leave_tick_policy(policy)

    thread = threading.Thread(target=loop)
    thread.start()
    thread.join()
    (cpu0, wall0), (cpu1, wall1) = seen["starts"][0], seen["starts"][-1]
    # 39 ticks and their rests; the loop's own bookkeeping (~us a tick) is not in the rest
    assert (cpu1 - cpu0) / (wall1 - wall0) <= 0.51
