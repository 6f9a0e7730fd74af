"""The constants vector of the hydraulic kernels (:mod:`~drs_model.fidelity.hydraulic_kernels`,
indexed by its ``AREA_A`` ... ``P_VAPOUR``): filled from
:class:`~drs_model.fidelity.hydraulic_params.HydraulicParams` and the stroke limits, and the same
vector with a fault's extra leak or friction added (the rung's ``set_leak`` and ``jam``). Not
kernels: plain Python the rung calls when its constants change.
"""

from __future__ import annotations

import math

from .. import kinematics as kin
from ..errors import InputError
from . import hydraulic_kernels as hk


def hydraulic_constants(hp, p) -> tuple[float, ...]:
    """The constants vector of the kernels for ``hp`` (a
    :class:`~drs_model.fidelity.hydraulic_params.HydraulicParams`) and the stroke limits of ``p``
    (a :class:`~drs_model.params.DRSParams`), indexed ``AREA_A`` ... of
    :mod:`~drs_model.fidelity.hydraulic_kernels`. The rung builds it once."""
    s_min, s_max = kin.stroke_limits(p)
    out = [0.0] * hk.N_HYDRAULIC_CONSTANTS
    out[hk.AREA_A], out[hk.AREA_B] = hp.piston_area, hp.rod_side_area
    out[hk.VOL_A0], out[hk.VOL_B0] = hp.dead_volume_piston_side, hp.dead_volume_rod_side
    out[hk.BETA] = hp.bulk_modulus
    out[hk.K_EDGE], out[hk.PORT_RATIO] = hp.orifice_coefficient, hp.port_ratio
    out[hk.P_LAMINAR] = hp.valve_laminar_pressure
    out[hk.LINEAR_LAW] = 1.0 if hp.flow_law == "linear" else 0.0
    out[hk.Q_NO_LOAD] = hp.no_load_flow
    out[hk.TAU_SPOOL] = hp.spool_time_constant
    out[hk.P_RELIEF], out[hk.K_RELIEF] = hp.relief_pressure, hp.relief_flow_gain
    out[hk.C_LEAK_AB], out[hk.C_LEAK_EXT] = hp.leak_across_piston, hp.leak_to_outside
    out[hk.P_RETURN] = hp.return_pressure
    out[hk.C_VISCOUS], out[hk.F_COULOMB] = hp.viscous_friction, hp.coulomb_friction
    out[hk.F_BREAKAWAY], out[hk.V_STRIBECK] = hp.breakaway_friction, hp.stribeck_velocity
    out[hk.V_SMOOTH] = hp.friction_smoothing_velocity
    out[hk.K_STOP], out[hk.C_STOP] = hp.stop_stiffness, hp.stop_damping
    out[hk.S_MIN], out[hk.S_MAX] = s_min, s_max
    out[hk.K_POSITION], out[hk.K_FEEDFORWARD] = hp.position_gain, hp.velocity_feedforward
    out[hk.K_FORCE] = hp.force_gain
    out[hk.AIR_FRACTION] = hp.entrained_air_fraction
    out[hk.P_AIR_SATURATION] = hp.air_saturation_pressure
    out[hk.AIR_INDEX] = hp.air_polytropic_index
    out[hk.P_VAPOUR] = hp.vapour_pressure
    return tuple(float(x) for x in out)


def with_extra(h: tuple[float, ...], what: str, extra: float, fields) -> tuple[float, ...]:
    """The constants vector ``h`` with ``extra`` added to each field of ``fields`` (pairs of an
    index and its value without the fault): a fault's extra leak [m^3/(s Pa)] or friction [N]
    on top of the parameters'. ``what`` names the fault in the error: an ``extra`` that is not
    a finite number >= 0, or a friction without the Stribeck and smoothing velocities it
    needs, raises :class:`~drs_model.errors.InputError`."""
    if not (isinstance(extra, (int, float)) and math.isfinite(extra) and extra >= 0.0):
        raise InputError(f"{what} must be a finite number >= 0, got {extra!r}")
    out = list(h)
    for index, base in fields:
        out[index] = base + float(extra)
    friction = out[hk.F_COULOMB] > 0.0 or out[hk.F_BREAKAWAY] > 0.0
    if friction and (out[hk.V_STRIBECK] <= 0.0 or out[hk.V_SMOOTH] <= 0.0):
        raise InputError(
            f"{what} needs stribeck_velocity and friction_smoothing_velocity > 0 in HydraulicParams"
        )
    return tuple(out)


def leaking(h: tuple[float, ...], hp, coefficient: float) -> tuple[float, ...]:
    """``h`` with an extra leak from each chamber to the outside [m^3/(s Pa)] on top of
    ``hp.leak_to_outside``."""
    return with_extra(h, "leak", coefficient, ((hk.C_LEAK_EXT, hp.leak_to_outside),))


def jammed(h: tuple[float, ...], hp, friction: float) -> tuple[float, ...]:
    """``h`` with an extra Coulomb and breakaway friction [N] on the rod on top of ``hp``'s."""
    fields = ((hk.F_COULOMB, hp.coulomb_friction), (hk.F_BREAKAWAY, hp.breakaway_friction))
    return with_extra(h, "jam friction", friction, fields)
