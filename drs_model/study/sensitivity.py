"""Sobol' indices of each result from the pick-freeze rows of a study
(:func:`scipy.stats.sobol_indices` on the evaluations, given as its ``f_A``, ``f_B``, ``f_AB``).

scipy rather than SALib: scipy's estimator (Saltelli 2010 first order, Jansen total order) takes
evaluations made elsewhere (here on Dask), its design is the one :mod:`.design` builds with the
same ``scipy.stats.qmc`` samplers, and drs already depends on scipy: no new package for one
function.

A group ``j`` (the rows ``A_j``, ``B_j`` and every ``AB_i,j``) in which a result is not finite (a
sample that does not assemble, a flap that does not open) is left out of that result's indices,
which then estimate the indices over the samples where the result exists.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.stats import sobol_indices

#: Fewer complete groups than this and a result gets no indices (the estimators need a sample).
MIN_GROUPS = 8


class Indices(NamedTuple):
    """First-order and total Sobol' indices of one result, one value per field, and the number of
    complete groups they were estimated from."""

    first_order: np.ndarray
    total_order: np.ndarray
    groups: int


def sobol(result: np.ndarray, blocks: np.ndarray, fields) -> Indices | None:
    """The indices of ``result`` (one value per row) over the pick-freeze ``blocks`` (``"A"``,
    ``"B"``, ``"AB:<field>"`` per row, each block ``n`` rows in the same order), or None with fewer
    than :data:`MIN_GROUPS` complete groups."""
    f_a = result[blocks == "A"]
    f_b = result[blocks == "B"]
    f_ab = np.stack([result[blocks == f"AB:{name}"] for name in fields])
    complete = np.isfinite(f_a) & np.isfinite(f_b) & np.all(np.isfinite(f_ab), axis=0)
    n = int(complete.sum())
    if n < MIN_GROUPS:
        return None
    res = sobol_indices(
        func={
            "f_A": f_a[complete][None, :],
            "f_B": f_b[complete][None, :],
            "f_AB": f_ab[:, complete][:, None, :],
        },
        n=n,
    )
    return Indices(np.atleast_1d(res.first_order), np.atleast_1d(res.total_order), n)
