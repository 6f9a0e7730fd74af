"""RateSchedule: a topic of a lower rate takes one state a period on average, from a stream of
states at any rate; the reference is the count and the spacing a rate implies."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drs_ros.rate_schedule import RateSchedule


def taken(schedule: RateSchedule, times) -> list[float]:
    return [t for t in times if schedule.due(t)]


@given(
    state_period_us=st.integers(50, 20_000),
    period_us=st.integers(50, 1_000_000),
    states=st.integers(1, 3000),
)
def test_one_state_a_period_on_average(state_period_us, period_us, states):
    dt, period = state_period_us * 1e-6, period_us * 1e-6
    times = [k * dt for k in range(states)]  # as the node's simulated time: steps summed
    out = taken(RateSchedule(period), times)
    assert out[0] == times[0]  # the first state goes out at once
    if period <= dt:
        assert out == times  # never more than one per state
        return
    span = times[-1] - times[0]
    # the mean rate is the schedule's: one per whole period of the span (not one per period
    # rounded up to the states' period, which 100 Hz from 250 Hz states would make 83 Hz)
    assert abs(len(out) - (math.floor(span / period + 1e-6) + 1)) <= 1
    gaps = [b - a for a, b in pairwise(out)]
    assert all(period - dt - 1e-9 <= g < period + dt + 1e-9 for g in gaps)


def test_100_hz_from_250_hz_states_alternates_12_and_8_ms():
    out = taken(RateSchedule(0.01), [k * 0.004 for k in range(251)])
    gaps_ms = {round((b - a) * 1e3, 6) for a, b in pairwise(out)}
    assert gaps_ms == {12.0, 8.0}
    assert len(out) == 101  # 1 s of states at 100 Hz, both ends


def test_a_pause_or_a_time_that_went_back_starts_the_schedule_again():
    s = RateSchedule(0.01)
    assert s.due(0.0) and not s.due(0.004)
    assert s.due(5.0)  # after a pause: at once, not at the old schedule
    assert not s.due(5.004) and s.due(5.01)
    assert s.due(0.5)  # a simulation whose time went back: at once, not in 4.5 s
    assert not s.due(0.504) and s.due(0.51)


@pytest.mark.parametrize("period", [0.0, -0.01, math.nan])
def test_a_period_that_is_not_positive_is_refused(period):
    with pytest.raises(ValueError, match="period must be > 0 s"):
        RateSchedule(period)
