"""drs_ros.log_throttle: a line at most once per period, the left-out ones counted; and the node's
refusals logged through it, so that a flood of refused commands never reaches rclpy's logger
(whose own throttle costs ~0.16 ms a call, suppressed or not)."""

from __future__ import annotations

import sys
import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st
from ros_support import require_rclpy

require_rclpy()

import rclpy.logging  # noqa: E402

from drs_ros.log_throttle import LogThrottle  # noqa: E402
from drs_ros.node.effect_record import EffectRecord  # noqa: E402


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
def test_a_line_is_written_exactly_when_a_period_has_passed_since_the_last_written(period, steps):
    clock, lines = FakeClock(), []
    throttle = LogThrottle(lambda text: lines.append((clock.now, text)), period, clock)
    expected, last, left_out = [], None, 0  # the rule, stated apart from the code
    for step in steps:
        clock.now += step
        if last is None or clock.now - last >= period:
            expected.append((clock.now, left_out))
            last, left_out = clock.now, 0
        else:
            left_out += 1
        throttle("x")
    assert [t for t, _text in lines] == [t for t, _n in expected]
    for (_t, text), (_t2, n) in zip(lines, expected, strict=True):
        assert text == (
            "x"
            if n == 0
            else f"x ({n} more line{'s' if n > 1 else ''} like it not logged since the last)"
        )
    assert throttle.suppressed == left_out


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
        for _ in range(20_000):
            throttle("x")

    threads = [threading.Thread(target=hammer) for _ in range(4)]
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # threads switch at every chance the interpreter gives
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
    assert lines == ["x"]
    assert throttle.suppressed == 4 * 20_000 - 1  # no count lost between threads


def test_throttles_of_two_severities_on_one_rclpy_logger_both_write_from_their_callers():
    """rclpy keys a logger's state on the calling location and raises ValueError when one
    location logs at two severities: the throttle's own line must not be that location."""
    logger = rclpy.logging.get_logger("drs_test_log_throttle")
    warn, error = LogThrottle(logger.warning), LogThrottle(logger.error)
    assert warn("a refusal (logged by the test on purpose)")
    assert error("a failed callback (logged by the test on purpose)")  # no ValueError
    callers = {(c.file_path, c.function_name) for c in logger.contexts}
    here = __file__.replace(".pyc", ".py")
    assert callers == {
        (here, "test_throttles_of_two_severities_on_one_rclpy_logger_both_write_from_their_callers")
    }
    assert len(logger.contexts) == 2  # one per calling line


class CountingLogger:
    """What EffectRecord asks of rclpy's logger: a refusal's WARN line (no rclpy throttle)."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def warning(self, text: str, **kwargs) -> None:
        assert not kwargs, "rclpy's own throttle would identify its caller on every call"
        self.lines.append(text)


class Publisher:
    topic_name = "/drs/command_events"

    def get_subscription_count(self) -> int:
        return 1

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
