"""benchmarks/tick_waits.py's reading of ``perf script``: the main thread's blocks, where each
stopped, who ended it, and the blocks perf lost part of left out. The text below is written by
hand in perf's format (``-F pid,tid,time,event,trace,ip,sym`` with call chains, ``--ns``); perf
itself is not run here (it needs root and the tracepoints: the benchmark says so and exits)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from tick_waits import PREEMPTED, blocks_of, parse_script, report  # noqa: E402

MAIN, EXECUTOR, OTHER = 100, 105, 900
NAMES = {MAIN: "python", EXECUTOR: "drs-executor", OTHER: "listener", 0: "swapper/1"}


def owner(tid: int) -> int:
    return {MAIN: MAIN, EXECUTOR: MAIN, OTHER: OTHER, 0: 0}[tid]


def switch(t: float, prev: int, nxt: int, frames: list[str], state: str = "S") -> str:
    head = (
        f" {owner(prev)}/{prev}  {t:.9f}: sched:sched_switch: prev_comm={NAMES[prev]} "
        f"prev_pid={prev} prev_prio=89 prev_state={state} ==> next_comm={NAMES[nxt]} "
        f"next_pid={nxt} next_prio=120"
    )
    chain = ["\tffffffff821f7f58 __schedule", *[f"\t           cf545 {f}" for f in frames]]
    return "\n".join([head, *chain]) + "\n"


def wake(t: float, kind: str, by: int, frames: list[str]) -> str:
    head = (
        f" {owner(by)}/{by}  {t:.9f}: sched:{kind}: comm=python pid={MAIN} prio=89 target_cpu=001"
    )
    return "\n".join([head, *[f"\tffffffff813a8255 {f}" for f in frames]]) + "\n"


def script() -> str:
    """The main thread's blocks: a sleep ended by its timer (800 us); a GIL wait of 1.2 ms the
    executor ended (its waking in the executor, its wake-up reported by the idle task of the
    main thread's core); a preempted stretch; a mutex wait whose switch on was lost (another
    switch off comes first); a wait inside which the main thread itself issued an event (it
    ran: events lost); a last short sleep."""
    exe = ["epoll_wait"]
    parts = [
        switch(0.0, EXECUTOR, MAIN, exe),
        switch(1.0000, MAIN, EXECUTOR, ["clock_nanosleep@GLIBC+0x65"]),
        wake(1.0008, "sched_waking", EXECUTOR, ["try_to_wake_up", "hrtimer_wakeup"]),
        wake(1.0008, "sched_wakeup", EXECUTOR, ["ttwu_do_activate", "hrtimer_wakeup"]),
        switch(1.0008, EXECUTOR, MAIN, exe),
        switch(1.0010, MAIN, EXECUTOR, ["__futex_abstimed_wait_common+0xc6"]),
        wake(1.0021, "sched_waking", EXECUTOR, ["try_to_wake_up", "futex_wake"]),
        wake(1.0021, "sched_wakeup", 0, ["ttwu_do_activate", "sched_ttwu_pending"]),
        switch(1.0022, EXECUTOR, MAIN, exe),
        switch(1.0023, MAIN, EXECUTOR, ["_PyEval_EvalFrameDefault+0x181f"], state="R"),
        switch(1.00232, EXECUTOR, MAIN, exe),
        switch(1.0030, MAIN, EXECUTOR, ["__GI___lll_lock_wait+0x2b"]),
        # the switch on after that wait is lost: the next event is another switch off
        switch(1.0040, MAIN, OTHER, ["__futex_abstimed_wait_common+0xc6"]),
        # a waking by the main thread itself inside its block: it ran, the events between lost
        wake(1.0042, "sched_waking", MAIN, ["try_to_wake_up", "futex_wake"]),
        switch(1.0049, OTHER, MAIN, exe),
        switch(1.0050, MAIN, OTHER, ["clock_nanosleep@GLIBC+0x65"]),
        # a wake-up the kernel reports under the main thread while it is off its core (on its
        # core's wake list): no evidence that it ran
        wake(1.0052, "sched_wakeup", MAIN, ["ttwu_do_activate", "sched_ttwu_pending"]),
        wake(1.0055, "sched_waking", 0, ["try_to_wake_up", "hrtimer_wakeup"]),
        switch(1.0055, OTHER, MAIN, exe),
    ]
    return "\n".join(parts)


def blocks():
    return blocks_of(MAIN, parse_script(script()))


def test_blocks_are_named_by_where_they_stopped() -> None:
    reasons = [b.reason.split(" ")[0] for b in blocks()]
    assert reasons == ["deadline", "timed", PREEMPTED.split(" ")[0], "deadline"]
    sleep, gil, preempted, last = blocks()
    assert sleep.seconds == pytest.approx(0.0008, abs=1e-9)
    assert gil.seconds == pytest.approx(0.0012, abs=1e-9)
    assert preempted.state == "R" and preempted.waker is None
    assert last.seconds == pytest.approx(0.0005, abs=1e-9)


def test_the_waker_is_the_thread_that_woke_it_not_the_core_that_reported_it() -> None:
    """The GIL wait's wake-up is reported by the idle task of the woken thread's core; its
    waking, in the executor: the executor ended it, 100 us before the main thread ran."""
    sleep, gil, _preempted, last = blocks()
    assert gil.waker == (MAIN, EXECUTOR, "drs-executor")
    assert gil.delay == pytest.approx(0.0001, abs=1e-9)
    assert sleep.waker[2] == "timer" and last.waker[2] == "timer"


def test_blocks_perf_lost_part_of_are_left_out() -> None:
    """The mutex wait at 1.003 s has no switch on before the next switch off; the wait at
    1.004 s holds an event of the main thread itself. Neither is reported as a wait."""
    starts = [round(b.start, 6) for b in blocks()]
    assert 1.003 not in starts and 1.004 not in starts
    assert "mutex" not in report(blocks(), MAIN, 1e-3)


def test_the_report_names_the_long_wait_and_its_waker() -> None:
    text = report(blocks(), MAIN, 1e-3)
    assert "drs-executor (the node): 1" in text
    assert "1 over half a period" in text


def test_a_second_switch_off_closes_nothing() -> None:
    """A wait whose switch on perf lost, then a clean sleep: only the sleep is a block, from
    its own switch off (not from the first one)."""
    text = "\n".join(
        [
            switch(2.0, MAIN, EXECUTOR, ["__GI___lll_lock_wait+0x2b"]),
            switch(2.003, MAIN, EXECUTOR, ["clock_nanosleep@GLIBC+0x65"]),
            wake(2.0035, "sched_waking", EXECUTOR, ["try_to_wake_up", "hrtimer_wakeup"]),
            switch(2.0036, EXECUTOR, MAIN, ["epoll_wait"]),
        ]
    )
    (only,) = blocks_of(MAIN, parse_script(text))
    assert only.start == pytest.approx(2.003)
    assert only.seconds == pytest.approx(0.0006, abs=1e-9)
