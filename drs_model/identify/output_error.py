r"""Stage 2, output error: re-simulate the recorded commands with trial parameters and fit the
recorded signals (``scipy.optimize.least_squares``, trust-region reflective, with bounds).

The residual of signal ``j`` at its samples is ``(simulated - measured) / sigma_j``; ``sigma_j``
is the signal's noise: given, or estimated from the record in two passes (the first with the
sensors' typical resolutions :data:`RESOLUTION` as weights, the second with each signal's
residual RMS from the first, ``sqrt(n / (n - p))``-corrected for what the fit took, never below
the recorded values' own resolution: a float64's spacing over sqrt 12, what a noise-free record
holds). A record the re-simulation reproduces to its last bits at most of its samples is
noise-free, and its noise is that resolution (:func:`holds_exactly`). A noise-free record so
gets intervals as narrow as its re-simulation's agreement with it allows, and the stage's note
says which noise each signal was given and from where.

Parameters are fitted in units of their typical size (``x = theta / scale``), each within its
physical bounds; the start is the equation error's estimate where it has one. Each evaluation
is one re-simulation (the caller's ``simulate``, on the compiled rung); the Jacobian is by
forward differences, one re-simulation per parameter.

The covariance is ``s^2 (J^T J)^{-1}`` (in the parameters' units) with ``s^2 = max(1, chi2 /
dof)``: the noise as estimated, inflated where the fit is worse than it (Birge's ratio), plus
the optimiser's own stopping error (:func:`stopping_error`: the Gauss-Newton step left from
where it stopped, and the re-simulation's arithmetic, which a noise-free record's interval
would otherwise be narrower than); its intervals are checked against the profile likelihood
(:mod:`.intervals`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ..errors import ConvergenceError, InputError
from .least_squares import checked_covariance, hac_lag

#: A sensor's typical resolution [unit]: the first solve's weights, before the record's own noise
#: is known, and the identifiability's scale (stroke: a good LVDT's 1 um; pressures: 0.1 bar,
#: 0.025 % of a 400 bar transducer; force: 1 N; spool 0.1 %).
RESOLUTION = {
    "stroke": 1e-6,
    "stroke_rate": 1e-4,
    "piston_force": 1.0,
    "pressure_a": 1e4,
    "pressure_b": 1e4,
    "supply_pressure": 1e4,
    "spool": 1e-3,
}

#: The optimiser's stopping tolerance on the scaled parameters (``xtol``: a step below
#: ``xtol * ||x||`` ends it). What is left to go when it stops is estimated, not assumed
#: (:func:`stopping_error`).
STOP_TOLERANCE = 1e-10
#: The re-simulation's own arithmetic, relative to each scaled parameter: no interval is
#: narrower. On exact records the estimates lie up to ~2e-12 of their values from the truth
#: (the hydraulic rung's friction from a re-run that matches the record to ~10 units in the
#: last place, not bit for bit, through 240 stiff steps; the rigid rung's to ~1e-15), where
#: the residuals' own scatter stated 1e-14; this bound holds both with a margin.
ARITHMETIC_ERROR = 3e-10
#: Passes at most of the noise's estimate: a pass whose noise is within 2x of the one before
#: ends them (a first fit weighted by a sensor's resolution may stop short of the minimum that
#: a noise-free record's own weights find).
NOISE_PASSES = 4
#: Relative step of the forward-difference Jacobian (in ``x = theta / scale``).
DIFF_STEP = 1e-4
#: Distance [typical sizes] a start keeps from a bound.
START_MARGIN = 1e-2
#: Iterations of each re-fit of the others along a profile (each starts at the estimate, a
#: small step away from where they fit: a few Gauss-Newton steps converge).
PROFILE_ITERATIONS = 4


@dataclass
class OutputErrorProblem:
    """What an output-error fit needs.

    Attributes
    ----------
    names : tuple of str
    start, lower, upper, scale : ndarray
        Start, bounds and typical size of each parameter [its unit].
    simulate : callable
        ``simulate({name: value}) -> {signal: ndarray}``: the re-simulated signals at the
        measured samples (may raise :class:`~drs_model.errors.DRSError` for a trial the model
        refuses; the fit then treats that trial as very bad).
    measured : dict
        ``signal -> ndarray`` (NaN: a lost sample, left out).
    noise : dict, optional
        ``signal -> sigma`` [unit]; missing signals are estimated.
    """

    names: tuple[str, ...]
    start: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    scale: np.ndarray
    simulate: Callable[[dict], dict]
    measured: dict
    noise: dict | None = None


@dataclass
class NonlinearFit:
    """An output-error fit: estimates, covariance (with ``s^2``), the Jacobian of the whitened
    residuals in the parameters' units, ``chi2``, degrees of freedom, the noise used, the
    simulated signals at the estimate, evaluations, the optimiser's message, ``chi2`` as a
    function of the parameters, and each parameter's standard error from the optimiser's
    stopping alone (``floor_std``: no interval is narrower), and the signals whose noise was
    estimated that the re-simulation reproduces to their last bits (``exact``:
    :func:`holds_exactly`; their noise is their resolution)."""

    estimate: np.ndarray
    covariance: np.ndarray
    jacobian: np.ndarray
    chi2: float
    dof: int
    s2: float
    noise: dict
    simulated: dict
    nfev: int
    message: str
    chi2_of: Callable[[np.ndarray], float]
    floor_std: np.ndarray | None = None
    exact: tuple[str, ...] = ()


class _Residuals:
    """The whitened residual vector of a problem for parameters in scaled units, counting its
    evaluations; a refused trial gives large residuals (the optimiser steps back)."""

    def __init__(self, problem: OutputErrorProblem, noise: dict) -> None:
        self.problem, self.noise = problem, noise
        self.masks = {k: np.isfinite(v) for k, v in problem.measured.items()}
        self.size = sum(int(m.sum()) for m in self.masks.values())
        self.nfev = 0

    def block_sizes(self) -> list[int]:
        """The residual vector's length for each signal, in order."""
        return [int(m.sum()) for m in self.masks.values()]

    def signals(self, theta: np.ndarray) -> dict:
        self.nfev += 1
        return self.problem.simulate(dict(zip(self.problem.names, map(float, theta), strict=True)))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        from ..errors import DRSError

        try:
            sim = self.signals(x * self.problem.scale)
        except DRSError:
            return np.full(self.size, 1e6)
        out = []
        for name, measured in self.problem.measured.items():
            m = self.masks[name]
            r = (np.asarray(sim[name])[m] - measured[m]) / self.noise[name]
            out.append(np.where(np.isfinite(r), r, 1e6))
        return np.concatenate(out)


def _solve(problem, noise, x0, max_nfev):
    res_fn = _Residuals(problem, noise)
    lb, ub = problem.lower / problem.scale, problem.upper / problem.scale
    # strictly inside: the trust-region-reflective scaling holds a variable that starts on a
    # bound there (a leak started at 0 never moved)
    x0 = np.clip(x0, lb + START_MARGIN, ub - START_MARGIN)
    res = least_squares(
        res_fn,
        x0,
        bounds=(lb, ub),
        method="trf",
        diff_step=DIFF_STEP,
        x_scale=1.0,
        max_nfev=max_nfev,
        xtol=STOP_TOLERANCE,
    )
    return res, res_fn


def fit_output_error(problem: OutputErrorProblem, max_nfev: int | None = None) -> NonlinearFit:
    """Fit ``problem`` (module docstring).

    Raises
    ------
    InputError
        No parameter, or no measured sample.
    ConvergenceError
        The optimiser ended without a usable Jacobian (every trial refused).
    """
    p = len(problem.names)
    if p == 0:
        raise InputError("an output-error fit needs at least one parameter")
    scale = problem.scale
    max_nfev = max_nfev or 30 * (p + 1)
    given = dict(problem.noise or {})
    noise = {k: given.get(k, RESOLUTION.get(k, 1.0)) for k in problem.measured}
    res, fn = _solve(problem, noise, problem.start / scale, max_nfev)
    nfev = fn.nfev
    for _ in range(NOISE_PASSES):  # the noise from the residual, until it settles
        if given.keys() >= problem.measured.keys():
            break
        before = dict(noise)
        # at the estimate: the optimiser's last evaluation may be a Jacobian's trial step
        at_estimate = fn.signals(res.x * scale)
        for k, measured in problem.measured.items():
            if k not in given:
                noise[k] = signal_noise(np.asarray(at_estimate[k]), measured, p)
        res, fn = _solve(problem, noise, res.x, max_nfev)
        nfev += fn.nfev
        if all(0.5 < noise[k] / before[k] < 2.0 for k in noise):
            break
    fn.nfev = nfev
    if fn.size <= p:
        raise InputError(f"{fn.size} measured samples cannot determine {p} parameters")
    J = res.jac / scale[None, :]  # d r / d theta
    if not np.all(np.isfinite(J)):
        raise ConvergenceError(f"the output-error fit ended without a Jacobian: {res.message}")
    chi2 = float(2.0 * res.cost)
    dof = fn.size - p
    s2 = max(1.0, chi2 / dof)
    # inverted in the scaled units (the parameters may differ by 15 orders of magnitude)
    stop = stopping_error(res.jac, res.fun, res.x)
    information = np.linalg.pinv(res.jac.T @ res.jac)
    s2 = s2 * serial_inflation(res.jac, res.fun, fn.block_sizes(), information, s2)
    cov = checked_covariance(
        (s2 * information + np.diag(stop * stop)) * np.outer(scale, scale), "output-error"
    )
    estimate = res.x * scale
    simulated = fn.signals(estimate)
    exact = tuple(
        k
        for k, measured in problem.measured.items()
        if k not in given and _holds_exactly_where_finite(np.asarray(simulated[k]), measured)
    )

    def chi2_of(theta: np.ndarray) -> float:
        r = fn(np.asarray(theta) / scale)
        return float(r @ r)

    return NonlinearFit(
        estimate,
        cov,
        J,
        chi2,
        dof,
        s2,
        noise,
        simulated,
        fn.nfev,
        res.message,
        chi2_of,
        stop * scale,
        exact,
    )


def _holds_exactly_where_finite(simulated: np.ndarray, measured: np.ndarray) -> bool:
    finite = np.isfinite(simulated) & np.isfinite(measured)
    return holds_exactly(simulated[finite], measured[finite])


def serial_inflation(
    jacobian: np.ndarray, residuals: np.ndarray, blocks: list[int], information, s2: float
) -> float:
    """How much wider than independent errors the residuals' serial correlation makes the
    estimates, ``>= 1``: the largest ratio of a variance of the Newey-West sandwich (each
    signal's residuals a series of its own, Bartlett weights to :func:`.least_squares.hac_lag`
    lags) to the same variance from ``s^2 (J^T J)^{-1}``. Residuals that are not independent
    (a misfit, a re-simulation's rounding that runs through the samples, a sensor's drift)
    hold less information than their count says."""
    meat = np.zeros((jacobian.shape[1],) * 2)
    start = 0
    for size in blocks:
        scores = jacobian[start : start + size] * residuals[start : start + size, None]
        start += size
        meat += scores.T @ scores
        lags = hac_lag(size)
        for lag in range(1, min(lags, size - 1) + 1):
            gamma = scores[lag:].T @ scores[:-lag]
            meat += (1.0 - lag / (lags + 1.0)) * (gamma + gamma.T)
    n, p = jacobian.shape
    sandwich = information @ meat @ information * (n / max(n - p, 1))
    classic = s2 * np.diag(information)
    ratio = np.diag(sandwich)[classic > 0.0] / classic[classic > 0.0]
    return float(max(1.0, np.max(ratio))) if ratio.size else 1.0


def stopping_error(jacobian: np.ndarray, residuals: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Each scaled parameter's error from where the optimiser stopped: the Gauss-Newton step
    still to go from there (what the linearised problem says is left to the minimum; 0 at an
    exact one), with the re-simulation's own arithmetic (:data:`ARITHMETIC_ERROR` of each
    value) in quadrature."""
    remaining = np.linalg.lstsq(jacobian, residuals, rcond=None)[0]
    arithmetic = ARITHMETIC_ERROR * np.maximum(np.abs(x), 1.0)
    return np.hypot(remaining, arithmetic)


def recorded_resolution(values: np.ndarray) -> float:
    """The resolution of recorded float64 values [their unit]: the RMS of their spacing over
    sqrt 12 (a rounding's standard deviation)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(np.spacing(np.abs(v)) ** 2) / 12.0)) if v.size else 0.0


def signal_noise(simulated: np.ndarray, measured: np.ndarray, p: int) -> float:
    """A signal's noise [its unit] from a first fit: the residual RMS, corrected for the ``p``
    parameters fitted, never below the record's resolution (:func:`recorded_resolution`).

    A record the re-simulation reproduces to its last bits at most of its samples
    (:func:`holds_exactly`) is noise-free: its noise is its resolution. Its few other samples'
    residuals are the fit's own misfit, and over the exact ones their RMS would stand for a
    sensor's scatter that is not there (a force recorded exactly, whose rest sample alone
    depends on the parameters, got a noise of 1e-4 N and intervals 16x its estimates' scatter).
    A sensor's noise, or a quantised sensor's rounding, never lands on a float simulation's bits.
    """
    floor = recorded_resolution(measured)
    if _holds_exactly_where_finite(simulated, measured):
        return floor
    r = simulated - measured
    r = r[np.isfinite(r)]
    if r.size <= p:
        return max(floor, float(np.sqrt(np.mean(r * r))) if r.size else floor)
    return max(float(np.sqrt(np.sum(r * r) / (r.size - p))), floor)


#: Unit roundoffs within which a re-simulated sample equals its record (the record and the
#: re-simulation may take the same value by differently ordered operations).
EXACT_ULPS = 4.0


def holds_exactly(simulated: np.ndarray, measured: np.ndarray) -> bool:
    """Whether the re-simulation reproduces more than half of the record's samples to
    :data:`EXACT_ULPS` of their spacing: the record is the model's own arithmetic, not a
    sensor's reading."""
    if measured.size == 0:
        return False
    close = np.abs(simulated - measured) <= EXACT_ULPS * np.spacing(np.abs(measured))
    return bool(np.count_nonzero(close) * 2 > measured.size)


def profile_chi2(
    problem: OutputErrorProblem, fit: NonlinearFit, i: int, max_nfev: int | None = None
) -> Callable[[float], float]:
    """``v -> min chi2`` with parameter ``i`` held at ``v`` and the others re-fitted from the
    estimate (the profile likelihood's objective), at the noise of ``fit``."""
    others = [k for k in range(len(problem.names)) if k != i]

    def at(v: float) -> float:
        if not others:
            return fit.chi2_of(np.array([v]))
        theta = fit.estimate.copy()
        theta[i] = v

        def sub(theta_o):
            full = theta.copy()
            full[others] = theta_o
            return dict(zip(problem.names, map(float, full), strict=True))

        reduced = OutputErrorProblem(
            tuple(problem.names[k] for k in others),
            fit.estimate[others],
            problem.lower[others],
            problem.upper[others],
            problem.scale[others],
            lambda values: problem.simulate(
                sub(np.array([values[problem.names[k]] for k in others]))
            ),
            problem.measured,
            fit.noise,
        )
        res, fn = _solve(
            reduced,
            fit.noise,
            fit.estimate[others] / problem.scale[others],
            max_nfev or PROFILE_ITERATIONS,
        )
        return float(2.0 * res.cost)

    return at


__all__ = [
    "DIFF_STEP",
    "RESOLUTION",
    "NonlinearFit",
    "OutputErrorProblem",
    "fit_output_error",
    "profile_chi2",
    "recorded_resolution",
    "holds_exactly",
    "signal_noise",
]
