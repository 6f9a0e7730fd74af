"""What can be fitted: every parameter a fit may be asked for, where it lives, its unit, its
typical size, its physical bounds and the motion that determines it.

Two owners, by field name:

* ``model``: the fields of :class:`~drs_model.params.DRSParams` the rigid dynamics are linear in
  (:data:`RIGID_PARAMETERS`: masses, inertias, the air law's four end values);
* ``hydraulic``: every numeric field of
  :class:`~drs_model.fidelity.hydraulic_params.HydraulicParams`, found by name at run time, so a
  field added to it later is fittable (by output error) without a change here. The equation-error
  regressions know the fields their equations are linear in (:mod:`.continuity`,
  :mod:`.friction`); a field they do not know is fitted by output error only.

``scale`` is a typical magnitude: the unit in which the fit and the identifiability measures
work (a leak of 1e-13 m^3/(s Pa) and a mass of 0.08 kg are both "1"), and the width beyond which
an interval says the data do not determine the parameter.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..errors import ParameterError
from ..fidelity.hydraulic_params import HydraulicParams
from ..params import DRSParams

#: The DRSParams fields the rigid piston force is linear in (:mod:`.regressor`), in the order of
#: the regressor's columns.
RIGID_PARAMETERS = (
    "m_pist",
    "m_link",
    "m_wing",
    "Iz_link",
    "Iz_wing",
    "F_drag_open",
    "F_drag_closed",
    "F_down_open",
    "F_down_closed",
)

#: The motion that determines each parameter (what ``drs-bag fit`` says when the data do not).
MOTION = {
    "m_pist": "accelerate the rod (the piston mass is a force proportional to s'')",
    "m_link": "accelerate the rod at several strokes (the link's mass shares its effect with the "
    "piston mass and the flap's inertia)",
    "m_wing": "accelerate the flap; its weight alone acts like a constant downforce",
    "Iz_link": "accelerate the link at several strokes",
    "Iz_wing": "accelerate the flap (psi3''), e.g. a fast opening",
    "F_drag_open": "hold or move slowly near the open stop",
    "F_drag_closed": "hold or move slowly near the closed stop",
    "F_down_open": "hold or move slowly near the open stop",
    "F_down_closed": "hold or move slowly near the closed stop",
    "viscous_friction": "move at several steady speeds (viscous friction grows with the speed)",
    "coulomb_friction": "move at several steady speeds, both ways (Coulomb friction does not "
    "grow with the speed)",
    "breakaway_friction": "start and stop the rod slowly (speeds below the Stribeck velocity)",
    "stribeck_velocity": "move slowly, at speeds of a few Stribeck velocities",
    "leak_to_outside": "hold against a pressure (the valve then makes up the leak alone)",
    "leak_across_piston": "hold against a pressure difference between the chambers",
    "bulk_modulus": "change the pressures fast (a spool step) at several strokes",
    "dead_volume_piston_side": "change the pressures fast near the closed stop",
    "dead_volume_rod_side": "change the pressures fast near the open stop",
    "valve_rated_flow": "move at full spool (the flow then sets the speed)",
    "spool_time_constant": "reverse the spool fast (a step of the command)",
    "supply_pressure": "move against a load at full spool",
}

#: Typical magnitudes of the hydraulic fields whose default is zero.
_ZERO_DEFAULT_SCALES = {"leak_to_outside": 1e-13}

#: Units of the hydraulic fields, by suffix of meaning (HydraulicParams' docstring: SI).
_HYDRAULIC_UNITS = {
    "pressure": "Pa",
    "bulk_modulus": "Pa",
    "diameter": "m",
    "volume": "m^3",
    "rated_flow": "m^3/s",
    "time_constant": "s",
    "flow_gain": "m^3/(s Pa)",
    "leak": "m^3/(s Pa)",
    "viscous_friction": "N s/m",
    "friction": "N",
    "velocity": "m/s",
    "stop_stiffness": "N/m",
    "stop_damping": "N s/m",
    "position_gain": "1/m",
    "force_gain": "1/N",
    "velocity_feedforward": "1",
    "port_ratio": "1",
}


@dataclass(frozen=True)
class FitParameter:
    """One parameter a fit may estimate.

    Attributes
    ----------
    name : str
        The field's name in its owner.
    owner : str
        ``"model"`` (DRSParams) or ``"hydraulic"`` (HydraulicParams).
    unit : str
    scale : float
        Typical magnitude [unit] (module docstring).
    lower, upper : float
        Physical bounds [unit] of an output-error fit.
    motion : str
        The motion that determines it.
    """

    name: str
    owner: str
    unit: str
    scale: float
    lower: float
    upper: float
    motion: str


def _unit(name: str) -> str:
    for key, unit in _HYDRAULIC_UNITS.items():
        if key in name:
            return unit
    return "SI"


def _rigid_parameter(name: str, p: DRSParams) -> FitParameter:
    value = float(getattr(p, name))
    if name.startswith("F_"):
        return FitParameter(
            name, "model", "N", max(abs(value), 1.0), -math.inf, math.inf, MOTION[name]
        )
    unit = "kg" if name.startswith("m_") else "kg m^2"
    # masses must stay > 0 (DRSParams refuses 0); inertias may be 0
    lower = 1e-6 * value if name.startswith("m_") else 0.0
    return FitParameter(name, "model", unit, max(abs(value), 1e-9), lower, math.inf, MOTION[name])


def _hydraulic_parameter(name: str, hp: HydraulicParams) -> FitParameter:
    value = getattr(hp, name)
    scale = abs(float(value)) if value else _ZERO_DEFAULT_SCALES.get(name, 1.0)
    motion = MOTION.get(name, "a motion whose simulated signals change with it (output error)")
    # every HydraulicParams field is >= 0 except where its own checks say more: the fit keeps
    # them in [0, inf) and HydraulicParams refuses what it refuses, with its reason
    return FitParameter(name, "hydraulic", _unit(name), scale, 0.0, math.inf, motion)


def hydraulic_field_names(hp: HydraulicParams | None = None) -> tuple[str, ...]:
    """The numeric fields of HydraulicParams (found by name: a field added later is in)."""
    hp = HydraulicParams() if hp is None else hp
    return tuple(
        f.name
        for f in dataclasses.fields(hp)
        if isinstance(getattr(hp, f.name), (int, float))
        and not isinstance(getattr(hp, f.name), bool)
    )


def fit_parameter(
    name: str, p: DRSParams | None = None, hp: HydraulicParams | None = None
) -> FitParameter:
    """The :class:`FitParameter` of ``name``, sized from ``p`` and ``hp`` (defaults: the seed's
    and HydraulicParams' defaults).

    Raises
    ------
    ParameterError
        ``name`` is not a fittable parameter (the message lists those that are).
    """
    p = DRSParams() if p is None else p
    hp = HydraulicParams() if hp is None else hp
    if name in RIGID_PARAMETERS:
        return _rigid_parameter(name, p)
    if name in hydraulic_field_names(hp):
        return _hydraulic_parameter(name, hp)
    reason = ""
    if name == "Iz_pist":
        reason = " (the piston does not turn: its inertia is in no equation)"
    elif hasattr(p, name):
        reason = " (a geometry, gravity or manoeuvre value: fixed, not identified)"
    raise ParameterError(
        f"{name!r} cannot be fitted{reason}; fittable: {', '.join(RIGID_PARAMETERS)} (rigid "
        f"dynamics) and {', '.join(hydraulic_field_names(hp))} (hydraulic)"
    )


def current_value(name: str, p: DRSParams, hp: HydraulicParams) -> float:
    """The value [unit] ``name`` has in ``p`` or ``hp``."""
    return float(getattr(p if fit_parameter(name, p, hp).owner == "model" else hp, name))


def with_values(
    values: dict[str, float], p: DRSParams, hp: HydraulicParams
) -> tuple[DRSParams, HydraulicParams]:
    """``p`` and ``hp`` with ``values`` (name -> value) set, validated by their dataclasses.

    The inertias of ``p`` are passed as they are, so that a fitted mass never drags a derived
    inertia with it (:func:`drs_model.params.from_dict` would)."""
    model = {k: float(v) for k, v in values.items() if k in RIGID_PARAMETERS}
    hydraulic = {k: float(v) for k, v in values.items() if k not in RIGID_PARAMETERS}
    if model:
        p = dataclasses.replace(p, **model)
    if hydraulic:
        hp = hp.replace(**hydraulic)
    return p, hp


__all__ = [
    "MOTION",
    "RIGID_PARAMETERS",
    "FitParameter",
    "current_value",
    "fit_parameter",
    "hydraulic_field_names",
    "with_values",
]
