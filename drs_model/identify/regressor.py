r"""The rigid regressor: the piston force as a linear function of the inertial and air-load
parameters, ``F = Y(s, s', s'') theta``, derived from the model's own inverse dynamics.

No formula is written here. The fused inverse dynamics (:func:`drs_model.kernels.fused_force`)
is linear in nine of its constants ``c_L`` (masses ``M1 M2 M3``, inertias ``I2 I3``, the air law's
open values and slopes) with no term free of them, so

.. math::

    F(s, s', s'') = \sum_k \Phi_k(s, s', s'')\, c_k, \qquad
    \Phi_k = F \text{ evaluated with } c_L = e_k

(one evaluation of the kernel per constant). The constants are affine in the DRSParams fields
``theta`` (:data:`~.parameters.RIGID_PARAMETERS`; the slopes are differences of the end values
over the flap's travel), ``c_L = D theta``, and :func:`constants_map` reads ``D`` off
:func:`drs_model.bodies.model_constants` by unit steps of each field (exact: the map is linear).
Hence ``Y = Phi D``. The tests check ``Y theta`` against every inverse-dynamics formulation over
the manoeuvre.

On the ``quasi-static`` rung the force is the statics alone: the regressor at ``s' = s'' = 0``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence

import numpy as np

from .. import elementwise, kernels
from ..bodies import model_constants
from ..errors import InputError
from ..params import DRSParams
from .parameters import RIGID_PARAMETERS

#: The constants of :mod:`drs_model.kernels` the fused force is linear in.
LINEAR_CONSTANTS = (
    kernels.M1,
    kernels.M2,
    kernels.M3,
    kernels.I2,
    kernels.I3,
    kernels.DRAG_OPEN,
    kernels.DRAG_SLOPE,
    kernels.DOWN_OPEN,
    kernels.DOWN_SLOPE,
)


def constants_map(p: DRSParams) -> np.ndarray:
    """``D = d c_L / d theta``, shape ``(9, 9)``: how the linear constants follow the fields of
    :data:`RIGID_PARAMETERS` at the geometry of ``p`` (a unit step of each field)."""
    return _constants_map(p).copy()


@functools.lru_cache(maxsize=64)
def _constants_map(p: DRSParams) -> np.ndarray:
    """:func:`constants_map`, once per parameter set (each step solves the gap rule: ~1 ms)."""
    idx = list(LINEAR_CONSTANTS)
    base = np.array(model_constants(p))[idx]
    out = np.empty((len(idx), len(RIGID_PARAMETERS)))
    for j, name in enumerate(RIGID_PARAMETERS):
        stepped = dataclasses.replace(p, **{name: float(getattr(p, name)) + 1.0})
        out[:, j] = np.array(model_constants(stepped))[idx] - base
    return out


@functools.lru_cache(maxsize=64)
def _model_constants(p: DRSParams) -> tuple[float, ...]:
    return model_constants(p)


def constant_columns(s, sd, sdd, p: DRSParams) -> np.ndarray:
    """``Phi``, shape ``(n, 9)``: the fused force with each linear constant set to 1 and the
    others to 0, at strokes ``s`` [m], rates ``sd`` [m/s], accelerations ``sdd`` [m/s^2]."""
    s, sd, sdd = np.broadcast_arrays(*(np.asarray(x, dtype=float).ravel() for x in (s, sd, sdd)))
    consts = np.array(_model_constants(p))
    out = np.empty((s.size, len(LINEAR_CONSTANTS)))
    for j, k in enumerate(LINEAR_CONSTANTS):
        unit = consts.copy()
        unit[list(LINEAR_CONSTANTS)] = 0.0
        unit[k] = 1.0
        out[:, j] = elementwise.fused_force(s, sd, sdd, tuple(unit))
    return out


def rigid_regressor(
    s, sd, sdd, p: DRSParams, names: Sequence[str] = RIGID_PARAMETERS
) -> np.ndarray:
    """``Y``, shape ``(n, len(names))``: the piston force [N] per unit of each parameter of
    ``names`` (a subset of :data:`RIGID_PARAMETERS`) at the samples ``(s, sd, sdd)``, so that
    ``Y @ theta`` is the rigid inverse-dynamics force. NaN rows where the loop cannot close.

    Raises
    ------
    InputError
        A name not in :data:`RIGID_PARAMETERS`.
    """
    unknown = [n for n in names if n not in RIGID_PARAMETERS]
    if unknown:
        raise InputError(
            f"{unknown} are not rigid parameters; the rigid force is linear in "
            f"{', '.join(RIGID_PARAMETERS)}"
        )
    cols = [RIGID_PARAMETERS.index(n) for n in names]
    return constant_columns(s, sd, sdd, p) @ constants_map(p)[:, cols]


def rigid_values(p: DRSParams, names: Sequence[str] = RIGID_PARAMETERS) -> np.ndarray:
    """``theta``: the values of ``names`` in ``p``."""
    return np.array([float(getattr(p, n)) for n in names])


#: Relative step [of the stroke range] of the force's stroke derivative in the rigid weights.
_WEIGHT_STEP = 1e-6
#: Floor of ``|dF/ds|`` in the rigid weights, as a fraction of its RMS over the run.
_WEIGHT_FLOOR = 1e-6


def rigid_weights(s, sd, sdd, p: DRSParams) -> np.ndarray:
    """``1 / ((dF/ds)^2 + floor^2)`` at each sample: the inverse variance, up to the stroke
    noise's, that a stroke error gives the residual ``F - Y(s) theta``."""
    consts = _model_constants(p)
    h = _WEIGHT_STEP * (p.gap_open - p.gap_closed)
    up = elementwise.fused_force(np.asarray(s) + h, sd, sdd, consts)
    down = elementwise.fused_force(np.asarray(s) - h, sd, sdd, consts)
    g = (np.asarray(up) - np.asarray(down)) / (2 * h)  # the force Y theta, evaluated directly
    floor = _WEIGHT_FLOOR * math.sqrt(float(np.mean(g * g))) + 1e-300
    return 1.0 / (g * g + floor * floor)


__all__ = [
    "LINEAR_CONSTANTS",
    "constant_columns",
    "constants_map",
    "rigid_regressor",
    "rigid_values",
    "rigid_weights",
]
