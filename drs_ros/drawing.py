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
    box = np.array([[0.0, 0.0], [p.box_width, 0.0], [p.box_width, p.box_height],
                    [0.0, p.box_height]])  # fmt: skip
    return {
        "fia_box": closed(box),
        "main_wing": closed(kinematics.main_wing_outline(p)),
        "pylon": closed(np.asarray(p.pylon_outline)),
    }


def moving_drawings(
    q: np.ndarray, p: DRSParams
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Drawings of configurations ``q`` (n, 3): piston A-B, link B-C, the closed flap outline,
    the gap (from R up to the height of the flap tip T), as (n, k, 2) arrays [m]; the pins
    (n, len(PIN_NAMES), 2); and P, where the piston force acts (n, 2)."""
    pts = kinematics.point_positions(q, p, (*PIN_NAMES, "P"))
    gap_top = np.stack([pts["R"][:, 0], pts["T"][:, 1]], axis=-1)
    lines = {
        "piston": np.stack([pts["A"], pts["B"]], axis=1),
        "link": np.stack([pts["B"], pts["C"]], axis=1),
        "flap": closed(kinematics.flap_outline(q, p)),
        "gap": np.stack([pts["R"], gap_top], axis=1),
    }
    return lines, np.stack([pts[name] for name in PIN_NAMES], axis=1), pts["P"]


__all__ = ["PIN_NAMES", "closed", "moving_drawings", "still_drawings"]
