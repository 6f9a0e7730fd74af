"""The faults in force on a rung, set one by one at a physics step (the node's ``fault.*``
parameters, a bag's re-run): supply loss (a step or a ramp), a stuck valve, a leak, a jammed flap,
and the stroke sensor's faults (:mod:`~drs_model.fidelity.sensor_faults`).

:class:`RunFaults` checks a value (type, range, and whether the rung can model it) before it
acts, applies it to the rung, and turns the true stroke into the published one. What each rung
makes of a fault (docs/fidelity.md, "Faults at run time"):

* ``supply_loss``: ``hydraulic``: the supply falls to the return pressure over
  ``supply_loss_ramp_s`` and the servo is commanded closed (:meth:`HydraulicRung.lose_supply`);
  back on, it rises to the supply pressure over the same ramp. ``rigid`` and ``quasi-static``:
  the documented equivalent, a zero piston force from now on (the air load closes the flap);
  back on, nothing changes until the next command. ``kinematic``: refused (no forces).
* ``stuck_valve``, ``leak_m3_per_s_per_pa``, ``jam_friction_n``: ``hydraulic`` only; refused
  on the other rungs, which model no valve, no oil and no friction.
* ``sensor.*``: every rung; they change the published stroke only, never the simulation.

A healthy value (the default) is accepted on every rung. Each numeric fault has a physical range
(:data:`FAULT_RANGES`, with its reason); a value outside it is refused with the range. A jam or a
leak that would make the hydraulic rung too stiff for its physics step is refused with the rung's
own reason (:meth:`HydraulicRung.check_stiffness`, a
:class:`~drs_model.errors.TooStiffError`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import MappingProxyType

import numpy as np

from ..commanded import HYDRAULIC_FAULTS
from ..errors import InputError
from ..timebase import nearest_step
from .sensor_faults import SensorFaults, StrokeSensor

#: fault name -> (healthy value, what it is). The node's parameters are ``fault.<name>``; faults
#: set together act in this order (the ramp before the supply loss it shapes).
FAULTS = MappingProxyType(
    {
        "supply_loss_ramp_s": (0.0, "time [s] the supply takes to fall (or rise)"),
        "supply_loss": (False, "the hydraulic supply is lost (true) or back (false)"),
        "stuck_valve": (False, "the servo valve's spool sticks where it is"),
        "leak_m3_per_s_per_pa": (0.0, "extra leak of each chamber to the outside [m^3/(s Pa)]"),
        "jam_friction_n": (0.0, "extra Coulomb and breakaway friction on the rod [N]"),
        "sensor.bias_m": (0.0, "bias added to the published stroke [m]"),
        "sensor.noise_std_m": (0.0, "standard deviation of the published stroke's noise [m]"),
        "sensor.noise_seed": (0, "seed of the noise and dropouts (each draw: seed and step)"),
        "sensor.dropout": (0.0, "probability a published stroke is lost (NaN)"),
        "sensor.frozen": (False, "the published stroke repeats the value of the step set"),
    }
)

#: The faults only the hydraulic rung models.
HYDRAULIC_ONLY = HYDRAULIC_FAULTS

#: The physical range ``(low, high, why)`` of each numeric fault, in its unit: a value outside is
#: refused with the range (the booleans are true or false). Beyond each bound the fault models
#: nothing more, and the stiffness its value adds to the hydraulic rung stays bounded (a 5 kN jam
#: at the open stop, the stiffest case, needs 357 RK4 sub-steps of a 1 ms step, within the
#: rung's cap of 1000 with its margin of 2).
FAULT_RANGES = MappingProxyType(
    {
        "supply_loss_ramp_s": (
            0.0,
            10.0,
            "an engine stall and the accumulator's reserve take "
            "seconds to empty the supply; a slower decline is a leak",
        ),
        "leak_m3_per_s_per_pa": (
            0.0,
            1e-10,
            "1e-10 m^3/(s Pa) passes 120 l/min at 200 bar, 16 "
            "times the servo valve's rated 7.5 l/min (as much as the relief "
            "valve's full gain): the chamber holds no pressure at all, as "
            "through a burst line",
        ),
        "jam_friction_n": (
            0.0,
            5000.0,
            "the cylinder's force at the relief pressure (250 bar "
            "on the 2.0 cm^2 piston: 5.0 kN): a jam that strong holds the flap "
            "against all the cylinder and the air load can do (a seized flap); "
            "a stronger one holds it no better",
        ),
        "sensor.bias_m": (
            -0.1,
            0.1,
            "a stroke sensor spans the piston's stroke (46 mm with the "
            "seed's geometry): a reading 0.1 m off is no reading of this actuator",
        ),
        "sensor.noise_std_m": (
            0.0,
            0.1,
            "noise of 0.1 m, twice the whole stroke, already hides the stroke",
        ),
        "sensor.noise_seed": (0, 2**63 - 1, "a ROS integer parameter (int64) >= 0"),
        "sensor.dropout": (0.0, 1.0, "a probability"),
    }
)


def describe_range(name: str) -> str:
    """``[low, high] unit`` of fault ``name`` (the unit from its name's suffix)."""
    low, high, _ = FAULT_RANGES[name]
    unit = {"_s": " s", "_m": " m", "_n": " N", "_pa": " m^3/(s Pa)"}
    suffix = next((u for end, u in unit.items() if name.endswith(end)), "")
    return (
        "["
        + ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in (low, high))
        + ("]" + suffix)
    )


class RunFaults:
    """The faults in force on ``sim`` (a rung of :data:`~drs_model.fidelity.RUNGS`) and the
    stroke sensor that reports it."""

    def __init__(self, sim) -> None:
        self.sim = sim
        self._values = {name: healthy for name, (healthy, _) in FAULTS.items()}
        self.sensor = StrokeSensor(SensorFaults())
        self._sensor_healthy = True

    def check(self, name: str, value):
        """``value`` as the fault ``name`` takes it; raises :class:`InputError` for a bad value
        and :class:`UnsupportedCommandError` for a fault this rung cannot model."""
        if name not in FAULTS:
            raise InputError(f"unknown fault {name!r} (known: {', '.join(FAULTS)})")
        healthy = FAULTS[name][0]
        if isinstance(healthy, bool):
            if not isinstance(value, bool):
                raise InputError(f"fault {name} must be true or false, got {value!r}")
        elif isinstance(healthy, int):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise InputError(f"fault {name} must be an integer, got {value!r}")
            value = int(value)
        else:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise InputError(f"fault {name} must be a number, got {value!r}")
            value = float(value)
            if not math.isfinite(value):
                raise InputError(f"fault {name} must be finite, got {value!r}")
        low, high, why = FAULT_RANGES.get(name, (value, value, ""))
        if not low <= value <= high:
            raise InputError(
                f"fault {name} must be in {describe_range(name)} ({why}), got {value!r}"
            )
        if value == healthy or name.startswith("sensor."):
            return value
        self.sim.check_fault(name, value)  # what the rung can model, and its own bounds
        return value

    def apply(self, name: str, value) -> None:
        """Set fault ``name`` to ``value`` now (at the rung's present step); checked first, and a
        refused value changes nothing."""
        value = self.check(name, value)
        if name.startswith("sensor."):
            self._apply_to_sensor(name, value)
        elif name == "supply_loss" and not value:
            if self._values["supply_loss"]:  # back on: only a supply that was lost comes back
                self.sim.apply_fault(name, value, self._values["supply_loss_ramp_s"])
        elif name != "supply_loss_ramp_s":
            self.sim.apply_fault(name, value, self._values["supply_loss_ramp_s"])
        self._values[name] = value
        # asked at every tick of the node, changed only here
        self._sensor_healthy = all(
            self._values[n] == FAULTS[n][0] for n in FAULTS if n.startswith("sensor.")
        )

    def _apply_to_sensor(self, name: str, value) -> None:
        if name == "sensor.frozen":
            if value and not self._values["sensor.frozen"]:
                t, s, _, _ = self.sim.sample()
                self.sensor.freeze(t, self._step(t), s)
            elif not value:
                self.sensor.thaw()
            return
        field = {
            "sensor.bias_m": "bias",
            "sensor.noise_std_m": "noise",
            "sensor.noise_seed": "seed",
            "sensor.dropout": "dropout",
        }[name]
        self.sensor.faults = replace(self.sensor.faults, **{field: value})

    def _step(self, t: float) -> int:
        return nearest_step(t, self.sim.dt)

    @property
    def values(self) -> MappingProxyType:
        """Every fault's value in force, ``name -> value`` (read-only: :meth:`apply` sets them)."""
        return MappingProxyType(self._values)

    @property
    def sensor_healthy(self) -> bool:
        """Whether the published stroke is the true one (every sensor fault at its healthy
        value)."""
        return self._sensor_healthy

    def published_stroke(self, t: float, stroke: float) -> float:
        """The stroke [m] the sensor reports at simulated time ``t`` [s] for the true ``stroke``
        (each draw a function of the seed and the step ``nearest_step(t, dt)``)."""
        if self.sensor_healthy:
            return stroke
        return self.sensor.read(t, self._step(t), stroke)

    def active(self) -> dict:
        """The faults set away from healthy, ``name -> value``."""
        return {n: v for n, v in self._values.items() if v != FAULTS[n][0]}


__all__ = ["FAULTS", "FAULT_RANGES", "HYDRAULIC_ONLY", "RunFaults", "describe_range"]
