"""The wait for /clock under use_sim_time, without rclpy's executor: no warning before
CLOCK_WAIT_WARNING_S, one warning after it (never repeated), and the check's timer cancelled as
soon as the node clock runs. The node's own warning is tested end to end in
test_node_process.py."""

from __future__ import annotations

import pytest

from drs_ros.node import clock_wait
from drs_ros.node.clock_wait import CLOCK_WAIT_WARNING_S, ClockWait


class _Timer:
    def __init__(self) -> None:
        self.cancelled = 0

    def cancel(self) -> None:
        self.cancelled += 1


class _Steady:
    """A settable monotonic clock [s] in place of time.monotonic."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def steady(monkeypatch) -> _Steady:
    clock = _Steady()
    monkeypatch.setattr(clock_wait.time, "monotonic", clock)
    return clock


def _wait(now: list[int], warnings: list[str]) -> ClockWait:
    wait = ClockWait(lambda: now[0], warnings.append)
    wait.timer = _Timer()
    return wait


def test_warns_once_after_the_wait(steady: _Steady) -> None:
    now, warnings = [0], []
    wait = _wait(now, warnings)
    steady.t += 0.9 * CLOCK_WAIT_WARNING_S
    wait.check()
    assert warnings == []
    steady.t += 0.2 * CLOCK_WAIT_WARNING_S
    wait.check()
    wait.check()
    assert len(warnings) == 1
    assert f"no /clock message arrived in {CLOCK_WAIT_WARNING_S:g} s" in warnings[0]
    assert wait.timer.cancelled == 0


def test_cancelled_once_the_clock_runs(steady: _Steady) -> None:
    now, warnings = [0], []
    wait = _wait(now, warnings)
    now[0] = 1
    steady.t += 10 * CLOCK_WAIT_WARNING_S
    wait.check()
    assert wait.timer.cancelled == 1
    assert warnings == []
