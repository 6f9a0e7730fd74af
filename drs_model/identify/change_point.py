r"""Where a parameter left its level over a season: a two-sided CUSUM of standardised residuals
(Page, "Continuous inspection schemes", Biometrika 41, 1954; Hawkins & Olwell, "Cumulative Sum
Charts and Charting for Quality Improvement", 1998, ch. 7 for the self-starting form).

Each run ``n`` (from :data:`MIN_RUNS` on) is compared with the level of the runs before the
current candidate onset ``c`` (the first run of the running sums' current excursion; ``c = n``
when both sums are at zero), so a drift never moves the level it is judged against, and with the
scale of the run-to-run differences of the runs before it:

.. math::

    \mu = \frac{\sum_{j<c} w_j y_j}{\sum_{j<c} w_j}, \qquad
    s^2 = \frac{1}{2}\,\mathrm{var}\!\left(\frac{y_j - y_{j-1}}
          {\sqrt{(\sigma_j^2 + \sigma_{j-1}^2)/2}}\right)_{0<j<n}

``w_j = 1/sigma_j^2`` from each run's own standard error ``sigma_j`` (its fit's), and ``s`` the
ratio of the runs' real scatter to it. A drift moves the differences it spans all the same way,
and their mean is taken out, so it hardly widens ``s`` (two drifted differences of two standard
deviations among 28 widen it by about 7 %), where it widens the scatter about a line or a mean by
its full size; the scale keeps growing with the runs (freezing it with the level would let a
reference that is tight by chance judge a whole excursion). The residual
``t = (y_n - mu) / (s sqrt(sigma_n^2 + 1/sum w))`` is about Student-t under no change (the
centred differences' variance has about ``2 (n-1)^2 / (3n - 4) - 1`` degrees of freedom, von
Neumann); it is mapped to its normal quantile ``z`` and summed,

.. math::

    S^+_n = \max(0, S^+_{n-1} + z_n - k), \qquad S^-_n = \max(0, S^-_{n-1} - z_n - k),

a drift is flagged at the first run where either sum exceeds ``h``, and its onset is the first
run of that sum's excursion. ``k = 1.5`` and ``h = 3.5`` were chosen over seeded seasons (the
tests measure both rates): a drift of two standard deviations a run is flagged within three runs
of its onset, and more than 99 % of 40-run seasons without a change raise no flag.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtri, stdtr

from ..errors import InputError

#: Runs in the first reference (the first run tested is the run after them).
MIN_RUNS = 8
#: Allowance ``k`` [standard deviations]: half the level shift the sums are tuned to.
ALLOWANCE = 1.5
#: Decision interval ``h`` [standard deviations].
DECISION = 3.5
#: Largest |z| summed: a run far off its level counts as this many standard deviations.
Z_CAP = 40.0


@dataclass(frozen=True)
class ChangePoint:
    """The CUSUM's verdict over one series (indices are 0-based among the runs given).

    Attributes
    ----------
    z : ndarray
        Each run's standardised residual (NaN before :data:`MIN_RUNS`).
    upper, lower : ndarray
        ``S+`` and ``S-`` after each run [standard deviations].
    onset : int or None
        The first run of the drift that was flagged.
    detected : int or None
        The run at which it was flagged.
    direction : int
        +1 rising, -1 falling, 0 no drift.
    scale : float
        The reference's scatter relative to the runs' standard errors ``s`` at the flag (or at
        the last run).
    """

    z: np.ndarray
    upper: np.ndarray
    lower: np.ndarray
    onset: int | None
    detected: int | None
    direction: int
    scale: float


def _reference(y, sy, c, n) -> tuple[float, float, float, int]:
    """``(mu, var(mu), s, dof)``: the level of the runs ``[0, c)``, the scale of ``[0, n)``."""
    w = 1.0 / sy[:c] ** 2
    mu = float(np.sum(w * y[:c]) / np.sum(w))
    d = np.diff(y[:n]) / np.sqrt(0.5 * (sy[1:n] ** 2 + sy[: n - 1] ** 2))
    s = math.sqrt(0.5 * float(np.var(d, ddof=1)))
    # the centred successive differences' variance has about 2 (n-1)^2 / (3n - 4) degrees of
    # freedom (von Neumann's ratio), less the one their mean took
    dof = max(1, round(2.0 * (n - 1) ** 2 / (3.0 * n - 4.0)) - 1)
    return mu, 1.0 / float(np.sum(w)), s, dof


def _z(t: float, dof: int) -> float:
    """The normal quantile of Student-t's ``t`` with ``dof`` degrees of freedom."""
    tail = float(stdtr(dof, -abs(t)))
    z = -float(ndtri(tail)) if tail > 0.0 else Z_CAP
    return math.copysign(min(z, Z_CAP), t)


def cusum(
    y, sy, allowance: float = ALLOWANCE, decision: float = DECISION, min_runs: int = MIN_RUNS
) -> ChangePoint:
    """The two-sided CUSUM (module docstring) of the runs' values ``y`` with standard errors
    ``sy`` (in the same unit, in run order).

    Raises
    ------
    InputError
        ``min_runs < 3``, a standard error that is not finite and > 0, or a bad ``k``/``h``.
    """
    y, sy = np.asarray(y, dtype=float), np.asarray(sy, dtype=float)
    if min_runs < 3:
        raise InputError(f"the CUSUM needs a reference of >= 3 runs, got min_runs={min_runs}")
    if not np.all(np.isfinite(sy) & (sy > 0.0)) or not np.all(np.isfinite(y)):
        raise InputError("the CUSUM needs finite values and standard errors > 0")
    if not (allowance >= 0.0 and decision > 0.0):
        raise InputError(f"allowance must be >= 0 and decision > 0, got {allowance}, {decision}")
    n_runs = y.size
    z, upper, lower = (np.full(n_runs, math.nan) for _ in range(3))
    up = down = 0.0
    start_up = start_down = None
    scale = math.nan
    for n in range(min_runs, n_runs):
        c = min(x for x in (start_up, start_down, n) if x is not None)
        mu, var_mu, scale, dof = _reference(y, sy, c, n)
        spread = scale * math.sqrt(sy[n] ** 2 + var_mu)
        off = y[n] - mu
        t = off / spread if spread > 0.0 else (0.0 if off == 0.0 else math.copysign(math.inf, off))
        z[n] = _z(t, dof) if math.isfinite(t) else math.copysign(Z_CAP, t)
        up, down = max(0.0, up + z[n] - allowance), max(0.0, down - z[n] - allowance)
        start_up = None if up == 0.0 else (n if start_up is None else start_up)
        start_down = None if down == 0.0 else (n if start_down is None else start_down)
        upper[n], lower[n] = up, down
        if up > decision or down > decision:
            rising = up - decision >= down - decision
            onset = start_up if rising else start_down
            return ChangePoint(z, upper, lower, onset, n, 1 if rising else -1, scale)
    return ChangePoint(z, upper, lower, None, None, 0, scale)


__all__ = ["ALLOWANCE", "DECISION", "MIN_RUNS", "ChangePoint", "cusum"]
