"""Which states of a stream go out on a topic of a lower rate: a schedule in simulated time.

The node publishes its joint states at ``publish_rate_hz``; a topic of its own rate (``/tf`` at
``tf_rate_hz``, as robot_state_publisher's ``publish_frequency`` limits its ``/tf``) takes one of
them each period. The schedule advances by whole periods, so that a rate that does not divide
the states' rate keeps its mean: 100 Hz taken from 250 Hz states is every 12, 8, 12, 8 ms, not
every 12 ms (83 Hz).
"""

from __future__ import annotations

#: Tolerance [s] of the comparison with the schedule: simulated time is a float sum of steps.
TIME_TOL_S = 1e-9


class RateSchedule:
    """States at simulated times ``t`` [s] (increasing) taken at most one each ``period_s`` [s]
    on average: :meth:`due`."""

    def __init__(self, period_s: float) -> None:
        if not period_s > 0.0:
            raise ValueError(f"a schedule's period must be > 0 s, got {period_s!r}")
        self.period_s = period_s
        #: Simulated time [s] from which the next state is taken (None: the next state).
        self.next_t: float | None = None

    def due(self, t: float) -> bool:
        """Whether the state at ``t`` [s] is taken: the first, then the first at or after each
        whole period of the schedule. A state more than a period off the schedule (after a
        pause, or a simulation whose time went back) is taken and starts it again from ``t``."""
        nxt, period = self.next_t, self.period_s
        if nxt is not None and nxt - period <= t < nxt - TIME_TOL_S:
            return False
        on_schedule = nxt is not None and abs(t - nxt) < period
        self.next_t = (nxt if on_schedule else t) + period
        return True


__all__ = ["TIME_TOL_S", "RateSchedule"]
