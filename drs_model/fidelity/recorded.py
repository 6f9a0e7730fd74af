"""What each rung's own equations say about the samples of a recorded run: the model side of
``drs-bag check`` (docs/bags.md, "What check judges"). Every value comes from the rung's own
code, never from a copy of its formulas, so a change of a rung carries over to the check.

* :func:`true_stroke`: the stroke [m] of the mechanism at a recorded flap angle (what a stroke
  sensor fault leaves untouched: it changes the published stroke only).
* :class:`StaticForce`: the ``quasi-static`` rung's piston force at a stroke
  (:meth:`drs_model.fidelity.quasi_static.QuasiStaticRung.static_force`).
* :class:`HydraulicRecord`: the ``hydraulic`` rung's constants and supply pressure as the faults a
  run recorded set them (leak, jam, supply loss and its ramp, through
  :class:`~drs_model.fidelity.faults.RunFaults` on the rung itself), and from them the rod force
  of recorded chamber pressures (:func:`~drs_model.fidelity.hydraulic_kernels.rod_force`) and the
  end stops' contact force (:func:`~drs_model.fidelity.hydraulic_kernels.stop_force`).
* :class:`SensorReplay`: the stroke a faulty sensor publishes, replayed from the recorded sensor
  faults (:class:`~drs_model.fidelity.sensor_faults.StrokeSensor` through ``RunFaults``: a seed
  replays the same noise and dropouts, each draw a function of the seed and the step).
"""

from __future__ import annotations

import math

from .. import kernels
from ..bodies import model_constants
from ..params import DRSParams
from . import hydraulic_kernels as hk
from .faults import FAULTS, RunFaults
from .hydraulic import HydraulicRung
from .hydraulic_params import HydraulicParams
from .quasi_static import QuasiStaticRung


class TrueStroke:
    """The stroke [m] at a flap angle ``psi3`` [rad] (:func:`drs_model.kernels.psi3_configuration`,
    the closed form the rungs share), for parameters ``p``."""

    def __init__(self, p: DRSParams) -> None:
        self._c = model_constants(p)

    def __call__(self, psi3: float) -> float:
        return float(kernels.psi3_configuration(float(psi3), self._c)[0])


def true_stroke(psi3: float, p: DRSParams) -> float:
    """The stroke [m] of the mechanism at the flap angle ``psi3`` [rad] (:class:`TrueStroke`)."""
    return TrueStroke(p)(psi3)


class StaticForce:
    """The ``quasi-static`` rung's piston force [N] at a stroke ``s`` [m]: the force that holds
    the mechanism at rest there (the rung's own :meth:`QuasiStaticRung.static_force`)."""

    def __init__(self, p: DRSParams, dt: float = 1e-3) -> None:
        self._rung = QuasiStaticRung(p, dt)

    def __call__(self, s: float) -> float:
        return self._rung.static_force(float(s))


class HydraulicRecord:
    """The ``hydraulic`` rung's constants and supply over a recorded run.

    The faults the run recorded are set with :meth:`set` in their order, each at its simulated
    instant, on a rung of the run's parameters (never stepped): the rung and
    :class:`~drs_model.fidelity.faults.RunFaults` decide what each does (a leak and a jam change
    the constants, a supply loss starts the supply's ramp), so the values below are the run's
    from that instant on.
    """

    def __init__(
        self, p: DRSParams, dt: float = 1e-3, hydraulic: HydraulicParams | None = None
    ) -> None:
        self._rung = HydraulicRung(p, dt, hydraulic=hydraulic)
        self._faults = RunFaults(self._rung)

    @property
    def hydraulic(self) -> HydraulicParams:
        return self._rung.hydraulic

    def set(self, name: str, value, sim_time: float) -> None:
        """Fault ``name`` (a key of :data:`~drs_model.fidelity.faults.FAULTS`) set to ``value`` at
        simulated time ``sim_time`` [s]; a refused value raises as in the run."""
        self._rung.t = float(sim_time)
        self._faults.apply(name, value)

    def supply_pressure(self, t: float) -> float:
        """The supply pressure [Pa] at simulated time ``t`` [s], at or after the last fault set."""
        return self._rung.supply_pressure(float(t))

    def rod_force(self, pa: float, pb: float, sd: float) -> float:
        """The cylinder's force [N] on the rod at chamber pressures ``pa``, ``pb`` [Pa] and rod
        speed ``sd`` [m/s], with the friction in force (a jam adds to it)."""
        return hk.rod_force(float(pa), float(pb), float(sd), self._rung.constants)

    def stop_force(self, s: float, sd: float) -> float:
        """The end stops' contact force [N] on the rod at stroke ``s`` [m] and rate ``sd`` [m/s]
        (zero between the stops)."""
        return hk.stop_force(float(s), float(sd), self._rung.constants)


class _Observed:
    """What :class:`RunFaults` reads of a rung to replay its sensor: its name, physics step and
    present sample ``(t, s, psi3, force)`` (the last recorded state)."""

    def __init__(self, rung: str, dt: float) -> None:
        self.name, self.dt = rung, float(dt)
        self.t = self.s = math.nan

    def sample(self) -> tuple[float, float, float, float]:
        return self.t, self.s, math.nan, math.nan


class SensorReplay:
    """The stroke [m] the node's (possibly faulty) sensor published, replayed from the sensor
    faults a run recorded (``sensor.*`` of :data:`~drs_model.fidelity.faults.FAULTS`).

    Feed every published state in order with :meth:`reading` (the node read its sensor at each
    one), and each sensor fault with :meth:`set` where it took effect, between the states: a
    frozen sensor holds the reading of the last state before it. A fault set before any state
    (at the node's first tick) acts from the first state on, which is the state it was set at.
    """

    def __init__(self, rung: str, dt: float) -> None:
        self._state = _Observed(rung, dt)
        self._faults = RunFaults(self._state)
        self._early: list[tuple[str, object]] = []

    @property
    def healthy(self) -> bool:
        """Whether the published stroke is the true one now."""
        return self._faults.sensor_healthy and not self._early

    def set(self, name: str, value) -> None:
        """Sensor fault ``name`` (``sensor.bias_m`` ...) set to ``value`` now."""
        if not name.startswith("sensor.") or name not in FAULTS:
            raise ValueError(f"not a sensor fault: {name!r}")
        if math.isnan(self._state.t):
            self._early.append((name, value))
        else:
            self._faults.apply(name, value)

    def reading(self, t: float, stroke: float) -> float:
        """The stroke [m] published at simulated time ``t`` [s] for the true ``stroke`` [m]."""
        self._state.t, self._state.s = float(t), float(stroke)
        while self._early:
            self._faults.apply(*self._early.pop(0))
        return self._faults.published_stroke(float(t), float(stroke))


__all__ = ["HydraulicRecord", "SensorReplay", "StaticForce", "TrueStroke", "true_stroke"]
