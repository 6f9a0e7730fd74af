r"""Rotating-frame kinematics of a point sliding along a rotating link (seed 000, Coriolis motion).

:mod:`~drs_model.coriolis.rotating_rod`: a collar on a rotating rod (examples 1 and 2);
:mod:`~drs_model.coriolis.slotted_link`: the slotted link (example 3). The equations and sign
conventions are in each module's docstring.
"""

from .rotating_rod import (
    MIN_RADIUS,
    SEED_COLLAR,
    AccelerationTerms,
    CollarExample,
    CollarKinematics,
    DegenerateGeometryError,
    FrameKinematics,
    LinkMotion,
    SlottedLinkMotion,
    VelocityTerms,
    collar_kinematics,
    polar_kinematics,
)
from .slotted_link import (
    SEED_SLOTTED_LINK,
    SLOTTED_LINK_METHODS,
    SlottedLinkExample,
    slotted_link_closed_form,
    slotted_link_closure,
    slotted_link_position,
    to_seed_convention,
)

__all__ = [
    "AccelerationTerms",
    "CollarExample",
    "CollarKinematics",
    "DegenerateGeometryError",
    "FrameKinematics",
    "LinkMotion",
    "MIN_RADIUS",
    "SEED_COLLAR",
    "SEED_SLOTTED_LINK",
    "SLOTTED_LINK_METHODS",
    "SlottedLinkExample",
    "SlottedLinkMotion",
    "VelocityTerms",
    "collar_kinematics",
    "polar_kinematics",
    "slotted_link_closed_form",
    "slotted_link_closure",
    "slotted_link_position",
    "to_seed_convention",
]
