r"""Confidence intervals of fitted parameters: from the Jacobian, and from the profile likelihood
where the two disagree.

With ``chi2(theta)`` the sum of squared whitened residuals, ``s^2 = max(1, chi2_min / dof)`` (the
noise as assumed, or larger where the residuals say so) and ``q`` the two-sided Student-t
quantile of the level at ``dof``:

* **Jacobian (Wald)**: ``theta_i +- q sqrt(C_ii)``, ``C = s^2 (J^T J)^{-1}``: exact for a linear
  model, a linearisation otherwise;
* **profile likelihood**: ``{v : min_{theta_i = v} chi2 - chi2_min <= q^2 s^2}``, each other
  parameter re-fitted at every trial value (Venzon and Moolgavkar 1988; lmfit's
  ``conf_interval``).

**Physical bounds.** A parameter that is positive by nature (a mass, an inertia, a friction, a
leak, a bulk modulus: a lower bound >= 0) never gets an interval that crosses its bound: where
the Wald interval would, it is taken on a log scale (:func:`bounded_interval`,
``b + (theta - b) exp(-+ q std / (theta - b))`` for the bound ``b``, the delta method in
``log(theta - b)``: asymmetric, as the likelihood of a positive quantity is), and an estimate
at or below the bound has none.

Which one to trust is measured, not assumed (:func:`linearity_ratios`): along the line on which
the linearised profile runs, ``theta(d) = theta_hat + d C e_i / C_ii``, the linear model predicts
``chi2`` to rise by ``q^2 s^2`` at the Wald interval's ends; the actual rise, from two
evaluations of the model, is compared with it. Outside :data:`AGREEMENT` the profile interval is
computed.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import brentq
from scipy.stats import t as student_t

#: Range of actual over predicted chi2 rise within which the Jacobian interval stands.
AGREEMENT = (0.75, 1.33)
#: Expansions of a profile bracket (each 1.6x) before an interval end is called open.
MAX_EXPANSIONS = 8


def quantile(level: float, dof: int) -> float:
    """The two-sided Student-t quantile of ``level`` (e.g. 0.95) at ``dof`` degrees of freedom
    (the normal one for ``dof`` over 10^6)."""
    return float(student_t.ppf(0.5 + 0.5 * level, max(int(dof), 1)))


def wald_interval(estimate: float, std: float, q: float) -> tuple[float, float]:
    """``estimate -+ q std``."""
    return estimate - q * std, estimate + q * std


def bounded_interval(
    estimate: float, std: float, q: float, lower_bound: float
) -> tuple[tuple[float, float], str]:
    """The Wald interval, or where it would cross ``lower_bound`` of a positive parameter
    (``lower_bound >= 0``), the log-scale one (module docstring): ``((lo, hi), kind)`` with
    ``kind`` ``"jacobian"`` or ``"log"``; ``(nan, nan)`` for an estimate at or below the
    bound."""
    lo, hi = wald_interval(estimate, std, q)
    if not (math.isfinite(lower_bound) and lower_bound >= 0.0) or lo > lower_bound:
        return (lo, hi), "jacobian"
    if not estimate > lower_bound:
        return (math.nan, math.nan), "log"
    room = estimate - lower_bound  # the log of the distance to the bound
    spread = q * std / room
    return (lower_bound + room * math.exp(-spread), lower_bound + room * math.exp(spread)), "log"


def linearity_ratios(
    chi2: Callable[[np.ndarray], float],
    estimate: np.ndarray,
    covariance: np.ndarray,
    i: int,
    q: float,
    s2: float,
    chi2_min: float,
) -> tuple[float, float]:
    """Actual over predicted rise of ``chi2`` at the two ends of parameter ``i``'s Wald
    interval, along the linearised profile (module docstring). NaN where ``chi2`` failed."""
    ci = covariance[:, i] / covariance[i, i]
    half = q * math.sqrt(covariance[i, i])
    predicted = q * q * s2
    out = []
    for sign in (-1.0, 1.0):
        try:
            value = chi2(estimate + sign * half * ci)
        except Exception:  # noqa: BLE001 - a model that fails there: no agreement
            value = math.nan
        out.append((value - chi2_min) / predicted)
    return out[0], out[1]


def agrees(ratios: tuple[float, float]) -> bool:
    """Whether both ratios lie within :data:`AGREEMENT`."""
    return all(AGREEMENT[0] <= r <= AGREEMENT[1] for r in ratios)


def _end(
    excess: Callable[[float], float], start: float, step: float, bound: float, rtol: float
) -> float:
    """Where ``excess`` (negative at ``start``) crosses zero going by ``step``, found by
    bracket expansion then Brent; ``bound`` if it does not before it; NaN if never."""
    a, fa = start, excess(start)
    if not fa < 0.0:
        return math.nan
    b = start + step
    for _ in range(MAX_EXPANSIONS):
        if (step > 0 and b >= bound) or (step < 0 and b <= bound):
            b = bound
            fb = excess(b)
            return b if fb < 0.0 else brentq(excess, a, b, xtol=rtol * abs(step))
        fb = excess(b)
        if fb >= 0.0:
            return brentq(excess, a, b, xtol=rtol * abs(step))
        a, b, step = b, b + 1.6 * step, 1.6 * step
    return math.nan


def profile_interval(
    profile_chi2: Callable[[float], float],
    estimate: float,
    half_width: float,
    threshold: float,
    bounds: tuple[float, float],
    chi2_min: float,
    rtol: float = 0.02,
) -> tuple[float, float]:
    """The profile-likelihood interval of one parameter: where ``profile_chi2(v) - chi2_min``
    (the others re-fitted at ``v``) reaches ``threshold`` (``q^2 s^2``) on each side of
    ``estimate``, searched from the Wald ``half_width`` outwards; an end is the bound where the
    profile stays below the threshold up to it, NaN where it could not be found."""

    def excess(v: float) -> float:
        return profile_chi2(v) - chi2_min - threshold

    # the parameter's own scale: a leak of 2e-13 m^3/(s Pa) has an interval of ~1e-16, so no
    # step may be floored in absolute units
    step = half_width if half_width > 0.0 else 1e-6 * abs(estimate)
    if not step > 0.0:
        return math.nan, math.nan
    lo = _end(excess, estimate, -step, bounds[0], rtol)
    hi = _end(excess, estimate, step, bounds[1], rtol)
    return lo, hi


__all__ = [
    "AGREEMENT",
    "agrees",
    "bounded_interval",
    "linearity_ratios",
    "profile_interval",
    "quantile",
    "wald_interval",
]
