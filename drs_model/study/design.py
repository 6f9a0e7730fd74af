"""The samples of a study: quasi-random points of the unit hypercube (scipy.stats.qmc), mapped
through each field's distribution, in the pick-freeze design of Sobol' indices when asked.

Pick-freeze (Saltelli 2010, the design of :func:`scipy.stats.sobol_indices`): two independent
samples ``A`` and ``B`` of ``n`` points (the two halves of one ``2 d``-dimensional sample), and
for each field ``i`` the matrix ``AB_i``, ``A`` with column ``i`` taken from ``B``. Every row is a
draw of the joint distribution (the fields are independent), so histograms use them all; the
Sobol' estimators use the blocks. Without sensitivity the study is ``A`` alone.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.stats import qmc

from .spec import StudySpec


class Design(NamedTuple):
    """The study's rows: ``values`` (runs, d) of the fields, ``block`` (runs,) the block of each
    row (``"A"``, ``"B"``, or ``"AB:<field>"``), ``unit`` (runs, d) the hypercube points."""

    values: np.ndarray
    block: np.ndarray
    unit: np.ndarray


def unit_sample(method: str, n: int, d: int, seed: int) -> np.ndarray:
    """``n`` points of ``[0, 1)^d``: a Latin hypercube (``"lhs"``) or a scrambled Sobol'
    sequence (``"sobol"``; a power of two keeps its balance), from ``seed``."""
    rng = np.random.default_rng(seed)
    if method == "lhs":
        engine = qmc.LatinHypercube(d=d, rng=rng)
    else:
        engine = qmc.Sobol(d=d, scramble=True, rng=rng)
    return engine.random(n)


def design(spec: StudySpec) -> Design:
    """The rows of ``spec``: ``A`` (and ``B``, ``AB_i`` with sensitivity), values in SI units."""
    d, n = len(spec.fields), spec.samples
    if spec.sensitivity:
        both = unit_sample(spec.sampler, n, 2 * d, spec.seed)
        a, b = both[:, :d], both[:, d:]
        blocks = [a, b]
        labels = ["A", "B"]
        for i, name in enumerate(spec.fields):
            ab = a.copy()
            ab[:, i] = b[:, i]
            blocks.append(ab)
            labels.append(f"AB:{name}")
        unit = np.concatenate(blocks)
        block = np.repeat(np.array(labels, dtype=object), n)
    else:
        unit = unit_sample(spec.sampler, n, d, spec.seed)
        block = np.full(n, "A", dtype=object)
    values = np.column_stack([dist.ppf(unit[:, i]) for i, dist in enumerate(spec.distributions)])
    return Design(values, block, unit)
