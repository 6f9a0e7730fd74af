"""The ``hydraulic`` rung: the rigid mechanism driven by a double-acting cylinder through a servo
valve, with the position servo loop that turns the commanded moves into valve commands
(equations: :mod:`~drs_model.fidelity.hydraulic_kernels`; constants and their sources:
:class:`~drs_model.fidelity.hydraulic_params.HydraulicParams`).

Commands are :class:`~drs_model.actuator.ActuatorSim`'s: a stroke move or trajectory becomes the
servo's reference (the same quintic the other rungs follow exactly), a force command the force
loop's reference; :meth:`HydraulicRung.lose_supply` drops the supply pressure to the return
pressure (a step or a ramp). Each physics step ``dt`` is taken in sub-steps of a fixed-step
method (:mod:`~drs_model.fidelity.hydraulic_steps`): ``"rk4"`` by default (explicit: each
sub-step checked against the oil column's stability limit, and refused with
:class:`~drs_model.errors.StiffStepError` above it), or the L-stable ``"ros2"`` and
``"linearly-implicit-euler"``.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np

from .. import kernels
from .. import kinematics as kin
from ..bodies import model_constants
from ..commanded import CommandedActuator
from ..compiled.scalar import compiled_or_plain
from ..errors import StiffStepError
from ..params import FORCE_LIMIT_DEFAULT_N, DRSParams
from . import hydraulic_kernels as hk
from . import hydraulic_steps as hs
from . import hydraulic_vector
from .base import RungState
from .hydraulic_events import ContactLocator, EventLocator
from .hydraulic_kernels import equilibrium_state
from .hydraulic_params import HydraulicParams
from .hydraulic_steps import CALLEES, RK4_LIMIT, STEP_METHODS, state_rate
from .hydraulic_vector import hydraulic_constants
from .supply import SupplyPressure


class HydraulicRung(CommandedActuator):
    """The hydraulic actuator behind the rung interface (module docstring).

    Parameters
    ----------
    p : DRSParams
    dt : float
        Physics step [s].
    force_limit, limit_moves : float, bool
        As :class:`~drs_model.commanded.CommandedActuator`'s.
    hydraulic : HydraulicParams, optional
        Default: the documented defaults.
    method : str
        A key of :data:`~drs_model.fidelity.hydraulic_steps.STEP_METHODS`; ``"rk4"`` (default)
        at its largest stable sub-step is both the most accurate and the cheapest on the
        standard scenes (docs/fidelity.md; ``ros2`` needs 20 us sub-steps for the same accuracy).
    substep : float, optional
        Longest sub-step [s]. Default: for ``"rk4"`` ``stability_fraction`` times the largest
        stable one at each step's start (``RK4_LIMIT / stiffest_rate``); for the implicit
        methods :data:`DEFAULT_IMPLICIT_SUBSTEP`. Given with ``"rk4"``, a sub-step above the
        stability limit raises :class:`StiffStepError` (the state is kept).
    stability_fraction : float
        In (0, 1]: the fraction of the stable RK4 sub-step taken (a tighter run).
    guard : bool
        Refuse an RK4 sub-step above the stability limit (default; off: hydraulic_stability.py).
    locate_events : bool or "contacts"
        Split the sub-steps where the right-hand side is not smooth (a stop's contact, the
        vapour pressure, the relief, the spool's null...: :class:`~.hydraulic_events.EventLocator`),
        so that the method keeps its order across them: ``True``, the chart's reference.
        ``"contacts"`` (default, the node's rung): only where a stop's contact begins or ends (its
        damping force jumps there: :class:`~.hydraulic_events.ContactLocator`). ``False``: none.
    max_substeps : int, optional
        Most sub-steps of one physics step; a step that needs more raises
        :class:`~drs_model.errors.TooStiffError` before it is taken (the state is kept). Default:
        ``ceil(dt / (MIN_SUBSTEP * stability_fraction))``.
    recheck : bool
        With RK4's own sub-step: check the stiffest rate at each sub-step's end and take a
        sub-step again, shorter, where the state stiffened within it (default; :meth:`step`).
    """

    name = "hydraulic"
    state_type = RungState
    has_fluid = True

    def __init__(
        self,
        p: DRSParams,
        dt: float = 1e-3,
        force_limit: float = FORCE_LIMIT_DEFAULT_N,
        integrator: str = "rk4",
        force_method: str = "fused",
        hydraulic: HydraulicParams | None = None,
        method: str = "rk4",
        substep: float | None = None,
        stability_fraction: float = 1.0,
        guard: bool = True,
        locate_events: bool | str = "contacts",
        max_substeps: int | None = None,
        recheck: bool = True,
        limit_moves: bool = True,
    ) -> None:
        self.locate_events = hs.checked_options(
            method, substep, stability_fraction, max_substeps, locate_events
        )
        self._max_substeps = max_substeps
        self.stability_fraction = float(stability_fraction)
        self.guard = bool(guard)
        self.recheck = bool(recheck)
        self.hydraulic = HydraulicParams() if hydraulic is None else hydraulic
        self.method = method
        self.substep = substep
        self._explicit = STEP_METHODS[method][1]
        self._c = model_constants(p)
        self._h = hydraulic_constants(self.hydraulic, p)
        super().__init__(p, dt, force_limit, integrator, force_method, limit_moves)
        self.reset()

    @property
    def max_substeps(self) -> int:
        """Most sub-steps of one physics step: as given, or ``ceil(dt / (MIN_SUBSTEP *
        stability_fraction))``: a rung asked for sub-steps at a fraction of the stable one (the
        chart's reference) may take proportionally more, and the bound stays finite."""
        if self._max_substeps is not None:
            return self._max_substeps
        shortest = hs.MIN_SUBSTEP * self.stability_fraction
        return max(1, math.ceil(self.dt / shortest * (1.0 - 1e-12)))

    @cached_property
    def _step_fn(self):
        return compiled_or_plain(STEP_METHODS[self.method][0], CALLEES)

    @cached_property
    def _rate_fn(self):
        return compiled_or_plain(hk.stiffest_rate, CALLEES)

    @cached_property
    def _consts(self):
        return np.array(self._c), np.array(self._h)

    # ---- state ----------------------------------------------------------------------------------
    def reset(self, t: float = 0.0, s: float | None = None) -> RungState:
        """At rest at stroke ``s`` (default closed), pressures in equilibrium, full supply."""
        s = self.s_min if s is None else float(kin.check_stroke(s, self.p))
        self._y = equilibrium_state(s, self.p, self.hydraulic)
        self._hold_stroke = s
        hp = self.hydraulic
        self._supply = SupplyPressure(t, hp.supply_pressure)
        self._spool_held = False
        self._force_cmd = 0.0
        self._peak_rate = 0.0
        super().reset(t, s)
        self._update_outputs()
        return self.state

    def _update_outputs(self) -> None:
        """``q, qd, qdd``, the piston force and the stop from the hydraulic state ``self._y``."""
        c, h = self._c, self._h
        psi3, psi3d, pa, pb, xv = (float(v) for v in self._y)
        s_ref, v_ref = self._reference(self.t)
        ps = self.supply_pressure(self.t)
        mode = hk.MODE_FORCE if self.mode == "force" else hk.MODE_STROKE
        f_ref, held = self._force_cmd, float(self._spool_held)
        _, bdd, _, _, _ = hk.hydraulic_derivatives(
            psi3, psi3d, pa, pb, xv, mode, s_ref, v_ref, f_ref, ps, held, c, h
        )
        s, psi1, _, _ = kernels.psi3_configuration(psi3, c)
        q = (s, psi1, psi3)
        sin1, cos1 = math.sin(psi1), math.cos(psi1)
        u0, u1, _, _ = kernels.flap_rates(sin1, cos1, math.sin(psi3), math.cos(psi3), c)
        qd = (u0 * psi3d, u1 * psi3d, psi3d)
        m = self.motion
        m.q, m.qd = q, qd
        m.qdd = kin.accelerations_from_flap_scalar(q, qd, bdd, self.p)
        pa, pb = hk.chamber_pressure(pa, h), hk.chamber_pressure(pb, h)
        self._force = hk.rod_force(pa, pb, qd[0], h)
        m.at_stop = "closed" if s < self.s_min else "open" if s > self.s_max else None

    def _state_extras(self) -> dict:
        xv = float(self._y[4])
        pa, pb = self.chamber_pressures()
        return {
            "rung": self.name,
            "pressure_a": pa,
            "pressure_b": pb,
            "spool": xv if self.hydraulic.spool_time_constant > 0.0 or self._spool_held else None,
            "supply_pressure": self.supply_pressure(self.t),
        }

    @property
    def constants(self) -> tuple[float, ...]:
        """The constants vector of :mod:`~drs_model.fidelity.hydraulic_kernels` in force now
        (a leak or a jam set at run time changes it)."""
        return self._h

    @property
    def y(self) -> np.ndarray:
        """The hydraulic state ``(psi3, psi3', x_A, x_B, x_v)`` (a copy; ``x_A``, ``x_B`` are the
        chamber pressures while no vapour cavity is open, :mod:`hydraulic_kernels`)."""
        return self._y.copy()

    def chamber_pressures(self) -> tuple[float, float]:
        """``(p_A, p_B)`` [Pa, absolute]: the chamber pressures, never below the vapour
        pressure."""
        h = self._h
        return hk.chamber_pressure(float(self._y[2]), h), hk.chamber_pressure(float(self._y[3]), h)

    def cavity_volumes(self) -> tuple[float, float]:
        """``(V_cav,A, V_cav,B)`` [m^3]: the vapour cavities of the chambers (0 while full)."""
        s, _, _, _ = kernels.psi3_configuration(float(self._y[0]), self._c)
        va, vb = hk.chamber_volumes(s, self._h)
        return (
            hk.cavity_volume(float(self._y[2]), va, self._h),
            hk.cavity_volume(float(self._y[3]), vb, self._h),
        )

    # ---- supply and faults ---------------------------------------------------------------------
    def supply_pressure(self, t: float) -> float:
        """The supply pressure [Pa] at time ``t`` [s] (a ramp between two set values)."""
        return self._supply.at(t)

    def set_supply_pressure(self, pressure: float, ramp_time: float = 0.0) -> None:
        """The supply pressure goes from its present value to ``pressure`` [Pa] over
        ``ramp_time`` [s] from now."""
        self._supply.set(self.t, pressure, ramp_time)

    def stick_valve(self, stuck: bool = True) -> None:
        """The spool sticks where it is (``stuck``) or moves again: a stuck valve."""
        self._spool_held = bool(stuck)

    def set_leak(self, coefficient: float) -> None:
        """An extra leak from each chamber to the outside [m^3/(s Pa)] from now on, on top of
        ``HydraulicParams.leak_to_outside`` (0 ends it). Refused (:class:`TooStiffError`) when it
        makes the rung too stiff for its step (:meth:`check_stiffness`)."""
        self._use_constants(self.leaking(coefficient))

    def jam(self, friction: float) -> None:
        """An extra Coulomb (and breakaway) friction [N] on the rod from now on: a jammed flap
        (0 ends it). Refused (:class:`TooStiffError`) when it makes the rung too stiff for its
        step (:meth:`check_stiffness`)."""
        self._use_constants(self.jammed(friction))

    def leaking(self, coefficient: float) -> tuple[float, ...]:
        """The rung's constants with the extra leak of :meth:`set_leak` (nothing changes)."""
        return hydraulic_vector.leaking(self._h, self.hydraulic, coefficient)

    def jammed(self, friction: float) -> tuple[float, ...]:
        """The rung's constants with the extra friction of :meth:`jam` (nothing changes)."""
        return hydraulic_vector.jammed(self._h, self.hydraulic, friction)

    def _use_constants(self, h: tuple[float, ...]) -> None:
        self.check_stiffness(h)
        self._h = h
        self.__dict__.pop("_consts", None)  # rebuilt from self._h at the next step

    def check_stiffness(self, h: tuple[float, ...] | None = None) -> int:
        """The sub-steps a physics step needs at the stiffest of the probed states (the present
        one, and at rest on either stop, where the chambers are smallest and the stop counts)
        with the constants ``h`` (default: the rung's own). Raises :class:`TooStiffError` when
        that is above ``max_substeps / STIFFNESS_MARGIN`` (module constants)."""
        h = self._h if h is None else h
        if not self._explicit:
            return math.ceil(self.dt / (self.substep or hs.DEFAULT_IMPLICIT_SUBSTEP) * (1 - 1e-12))
        c, h_arr = self._consts[0], np.array(h)
        full = self.hydraulic.supply_pressure
        probes = [(self._y, self.supply_pressure(self.t))]
        probes += [(y, full) for y in self._rest_at_stops]
        rate = max(self._rate_fn(*(float(v) for v in y[:5]), p, c, h_arr) for y, p in probes)
        return hs.substeps_within_margin(
            rate, self.dt, self.stability_fraction, self.substep, self.max_substeps, self.method
        )

    @cached_property
    def _rest_at_stops(self) -> tuple[np.ndarray, np.ndarray]:
        return tuple(equilibrium_state(s, self.p, self.hydraulic) for s in (self.s_min, self.s_max))

    def lose_supply(self, ramp_s: float = 0.0, close: bool = True) -> None:
        """The supply falls to the return pressure over ``ramp_s`` [s]. With ``close`` (the
        DRS controller's fail-safe reaction) the servo is commanded closed, which opens the
        piston side to return so that the air load can push the oil out; without it the servo
        holds its reference, the valve stays near its null and the trapped oil holds the flap
        (it then moves only as fast as the oil leaks)."""
        self.set_supply_pressure(self.hydraulic.return_pressure, ramp_s)
        if close:
            self.command_drs(False)

    def models(self, fault: str) -> bool:
        """Every fault of :data:`~drs_model.fidelity.faults.FAULTS`: this rung has the oil."""
        return True

    def check_fault(self, fault: str, value) -> None:
        """Refuse a jam or a leak that makes the rung too stiff for its step
        (:meth:`check_stiffness`, a :class:`TooStiffError`)."""
        if fault == "jam_friction_n":
            self.check_stiffness(self.jammed(value))
        elif fault == "leak_m3_per_s_per_pa":
            self.check_stiffness(self.leaking(value))

    def apply_fault(self, fault: str, value, ramp_s: float = 0.0) -> None:
        """Fault ``fault`` set to ``value`` now: a supply loss (:meth:`lose_supply`) or its end
        (the supply rises back over ``ramp_s`` [s]), a stuck valve, a leak, a jam."""
        if fault == "supply_loss":
            if value:
                self.lose_supply(ramp_s)
            else:
                self.set_supply_pressure(self.hydraulic.supply_pressure, ramp_s)
        elif fault == "stuck_valve":
            self.stick_valve(value)
        elif fault == "leak_m3_per_s_per_pa":
            self.set_leak(value)
        elif fault == "jam_friction_n":
            self.jam(value)

    # ---- commands ------------------------------------------------------------------------------
    def command_force(self, force: float) -> None:
        """The force loop's reference [N] from now on (validated as by ActuatorSim)."""
        self._force_cmd = self._checked_force(force)
        self.motion.hold_force_mode()
        self._force = self._rod_force()
        self.motion.at_stop = None

    def command_stroke(self, target: float, duration: float | None = None):
        """A move of the servo's reference to ``target`` [m], planned from the reference (not
        from the rod, which lags it and may sit a micrometre inside a compliant stop)."""
        return self.motion.command_stroke(target, duration, start=self._command_start())

    def command_trajectory(self, times, strokes=None, rates=None):
        """A trajectory of the servo's reference, planned from the reference."""
        return self.motion.command_trajectory(times, strokes, rates, start=self._command_start())

    def _command_start(self) -> tuple[float, float, float]:
        """``(s, s', s'')`` a new command starts from: the path in force, else the reference
        at rest inside the stroke range."""
        m = self.motion
        if m.mode == "stroke" and m.t < m.path.t_end:
            return m.path.at(m.t)
        return min(max(self._reference(m.t)[0], self.s_min), self.s_max), 0.0, 0.0

    def _force_now(self) -> float:
        return self._rod_force()

    def _rod_force(self) -> float:
        pa, pb = self.chamber_pressures()
        return hk.rod_force(pa, pb, float(self.motion.qd[0]), self._h)

    def _reference(self, t: float) -> tuple[float, float]:
        """The servo's stroke reference ``(s_ref, v_ref)`` [m, m/s] at ``t`` [s]."""
        ref = self.motion.reference(t)
        if ref is not None:
            return ref[0], ref[1]
        if self.mode == "hold":
            return self._hold_stroke, 0.0
        return float(self.motion.q[0]), 0.0  # force mode: the position reference is unused

    # ---- stepping ------------------------------------------------------------------------------
    def _advance_one(self) -> None:
        """One physics step in sub-steps; with ``recheck``, a sub-step whose end is stiffer than
        its length allows is taken again with the rest of the step, shorter
        (:data:`~.hydraulic_steps.RETAKE_HEADROOM`). At most ``max_substeps`` sub-steps."""
        t, t1 = self.t, self.motion.t_reset + (self.steps + 1) * self.dt
        y = self._y
        mode = hk.MODE_FORCE if self.mode == "force" else hk.MODE_STROKE
        held, f_ref = (1.0 if self._spool_held else 0.0), self._force_cmd
        watch = self.recheck and self._explicit and self.substep is None
        rate = self._stiffest(y, t)
        if watch:  # what the previous step met: a stiffening that lasts is not met again
            rate = max(rate, self._peak_rate)
        n, used, peak, k = self._substeps_for(rate, t, t1, 0), 0, 0.0, 0
        hsub = (t1 - t) / n
        while k < n:  # sub-step k of n of hsub from t
            y1 = self._substep(y, t + k * hsub, hsub, mode, f_ref, held)
            used += 1
            if watch:
                met = self._stiffest(y1, t + (k + 1) * hsub)
                if not met * hsub <= self.stability_fraction * RK4_LIMIT:  # NaN: refused below
                    rate, t = hs.RETAKE_HEADROOM * met, t + k * hsub
                    n, k = max(n - k + 1, self._substeps_for(rate, t, t1, used)), 0
                    hsub = (t1 - t) / n
                    continue
                peak = max(peak, met)
            y, k = y1, k + 1
        if not np.all(np.isfinite(y)):
            raise StiffStepError(
                f"the hydraulic state became non-finite in a step of {self.dt:.3g} s "
                f"({used} sub-steps, method {self.method!r}) at t = {self.t:.6g} s"
            )
        self._peak_rate = max(peak, hs.RATE_MEMORY * rate)
        self.motion.tick()  # t1, as computed from the reset time
        self._y = np.asarray(y, dtype=float)
        self._update_outputs()

    def _stiffest(self, y, t: float) -> float:
        """:func:`~.hydraulic_kernels.stiffest_rate` [1/s] at the state ``y`` at ``t`` [s]."""
        c, h = self._consts
        return self._rate_fn(
            float(y[0]),
            float(y[1]),
            float(y[2]),
            float(y[3]),
            float(y[4]),
            self.supply_pressure(t),
            c,
            h,
        )

    def _substeps_for(self, rate: float, t0: float, t1: float, used: int) -> int:
        return hs.substeps_needed(
            rate,
            t0,
            t1,
            used,
            self.max_substeps,
            self.method,
            self.substep,
            self.stability_fraction,
            self.guard,
            self.dt,
        )

    def _substep(self, y, ta: float, hsub: float, mode: float, f_ref: float, held: float):
        """One sub-step of ``hsub`` [s] from ``ta`` [s], split as ``locate_events`` says where the
        right-hand side is not smooth (:func:`~.hydraulic_kernels.switching_functions`)."""
        if self.locate_events is True:
            return self._events.advance(y, ta, hsub, mode, f_ref, held)
        if self.locate_events == "contacts":
            return self._contacts.advance(y, ta, hsub, mode, f_ref, held)
        return self._step_to(y, ta, hsub, mode, f_ref, held)

    def _step_to(self, y, ta: float, hsub: float, mode: float, f_ref: float, held: float):
        """One step of the method over ``[ta, ta + hsub]``, the references taken there."""
        c, h = self._consts
        s0, v0 = self._reference(ta)
        sm, vm = self._reference(ta + 0.5 * hsub)
        s1, v1 = self._reference(ta + hsub)
        return self._step_fn(
            y,
            mode,
            s0,
            v0,
            sm,
            vm,
            s1,
            v1,
            f_ref,
            self.supply_pressure(ta),
            self.supply_pressure(ta + hsub),
            held,
            hsub,
            c,
            h,
        )

    def _switches(self, y, t: float, mode: float, f_ref: float, held: float):
        c, h = self._consts
        (s_ref, v_ref), ps = self._reference(t), self.supply_pressure(t)
        psi3, psi3d, pa, pb, xv = (float(v) for v in y[:5])
        return self._switch_fn(psi3, psi3d, pa, pb, xv, mode, s_ref, v_ref, f_ref, ps, held, c, h)

    def _rate(self, y, t: float, mode: float, f_ref: float, held: float):
        c, h = self._consts
        (s_ref, v_ref), ps = self._reference(t), self.supply_pressure(t)
        return self._rhs_fn(np.asarray(y, dtype=float), mode, s_ref, v_ref, f_ref, ps, held, c, h)

    @cached_property
    def _switch_fn(self):
        return compiled_or_plain(hk.switching_functions, CALLEES)

    @cached_property
    def _stop_fn(self):
        return compiled_or_plain(hk.stop_switches, CALLEES)

    @cached_property
    def _rhs_fn(self):
        return compiled_or_plain(state_rate, CALLEES)

    @cached_property
    def _events(self) -> EventLocator:
        return EventLocator(self._step_to, self._switches, self._rate)

    @cached_property
    def _contacts(self) -> ContactLocator:
        closed, open_ = (float(y[0]) for y in self._rest_at_stops)  # psi3 at each stop
        return ContactLocator(self._step_to, self._stop_switches, self._rate, closed, open_)

    def _stop_switches(self, y, t: float, mode: float, f_ref: float, held: float):
        return self._stop_fn(float(y[0]), float(y[1]), *self._consts)
