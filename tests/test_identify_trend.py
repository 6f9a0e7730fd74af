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
    (e,) = continuity_stage(
        noisy_record(table, 1e-5, seed), ["leak_to_outside"], params, HydraulicParams(), 0.95
    ).estimates
    return e.value, e.std


def _opening(params, leak):
    """A short run (the opening, 60 ms at 2 kHz) with a leak to the outside."""
    return run_rung(
        "hydraulic",
        params,
        moves=((0, True),),
        steps=120,
        dt=5e-4,
        hydraulic=HydraulicParams(leak_to_outside=leak),
    )


def test_a_leak_growing_5_percent_per_run_is_flagged(params):
    fits = np.array([_leak_fit(_opening(params, 1e-13 * 1.05**k), params, k) for k in range(RUNS)])
    tr = trend("leak_to_outside", np.arange(RUNS) * DAY, fits[:, 0], fits[:, 1])
    assert tr.model == "exponential" and tr.direction == 1
    assert tr.detected is not None and tr.detected <= 12
    assert tr.slope * DAY == pytest.approx(math.log(1.05), rel=0.05)


def test_healthy_seasons_of_real_fits_raise_no_flag(params):
    """Ten seasons of forty runs, one leak, each run its own stroke noise: no flag."""
    table = _opening(params, 1e-13)
    flags = 0
    for season in range(10):
        fits = np.array([_leak_fit(table, params, 1000 + RUNS * season + k) for k in range(RUNS)])
        flags += trend("leak", np.arange(RUNS) * DAY, fits[:, 0], fits[:, 1]).detected is not None
    assert flags == 0


def _season(rng, onset=None, step=2.0, runs=RUNS):
    """A season of ``runs`` of a parameter at 100 with a scatter of 1 (each run's standard
    error 1); from the run ``onset`` (1-based) on, ``step`` more each run (run ``onset`` is the
    first off its level)."""
    values = 100.0 + rng.normal(size=runs)
    if onset is not None:
        values[onset - 1 :] += step * np.arange(1, runs - onset + 2)
    return values


def test_a_drift_from_run_28_is_flagged_by_run_31_with_its_onset():
    """2 standard deviations a run from run 28 of 40: the line's scatter would hide it for
    runs; the CUSUM names run 28 (+-1) as its onset and flags it by run 31."""
    tr = trend(
        "p", np.arange(RUNS) * DAY, _season(np.random.default_rng(28), 28), np.ones(RUNS), "linear"
    )
    assert tr.direction == 1 and tr.onset is not None and tr.detected is not None
    assert 27 <= tr.onset + 1 <= 29 and 28 <= tr.detected + 1 <= 31


def test_a_drift_over_the_last_four_of_twelve_runs_is_mostly_flagged():
    """Twelve runs, 2 standard deviations a run from run 9: a reference of eight runs leaves
    four tests; over 200 seeded seasons at least 60 % are flagged (the line's test flagged 9 %),
    none before run 9, each naming an onset in runs 9-11."""
    rng = np.random.default_rng(12)
    flagged = 0
    for _ in range(200):
        tr = trend("p", np.arange(12) * DAY, _season(rng, 9, runs=12), np.ones(12), "linear")
        if tr.detected is not None:
            flagged += 1
            assert tr.direction == 1 and tr.detected + 1 >= 9 and 9 <= tr.onset + 1 <= 11
    assert flagged >= 120


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_drifts_of_two_standard_deviations_a_run_are_flagged_within_three_runs(sign):
    """200 seeded seasons, a drift either way from run 28: every one flagged within three runs
    of its onset (a flag before the onset is a false alarm, at most 1 %)."""
    rng = np.random.default_rng(7 if sign > 0 else 8)
    delays = []
    for _ in range(200):
        tr = trend(
            "p", np.arange(RUNS) * DAY, _season(rng, 28, 2.0 * sign), np.ones(RUNS), "linear"
        )
        assert tr.detected is not None and tr.direction == (1 if sign > 0 else -1)
        delays.append(tr.detected + 1 - 28)
    delays = np.array(delays)
    assert np.sum(delays < 0) <= 2 and delays.max() <= 3


@pytest.mark.parametrize("heteroscedastic", [False, True])
def test_at_least_99_percent_of_drift_free_seasons_raise_no_flag(heteroscedastic):
    """200 seasons of forty runs of a constant parameter (with the runs' own, varying standard
    errors, or one scatter): at most 2 raise a flag."""
    rng = np.random.default_rng(40 + heteroscedastic)
    flags = 0
    for _ in range(200):
        std = rng.uniform(0.5, 2.0, RUNS) if heteroscedastic else np.ones(RUNS)
        values = 100.0 + std * rng.normal(size=RUNS)
        flags += trend("p", np.arange(RUNS) * DAY, values, std, "linear").detected is not None
    assert flags <= 2


def test_the_scale_is_the_runs_scatter_not_their_stated_errors():
    """Runs whose fits state a tenth of their real scatter: the reference's scale finds the
    ratio (10), so the drift-free seasons still raise no flag and a drift is still seen."""
    rng = np.random.default_rng(9)
    flags = 0
    for _ in range(100):
        values = 100.0 + rng.normal(size=RUNS)
        flags += (
            trend("p", np.arange(RUNS) * DAY, values, np.full(RUNS, 0.1), "linear").detected
            is not None
        )
    assert flags <= 1
    tr = trend("p", np.arange(RUNS) * DAY, _season(rng, 28), np.full(RUNS, 0.1), "linear")
    assert 28 <= tr.detected + 1 <= 31


def test_the_standardised_residuals_of_drift_free_seasons_are_standard_normal():
    """The CUSUM's z (each run against the runs before it) over 300 seasons: mean 0 and standard
    deviation 1 within their sampling error, tails as the normal's."""
    from drs_model.identify.change_point import cusum

    rng = np.random.default_rng(11)
    z = np.concatenate(
        [cusum(rng.normal(size=RUNS), np.ones(RUNS), decision=1e9).z[8:] for _ in range(300)]
    )
    assert abs(z.mean()) < 0.05 and abs(z.std() - 1.0) < 0.05
    assert abs(np.mean(np.abs(z) > 1.96) - 0.05) < 0.015


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
