"""Weighted least squares: the normal equations, the covariance's coverage with independent
and with correlated errors, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from drs_model.errors import InputError
from drs_model.identify.least_squares import weighted_least_squares


def test_estimates_solve_the_weighted_normal_equations():
    rng = np.random.default_rng(1)
    X = rng.normal(size=(50, 3)) * np.array([1e-13, 1.0, 1e9])  # columns of any size
    y = rng.normal(size=50)
    w = rng.uniform(0.5, 2.0, 50)
    fit = weighted_least_squares(X, y, w)
    W = np.diag(w)
    expected = np.linalg.solve(X.T @ W @ X, X.T @ W @ y)
    assert np.allclose(fit.estimate, expected, rtol=1e-8)
    r = y - X @ expected
    s2 = float(r @ W @ r) / 47
    assert fit.sigma2 == pytest.approx(s2, rel=1e-9)
    assert np.allclose(fit.covariance, s2 * np.linalg.inv(X.T @ W @ X), rtol=1e-7)


def _coverage(noise, covariance, runs=400):
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1.0, 200)
    X = np.column_stack([np.ones_like(t), t])
    hit = 0
    for _ in range(runs):
        fit = weighted_least_squares(X, X @ [1.0, 2.0] + noise(rng, t.size), covariance=covariance)
        hit += abs(fit.estimate[0] - 1.0) < 1.96 * fit.std[0]
    return hit / runs


def test_classic_intervals_cover_independent_errors():
    assert 0.92 <= _coverage(lambda rng, n: rng.normal(size=n), "classic") <= 0.98


def test_hac_intervals_cover_correlated_errors_the_classic_ones_do_not():
    """Errors correlated from sample to sample (a moving average, as a smooth model error gives):
    the classic intervals are too narrow, the Newey-West ones close to nominal."""

    def moving_average(rng, n):
        e = rng.normal(size=n + 1)
        return e[1:] + 0.8 * e[:-1]

    assert _coverage(moving_average, "classic") < 0.88
    assert 0.90 <= _coverage(moving_average, "hac") <= 0.98


def test_hac_intervals_of_differenced_noise_are_narrower_and_still_cover():
    """Errors that are differences of white noise (an equation written on a stroke step)
    cancel over a run: the classic intervals are far too wide; the Newey-West ones less so."""

    def differenced(rng, n):
        e = rng.normal(size=n + 1)
        return e[1:] - e[:-1]

    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 200)
    X = np.column_stack([np.ones_like(t), t])
    y = X @ [1.0, 2.0] + differenced(rng, t.size)
    ratio = weighted_least_squares(X, y, covariance="hac").std / weighted_least_squares(X, y).std
    assert np.all(ratio < 0.6)
    assert _coverage(differenced, "hac") >= 0.95


@pytest.mark.parametrize(
    ("X", "y", "match"),
    [
        (np.ones((3, 3)), np.ones(3), "3 samples cannot determine 3 parameters"),
        (np.ones((5, 2)), np.array([1.0, np.nan, 1.0, 1.0, 1.0]), "y must be finite"),
        (np.ones((5, 2)), np.ones(4), r"X must be \(n, p\)"),
    ],
)
def test_bad_input_is_refused(X, y, match):
    with pytest.raises(InputError, match=match):
        weighted_least_squares(X, y)


def test_an_unknown_covariance_is_refused():
    with pytest.raises(InputError, match="covariance must be one of"):
        weighted_least_squares(np.ones((5, 1)), np.ones(5), covariance="robust")


def test_errors_in_variables_takes_the_attenuation_off():
    """``y = theta s`` with ``s`` read with noise: plain least squares shrinks ``theta`` by
    ``sum s^2 / (sum s^2 + n sigma^2)`` (3.6 % here: the classic attenuation), the corrected
    one does not."""
    from drs_model.identify.least_squares import errors_in_variables

    rng = np.random.default_rng(2)
    s = np.linspace(0.5, 1.5, 400)
    sigma = 0.2
    plain, corrected = [], []
    for _ in range(200):
        m = s + sigma * rng.normal(size=s.size)
        X = np.column_stack([m])
        y = 3.0 * s
        plain.append(weighted_least_squares(X, y).estimate[0])
        corrected.append(
            errors_in_variables(
                X, y, np.ones_like(s), np.ones_like(X), np.zeros_like(s), sigma**2
            ).estimate[0]
        )
    expected = np.sum(s * s) / (np.sum(s * s) + s.size * sigma**2)
    assert np.mean(plain) / 3.0 == pytest.approx(expected, abs=2e-3)
    assert np.mean(corrected) / 3.0 == pytest.approx(1.0, abs=2e-3)


def test_exact_data_keep_the_arithmetics_own_error():
    """An exactly linear, ill-conditioned problem (condition ~1e6): the residual is rounding, and
    an interval from it alone may miss the truth; with the solve's backward error counted, every
    interval has a width and holds the truth with a wide margin, also when each datum is moved
    by a few ulps (what another machine's arithmetic gives)."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 300)
    X = np.column_stack([np.ones_like(t), t, t + 1e-6 * t**2]) * np.array([1.0, 1e3, 1e-3])
    truth = np.array([2.0, -0.5, 7.0])
    for trial in range(20):
        y = X @ truth
        if trial:
            y = y + np.spacing(np.abs(y)) * rng.integers(-3, 4, y.size)
        fit = weighted_least_squares(X, y)
        assert np.all(fit.std > 0.0)
        z = np.abs(fit.estimate - truth) / fit.std
        assert np.all(z < 0.5), z  # and not only just inside: other machines round otherwise


def test_a_singular_covariance_is_an_error_not_a_zero_width():
    """A covariance with a variance that is not > 0 is refused, naming the column."""
    from drs_model.errors import ConvergenceError
    from drs_model.identify.least_squares import checked_covariance

    with pytest.raises(ConvergenceError, match=r"columns \[1\]"):
        checked_covariance(np.diag([1.0, -1e-30, 2.0]), "test")
    with pytest.raises(ConvergenceError, match="singular"):
        checked_covariance(np.diag([1.0, 0.0]), "test")
