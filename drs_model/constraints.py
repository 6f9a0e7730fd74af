r"""Constraint equations of the DRS loop and their derivatives (seed 003, "Constraints").

Coordinates ``q = [s, psi1, psi3]`` (stroke [m], link angle [rad], flap angle [rad]). The loop
closes at C: the link's end ``C = B + L2 (-sin psi1, cos psi1)`` and the flap's pin
``C3 = D - L3 (cos psi3, sin psi3)`` coincide. As in the seed, ``Phi = r_C3 - r_C``:

.. math::

    \Phi(q) = \begin{bmatrix} L_2 \sin\psi_1 - L_3 \cos\psi_3 - x_A + x_D \\
                              -L_2 \cos\psi_1 - L_3 \sin\psi_3 - L_1 - s - y_A + y_D \end{bmatrix}

Jacobian ``Phi_q`` (2 x 3), and ``gamma`` such that the acceleration constraint reads
``Phi_q qdd = gamma`` (``gamma = -(Phi_q qd)_q qd``).

With an independent coordinate ``q_I`` and the two others dependent ``q_D``, the dependent block's
determinant is ``-L2 L3 cos(psi1 - psi3)`` for ``q_I = s`` (zero when B, C and D are aligned) and
``L2 cos(psi1)`` for ``q_I = psi3`` (with ``q_D = [s, psi1]``).

Every function is vectorised: ``q`` has shape ``(..., 3)``.
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from . import kernels
from .errors import InputError
from .params import DRSParams

#: Index of each coordinate in q.
S, PSI1, PSI3 = 0, 1, 2
#: Independent-coordinate choices: name -> (independent index, dependent indices).
PARTITIONS = MappingProxyType({"s": (S, (PSI1, PSI3)), "psi3": (PSI3, (S, PSI1))})


def _split(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = np.asarray(q, dtype=float)
    return q[..., S], q[..., PSI1], q[..., PSI3]


def constraint(q: np.ndarray, p: DRSParams) -> np.ndarray:
    """Constraint residual ``Phi(q)`` [m], shape ``(..., 2)``."""
    s, p1, p3 = _split(q)
    phi = kernels.loop_residual(s, np.sin(p1), np.cos(p1), np.sin(p3), np.cos(p3), p.loop_constants)
    return np.stack(np.broadcast_arrays(*phi), axis=-1)


def constraint_jacobian(q: np.ndarray, p: DRSParams) -> np.ndarray:
    """``Phi_q`` [m/m, m/rad], shape ``(..., 2, 3)``; columns are d/ds, d/dpsi1, d/dpsi3."""
    _, p1, p3 = _split(q)
    z = np.zeros_like(p1)
    row_x = np.stack([z, p.L2 * np.cos(p1), p.L3 * np.sin(p3)], axis=-1)
    row_y = np.stack([z - 1.0, p.L2 * np.sin(p1), -p.L3 * np.cos(p3)], axis=-1)
    return np.stack([row_x, row_y], axis=-2)


def jacobian_blocks(
    q: np.ndarray, p: DRSParams, independent: str = "s"
) -> tuple[np.ndarray, np.ndarray]:
    """Independent and dependent blocks of ``Phi_q``: shapes ``(..., 2, 1)`` and ``(..., 2, 2)``.

    ``independent`` is ``"s"`` (dependent ``[psi1, psi3]``, the seed's ``JPhiI``/``JPhiD``) or
    ``"psi3"`` (dependent ``[s, psi1]``).
    """
    i, dep = partition(independent)
    jac = constraint_jacobian(q, p)
    return jac[..., [i]], jac[..., list(dep)]


def partition(independent: str) -> tuple[int, tuple[int, int]]:
    """(independent index, dependent indices) for ``independent`` in ``{"s", "psi3"}``."""
    try:
        return PARTITIONS[independent]
    except KeyError:
        raise InputError(
            f"independent coordinate must be one of {sorted(PARTITIONS)}, got {independent!r}"
        ) from None


def dependent_determinant(q: np.ndarray, p: DRSParams, independent: str = "s") -> np.ndarray:
    """det of the dependent Jacobian block, shape ``(...)`` [m^2 for s, m for psi3]; ``q`` as a
    tuple of three floats is one sample, computed with ``math`` (a float, no 0-d arrays)."""
    if isinstance(q, tuple):
        (_, p1, p3), cos = q, math.cos
    else:
        (_, p1, p3), cos = _split(q), np.cos
    partition(independent)
    if independent == "s":
        return -p.L2 * p.L3 * cos(p1 - p3)
    # dependent [s, psi1]: [[0, L2 c1], [-1, L2 s1]] -> det = L2 cos(psi1)
    return p.L2 * cos(p1)


def singularity_measure(q: np.ndarray, p: DRSParams, independent: str = "s") -> np.ndarray:
    """Normalised distance to a singular configuration, in [0, 1] (0 = singular).

    ``|cos(psi1 - psi3)|`` for ``independent="s"`` (the transmission of the link to the flap), and
    ``|cos(psi1)|`` for ``independent="psi3"``. ``q`` as a tuple of three floats: a float.
    """
    scale = p.L2 * p.L3 if independent == "s" else p.L2
    det = dependent_determinant(q, p, independent)
    return (abs(det) if isinstance(q, tuple) else np.abs(det)) / scale


def constraint_velocity_term(q: np.ndarray, qd: np.ndarray, p: DRSParams) -> np.ndarray:
    """``Phi_q qd`` [m/s], shape ``(..., 2)``."""
    return np.einsum("...ij,...j->...i", constraint_jacobian(q, p), np.asarray(qd, dtype=float))


def constraint_gamma(q: np.ndarray, qd: np.ndarray, p: DRSParams) -> np.ndarray:
    """Right-hand side of ``Phi_q qdd = gamma`` [m/s^2], shape ``(..., 2)``."""
    _, p1, p3 = _split(q)
    qd = np.asarray(qd, dtype=float)
    gam = kernels.loop_gamma(
        np.sin(p1),
        np.cos(p1),
        np.sin(p3),
        np.cos(p3),
        qd[..., PSI1],
        qd[..., PSI3],
        p.loop_constants,
    )
    return np.stack(np.broadcast_arrays(*gam), axis=-1)
