"""benchmarks/tick_waits.py's reading of ``perf script``: the main thread's blocks, where each
stopped, who ended it, and a block whose end perf lost left out. The text below is written by
hand in perf's format (``-F pid,tid,time,event,trace,ip,sym`` with call chains); perf itself is
not run here (it needs root and the tracepoints: the benchmark says so and exits)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from tick_waits import blocks_of, parse_script, report  # noqa: E402

MAIN, EXECUTOR, OTHER = 100, 105, 900


def switch(t: float, prev: int, prev_name: str, nxt: int, nxt_name: str, frames: list[str]):
    pid = MAIN if prev in (MAIN, EXECUTOR) else OTHER
    head = (
        f" {pid}/{prev}  {t:.6f}: sched:sched_switch: prev_comm={prev_name} prev_pid={prev} "
        f"prev_prio=89 prev_state=S ==> next_comm={nxt_name} next_pid={nxt} next_prio=120"
    )
    chain = ["\tffffffff821f7f58 __schedule", *[f"\t           cf545 {f}" for f in frames]]
    return "\n".join([head, *chain]) + "\n"


def wakeup(t: float, waker_pid: int, waker: int, frames: list[str]):
    head = (
        f" {waker_pid}/{waker}  {t:.6f}: sched:sched_wakeup: comm=python pid={MAIN} prio=89 "
        "target_cpu=001"
    )
    return "\n".join([head, *[f"\tffffffff813a8255 {f}" for f in frames]]) + "\n"


def script() -> str:
    """Three blocks of the main thread: a sleep ended by its timer (800 us), a GIL wait ended
    by the executor (1.2 ms), a mutex wait whose switch on was lost (another switch off
    comes first), and a last short sleep."""
    parts = [
        # the executor runs first, so its name is known
        switch(0.0, EXECUTOR, "drs-executor", MAIN, "python", ["epoll_wait"]),
        switch(1.0000, MAIN, "python", EXECUTOR, "drs-executor", ["clock_nanosleep@GLIBC+0x65"]),
        wakeup(1.0008, MAIN, EXECUTOR, ["ttwu_do_activate", "hrtimer_wakeup"]),
        switch(1.0008, EXECUTOR, "drs-executor", MAIN, "python", ["epoll_wait"]),
        switch(
            1.0010, MAIN, "python", EXECUTOR, "drs-executor", ["__futex_abstimed_wait_common+0xc6"]
        ),
        wakeup(1.0021, MAIN, EXECUTOR, ["ttwu_do_activate", "futex_wake"]),
        switch(1.0022, EXECUTOR, "drs-executor", MAIN, "python", ["epoll_wait"]),
        switch(1.0030, MAIN, "python", EXECUTOR, "drs-executor", ["__GI___lll_lock_wait+0x2b"]),
        # the switch on after that wait is lost: the next event is another switch off
        switch(1.0040, MAIN, "python", OTHER, "listener", ["clock_nanosleep@GLIBC+0x65"]),
        wakeup(1.0045, 0, 0, ["ttwu_do_activate", "hrtimer_wakeup"]),
        switch(1.0045, OTHER, "listener", MAIN, "python", ["epoll_wait"]),
    ]
    return "\n".join(parts)


def test_blocks_are_named_by_where_they_stopped_and_who_ended_them() -> None:
    blocks = blocks_of(MAIN, parse_script(script()))
    assert [b.reason.split(" ")[0] for b in blocks] == ["deadline", "timed", "deadline"]
    sleep, gil, last = blocks
    assert sleep.seconds == pytest.approx(0.0008, abs=1e-9)
    assert sleep.waker[2] == "timer"
    assert gil.seconds == pytest.approx(0.0012, abs=1e-9)
    assert gil.waker == (MAIN, EXECUTOR, "drs-executor")
    assert gil.delay == pytest.approx(0.0001, abs=1e-9)
    assert last.seconds == pytest.approx(0.0005, abs=1e-9)


def test_a_block_whose_end_was_lost_is_left_out() -> None:
    """The mutex wait at 1.003 s has no switch on before the next switch off: perf lost it. Its
    apparent length (to the switch on at 1.0045 s) is not reported as a wait."""
    blocks = blocks_of(MAIN, parse_script(script()))
    assert all(b.start != pytest.approx(1.0030) for b in blocks)
    assert "mutex" not in report(blocks, MAIN, 1e-3)


def test_the_report_names_the_long_wait_and_its_waker() -> None:
    text = report(blocks_of(MAIN, parse_script(script())), MAIN, 1e-3)
    assert "drs-executor (the node): 1" in text
    assert "1 over half a period" in text
