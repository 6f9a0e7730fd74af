"""Which states of a stream go out on a topic of a lower rate: a schedule in simulated time.

The node publishes its joint states at ``publish_rate_hz``; a topic of its own rate (``/tf`` at
``tf_rate_hz``, as robot_state_publisher's ``publish_frequency`` limits its ``/tf``) takes one of
them each period. The schedule advances by whole periods, so that a rate that does not divide
the states' rate keeps its mean: 100 Hz taken from 250 Hz states is every 12, 8, 12, 8 ms, not
every 12 ms (83 Hz). The states' own spacing varies (a late tick catches up several physics
steps: 3 and 5 ms at 250 Hz; 300 Hz from 1 kHz physics is 3, 3, 4 ms), so a state up to half a
states' period early is on time.
"""

from __future__ import annotations

import math


class RateSchedule:
    """States at simulated times ``t`` [s] taken one each ``period_s`` [s] on average
    (:meth:`due`); ``states_period_s`` [s] is the states' nominal spacing, half of which is the
    schedule's slack. A period no longer than the states' takes every state."""

    def __init__(self, period_s: float, states_period_s: float) -> None:
        for name, value in (("period", period_s), ("states' period", states_period_s)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"a schedule's {name} must be finite and > 0 s, got {value!r}")
        self.period_s = period_s
        self.every_state = period_s <= states_period_s
        self.slack_s = states_period_s / 2
        #: Simulated time [s] at which the next state is taken (None: the next state).
        self.next_t: float | None = None

    def due(self, t: float) -> bool:
        """Whether the state at ``t`` [s] is taken: the first, then the first within the slack
        of each whole period of the schedule. A state more than a period off the schedule (after
        a pause, or a simulation whose time went back) is taken and starts it again from
        ``t``."""
        if self.every_state:
            return True
        nxt, period, slack = self.next_t, self.period_s, self.slack_s
        if nxt is not None and nxt - period - slack <= t < nxt - slack:
            return False  # after the last one taken (slack early at most), before the next
        on_schedule = nxt is not None and nxt - slack <= t < nxt + period
        self.next_t = (nxt if on_schedule else t) + period
        return True


__all__ = ["RateSchedule"]
