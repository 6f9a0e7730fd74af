"""The wait for ``/clock`` under ``use_sim_time``: a part of :class:`drs_ros.node.adapter.DRSNode`
that checks on a steady-clock timer (it runs without ``/clock``) whether the node clock has
started, and says once, as a warning, when it has not within :data:`CLOCK_WAIT_WARNING_S`: the
simulation then waits and publishes nothing, which is otherwise silent.
"""

from __future__ import annotations

import time

from rclpy.clock import Clock, ClockType

#: Without /clock for this long under use_sim_time, the node says so (wall time) [s].
CLOCK_WAIT_WARNING_S = 2.0

#: How often the wait is checked (steady time) [s].
CHECK_PERIOD_S = 0.5


class ClockWait:
    """The wait of one configured node for ``/clock``: ``now_ns`` the node clock [ns] (0 until
    ``/clock`` arrives), ``log_warning`` the node logger's ``warning``; the wait counts from
    construction (steady time)."""

    def __init__(self, now_ns, log_warning) -> None:
        self._now_ns, self._log_warning = now_ns, log_warning
        self._started = time.monotonic()
        self._warned = False
        self.timer = None

    def start(self, node):
        """The steady-clock timer on ``node`` that checks the wait (returned: the node destroys
        it when it deactivates)."""
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.timer = node.create_timer(CHECK_PERIOD_S, self.check, clock=steady)
        return self.timer

    def check(self) -> None:
        """Cancel the timer once ``/clock`` has arrived; warn once after
        :data:`CLOCK_WAIT_WARNING_S` without it."""
        if self._now_ns() != 0:
            self.timer.cancel()
            return
        if not self._warned and time.monotonic() - self._started > CLOCK_WAIT_WARNING_S:
            self._warned = True
            self._log_warning(
                f"use_sim_time is set and no /clock message arrived in {CLOCK_WAIT_WARNING_S:g} s: "
                "the simulation waits for /clock and publishes nothing"
            )


__all__ = ["CLOCK_WAIT_WARNING_S", "ClockWait"]
