"""RateSchedule: a topic of a lower rate takes one state a period on average from a stream of
states whose spacing varies as the node's does (whole physics steps, late ticks); the reference
is the count and the spacing a rate implies."""

from __future__ import annotations

import math
from itertools import pairwise

import pytest
from hypothesis import given
from hypothesis import strategies as st

from drs_ros.rate_schedule import RateSchedule


def taken(schedule: RateSchedule, times) -> list[float]:
    return [t for t in times if schedule.due(t)]


def node_states(physics_hz: int, publish_hz: float, lateness: list[float]) -> list[float]:
    """Simulated times of the states a node publishes: tick k at ``k / publish_hz`` late by
    ``lateness[k]`` of a period catches up whole physics steps, and publishes when it took one."""
    dt, out, steps = 1.0 / physics_hz, [], -1
    for k, late in enumerate(lateness):
        now_steps = math.floor((k + late) / publish_hz * physics_hz + 1e-9)
        if now_steps > steps:
            steps = now_steps
            out.append(steps * dt)
    return out


@given(
    physics_hz=st.sampled_from([1000, 2000, 5000]),
    publish_div=st.floats(1.0, 20.0),
    tf_hz=st.floats(1.0, 2000.0),
    lateness=st.lists(st.sampled_from([0.0, 0.0, 0.0, 0.05, 0.3, 0.9]), min_size=2, max_size=600),
)
def test_one_state_a_period_on_average_from_irregular_states(
    physics_hz, publish_div, tf_hz, lateness
):
    publish_hz = physics_hz / publish_div
    states = node_states(physics_hz, publish_hz, lateness)
    states_period, period = 1.0 / publish_hz, 1.0 / tf_hz
    out = taken(RateSchedule(period, states_period), states)
    assert out[0] == states[0]  # the first state goes out at once
    if period <= states_period:
        assert out == states  # at or above the states' rate: each one
        return
    if period < 2 * states_period:
        return  # a gap between states may exceed the period: the schedule restarts there
    max_gap = max((b - a for a, b in pairwise(states)), default=0.0)
    span = states[-1] - states[0]
    # the mean rate is the schedule's: one per whole period of the span (not one per period
    # rounded up to the states' spacing, which 100 Hz from 250 Hz states would make 83 Hz)
    assert abs(len(out) - (math.floor(span / period + 1e-9) + 1)) <= 1
    slack = states_period / 2
    assert all(period - slack - max_gap < g < period + slack + max_gap for g in pairwise_gaps(out))


def pairwise_gaps(times):
    return [b - a for a, b in pairwise(times)]


def test_100_hz_from_250_hz_states_alternates_12_and_8_ms():
    out = taken(RateSchedule(0.01, 0.004), [k * 0.004 for k in range(251)])
    assert {round(g * 1e3, 6) for g in pairwise_gaps(out)} == {12.0, 8.0}
    assert len(out) == 101  # 1 s of states at 100 Hz, both ends


def test_uneven_states_at_the_states_rate_or_above_are_each_taken():
    states = node_states(1000, 300.0, [0.0] * 300)  # 3, 3, 4 ms apart
    assert {round(g * 1e3, 6) for g in pairwise_gaps(states)} == {3.0, 4.0}
    for tf_hz in (300.0, 310.0, 1000.0):
        assert taken(RateSchedule(1 / tf_hz, 1 / 300.0), states) == states
    out = taken(RateSchedule(0.01, 1 / 300.0), states)  # 100 Hz of them, on average
    assert abs(len(out) - ((states[-1] - states[0]) / 0.01 + 1)) <= 1


def test_late_ticks_keep_the_rate():
    # 250 Hz ticks, one in three late by 0.9 period: 3 and 5 ms apart at times; 100 Hz of them
    states = node_states(1000, 250.0, [0.9 if k % 3 == 1 else 0.0 for k in range(2500)])
    out = taken(RateSchedule(0.01, 0.004), states)
    assert abs(len(out) - ((states[-1] - states[0]) / 0.01 + 1)) <= 1


def test_a_pause_or_a_time_that_went_back_starts_the_schedule_again():
    s = RateSchedule(0.01, 0.001)
    assert s.due(0.0) and not s.due(0.004)
    assert s.due(5.0)  # after a pause: at once, not at the old schedule
    assert not s.due(5.004) and s.due(5.01)
    assert s.due(0.5)  # a simulation whose time went back: at once, not in 4.5 s
    assert not s.due(0.504) and s.due(0.51)


@pytest.mark.parametrize("period", [0.0, -0.01, math.nan, math.inf])
def test_a_period_that_is_not_positive_and_finite_is_refused(period):
    with pytest.raises(ValueError, match="must be finite and > 0 s"):
        RateSchedule(period, 0.001)
    with pytest.raises(ValueError, match="must be finite and > 0 s"):
        RateSchedule(0.01, period)


def test_a_state_half_a_states_period_early_is_on_time():
    # 250 Hz states, one of them a millisecond early against the 10 ms schedule: it is the
    # nearest to the schedule, taken there; the next on time then is 20 ms
    s = RateSchedule(0.01, 0.004)
    assert [s.due(t) for t in (0.0, 0.004, 0.009, 0.012, 0.016, 0.0195)] == [
        True,
        False,
        True,
        False,
        False,
        True,
    ]
