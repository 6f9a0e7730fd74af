"""The mechanism as drawings: polylines in the seed's ground frame [m], for rerun and RViz.

Geometry comes from :mod:`drs_model.kinematics`; this module only arranges points (no physics).
Ground frame (seed 003): x rearwards along the main-wing chord, y up, origin at the lower front
corner of the FIA box.
"""

from __future__ import annotations

import numpy as np

from drs_model import kinematics
from drs_model.params import DRSParams

#: The pins drawn as points.
PIN_NAMES = ("A", "B", "C", "D", "R", "T")


def closed(points: np.ndarray) -> np.ndarray:
    """A polygon as a polyline whose last point repeats the first."""
    return np.concatenate([points, points[..., :1, :]], axis=-2)


def still_drawings(p: DRSParams) -> dict[str, np.ndarray]:
    """The FIA box, the main wing and the pylon: closed outlines (k, 2) [m]."""
    box = np.array(
        [[0.0, 0.0], [p.box_width, 0.0], [p.box_width, p.box_height], [0.0, p.box_height]]
    )
    return {
        "fia_box": closed(box),
        "main_wing": closed(kinematics.main_wing_outline(p)),
        "pylon": closed(np.asarray(p.pylon_outline)),
    }


#: The points :func:`moving_drawings` asks of the kinematics: the pins, then P.
_DRAWN = (*PIN_NAMES, "P")
_A, _B, _C, _R, _T = (_DRAWN.index(name) for name in ("A", "B", "C", "R", "T"))


def moving_drawings(
    q: np.ndarray, p: DRSParams
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Drawings of configurations ``q`` (n, 3): piston A-B, link B-C, the closed flap outline,
    the gap (from R up to the height of the flap tip T), as (n, k, 2) arrays [m]; the pins
    (n, len(PIN_NAMES), 2); and P, where the piston force acts (n, 2).

    The points are placed by one call of the kinematics and gathered into one array, which the
    drawings index (one configuration, the node's marker tick, is a few numpy calls)."""
    pts = kinematics.point_positions(q, p, _DRAWN)
    at = np.empty(np.shape(q)[:-1] + (len(_DRAWN), 2))
    for k, name in enumerate(_DRAWN):
        at[..., k, :] = pts[name]
    gap = at[..., [_R, _R], :]
    gap[..., 1, 1] = at[..., _T, 1]  # straight up from R to the tip's height
    lines = {
        "piston": at[..., [_A, _B], :],
        "link": at[..., [_B, _C], :],
        "flap": closed(kinematics.flap_outline(q, p)),
        "gap": gap,
    }
    return lines, at[..., : len(PIN_NAMES), :], at[..., -1, :]


__all__ = ["PIN_NAMES", "closed", "moving_drawings", "still_drawings"]
