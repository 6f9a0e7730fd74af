"""Trend over a season: a leak growing 5 % per run is flagged at a reported run, a healthy season
is not (its false-alarm rate measured over seeded seasons), and the predicted crossing of a
threshold holds the truth within its interval at its nominal rate."""

from __future__ import annotations

import math

import numpy as np
import pytest
from identify_support import noisy_record, run_rung

from drs_model.errors import InputError
from drs_model.fidelity import HydraulicParams
from drs_model.identify.equation_error import continuity_stage
from drs_model.identify.trend import trend

DAY = 86400.0
RUNS = 40


def _leak_fit(table, params, seed):
    (e,) = continuity_stage(noisy_record(table, 1e-5, seed), ["leak_to_outside"], params,
                            HydraulicParams(), 0.95).estimates  # fmt: skip
    return e.value, e.std


def _opening(params, leak):
    """A short run (the opening, 60 ms at 2 kHz) with a leak to the outside."""
    return run_rung("hydraulic", params, moves=((0, True),), steps=120, dt=5e-4,
                    hydraulic=HydraulicParams(leak_to_outside=leak))  # fmt: skip


def test_a_leak_growing_5_percent_per_run_is_flagged(params):
    fits = np.array([_leak_fit(_opening(params, 1e-13 * 1.05**k), params, k)
                     for k in range(RUNS)])  # fmt: skip
    tr = trend("leak_to_outside", np.arange(RUNS) * DAY, fits[:, 0], fits[:, 1])
    assert tr.model == "exponential" and tr.direction == 1
    assert tr.detected is not None and tr.detected <= 12
    assert tr.slope * DAY == pytest.approx(math.log(1.05), rel=0.05)


def test_healthy_seasons_of_real_fits_raise_no_flag(params):
    """Ten seasons of forty runs, one leak, each run its own stroke noise: no flag."""
    table = _opening(params, 1e-13)
    flags = 0
    for season in range(10):
        fits = np.array([_leak_fit(table, params, 1000 + RUNS * season + k)
                         for k in range(RUNS)])  # fmt: skip
        flags += trend("leak", np.arange(RUNS) * DAY, fits[:, 0], fits[:, 1]).detected is not None
    assert flags == 0


def test_the_false_alarm_rate_of_healthy_seasons_is_small():
    """2000 seasons of forty runs of a constant parameter, each with its scatter and its own
    (varying) standard errors: at most 2 % raise a flag (a flag per run tested at 2.5e-4 each
    way; the 33 tests of a season are far from independent)."""
    rng = np.random.default_rng(0)
    flags = 0
    seasons = 2000
    for _ in range(seasons):
        std = rng.uniform(0.5, 2.0, RUNS)
        values = 100.0 + std * rng.normal(size=RUNS)
        flags += trend("p", np.arange(RUNS) * DAY, values, std, "linear").detected is not None
    assert flags / seasons <= 0.02


def test_the_crossing_interval_holds_the_truth_at_its_nominal_rate():
    """A leak from 1 growing 5 % per run with 2 % scatter: the threshold 5 is reached at run
    log 5 / log 1.05 = 33.0; over 300 seasons the 95 % interval holds it in 90-98 %."""
    rng = np.random.default_rng(1)
    truth = math.log(5.0) / math.log(1.05) * DAY
    hits = 0
    seasons = 300
    for s in range(seasons):
        values = 1.05 ** np.arange(RUNS) * np.exp(0.02 * rng.normal(size=RUNS))
        tr = trend("leak", np.arange(RUNS) * DAY, values, 0.02 * values, threshold=5.0, seed=s)
        hits += tr.crossing[0] <= truth <= tr.crossing[2]
    assert 0.90 <= hits / seasons <= 0.98


@pytest.mark.parametrize(
    ("values", "kw", "match"),
    [
        ([1.0, 2.0], {}, "needs three runs with a value, got 2"),
        ([1.0, -2.0, 3.0], {"model": "exponential"}, "exponential trend needs values > 0"),
        ([1.0, 2.0, 3.0], {"model": "quadratic"}, "model must be one of"),
    ],
)
def test_a_trend_that_cannot_be_fitted_is_refused(values, kw, match):
    n = len(values)
    with pytest.raises(InputError, match=match):
        trend("p", np.arange(n) * DAY, values, np.ones(n), **kw)


def test_the_sequential_test_is_the_regression_of_each_prefix():
    from drs_model.identify.trend import drift_probability, sequential_rise_probability

    rng = np.random.default_rng(3)
    tau = np.arange(30) * DAY
    y = rng.normal(size=30) + 0.05 * np.arange(30)
    sy = rng.uniform(0.5, 2.0, 30)
    seq = sequential_rise_probability(tau, y, sy)
    ref = [drift_probability(tau[:n], y[:n], sy[:n])[0] for n in range(3, 31)]
    assert np.allclose(seq[2:], ref, rtol=0, atol=1e-12) and np.isnan(seq[:2]).all()
