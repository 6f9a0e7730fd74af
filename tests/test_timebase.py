"""drs_model.timebase's steps: :func:`steps_within` counts a step the span misses by rounding
only, and no more; :func:`nearest_step` is the grid point nearest a time (checked against exact
rational arithmetic, an independent reference)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from drs_model.timebase import nearest_step, nearest_steps, ns_from_seconds, split_ns, steps_within

DTS = st.sampled_from([1e-3, 4e-3, 1e-4, 1 / 3000, 0.1])


@given(st.integers(0, 100_000), DTS)
def test_a_whole_number_of_steps_is_counted_whole_despite_rounding(n, dt):
    # n * dt as a float, then divided again, can land just below n (0.3 / 0.1 = 2.999...)
    assert steps_within(n * dt, dt) == n


@given(st.integers(0, 100_000), DTS, st.floats(0.01, 0.99))
def test_a_span_a_fraction_of_a_step_short_counts_one_step_less(n, dt, frac):
    span = (n + frac) * dt
    exact = Fraction(span) / Fraction(dt)  # the float span's own step count, exactly
    assert steps_within(span, dt) == int(exact) == n


@given(st.integers(-100_000, 100_000), DTS, st.floats(-0.49, 0.49))
def test_the_nearest_step_is_the_nearest_grid_point(n, dt, off):
    t = (n + off) * dt
    assert nearest_step(t, dt) == n
    assert nearest_steps(np.array([t, t]), dt).tolist() == [n, n]


def test_a_split_of_seconds_is_exact_at_whole_seconds():
    assert split_ns(ns_from_seconds(2.3 - 1.3)) == (1, 0)  # 0.9999999999999998 s is 1 s 0 ns
    assert split_ns(ns_from_seconds(-0.5)) == (-1, 500_000_000)
