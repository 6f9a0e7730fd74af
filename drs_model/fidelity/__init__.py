"""The fidelity ladder: the DRS actuator at four levels of modelling behind one interface
(:class:`~drs_model.commanded.CommandedActuator`'s), each no more than a scene needs
(docs/fidelity.md).

``kinematic``
    the commanded moves' positions, rates and gap; no forces.
``quasi-static``
    plus the piston force of the statics (gravity, air load), no inertia.
``rigid``
    :class:`~drs_model.actuator.ActuatorSim`: inverse dynamics along moves, forward dynamics
    under a force.
``hydraulic``
    the rigid mechanism driven by a double-acting cylinder, a servo valve and a position servo
    loop (:class:`HydraulicParams`).
"""

from __future__ import annotations

from types import MappingProxyType

from ..errors import InputError
from .base import RungState
from .hydraulic import HydraulicRung
from .hydraulic_kernels import equilibrium_state
from .hydraulic_params import HydraulicParams
from .hydraulic_vector import hydraulic_constants
from .kinematic import KinematicRung
from .quasi_static import QuasiStaticRung
from .rigid import RigidRung

#: The rungs, cheapest first.
RUNGS = MappingProxyType(
    {
        "kinematic": KinematicRung,
        "quasi-static": QuasiStaticRung,
        "rigid": RigidRung,
        "hydraulic": HydraulicRung,
    }
)


def make_rung(name: str, p, dt: float = 1e-3, **options):
    """The rung ``name`` (a key of :data:`RUNGS`) for parameters ``p`` and physics step ``dt``
    [s]; ``options`` go to its constructor (``hydraulic=``, ``method=``, ``substep=`` for the
    hydraulic rung)."""
    try:
        cls = RUNGS[name]
    except KeyError:
        raise InputError(f"fidelity must be one of {list(RUNGS)}, got {name!r}") from None
    return cls(p, dt, **options)


__all__ = [
    "RUNGS",
    "HydraulicParams",
    "HydraulicRung",
    "KinematicRung",
    "QuasiStaticRung",
    "RigidRung",
    "RungState",
    "equilibrium_state",
    "hydraulic_constants",
    "make_rung",
]
