"""Intervals that respect a parameter's physical bound: the log-scale interval of a positive
parameter where the linear one would cross its bound, and none for an estimate at or below it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from drs_model.identify.intervals import bounded_interval, quantile


@given(value=st.floats(1e-9, 1e3), rel=st.floats(1e-6, 100.0), bound=st.sampled_from([0.0, 1e-12]))
def test_a_positive_parameters_interval_never_crosses_its_bound(value, rel, bound):
    (lo, hi), kind = bounded_interval(value, rel * value, 1.96, bound)
    assert bound <= lo <= value <= hi  # (== only where the float cannot hold bound + tiny)
    assert hi > lo
    if kind == "log" and rel < 10.0:  # the delta method in log(theta - bound): symmetric there
        up = math.log((hi - bound) / (value - bound))
        down = math.log((value - bound) / (lo - bound))
        assert up == pytest.approx(down, rel=1e-6)


def test_a_narrow_interval_stays_the_jacobians_and_an_unbounded_parameter_is_never_logged():
    assert bounded_interval(2.0, 0.1, 1.96, 0.0) == ((2.0 - 0.196, 2.0 + 0.196), "jacobian")
    assert bounded_interval(2.0, 5.0, 1.96, -math.inf) == ((2.0 - 9.8, 2.0 + 9.8), "jacobian")


def test_an_estimate_at_or_below_its_bound_has_no_interval():
    for value in (0.0, -8.26):
        (lo, hi), _ = bounded_interval(value, 1.0, 1.96, 0.0)
        assert math.isnan(lo) and math.isnan(hi)


def test_the_log_interval_covers_a_lognormal_estimate_at_its_level():
    """An estimate whose log is normal with a 60 % spread (a mass the run barely sees): the
    log interval holds the truth in 95 % of 4000 draws (within 1 %), the linear one would
    reach below 0 kg in most."""
    rng = np.random.default_rng(5)
    truth, spread = 2.0, 0.6
    draws = truth * np.exp(rng.normal(0.0, spread, 4000))
    q = quantile(0.95, 10**7)
    hits = 0
    for v in draws:
        (lo, hi), kind = bounded_interval(v, spread * v, q, 0.0)
        hits += lo <= truth <= hi
        assert lo > 0.0
    assert hits / draws.size == pytest.approx(0.95, abs=0.01)
