"""Parameters of the hydraulic rung: cylinder, oil, servo valve, relief, leakage, friction, end
stops and the position servo loop, as one frozen dataclass with documented defaults and sources.

Sources of the defaults (SI units throughout):

* Supply: F1 control hydraulics run at a few hundred bar from one engine-driven pump (gearshift,
  clutch, DRS); Moog's E024 subminiature servovalve, the F1 part, is rated for 210 bar maximum
  (Machine Design, "Ultralight servohydraulics for Formula 1", 2006). Supply 210 bar, return
  5 bar (a pressurised reservoir's back pressure: an estimate).
* Valve: the same E024 is rated 7.5 l/min at a 70 bar valve drop (35 bar per metering edge).
  Spool lag: a first-order time constant of 0.8 ms (a small servovalve's ~200 Hz bandwidth, the
  class Moog lists for its subminiature valves: an estimate, not a datasheet value).
* Oil: bulk modulus 1.4 GPa without free air (mineral oil is 1.4-1.8 GPa pure, lower with hose
  compliance: Merritt, "Hydraulic Control Systems", ch. 2).
* Entrained air and cavitation (``hydraulic_kernels.effective_bulk_modulus``):
  the oil carries free air bubbles, ``entrained_air_fraction`` of the oil's volume at the air's
  saturation pressure (the pressure at which the oil and its air are in equilibrium: where it was
  filled and bled, the atmosphere). The bubbles follow the polytropic law
  ``p V^n = const`` (``air_polytropic_index`` n: 1 isothermal, 1.4 adiabatic), so that below the
  saturation pressure they grow (the air released from the oil) and the mixture softens steeply;
  at high pressure they shrink to nothing and the modulus tends to ``bulk_modulus``. The
  mixture's modulus is the compression-only oil-air model of the fluid-power literature
  (Merritt's composite modulus ``1/beta_e = (1 - x)/beta + x/(n p)`` with the gas volume
  following the pressure: Rabie, "Fluid Power Engineering", McGraw-Hill 2009, eqs. 2.49-2.57;
  in this form the mixture modulus of MathWorks' Simscape hydraulic chambers, its "relative
  amount of trapped air"; compared with measurements in Gholizadeh, Burton and Schoenau, "Fluid
  bulk modulus: a literature survey", Int. J. Fluid Power 12(3):5-16, 2011). Defaults: 0.5 % of
  air at 1 atm (the usual "0.5-1 %" of a bled circuit, Simscape's default; an estimate for this
  actuator, to identify from pressure logs), isothermal (small bubbles exchange heat within a
  millisecond: an estimate). At the vapour pressure, 2 kPa (a few kPa, where mineral oil's light
  fractions boil off and a cavity opens: an estimate), a chamber's pressure stops falling and a
  vapour cavity opens instead; it closes again before the pressure can rise.
* Cylinder: bore 16 mm, rod 8 mm (our sizing: 210 bar on the 2.0 cm^2 piston gives 4.2 kN, 4x the
  1.0 kN static load at the closed stop); dead volumes of 2 cm^3 a side (ports, a short hose:
  an estimate).
* Relief: cracks at 250 bar (1.2x supply, the usual setting), flow gain 1e-10 m^3/(s Pa)
  (20 bar over the cracking pressure passes 12 l/min: an estimate).
* Leakage: across the piston seal 1e-13 m^3/(s Pa) (0.12 l/min at 200 bar: a worn-in servo
  cylinder's figure, an estimate); none to the outside.
* Friction: viscous 200 N s/m, Coulomb 40 N, breakaway 60 N, Stribeck velocity 10 mm/s,
  smoothed with ``tanh(v / 5 mm/s)``: a PTFE-sealed servo cylinder of this size (estimates of
  the usual order, a few % of the load).
* End stops: stiffness 5e7 N/m, damping 2e4 N s/m (a steel stop through a thin elastomer pad:
  estimates).
* Servo loop: proportional position gain 200 (spool per m of stroke error: a loop crossover near
  200 rad/s, well under the oil column's ~3000 rad/s), velocity feed-forward on (gain 1), force
  mode gain 1/2000 per N (full spool at 2 kN of force error).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ..errors import ParameterError
from ..params import check_signs, real_number

#: Flow laws of the valve: ``"orifice"`` (turbulent, ``Q ~ x sqrt(dp)``) or ``"linear"`` (the
#: ideal valve: flow proportional to the spool at the no-load flow gain, whatever the pressures).
FLOW_LAWS = ("orifice", "linear")


#: Fields a hydraulic parameter set no longer has, and why: giving one is an error naming it.
REMOVED_FIELDS = {
    "oil_density": "the oil's density is no parameter: no formula of the hydraulic rung reads it "
    "(the orifice law is written with the valve's rated flow and pressure drop)",
}


@dataclass(frozen=True)
class HydraulicParams:
    """Every constant of the hydraulic rung (module docstring: the sources).

    Pressures in Pa, volumes in m^3, flows in m^3/s, lengths in m, forces in N, times in s. The
    spool position is normalised: -1..1 (1 opens supply to the piston side, extending the rod and
    opening the flap).
    """

    supply_pressure: float = 210e5
    return_pressure: float = 5e5
    #: The oil's bulk modulus without free air [Pa]: the effective modulus at high pressure.
    bulk_modulus: float = 1.4e9
    #: Free air [m^3 per m^3 of oil] at ``air_saturation_pressure`` (0: pure oil).
    entrained_air_fraction: float = 0.005
    #: Pressure [Pa, absolute] at which the oil and its air are in equilibrium and the entrained
    #: fraction is stated.
    air_saturation_pressure: float = 101325.0
    #: Polytropic index of the air bubbles [-]: 1 isothermal, 1.4 adiabatic.
    air_polytropic_index: float = 1.0
    #: The oil's vapour pressure [Pa, absolute]: no chamber pressure falls below it.
    vapour_pressure: float = 2e3
    bore_diameter: float = 0.016
    rod_diameter: float = 0.008
    dead_volume_piston_side: float = 2e-6
    dead_volume_rod_side: float = 2e-6
    valve_rated_flow: float = 7.5 / 60000.0
    valve_rated_pressure_drop: float = 70e5
    #: Port B's metering edges relative to port A's; default: the area ratio (a valve matched to
    #: the differential cylinder, so that both chambers see the same pressure drop).
    valve_port_ratio: float | None = None
    #: Below this pressure drop [Pa] the orifice law turns laminar (linear), so that the flow is
    #: smooth through zero.
    valve_laminar_pressure: float = 1e5
    flow_law: str = "orifice"
    spool_time_constant: float = 0.8e-3
    relief_pressure: float = 250e5
    relief_flow_gain: float = 1e-10
    leak_across_piston: float = 1e-13
    leak_to_outside: float = 0.0
    viscous_friction: float = 200.0
    coulomb_friction: float = 40.0
    breakaway_friction: float = 60.0
    stribeck_velocity: float = 0.01
    friction_smoothing_velocity: float = 0.005
    stop_stiffness: float = 5e7
    stop_damping: float = 2e4
    position_gain: float = 200.0
    velocity_feedforward: float = 1.0
    force_gain: float = 1.0 / 2000.0

    _POSITIVE = (
        "bulk_modulus",
        "bore_diameter",
        "valve_rated_flow",
        "valve_rated_pressure_drop",
        "valve_laminar_pressure",
        "supply_pressure",
        "air_saturation_pressure",
        "vapour_pressure",
    )
    _NON_NEGATIVE = (
        "rod_diameter",
        "dead_volume_piston_side",
        "dead_volume_rod_side",
        "spool_time_constant",
        "relief_flow_gain",
        "leak_across_piston",
        "leak_to_outside",
        "viscous_friction",
        "coulomb_friction",
        "breakaway_friction",
        "stop_stiffness",
        "stop_damping",
        "position_gain",
        "velocity_feedforward",
        "force_gain",
        "return_pressure",
        "entrained_air_fraction",
    )

    def __new__(cls, *args: Any, **kwargs: Any) -> HydraulicParams:
        removed = sorted(set(kwargs) & set(REMOVED_FIELDS))
        if removed:
            raise ParameterError("; ".join(f"{name}: {REMOVED_FIELDS[name]}" for name in removed))
        return super().__new__(cls)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "flow_law":
                if value not in FLOW_LAWS:
                    raise ParameterError(f"flow_law must be one of {FLOW_LAWS}, got {value!r}")
                continue
            if value is None:
                continue
            object.__setattr__(self, f.name, real_number(f.name, value))
        check_signs(self, self._POSITIVE, self._NON_NEGATIVE)
        if self.rod_diameter >= self.bore_diameter:
            raise ParameterError(
                f"rod_diameter must be < bore_diameter = {self.bore_diameter!r} m, got "
                f"{self.rod_diameter!r}"
            )
        if not self.return_pressure < self.supply_pressure:
            raise ParameterError(
                f"return_pressure must be < supply_pressure = {self.supply_pressure!r} Pa, got "
                f"{self.return_pressure!r}"
            )
        if self.relief_pressure <= self.return_pressure:
            raise ParameterError(
                f"relief_pressure must be > return_pressure = {self.return_pressure!r} Pa, got "
                f"{self.relief_pressure!r}"
            )
        if not 1.0 <= self.air_polytropic_index <= 1.4:
            raise ParameterError(
                "air_polytropic_index must be in [1, 1.4] (isothermal to adiabatic air), got "
                f"{self.air_polytropic_index!r}"
            )
        if self.entrained_air_fraction > 0.2:
            raise ParameterError(
                "entrained_air_fraction must be in [0, 0.2] (free air per volume of oil), got "
                f"{self.entrained_air_fraction!r}"
            )
        if not self.vapour_pressure < self.return_pressure:
            raise ParameterError(
                f"vapour_pressure must be < return_pressure = {self.return_pressure!r} Pa, got "
                f"{self.vapour_pressure!r}"
            )
        if self.breakaway_friction < self.coulomb_friction:
            raise ParameterError(
                f"breakaway_friction must be >= coulomb_friction = {self.coulomb_friction!r} N, "
                f"got {self.breakaway_friction!r}"
            )
        if self.coulomb_friction > 0.0 or self.breakaway_friction > 0.0:
            for name in ("stribeck_velocity", "friction_smoothing_velocity"):
                if getattr(self, name) <= 0.0:
                    raise ParameterError(
                        f"{name} must be > 0 m/s with Coulomb friction, got {getattr(self, name)!r}"
                    )
        if self.valve_port_ratio is not None and self.valve_port_ratio <= 0.0:
            raise ParameterError(f"valve_port_ratio must be > 0, got {self.valve_port_ratio!r}")

    # ---- derived ------------------------------------------------------------------------------
    @property
    def piston_area(self) -> float:
        """Piston-side area [m^2] (pressure there extends the rod: opens the flap)."""
        return math.pi * self.bore_diameter**2 / 4.0

    @property
    def rod_side_area(self) -> float:
        """Annulus area on the rod side [m^2]."""
        return math.pi * (self.bore_diameter**2 - self.rod_diameter**2) / 4.0

    @property
    def orifice_coefficient(self) -> float:
        """``k`` of one metering edge, ``Q = k x sqrt(dp)`` [m^3/(s sqrt(Pa))] at full spool: the
        rated flow at half the rated valve drop (two edges in series share it)."""
        return self.valve_rated_flow / math.sqrt(0.5 * self.valve_rated_pressure_drop)

    @property
    def no_load_flow(self) -> float:
        """Flow into the piston side at full spool with no load [m^3/s]: each edge drops half of
        ``supply - return``. The linear (ideal) valve's flow gain."""
        return self.orifice_coefficient * math.sqrt(
            0.5 * (self.supply_pressure - self.return_pressure)
        )

    @property
    def no_load_speed(self) -> float:
        """Rod speed at full spool with no load [m/s] (extending)."""
        return self.no_load_flow / self.piston_area

    @property
    def port_ratio(self) -> float:
        """Port B's metering edges relative to port A's: ``valve_port_ratio`` if set, else the
        area ratio ``A_B / A_A``."""
        if self.valve_port_ratio is not None:
            return self.valve_port_ratio
        return self.rod_side_area / self.piston_area

    def replace(self, **overrides: Any) -> HydraulicParams:
        """A copy with ``overrides`` (validated)."""
        unknown = sorted(set(overrides) - {f.name for f in dataclasses.fields(self)})
        if unknown and set(unknown) <= set(REMOVED_FIELDS):
            return HydraulicParams(**overrides)  # raises, naming each and why
        if unknown:
            raise ParameterError(
                f"unknown hydraulic parameter(s) {unknown}; valid names: "
                f"{sorted(f.name for f in dataclasses.fields(self))}"
            )
        return dataclasses.replace(self, **overrides)

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


#: The fields of :class:`HydraulicParams`, in declaration order: each is the node parameter
#: ``hydraulic.<field>`` and a ``--set`` name of the tools.
HYDRAULIC_FIELDS = tuple(f.name for f in dataclasses.fields(HydraulicParams))

#: The valid range of each field with more than a sign (what ``__post_init__`` checks).
_RANGES = {
    "flow_law": f"one of {', '.join(FLOW_LAWS)}",
    "return_pressure": ">= 0, < supply_pressure",
    "relief_pressure": "> return_pressure",
    "vapour_pressure": "> 0, < return_pressure",
    "rod_diameter": ">= 0, < bore_diameter",
    "air_polytropic_index": "[1, 1.4]",
    "entrained_air_fraction": "[0, 0.2]",
    "breakaway_friction": ">= coulomb_friction",
    "stribeck_velocity": "> 0 with Coulomb friction",
    "friction_smoothing_velocity": "> 0 with Coulomb friction",
    "valve_port_ratio": "> 0; the node serves the ratio it runs (default: the area ratio)",
}


def field_range(name: str) -> str:
    """The valid range of field ``name``, as text (what :class:`HydraulicParams` refuses)."""
    if name in _RANGES:
        return _RANGES[name]
    if name in HydraulicParams._POSITIVE:
        return "> 0"
    return ">= 0"


def hydraulic_from_dict(
    overrides: dict[str, Any], base: HydraulicParams | None = None
) -> HydraulicParams:
    """``base`` (default: the defaults) with ``overrides`` applied, validated; an unknown name or
    a bad value raises :class:`ParameterError` naming it and the valid range.

    ``valve_port_ratio`` follows the bore and rod (the area ratio) unless given: a ``base``
    whose ratio is the area ratio (a recorded run, which records the ratio it ran) keeps
    following them when ``overrides`` change the bore or the rod, as a derived inertia follows
    its mass (:func:`drs_model.params.from_dict`)."""
    base = HydraulicParams() if base is None else base
    overrides = dict(overrides)
    if "valve_port_ratio" not in overrides and _ratio_is_derived(base):
        overrides["valve_port_ratio"] = None
    out = base.replace(**overrides) if overrides else base
    # a ratio given as the area ratio is the derived one (what the node records for None)
    return out.replace(valve_port_ratio=None) if _ratio_is_derived(out) else out


def _ratio_is_derived(hp: HydraulicParams) -> bool:
    """``valve_port_ratio`` is set, to the area ratio it would default to."""
    ratio = hp.valve_port_ratio
    return ratio is not None and ratio == hp.rod_side_area / hp.piston_area
