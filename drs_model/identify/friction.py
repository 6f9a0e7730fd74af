r"""The rod's force balance as a regression for the piston friction (equation error of the
hydraulic rung).

The chambers push with ``p_A A_A - p_B A_B``; what reaches the mechanism is that less the
friction (:func:`drs_model.fidelity.hydraulic_kernels.friction_force`):

.. math::

    p_A A_A - p_B A_B - F = c_v \dot s + \left(F_c + (F_b - F_c) e^{-(\dot s / v_s)^2}\right)
        \tanh(\dot s / v_{sm})

with ``F`` the measured piston force (the rod's ``effort``), or, for a run that recorded none,
the rigid mechanism's inverse dynamics at the measured motion (samples on a stop left out: the
stop's force is in no signal). The friction kernel is linear in ``c_v``, ``F_c``, ``F_b`` for a
given Stribeck velocity ``v_s``: its columns are the kernel itself with one of them 1 and the
others 0 (no second copy of the law). ``v_s`` enters nonlinearly: it is found by variable
projection (the linear ones solved for each trial ``v_s``, ``v_s`` by a bounded scalar search on
its logarithm), and its interval from the full Jacobian at the optimum.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from ..errors import InputError
from ..fidelity import hydraulic_kernels as hk
from ..fidelity.hydraulic import hydraulic_constants
from ..fidelity.hydraulic_params import HydraulicParams
from ..params import DRSParams
from .record import STOP_BAND, Record
from .regressor import rigid_regressor, rigid_values

#: The HydraulicParams fields of the friction law a rod balance determines.
FRICTION_PARAMETERS = (
    "viscous_friction",
    "coulomb_friction",
    "breakaway_friction",
    "stribeck_velocity",
)
_LINEAR = {
    "viscous_friction": hk.C_VISCOUS,
    "coulomb_friction": hk.F_COULOMB,
    "breakaway_friction": hk.F_BREAKAWAY,
}
#: Range [m/s] of the Stribeck velocity's search.
STRIBECK_RANGE = (1e-5, 1.0)


def friction_columns(sd: np.ndarray, h: tuple, stribeck_velocity: float) -> dict[str, np.ndarray]:
    """The friction [N] per unit of each linear coefficient at rates ``sd`` [m/s]: the kernel
    with that coefficient 1 and the other two 0, at Stribeck velocity ``stribeck_velocity``."""
    out = {}
    for name, index in _LINEAR.items():
        unit = list(h)
        for k in _LINEAR.values():
            unit[k] = 0.0
        unit[index] = 1.0
        unit[hk.V_STRIBECK] = stribeck_velocity
        out[name] = np.array([hk.friction_force(float(v), unit) for v in sd])
    return out


def rod_balance(record: Record, p: DRSParams, hp: HydraulicParams) -> tuple[np.ndarray, ...]:
    """``(mask, sd, friction)``: the samples used, their rates [m/s] and the friction [N] the
    rod balance says acted there."""
    if not record.has("pressure_a", "pressure_b"):
        raise InputError(
            "the rod balance needs the chamber pressures, which the run did not record"
        )
    h = hydraulic_constants(hp, p)
    sd, sdd = record.rates(5)  # the quintic, as the rigid regression's (equation_error)
    push = record.pressure_a * h[hk.AREA_A] - record.pressure_b * h[hk.AREA_B]
    if record.piston_force is not None:
        force = record.piston_force
        mask = np.ones(len(record), dtype=bool)
    else:  # the mechanism's need, off the stops and where its derived acceleration holds
        force = rigid_regressor(record.stroke, sd, sdd, p) @ rigid_values(p)
        # a rod measured within the band of a stop may rest on it: the stop's force is not in
        # the mechanism's need (taken as friction, a flap closed onto its stop by the air load
        # made the breakaway 41 kN)
        free = (h[hk.S_MIN] + STOP_BAND, h[hk.S_MAX] - STOP_BAND)
        mask = (record.stroke > free[0]) & (record.stroke < free[1])
        mask &= np.isfinite(force)
        window, kink = record.derivative_exclusions(mask)
        mask &= ~(window | kink)
    friction = push - force
    mask &= np.isfinite(friction) & np.isfinite(sd)
    return mask, sd[mask], friction[mask]


def friction_regression(
    sd: np.ndarray,
    friction: np.ndarray,
    names: Sequence[str],
    hp: HydraulicParams,
    h: tuple,
    stribeck_velocity: float,
) -> tuple[np.ndarray, np.ndarray]:
    """``(X, y)`` of ``y = X theta`` for the linear coefficients among ``names`` at a given
    Stribeck velocity; the coefficients not asked for at their values in ``hp``."""
    cols = friction_columns(sd, h, stribeck_velocity)
    y = friction.copy()
    for name in _LINEAR:
        if name not in names:
            y = y - float(getattr(hp, name)) * cols[name]
    linear = [n for n in names if n in _LINEAR]
    X = np.stack([cols[n] for n in linear], axis=1) if linear else np.zeros((sd.size, 0))
    return X, y


def best_stribeck_velocity(sd, friction, names, hp, h) -> float:
    """The Stribeck velocity [m/s] that minimises the rod balance's residual, the linear
    coefficients of ``names`` solved at each trial (variable projection)."""

    def rss(log_vs: float) -> float:
        X, y = friction_regression(sd, friction, names, hp, h, math.exp(log_vs))
        if X.shape[1]:
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            y = y - X @ coef
        return float(y @ y)

    lo, hi = (math.log(v) for v in STRIBECK_RANGE)
    grid = np.linspace(lo, hi, 41)
    values = [rss(g) for g in grid]
    k = int(np.argmin(values))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = minimize_scalar(rss, bounds=(a, b), method="bounded", options={"xatol": 1e-6})
    return float(math.exp(res.x))


def stribeck_column(sd, names, values: dict[str, float], h, step: float = 1e-4) -> np.ndarray:
    """``d friction / d v_s`` [N / (m/s)] at ``values`` (central difference in ``log v_s``)."""
    vs = values["stribeck_velocity"]
    full = list(h)
    for name, index in _LINEAR.items():
        full[index] = values[name]

    def at(v):
        full[hk.V_STRIBECK] = v
        return np.array([hk.friction_force(float(x), full) for x in sd])

    up, down = vs * math.exp(step), vs * math.exp(-step)
    return (at(up) - at(down)) / (up - down)


__all__ = [
    "FRICTION_PARAMETERS",
    "STRIBECK_RANGE",
    "best_stribeck_velocity",
    "friction_columns",
    "friction_regression",
    "rod_balance",
    "stribeck_column",
]
