"""benchmarks/deadline_floor.py: the bare deadline loop every floor of the node's deadline goals
runs (``DeadlineLoop``) counts a missed deadline as the node's diagnostics do.

Why a test of a benchmark: the loop built its clock for ``/clock`` time (460e1db), which since
2026-11-28 (4df3268) counts no missed deadline at all, and every floor then reported 0 missed
beside lateness maxima of 8-11 ms (benchmarks/results/node_vs_floor.json of 2026-11-29 11:02).
The floor is the reference the node's misses are read against: it must be able to show a miss.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import deadline_floor  # noqa: E402
from deadline_floor import DeadlineLoop  # noqa: E402

RATE_HZ = 1000.0
#: A stall [s] of a tick's work: 5 periods, far past the 1.5 periods that make a miss.
STALL_S = 0.005


def test_a_stall_in_the_loop_is_a_missed_deadline() -> None:
    """One tick's work stalls 5 ms in a 1 kHz loop: the next tick comes >= 5 ms after it, more
    than 1.5 periods, so at least that one is counted (the machine may add its own)."""
    loop = DeadlineLoop(RATE_HZ)
    for k, _ in enumerate(loop.ticks(0.05)):
        if k == 10:
            time.sleep(STALL_S)
    counts = loop.counts()
    assert counts["missed"] >= 1
    assert counts["missed"] <= counts["ticks"]
    assert counts["lateness_max_us"] >= 1e6 * STALL_S - 1e6 / RATE_HZ


class FakeClock:
    """``time.monotonic_ns`` and ``time.sleep`` on a clock that moves only when slept on or
    told to (:meth:`work`): the loop's deadlines, exactly."""

    def __init__(self) -> None:
        self.now_ns = 10**12

    def monotonic_ns(self) -> int:
        return self.now_ns

    def sleep(self, seconds: float) -> None:
        self.now_ns += round(seconds * 1e9)

    def work(self, seconds: float) -> None:
        self.now_ns += round(seconds * 1e9)


def test_the_loop_resumes_from_now_before_the_ticks_work(monkeypatch) -> None:
    """Tick 10's work stalls 5 periods; tick 11 comes 4 periods late and works 0.6 of one. The
    loop resumes from tick 11's wake, before its work, as the node's loop does: tick 12 comes a
    period after tick 11 (not 1.6 periods, which would count a second miss), and the 4 deadlines
    passed are counted as skipped."""
    clock = FakeClock()
    monkeypatch.setattr(deadline_floor, "time", clock)
    period_ns = round(1e9 / RATE_HZ)
    loop = DeadlineLoop(RATE_HZ)
    wakes = []
    for k, now in enumerate(loop.ticks(0.02)):
        wakes.append(now)
        if k == 10:
            clock.work(5 / RATE_HZ)
        elif k == 11:
            clock.work(0.6 / RATE_HZ)
    assert wakes[11] - wakes[10] == 5 * period_ns
    assert wakes[12] - wakes[11] == period_ns
    counts = loop.counts()
    assert counts["missed"] == 1
    assert counts["skipped_deadlines"] == 4
