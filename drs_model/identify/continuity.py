r"""The chambers' continuity equations as a linear regression (equation error of the hydraulic
rung), given the measured stroke, pressures, supply pressure and spool.

Each chamber's pressure obeys (:mod:`drs_model.fidelity.hydraulic_kernels`)

.. math::

    \frac{V_{A0} + A_A (s - s_{min})}{\beta} \dot p_A
        = k\,q_A - A_A \dot s - C_{AB} (p_A - p_B) - C_{ext} (p_A - p_r) - Q_{A,relief}

and likewise for B (``+ A_B s'``, ``+ C_AB (p_A - p_B)``, volume ``V_B0 + A_B (s_max - s)``).
``q_A`` is the valve's flow into A per unit of ``valve_rated_flow`` (the flow law is
proportional to it), so the equation is linear in ``k = valve_rated_flow``, the leaks ``C_AB =
leak_across_piston`` and ``C_ext = leak_to_outside``, ``phi = 1/beta`` and ``phi V_0``
(each dead volume over the bulk modulus).

Written on each sample interval ``[t_i, t_{i+1}]`` so that nothing is differentiated: the
pressure rate integrates to the pressure step, ``s'`` to the stroke step, the flows and leaks by
the trapezoidal rule. The stroke step's noise makes consecutive equations' errors correlated:
the covariance is the Newey-West one (:mod:`.least_squares`). The rule's error grows with the
sample interval against the oil column's period (~2 ms): at 2 kHz the estimates are within a few
per cent, at 1 kHz and below a start for the output error (docs/identify.md).

The regression's own parameters ``(k, C_AB, C_ext, phi, phi V_A0, phi V_B0)`` map back to the
fields (``bulk_modulus = 1/phi``, ``dead_volume_* = (phi V_0) / phi``) with the delta method.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..fidelity import hydraulic_kernels as hk
from ..fidelity.hydraulic import hydraulic_constants
from ..fidelity.hydraulic_params import HydraulicParams
from ..params import DRSParams
from .record import Record

#: The HydraulicParams fields the continuity equations are linear in (through the regression's
#: own parameters).
CONTINUITY_PARAMETERS = (
    "valve_rated_flow",
    "leak_across_piston",
    "leak_to_outside",
    "bulk_modulus",
    "dead_volume_piston_side",
    "dead_volume_rod_side",
)


def _trapezoid(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    return 0.5 * (x[1:] + x[:-1]) * np.diff(t)


def _flows(record: Record, h: tuple, rated_flow: float) -> tuple[np.ndarray, np.ndarray]:
    """The valve's net flows into A and B [m^3/s] per unit of rated flow at each sample."""
    qa = np.empty(len(record))
    qb = np.empty(len(record))
    for i, (x, pa, pb, ps) in enumerate(
        zip(record.spool, record.pressure_a, record.pressure_b, record.supply_pressure, strict=True)
    ):
        q_pa, q_at, q_pb, q_bt = hk.valve_flows(x, pa, pb, ps, h)
        qa[i], qb[i] = q_pa - q_at, q_pb - q_bt
    return qa / rated_flow, qb / rated_flow


def _terms(record: Record, p: DRSParams, hp: HydraulicParams) -> dict[str, np.ndarray]:
    """Each term of both chambers' integrated equations, stacked (A's intervals, then B's),
    signed as they stand on the right of ``0 = ...``; ``known`` holds the stroke and relief
    terms, whose coefficients are not fitted."""
    h = hydraulic_constants(hp, p)
    t, s = record.t, record.stroke
    pa, pb = record.pressure_a, record.pressure_b
    area_a, area_b, pr = h[hk.AREA_A], h[hk.AREA_B], hp.return_pressure
    qa, qb = _flows(record, h, hp.valve_rated_flow)
    relief_a = np.array([hk.relief_flow(x, h) for x in pa])
    relief_b = np.array([hk.relief_flow(x, h) for x in pb])
    va = area_a * (s - h[hk.S_MIN])  # the volume swept, without the dead volume
    vb = area_b * (h[hk.S_MAX] - s)
    dpa, dpb = np.diff(pa), np.diff(pb)
    swept_a = -0.5 * (va[1:] + va[:-1]) * dpa
    swept_b = -0.5 * (vb[1:] + vb[:-1]) * dpb
    zeros = np.zeros_like(dpa)

    def both(a, b):
        return np.concatenate([a, b])

    return {
        "valve_rated_flow": both(_trapezoid(qa, t), _trapezoid(qb, t)),
        "leak_across_piston": both(-_trapezoid(pa - pb, t), _trapezoid(pa - pb, t)),
        "leak_to_outside": both(-_trapezoid(pa - pr, t), -_trapezoid(pb - pr, t)),
        "compliance": both(swept_a, swept_b),  # times phi = 1 / beta
        "dead_volume_piston_side": both(-dpa, zeros),  # times phi V_A0
        "dead_volume_rod_side": both(zeros, -dpb),  # times phi V_B0
        "known": both(
            -area_a * np.diff(s) - _trapezoid(relief_a, t),
            area_b * np.diff(s) - _trapezoid(relief_b, t),
        ),
    }


def continuity_regression(
    record: Record, names: Sequence[str], p: DRSParams, hp: HydraulicParams
) -> tuple[np.ndarray, np.ndarray]:
    """``(X, y)`` of ``y = X phi`` for the fields ``names`` (a subset of
    :data:`CONTINUITY_PARAMETERS`), the others held at their values in ``hp``; one row per
    sample interval and chamber (A's, then B's). ``phi``'s entries: ``k``, ``C_AB``,
    ``C_ext``, ``1/beta``, ``V_A0/beta``, ``V_B0/beta`` for the names asked, in their order.

    Raises
    ------
    InputError
        A name outside :data:`CONTINUITY_PARAMETERS`, or a record without the pressures,
        supply pressure or spool.
    """
    unknown = [n for n in names if n not in CONTINUITY_PARAMETERS]
    if unknown:
        raise InputError(
            f"{unknown} are not in the continuity equations "
            f"({', '.join(CONTINUITY_PARAMETERS)} are)"
        )
    missing = [
        n
        for n in ("pressure_a", "pressure_b", "supply_pressure", "spool")
        if getattr(record, n) is None
    ]
    if missing:
        raise InputError(
            f"the continuity equations need the signals {missing}, which the run did not record"
        )
    terms = _terms(record, p, hp)
    y = -terms["known"]
    columns = {}
    for name in ("valve_rated_flow", "leak_across_piston", "leak_to_outside"):
        if name in names:
            columns[name] = terms[name]
        else:
            y = y - float(getattr(hp, name)) * terms[name]
    compliance = terms["compliance"]
    for name in ("dead_volume_piston_side", "dead_volume_rod_side"):
        if name in names:
            columns[name] = terms[name]
        else:  # a dead volume held is part of the compliance: it scales with 1/beta too
            compliance = compliance + float(getattr(hp, name)) * terms[name]
    if "bulk_modulus" in names:
        columns["bulk_modulus"] = compliance
    else:
        y = y - compliance / hp.bulk_modulus
    X = np.stack([columns[n] for n in names], axis=1)
    return X, y


def to_fields(
    phi: np.ndarray, cov: np.ndarray, names: Sequence[str], hp: HydraulicParams
) -> tuple[np.ndarray, np.ndarray]:
    """The fields' values and covariance from the regression's ``phi`` and its covariance
    (delta method): ``beta = 1/phi``, a dead volume ``(phi V_0) / phi`` (with ``phi`` fitted)
    or ``(phi V_0) beta`` (``beta`` held)."""
    names = list(names)
    values = np.array(phi, dtype=float)
    G = np.eye(len(names))
    inv_beta = phi[names.index("bulk_modulus")] if "bulk_modulus" in names else None
    for i, name in enumerate(names):
        if name == "bulk_modulus":
            values[i] = 1.0 / phi[i]
            G[i, i] = -1.0 / phi[i] ** 2
        elif name.startswith("dead_volume"):
            if inv_beta is None:
                values[i] = phi[i] * hp.bulk_modulus
                G[i, i] = hp.bulk_modulus
            else:
                j = names.index("bulk_modulus")
                values[i] = phi[i] / inv_beta
                G[i, i] = 1.0 / inv_beta
                G[i, j] = -phi[i] / inv_beta**2
    return values, G @ cov @ G.T


def from_fields(values: dict[str, float], names: Sequence[str]) -> np.ndarray:
    """The regression's ``phi`` for field values ``values`` (the inverse of :func:`to_fields`)."""
    out = []
    for name in names:
        if name == "bulk_modulus":
            out.append(1.0 / values[name])
        elif name.startswith("dead_volume"):
            out.append(values[name] / values["bulk_modulus"])
        else:
            out.append(values[name])
    return np.array(out)


__all__ = ["CONTINUITY_PARAMETERS", "continuity_regression", "from_fields", "to_fields"]
