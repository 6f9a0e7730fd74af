"""``fidelity: auto``: the lowest rung of the ladder whose error meets the tolerances for what is
asked of it (the gap and positions, the piston force, the hydraulic quantities).

The errors are measured, not written down: :func:`ladder_errors` runs the ladder's reduced
measurement (:func:`drs_model.fidelity.ladder.measure`, what ``drs fidelity --scene
open-hold-close-100ms`` prints) for the parameters it is given, on the scene a stroke-commanded
node runs, ``open-hold-close-100ms`` (the seed's manoeuvre with 100 ms moves, what the valve can
follow): the largest gap and piston-force errors of each rung against the tight hydraulic
reference, at the ladder's 1 kHz step. The node measures once at start, for its own model
parameters (a heavier flap makes the statics' force error larger); a process keeps the result per
parameters. A change of the model changes the table with it: nothing is left to go stale.

The rule takes the rungs in the ladder's order, kinematic < quasi-static < rigid < hydraulic
(:data:`drs_model.fidelity.RUNGS`, each modelling what the one below does and more, at a higher
cost by construction), and chooses the first that models everything asked within the tolerances;
``hydraulic``, the reference, when none does. Ties go to the lower rung; a timing never decides
(quasi-static and rigid cost about the same: which is cheaper changes from run to run).

The seed's 10 ms moves are faster than the valve can follow: there every rung but ``hydraulic``
is 33 mm off in gap, so a node whose commands are that fast needs ``hydraulic`` whatever it is
asked (set it by hand).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from ..errors import InputError
from ..params import DRSParams
from . import RUNGS

#: What can be asked of the node: ``gap`` (positions, rates, the gap), ``force`` (the piston
#: force, its acceleration, the joint reactions), ``hydraulics`` (pressures and spool).
ASKED = ("gap", "force", "hydraulics")
#: The scene the errors are measured on (drs_model.fidelity.scenes).
AUTO_SCENE = "open-hold-close-100ms"
#: The physics step [s] of the measurement (the ladder's chart, ``drs fidelity``'s default).
AUTO_DT = 1e-3


@dataclass(frozen=True)
class RungErrors:
    """A rung's largest errors against the hydraulic reference on :data:`AUTO_SCENE`: ``gap``
    [m] and ``force`` [N] (None: the rung models no force)."""

    gap: float
    force: float | None


def errors_from_rows(rows) -> Mapping[str, RungErrors]:
    """rung -> :class:`RungErrors` from the rows of :func:`drs_model.fidelity.ladder.measure` on
    :data:`AUTO_SCENE` (the stepped run of each rung; NaN force: none)."""
    out = {}
    for row in rows:
        if row.scene == AUTO_SCENE and row.label == row.rung and row.errors is not None:
            force = row.errors["force"]
            out[row.rung] = RungErrors(
                float(row.errors["gap"]), None if math.isnan(force) else float(force)
            )
    missing = [rung for rung in RUNGS if rung != "hydraulic" and rung not in out]
    if missing:
        raise InputError(f"the ladder's rows hold no errors of {missing} on {AUTO_SCENE}")
    return MappingProxyType(out)


@functools.lru_cache(maxsize=8)
def _measured(p: DRSParams, hydraulic) -> Mapping[str, RungErrors]:
    from .ladder import measure
    from .scenes import SCENES

    return errors_from_rows(measure(p, AUTO_DT, scenes=(SCENES[AUTO_SCENE],), hydraulic=hydraulic))


def ladder_errors(p: DRSParams | None = None, hydraulic=None) -> Mapping[str, RungErrors]:
    """Each rung's errors on :data:`AUTO_SCENE` for parameters ``p`` (default: the seed's) and
    ``hydraulic`` (the reference's HydraulicParams, default: their defaults), measured now: a
    few seconds of simulation, once per parameters in a process."""
    from .hydraulic_params import HydraulicParams

    return _measured(
        DRSParams() if p is None else p, HydraulicParams() if hydraulic is None else hydraulic
    )


def choose_rung(
    asked, gap_tolerance: float, force_tolerance: float, errors: Mapping[str, RungErrors]
) -> str:
    """The first rung in the ladder's order that models everything ``asked`` (a set of
    :data:`ASKED`) within ``gap_tolerance`` [m] and ``force_tolerance`` [N], by ``errors``
    (:func:`ladder_errors`); ``hydraulic``, the reference, when none lower does. Nothing asked:
    the lowest rung."""
    unknown = set(asked) - set(ASKED)
    if unknown:
        raise InputError(f"asked must be among {list(ASKED)}, got {sorted(unknown)}")
    for name, tol in (("gap_tolerance", gap_tolerance), ("force_tolerance", force_tolerance)):
        if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0.0):
            raise InputError(f"{name} must be a finite number > 0, got {tol!r}")
    if "hydraulics" in asked:  # pressures and spool: only the cylinder has them
        return "hydraulic"
    for rung in RUNGS:
        if rung == "hydraulic":  # the reference: what is left
            break
        e = errors[rung]
        if "gap" in asked and not e.gap <= gap_tolerance:
            continue
        if "force" in asked and (e.force is None or not e.force <= force_tolerance):
            continue
        return rung
    return "hydraulic"


__all__ = [
    "ASKED",
    "AUTO_DT",
    "AUTO_SCENE",
    "RungErrors",
    "choose_rung",
    "errors_from_rows",
    "ladder_errors",
]
