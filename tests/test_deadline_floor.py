"""benchmarks/deadline_floor.py: the bare deadline loop every floor of the node's deadline goals
runs (``DeadlineLoop``) counts a missed deadline as the node's diagnostics do.

Why a test of a benchmark: from 2026-11-27 the loop built its clock for ``/clock`` time, which
counts no missed deadline at all, and every floor reported 0 missed beside lateness maxima of
8-11 ms (benchmarks/results/node_vs_floor.json of 2026-11-29). The floor is the reference the
node's misses are read against: it must be able to show a miss.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

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


def test_the_stall_resumes_from_now() -> None:
    """After a tick late by more than a period the loop resumes from now (as the node's does):
    the deadlines it skipped are counted as skipped, not run as a burst of late ticks."""
    loop = DeadlineLoop(RATE_HZ)
    late_wakes = []
    previous = None
    for k, now in enumerate(loop.ticks(0.05)):
        if previous is not None and now - previous < 0.2e9 / RATE_HZ:
            late_wakes.append(now)  # two ticks within 0.2 periods: a catch-up burst
        previous = now
        if k == 10:
            time.sleep(STALL_S)
    assert loop.counts()["skipped_deadlines"] >= 3
    assert len(late_wakes) <= 1  # the one tick just after the stall may come early
