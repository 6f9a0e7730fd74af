"""drs_ros.log_throttle: a line at most once per period, the left-out ones counted; and the node's
refusals logged through it, so that a flood of refused commands never reaches rclpy's logger
(whose own throttle costs ~0.16 ms a call, suppressed or not)."""

from __future__ import annotations

import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drs_ros.log_throttle import LogThrottle
from drs_ros.node.effect_record import EffectRecord


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_the_first_line_is_written_and_the_next_within_the_period_only_counted():
    clock, lines = FakeClock(), []
    throttle = LogThrottle(lines.append, 1.0, clock)
    assert throttle("a") is True
    clock.now += 0.999
    assert throttle("b") is False
    assert throttle("c") is False
    assert lines == ["a"]
    assert throttle.suppressed == 2
    clock.now += 0.001  # a full period after the line written, not after the last call
    assert throttle("d") is True
    assert lines == ["a", "d (2 more lines like it not logged since the last)"]
    assert throttle.suppressed == 0
    clock.now += 5.0
    assert throttle("e") is True
    assert lines[-1] == "e"  # nothing left out: the line as given


def test_one_left_out_line_is_named_in_the_singular():
    clock, lines = FakeClock(), []
    throttle = LogThrottle(lines.append, 1.0, clock)
    throttle("a")
    throttle("b")
    clock.now += 1.0
    throttle("c")
    assert lines[-1] == "c (1 more line like it not logged since the last)"


@given(
    st.floats(min_value=0.0, max_value=10.0),
    st.lists(st.floats(min_value=0.0, max_value=3.0), min_size=1, max_size=60),
)
def test_written_lines_are_a_period_apart_and_every_call_is_accounted_for(period, steps):
    clock, lines = FakeClock(), []
    throttle = LogThrottle(lambda text: lines.append((clock.now, text)), period, clock)
    for step in steps:
        clock.now += step
        throttle("x")
    times = [t for t, _text in lines]
    assert times[0] == 100.0 + steps[0]  # the first call always writes
    assert all(b - a >= period for a, b in zip(times, times[1:], strict=False))
    left_out = sum(int(text.split("(")[1].split()[0]) for _t, text in lines if "not logged" in text)
    assert len(lines) + left_out + throttle.suppressed == len(steps)


def test_period_zero_writes_every_line_and_a_bad_period_is_refused():
    lines = []
    throttle = LogThrottle(lines.append, 0.0, FakeClock())
    for k in range(5):
        throttle(str(k))
    assert lines == ["0", "1", "2", "3", "4"]
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="period must be >= 0 s"):
            LogThrottle(lines.append, bad)


def test_threads_calling_at_once_write_one_line_and_count_the_rest():
    clock, lines = FakeClock(), []
    throttle = LogThrottle(lines.append, 1.0, clock)
    start = threading.Barrier(4)

    def hammer() -> None:
        start.wait()
        for _ in range(2000):
            throttle("x")

    threads = [threading.Thread(target=hammer) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert lines == ["x"]
    assert throttle.suppressed == 4 * 2000 - 1


class CountingLogger:
    """What EffectRecord asks of rclpy's logger: a refusal's WARN line (no rclpy throttle)."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def warning(self, text: str, **kwargs) -> None:
        assert not kwargs, "rclpy's own throttle would identify its caller on every call"
        self.lines.append(text)


class Publisher:
    topic_name = "/drs/command_events"

    def publish(self, data: bytes) -> None:
        pass


def test_a_flood_of_refusals_reaches_the_logger_once_a_second_and_is_all_counted():
    logger = CountingLogger()
    effects = EffectRecord(Publisher(), lambda *a: None, lambda: (0.0, 0, None), logger, 5.0)
    for k in range(1000):
        effects.refuse("stroke_cmd", 0.1 + k, "outside the stroke range", 10**9 + k)
    assert effects.refused == 1000  # counted, kept for diagnostics, in the trouble window
    assert len(effects.refusals) == 100
    assert sum(1 for _ in effects.troubles._events) == 1000
    assert len(logger.lines) == 1
    assert logger.lines[0].startswith("stroke_cmd 0.1 refused: outside the stroke range")
