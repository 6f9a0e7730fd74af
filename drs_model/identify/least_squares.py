r"""Weighted linear least squares with the covariance of its estimates.

For ``y = X theta + e`` with ``Var(e_i) = sigma^2 / w_i``:

.. math::

    \hat\theta = (X^T W X)^{-1} X^T W y, \qquad
    s^2 = \frac{\sum_i w_i r_i^2}{n - p}, \qquad
    \mathrm{Cov}(\hat\theta) = s^2 (X^T W X)^{-1}

(``covariance="classic"``: independent errors). When the errors are correlated from sample to
sample (an equation written on differences of a noisy signal, a regression residual that is a
smooth model error), ``covariance="hac"`` gives the Newey-West sandwich
``(X^T W X)^{-1} S (X^T W X)^{-1}`` with ``S`` the Bartlett-weighted autocovariances of the
scores ``x_i w_i r_i`` up to a lag ``L = ceil(4 (n / 100)^{2/9})`` (Newey and West 1994).

Columns are scaled to unit norm before solving (the parameters may differ by 15 orders of
magnitude: a leak and a mass); the results are in the original units.

**The arithmetic's own error.** A backward-stable solve in float64 gives the exact solution of a
problem perturbed by ``dA`` with ``||dA|| <= u ||A||`` (``u`` the unit roundoff; Higham,
"Accuracy and Stability of Numerical Algorithms", 2002, ch. 20), so each estimate carries an
error of about ``u ||A||_F ||theta|| sqrt((A^T A)^{-1}_ii)`` that no residual shows: on exact data
(a noise-free record) the residual scatter is rounding, and an interval from it alone would miss
the truth by a few of its widths on one machine and not on another. That error is added to the
covariance as ``(u ||A||_F ||theta||)^2 (A^T A)^{-1}`` (in the scaled units), so no interval has
zero width and an exact record's interval holds its truth on any machine.

A covariance whose diagonal is negative or not finite (a singular information matrix) is an
error (:class:`~drs_model.errors.ConvergenceError`), never clipped to zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError, InputError

COVARIANCES = ("classic", "hac")


@dataclass(frozen=True)
class LinearFit:
    """What :func:`weighted_least_squares` gives.

    Attributes
    ----------
    estimate : ndarray, shape (p,)
    covariance : ndarray, shape (p, p)
    residuals : ndarray, shape (n,)
        ``y - X estimate`` (unweighted).
    sigma2 : float
        ``s^2``, the weighted residual variance per degree of freedom.
    dof : int
        ``n - p``.
    """

    estimate: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    sigma2: float
    dof: int

    @property
    def std(self) -> np.ndarray:
        """Standard errors of the estimates."""
        return np.sqrt(np.diag(self.covariance))


#: Unit roundoff of float64.
UNIT_ROUNDOFF = float(np.finfo(float).eps) / 2.0
#: How many unit roundoffs each datum and the solve's backward error are counted as: Higham's
#: ``gamma_n = n u`` for the chain of ~32 operations that makes one entry of a regressor (the
#: fused inverse dynamics through its linear constants) before the solve sees it. Checked
#: against exact records in the tests: their errors are ~0.15 of the interval so counted.
ROUNDOFF_FACTOR = 32.0


def arithmetic_covariance(
    A: np.ndarray, estimate: np.ndarray, bread: np.ndarray, b_size: np.ndarray
) -> np.ndarray:
    """The covariance of the rounding error of a least-squares solve of ``A x = b`` (``A``
    whitened and column-scaled, ``estimate`` in the same units, ``bread = (A^T A)^{-1}``,
    ``b_size`` the per-row size of the terms ``b`` was summed from): the solve's
    ``(k u ||A||_F ||x||)^2 bread`` and the data's own rounding, ``k u (b_size_i + sum_j |A_ij
    x_j|)`` per row carried through ``bread A^T`` (module docstring)."""
    ku = ROUNDOFF_FACTOR * UNIT_ROUNDOFF
    size = ku * np.linalg.norm(A) * np.linalg.norm(estimate)
    rows = ku * (np.abs(b_size) + np.abs(A) @ np.abs(estimate))
    G = bread @ (A.T * rows)
    return size * size * bread + G @ G.T


def checked_covariance(cov: np.ndarray, what: str) -> np.ndarray:
    """``cov`` if its diagonal is finite and positive; else :class:`ConvergenceError` naming
    the parameters (by column) whose variance is not."""
    d = np.diag(cov)
    bad = [i for i, v in enumerate(d) if not (np.isfinite(v) and v > 0.0)]
    if bad:
        raise ConvergenceError(
            f"the {what} covariance has variances {[float(d[i]) for i in bad]} (columns {bad}): "
            "the information matrix is singular or the fit failed; a variance must be > 0"
        )
    return cov


def _check(X: np.ndarray, y: np.ndarray, w: np.ndarray) -> None:
    if X.ndim != 2 or y.shape != (X.shape[0],) or w.shape != y.shape:
        raise InputError(
            f"X must be (n, p) with y and weights (n,), got {X.shape}, {y.shape}, {w.shape}"
        )
    if X.shape[0] <= X.shape[1]:
        raise InputError(f"{X.shape[0]} samples cannot determine {X.shape[1]} parameters")
    for name, a in (("X", X), ("y", y), ("weights", w)):
        if not np.all(np.isfinite(a)):
            raise InputError(f"{name} must be finite (drop the samples without data first)")
    if np.any(w < 0.0):
        raise InputError("weights must be >= 0")


def hac_lag(n: int) -> int:
    """The Newey-West lag for ``n`` samples."""
    return max(1, math.ceil(4.0 * (n / 100.0) ** (2.0 / 9.0)))


def weighted_least_squares(
    X, y, weights=None, covariance: str = "classic", y_size=None
) -> LinearFit:
    """Solve ``min sum w_i (y_i - X_i theta)^2`` and give the estimates' covariance (module
    docstring).

    Parameters
    ----------
    X : array_like, shape (n, p)
    y : array_like, shape (n,)
    weights : array_like, shape (n,), optional
        ``w_i`` (default 1): inverse relative variances of the errors.
    covariance : str
        ``"classic"`` or ``"hac"``.
    y_size : array_like, shape (n,), optional
        Per sample, the size of the terms ``y`` was computed from (default ``|y|``): what its
        rounding is a fraction of (a force less a model's part of it rounds like the force).
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    w = np.ones_like(y) if weights is None else np.asarray(weights, dtype=float)
    _check(X, y, w)
    if covariance not in COVARIANCES:
        raise InputError(f"covariance must be one of {COVARIANCES}, got {covariance!r}")
    n, p = X.shape
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0.0] = 1.0
    sw = np.sqrt(w)
    A = X / norms * sw[:, None]
    scaled, *_ = np.linalg.lstsq(A, y * sw, rcond=None)
    estimate = scaled / norms
    residuals = y - X @ estimate
    dof = n - p
    sigma2 = float(np.sum(w * residuals**2) / dof)
    bread = np.linalg.pinv(A.T @ A)
    if covariance == "classic":
        cov_scaled = sigma2 * bread
    else:
        scores = A * (sw * residuals)[:, None]
        meat = scores.T @ scores
        for lag in range(1, hac_lag(n) + 1):
            gamma = scores[lag:].T @ scores[:-lag]
            meat += (1.0 - lag / (hac_lag(n) + 1.0)) * (gamma + gamma.T)
        cov_scaled = bread @ meat @ bread * (n / dof)
    y_size = np.abs(y) if y_size is None else np.asarray(y_size, dtype=float)
    cov_scaled = cov_scaled + arithmetic_covariance(A, scaled, bread, y_size * sw)
    cov = checked_covariance(cov_scaled / np.outer(norms, norms), "least-squares")
    return LinearFit(estimate, cov, residuals, sigma2, dof)


def errors_in_variables(X, y, w, dX, dy, sigma2: float, y_size=None) -> LinearFit:
    r"""Weighted least squares corrected for noise in one measured variable ``m = s + n`` that
    both ``X`` and ``y`` are evaluated at (``Var n = sigma2``), to first order in ``n``:
    ``X(m) = X(s) + dX n``, ``y(m) = y(s) + dy n``. The normal equations' expectations gain
    ``sigma2 sum w dX^T dX`` and ``sigma2 sum w dX^T dy``, which are taken off (corrected least
    squares, Fuller, "Measurement Error Models", 1987, ch. 2):

    .. math::  (X^T W X - \sigma^2 \textstyle\sum_i w_i dX_i^T dX_i)\,\theta
               = X^T W y - \sigma^2 \textstyle\sum_i w_i dX_i^T dy_i

    Without it the estimate is biased towards the noise's own direction, by an amount the
    information's smallest eigenvalues magnify (an ill-conditioned fit's bias outgrows its
    interval). The covariance is ``s^2`` times the corrected matrix's inverse, with the
    arithmetic's own error (``y_size`` as in :func:`weighted_least_squares`).
    """
    X, y, w = (np.asarray(a, dtype=float) for a in (X, y, w))
    dX, dy = np.asarray(dX, dtype=float), np.asarray(dy, dtype=float)
    _check(X, y, w)
    n, p = X.shape
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0.0] = 1.0
    Xn, dXn = X / norms, dX / norms
    sw = np.sqrt(w)
    # the uncorrected solution by QR (the normal equations square the condition number), then
    # the correction's step from it: (A - C)(theta + d) = b - e with A theta = b
    plain, *_ = np.linalg.lstsq(Xn * sw[:, None], y * sw, rcond=None)
    A = Xn.T @ (Xn * w[:, None])
    C = sigma2 * dXn.T @ (dXn * w[:, None])
    e = sigma2 * dXn.T @ (w * dy)
    A = A - C
    scaled = plain + np.linalg.solve(A, C @ plain - e)
    estimate = scaled / norms
    residuals = y - X @ estimate
    dof = n - p
    s2 = float(np.sum(w * residuals**2) / dof)
    bread = np.linalg.pinv(A)
    y_size = np.abs(y) if y_size is None else np.asarray(y_size, dtype=float)
    cov_scaled = s2 * bread + arithmetic_covariance(Xn * sw[:, None], scaled, bread, y_size * sw)
    cov = checked_covariance(cov_scaled / np.outer(norms, norms), "errors-in-variables")
    return LinearFit(estimate, cov, residuals, s2, dof)


__all__ = [
    "COVARIANCES",
    "ROUNDOFF_FACTOR",
    "UNIT_ROUNDOFF",
    "LinearFit",
    "arithmetic_covariance",
    "checked_covariance",
    "errors_in_variables",
    "hac_lag",
    "weighted_least_squares",
]
