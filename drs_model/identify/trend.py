r"""A parameter over a season of runs: drift detection and when a threshold will be crossed
(``drs-bag trend``).

Degradation model (Bayesian linear regression on run time, Gelman et al., "Bayesian Data
Analysis", ch. 14): with ``g`` the identity (``linear``) or the logarithm (``exponential``: a
leak that grows by a fixed fraction per run),

.. math::

    g(\theta_k) = a + b\,\tau_k + e_k, \qquad e_k \sim N(0, s^2 w_k^{-1})

``tau_k`` the run's time [s] from the first run, ``w_k`` the inverse of the run's own variance
(its fit's standard error, through ``g``) relative to their mean, ``s^2`` the scale the runs'
scatter gives. With the reference prior ``p(a, b, s^2) ~ 1/s^2`` the posterior of ``b`` is
Student-t with ``n - 2`` degrees of freedom about the weighted least-squares slope.

Detection is sequential and separate from the line: a two-sided CUSUM of each run's standardised
residual against the runs before it (:mod:`.change_point`), its scale from the run-to-run
differences before the drift, so a drift does not widen the scale it is judged by (the line's
residual scatter does: a drift over the last runs of a season would hide in it). It names the run
the drift began and the run it became significant. ``P(b > 0)`` after each run is still reported.

The threshold's crossing: ``tau* = (g(threshold) - a) / b`` over draws of ``(a, b)`` from the
posterior at the last run; its 2.5, 50 and 97.5 % quantiles (``inf`` where more of the draws
never reach it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import t as student_t

from ..errors import InputError
from .change_point import DECISION, MIN_RUNS, cusum

MODELS = ("linear", "exponential", "auto")
#: Posterior draws of the crossing time.
DRAWS = 4000


@dataclass(frozen=True)
class Trend:
    """One parameter's trend over a season.

    Attributes
    ----------
    name : str
    model : str
        ``linear`` or ``exponential``.
    origin : float
        The first run's time [s] (the runs' ``tau`` count from it).
    tau : ndarray
        Run times [s] from the first run, of the runs used (determined).
    values, std : ndarray
    slope, slope_std : float
        ``b`` and its posterior standard deviation [g-units per s] at the last run.
    intercept : float
    probability : ndarray
        ``max(P(b > 0), P(b < 0))`` of the line after each run (NaN before :data:`MIN_RUNS`).
    detected : int or None
        Index (among the runs used) of the run at which the CUSUM flagged a drift.
    onset : int or None
        Index of the run at which that drift began (the CUSUM's estimate).
    direction : int
        +1 rising, -1 falling, 0 no drift.
    crossing : tuple or None
        ``(low, median, high)`` time [s from the first run] the threshold is reached.
    threshold : float or None
    """

    name: str
    model: str
    origin: float
    tau: np.ndarray
    values: np.ndarray
    std: np.ndarray
    slope: float
    slope_std: float
    intercept: float
    dof: int
    scale2: float
    covariance: np.ndarray
    probability: np.ndarray
    detected: int | None
    direction: int
    onset: int | None = None
    crossing: tuple[float, float, float] | None = None
    threshold: float | None = None

    def fitted(self, tau) -> np.ndarray:
        """The trend's value [the parameter's unit] at times ``tau`` [s]."""
        y = self.intercept + self.slope * np.asarray(tau, dtype=float)
        return np.exp(y) if self.model == "exponential" else y


def _g(model: str, values, std):
    if model == "exponential":
        return np.log(values), std / values
    return values, std


def _fit(tau, y, sy):
    """Weighted regression of ``y`` on ``tau`` with relative weights ``1/sy^2``: ``(a, b),
    covariance of (a, b) with the scale estimated, dof, s^2``."""
    w = 1.0 / np.maximum(sy, 1e-300) ** 2
    w = w / w.mean()
    X = np.column_stack([np.ones_like(tau), tau])
    XtW = X.T * w
    cov0 = np.linalg.inv(XtW @ X)
    coef = cov0 @ (XtW @ y)
    r = y - X @ coef
    dof = tau.size - 2
    s2 = float(np.sum(w * r * r) / dof)
    return coef, cov0 * s2, dof, s2


def drift_probability(tau, y, sy) -> tuple[float, float, float, int]:
    """``(P(b > 0), b, sd(b), dof)`` of the runs given."""
    coef, cov, dof, _ = _fit(tau, y, sy)
    sd = math.sqrt(max(cov[1, 1], 0.0))
    if sd == 0.0:
        return (1.0 if coef[1] > 0 else 0.0 if coef[1] < 0 else 0.5), coef[1], sd, dof
    return float(student_t.cdf(coef[1] / sd, dof)), float(coef[1]), sd, dof


def sequential_rise_probability(tau, y, sy) -> np.ndarray:
    """``P(b > 0)`` given the first ``n`` runs, for every ``n`` (NaN for ``n < 3``): the
    weighted regression of each prefix from running sums (the same as :func:`drift_probability`
    on each prefix, in one pass)."""
    w = 1.0 / np.maximum(sy, 1e-300) ** 2
    x = (tau - tau[0]) / max(float(np.ptp(tau)), 1e-300)  # the t-statistic is scale-free
    y = y - y[0]
    s0, s1, s2 = (np.cumsum(w * x**k) for k in (0, 1, 2))
    sy_, sxy, syy = np.cumsum(w * y), np.cumsum(w * x * y), np.cumsum(w * y * y)
    n = np.arange(1, tau.size + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = s0 * s2 - s1 * s1
        b = (s0 * sxy - s1 * sy_) / d
        a = (sy_ - b * s1) / s0
        rss = np.maximum(syy - a * sy_ - b * sxy, 0.0)
        var_b = rss / (n - 2) * s0 / d
        t = b / np.sqrt(var_b)
    out = np.where(
        var_b > 0.0,
        student_t.cdf(t, np.maximum(n - 2, 1)),
        np.where(b > 0, 1.0, np.where(b < 0, 0.0, 0.5)),
    )
    out[n < 3] = math.nan
    return out


def _crossing(g_threshold, coef, cov, dof, seed) -> tuple[float, float, float]:
    rng = np.random.default_rng(seed)
    # multivariate t draws of (a, b)
    z = rng.multivariate_normal(np.zeros(2), cov, size=DRAWS)
    chi = rng.chisquare(dof, size=DRAWS) / dof
    a = coef[0] + z[:, 0] / np.sqrt(chi)
    b = coef[1] + z[:, 1] / np.sqrt(chi)
    with np.errstate(divide="ignore", invalid="ignore"):
        when = (g_threshold - a) / b
    when = np.where(np.isfinite(when) & (when >= 0.0), when, math.inf)
    lo, mid, hi = np.quantile(when, [0.025, 0.5, 0.975])
    return float(lo), float(mid), float(hi)


def trend(
    name: str,
    tau: Sequence[float],
    values: Sequence[float],
    std: Sequence[float],
    model: str = "auto",
    threshold: float | None = None,
    decision: float = DECISION,
    min_runs: int = MIN_RUNS,
    seed: int = 0,
) -> Trend:
    """The trend of one parameter (module docstring) over the runs at times ``tau`` [s] with
    fitted ``values`` and standard errors ``std``; runs without a value (NaN) are left out.

    ``decision`` is the CUSUM's decision interval [standard deviations]; the first drift test
    is at run ``min_runs + 1``.

    Raises
    ------
    InputError
        Fewer than three runs with a value, ``min_runs < 3``, a bad model, an exponential
        model on a value <= 0.
    """
    tau, values, std = (np.asarray(x, dtype=float) for x in (tau, values, std))
    ok = np.isfinite(tau) & np.isfinite(values) & np.isfinite(std) & (std > 0)
    tau, values, std = tau[ok], values[ok], std[ok]
    if tau.size < 3:
        raise InputError(f"{name}: a trend needs three runs with a value, got {tau.size}")
    order = np.argsort(tau, kind="stable")
    origin = float(tau[order][0])
    tau, values, std = tau[order] - origin, values[order], std[order]
    if model not in MODELS:
        raise InputError(f"model must be one of {MODELS}, got {model!r}")
    if model == "auto":
        model = "exponential" if np.all(values > 0) else "linear"
    if model == "exponential" and not np.all(values > 0):
        raise InputError(f"{name}: an exponential trend needs values > 0")
    y, sy = _g(model, values, std)
    up = sequential_rise_probability(tau, y, sy)
    prob = np.maximum(up, 1.0 - up)
    prob[: max(min_runs, 3) - 1] = math.nan
    change = cusum(y, sy, decision=decision, min_runs=min_runs)
    coef, cov, dof, s2 = _fit(tau, y, sy)
    crossing = None
    if threshold is not None:
        g_thr = _g(model, np.array([threshold]), np.array([1.0]))[0][0]
        crossing = _crossing(g_thr, coef, cov, dof, seed)
    return Trend(
        name,
        model,
        origin,
        tau,
        values,
        std,
        float(coef[1]),
        math.sqrt(cov[1, 1]),
        float(coef[0]),
        dof,
        s2,
        cov,
        prob,
        change.detected,
        change.direction,
        change.onset,
        crossing,
        threshold,
    )


__all__ = [
    "DECISION",
    "DRAWS",
    "MIN_RUNS",
    "MODELS",
    "Trend",
    "drift_probability",
    "sequential_rise_probability",
    "trend",
]
