"""The Fisher information a motion gives the equation-error fits (:mod:`.regressor`,
:mod:`.friction`), the standard errors it predicts, and the motions it is compared on: the seed's
manoeuvre as a rung runs it. :mod:`.excitation` designs a motion against these."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..fidelity.hydraulic_params import HydraulicParams
from ..fidelity.hydraulic_vector import hydraulic_constants
from ..params import DRSParams
from .friction import FRICTION_PARAMETERS, friction_columns
from .output_error import RESOLUTION
from .parameters import RIGID_PARAMETERS, fit_parameter
from .regressor import rigid_regressor, rigid_weights


def information(
    names: Sequence[str],
    s,
    sd,
    sdd,
    p: DRSParams,
    hp: HydraulicParams,
    rung: str = "rigid",
    stroke_noise: float = 1e-5,
) -> np.ndarray:
    """The Fisher information of the equation-error regressions for ``names`` at the samples
    ``(s, sd, sdd)``, the parameters in their typical sizes (block-diagonal: rigid, friction)."""
    scales = np.array([fit_parameter(n, p, hp).scale for n in names])
    info = np.zeros((len(names), len(names)))
    rigid = [i for i, n in enumerate(names) if n in RIGID_PARAMETERS]
    if rigid:
        if rung == "quasi-static":
            sd, sdd = np.zeros_like(sd), np.zeros_like(sdd)
        Y = rigid_regressor(s, sd, sdd, p, [names[i] for i in rigid]) * scales[rigid]
        w = rigid_weights(s, sd, sdd, p) / stroke_noise**2
        info[np.ix_(rigid, rigid)] = Y.T @ (Y * w[:, None])
    rod = [i for i, n in enumerate(names) if n in FRICTION_PARAMETERS]
    if rod:
        cols = friction_columns(sd, hydraulic_constants(hp, p), hp.stribeck_velocity)
        X = np.column_stack([cols[names[i]] for i in rod]) * scales[rod]
        sigma = RESOLUTION["pressure_a"] * math.hypot(hp.piston_area, hp.rod_side_area)
        info[np.ix_(rod, rod)] = X.T @ X / sigma**2
    return info


def log_det(info: np.ndarray) -> float:
    """``log det`` of an information matrix (``-inf`` where singular)."""
    sign, value = np.linalg.slogdet(info)
    return float(value) if sign > 0 else -math.inf


def standard_errors(info: np.ndarray, names, p, hp) -> np.ndarray:
    """Standard errors [units] an information matrix predicts (inf where singular)."""
    scales = np.array([fit_parameter(n, p, hp).scale for n in names])
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        return np.full(len(names), math.inf)
    return np.sqrt(np.maximum(np.diag(cov), 0.0)) * scales


def rung_motion(
    p: DRSParams,
    hp: HydraulicParams,
    rung: str,
    duration: float,
    sample_period: float = 1e-3,
    trajectory=None,
) -> tuple[np.ndarray, ...]:
    """``(s, s', s'')`` [m, m/s, m/s^2] every ``sample_period`` over ``duration`` [s] of the
    rung running the seed's manoeuvre as the node's service commands it (open, hold, close),
    or ``trajectory = (times, strokes, rates)`` commanded at the start."""
    from ..fidelity import make_rung

    options = {"hydraulic": hp} if rung == "hydraulic" else {}
    sim = make_rung(rung, p, sample_period, **options)
    close = int(round((p.T_opening + p.T_still) / sample_period))
    if trajectory is not None:
        sim.command_trajectory(*trajectory)
    rows = []
    for k in range(int(round(duration / sample_period)) + 1):
        if trajectory is None and k in (0, close):
            sim.command_drs(k == 0)
        st = sim.state
        rows.append((st.q[0], st.qd[0], st.qdd[0]))
        sim.step()
    out = np.array(rows)
    return out[:, 0], out[:, 1], out[:, 2]


def seed_manoeuvre_information(
    names: Sequence[str],
    p: DRSParams,
    hp: HydraulicParams,
    rung: str,
    duration: float,
    sample_period: float = 1e-3,
    stroke_noise: float = 1e-5,
) -> np.ndarray:
    """The information of the seed's manoeuvre as the rung runs it, sampled over
    ``duration``, for comparison with a design of the same length."""
    motion = rung_motion(p, hp, rung, duration, sample_period)
    return information(names, *motion, p, hp, rung, stroke_noise)


__all__ = [
    "information",
    "log_det",
    "rung_motion",
    "seed_manoeuvre_information",
    "standard_errors",
]
