r"""What a run can determine, before anything is fitted.

The sensitivity matrix ``J`` (``n x p``: each whitened residual's derivative in each parameter;
for a linear regression the weighted regressor itself) gives the Fisher information
``F = J^T J``. Parameters are measured in their typical size (``J`` times each ``scale``) and the
columns normalised, so that the measures compare directions, not units:

* ``rank``: the singular values of the normalised ``J`` above ``rtol`` times the largest;
* ``condition_number``: of ``F`` (the square of ``J``'s);
* a parameter with a zero column is in no equation of this run;
* where the rank falls short, QR with column pivoting (LAPACK ``geqp3``) keeps a largest set of
  independent columns; each one left out is not determined, and the parameters that share a null
  direction with it (a component above :data:`GROUP_COMPONENT` of the normalised null vector)
  are the ones it cannot be separated from;
* among the determined, pairs whose estimates correlate above :data:`PAIR_CORRELATION` trade
  off: the run determines mainly a combination of them.

A fit then refuses a value whose interval is wider than its size (:func:`too_wide`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ..errors import InputError

#: Singular values of the normalised sensitivity below this fraction of the largest: a null
#: direction (a condition number of the information above 1e14).
RANK_RTOL = 1e-7
#: Component of a normalised null vector above which a parameter belongs to its group.
GROUP_COMPONENT = 0.1
#: Correlation above which two determined parameters are reported as trading off.
PAIR_CORRELATION = 0.95


@dataclass(frozen=True)
class Identifiability:
    """What :func:`assess` found.

    Attributes
    ----------
    names : tuple of str
    rank : int
    condition_number : float
        Of the Fisher information of the normalised sensitivities (inf where singular).
    singular_values : ndarray
        Of the normalised sensitivities, largest first.
    determined : tuple of str
        The parameters the run can separate (a largest independent set).
    undetermined : dict
        name -> why not (no sensitivity, or the parameters it cannot be separated from).
    groups : tuple of tuple of str
        Each null direction's parameters.
    pairs : tuple of (str, str, float)
        Determined parameters whose estimates correlate above :data:`PAIR_CORRELATION`.
    """

    names: tuple[str, ...]
    rank: int
    condition_number: float
    singular_values: np.ndarray
    determined: tuple[str, ...]
    undetermined: dict[str, str] = field(default_factory=dict)
    groups: tuple[tuple[str, ...], ...] = ()
    pairs: tuple[tuple[str, str, float], ...] = ()

    def to_dict(self) -> dict:
        return {
            "rank": self.rank,
            "parameters": len(self.names),
            "condition_number": self.condition_number,
            "determined": list(self.determined),
            "undetermined": dict(self.undetermined),
            "groups": [list(g) for g in self.groups],
            "pairs": [{"a": a, "b": b, "correlation": c} for a, b, c in self.pairs],
        }


def _normalised(J: np.ndarray, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    Js = J * scales[None, :]
    norms = np.linalg.norm(Js, axis=0)
    safe = np.where(norms > 0.0, norms, 1.0)
    return Js / safe, norms


def _null_groups(Jn: np.ndarray, names: Sequence[str], rank: int) -> list[tuple[str, ...]]:
    _, _, vt = np.linalg.svd(Jn, full_matrices=True)
    groups = []
    for v in vt[rank:]:
        members = tuple(names[i] for i in np.flatnonzero(np.abs(v) > GROUP_COMPONENT))
        if len(members) > 1 and members not in groups:
            groups.append(members)
    return groups


def _pairs(Jn: np.ndarray, names: Sequence[str]) -> list[tuple[str, str, float]]:
    info = Jn.T @ Jn
    cov = np.linalg.pinv(info)
    d = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    corr = cov / np.outer(d, d)
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(corr[i, j]) > PAIR_CORRELATION:
                out.append((names[i], names[j], float(corr[i, j])))
    return out


def assess(J, names: Sequence[str], scales, rtol: float = RANK_RTOL) -> Identifiability:
    """Rank, condition number, null groups and trading pairs of the sensitivity ``J`` (``n x p``,
    whitened) for parameters ``names`` of typical sizes ``scales`` (module docstring)."""
    J = np.asarray(J, dtype=float)
    names = tuple(names)
    scales = np.asarray(scales, dtype=float)
    if J.ndim != 2 or J.shape[1] != len(names) or scales.shape != (len(names),):
        raise InputError(f"J must be (n, {len(names)}) with one scale per name, got {J.shape}")
    if not np.all(np.isfinite(J)):
        raise InputError("the sensitivity matrix holds non-finite values")
    Jn, norms = _normalised(J, scales)
    undetermined: dict[str, str] = {}
    live = [i for i in range(len(names)) if norms[i] > 0.0]
    for i in set(range(len(names))) - set(live):
        undetermined[names[i]] = "the recorded signals do not depend on it here (zero sensitivity)"
    sv = np.linalg.svd(Jn[:, live], compute_uv=False) if live else np.zeros(0)
    rank = int(np.sum(sv > rtol * sv[0])) if sv.size else 0
    cond = float((sv[0] / sv[-1]) ** 2) if sv.size and sv[-1] > 0.0 else float("inf")
    live_names = [names[i] for i in live]
    groups: list[tuple[str, ...]] = []
    keep = live
    if rank < len(live):
        _, _, piv = scipy.linalg.qr(Jn[:, live], mode="economic", pivoting=True)
        keep = sorted(live[k] for k in piv[:rank])
        groups = _null_groups(Jn[:, live], live_names, rank)
        for i in sorted(set(live) - set(keep)):
            partners = sorted({m for g in groups if names[i] in g for m in g} - {names[i]})
            with_whom = ", ".join(partners) if partners else "the other parameters"
            undetermined[names[i]] = f"this run cannot separate it from {with_whom}"
    determined = tuple(names[i] for i in keep)
    pairs = _pairs(Jn[:, keep], determined) if keep else []
    return Identifiability(
        names, rank, cond, sv, determined, undetermined, tuple(groups), tuple(pairs)
    )


def trades_with(name: str, ident: Identifiability) -> list[str]:
    """The determined parameters ``name`` trades off with (:attr:`Identifiability.pairs`)."""
    return [b if a == name else a for a, b, _ in ident.pairs if name in (a, b)]


def wide_reason(
    name: str,
    interval: tuple[float, float],
    unit: str,
    level: float,
    ident: Identifiability,
    motion: str,
) -> str:
    """Why an estimate whose interval is too wide (:func:`too_wide`) is not reported: the
    interval, what it trades off with, the motion that would determine it."""
    partners = trades_with(name, ident)
    trade = f"; it trades off with {', '.join(partners)}" if partners else ""
    return (
        f"its {100 * level:g} % interval [{interval[0]:.4g}, {interval[1]:.4g}] {unit} is "
        f"wider than its size (or a thousand times its typical size): the data do not "
        f"determine it{trade}; to determine it: {motion}"
    )


#: Typical sizes an interval's half-width may reach before it says nothing of the parameter,
#: however large the estimate (a column of near-zeros gave a breakaway friction of 9e20 N
#: +- 5e20 from a bag without slow motion, its truth 90 N).
WIDTH_IN_SCALES = 1e3


def too_wide(estimate: float, half_width: float, scale: float) -> bool:
    """Whether an interval of ``half_width`` says the data do not determine a parameter of
    ``estimate`` and typical size ``scale``: wider than ``max(|estimate|, scale)`` (the value
    is not even known to within itself), or than :data:`WIDTH_IN_SCALES` typical sizes."""
    return not half_width < min(max(abs(estimate), scale), WIDTH_IN_SCALES * scale)


__all__ = [
    "GROUP_COMPONENT",
    "PAIR_CORRELATION",
    "RANK_RTOL",
    "WIDTH_IN_SCALES",
    "Identifiability",
    "assess",
    "too_wide",
    "trades_with",
    "wide_reason",
]
