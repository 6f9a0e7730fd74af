"""``fidelity: auto``: the cheapest rung whose measured error meets the tolerances for what is
asked of it (the gap and positions, the piston force, the hydraulic quantities).

The errors and costs are the ladder's, measured by ``drs fidelity`` on the standard scene a
stroke-commanded node runs, ``open-hold-close-100ms`` (the seed's manoeuvre with 100 ms moves,
what the valve can follow; benchmarks/results/fidelity.json, docs/fidelity.md "The chart"): the
largest error against the tight hydraulic reference over the scene, and the cost per simulated
second at 1 kHz. The seed's 10 ms moves are faster than the valve can follow: there every rung
but ``hydraulic`` is 33 mm off in gap, so a node whose commands are that fast needs
``hydraulic`` whatever it is asked (set it by hand).
"""

from __future__ import annotations

import math
from types import MappingProxyType

from ..errors import InputError

#: What can be asked of the node: ``gap`` (positions, rates, the gap), ``force`` (the piston
#: force, its acceleration, the joint reactions), ``hydraulics`` (pressures and spool).
ASKED = ("gap", "force", "hydraulics")

#: rung -> (gap error [m], force error [N] or None if not modelled, cost per simulated s [s])
#: on ``open-hold-close-100ms`` (benchmarks/results/fidelity.json, committed with the chart).
LADDER_ERRORS = MappingProxyType(
    {
        "kinematic": (2.45e-4, None, 2.8e-3),
        "quasi-static": (2.45e-4, 1.32e3, 3.6e-3),
        "rigid": (2.45e-4, 1.41e3, 3.4e-3),
        "hydraulic": (6.1e-7, 9.1, 7.7e-2),
    }
)


def choose_rung(asked, gap_tolerance: float, force_tolerance: float) -> str:
    """The cheapest rung (by measured cost) that models everything ``asked`` (a set of
    :data:`ASKED`) within ``gap_tolerance`` [m] and ``force_tolerance`` [N]; ``hydraulic``,
    the reference, when none cheaper does. Nothing asked: the cheapest rung."""
    unknown = set(asked) - set(ASKED)
    if unknown:
        raise InputError(f"asked must be among {list(ASKED)}, got {sorted(unknown)}")
    for name, tol in (("gap_tolerance", gap_tolerance), ("force_tolerance", force_tolerance)):
        if not (isinstance(tol, (int, float)) and math.isfinite(tol) and tol > 0.0):
            raise InputError(f"{name} must be a finite number > 0, got {tol!r}")
    by_cost = sorted(LADDER_ERRORS, key=lambda rung: LADDER_ERRORS[rung][2])
    for rung in by_cost:
        gap, force, _ = LADDER_ERRORS[rung]
        if "hydraulics" in asked and rung != "hydraulic":
            continue
        if "gap" in asked and gap > gap_tolerance:
            continue
        if "force" in asked and (force is None or force > force_tolerance):
            continue
        return rung
    return "hydraulic"


__all__ = ["ASKED", "LADDER_ERRORS", "choose_rung"]
