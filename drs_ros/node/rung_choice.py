"""Which rung of :mod:`drs_model.fidelity` the node runs: a part of
:class:`drs_ros.node.adapter.DRSNode` that builds the actuator from the node's parameters and,
under ``fidelity: auto``, chooses the lowest rung that meets the tolerances for what the node's
subscribers ask (:func:`drs_model.fidelity.auto.choose_rung`), once, before the first step.
"""

from __future__ import annotations

import time

from drs_model import path_range
from drs_model.fidelity import RUNGS, make_rung
from drs_model.fidelity.auto import choose_rung, ladder_errors


class RungChoice:
    """The rung of one configured node (``fidelity``, a rung's name or ``auto``).

    ``auto`` runs ``rigid`` until the subscribers are seen; each rung's errors are measured at
    construction, for ``params`` (a few seconds, once per parameters). ``params``: the
    DRSParams and HydraulicParams the node runs (the latter given to the hydraulic rung, and to
    the reference ``auto`` measures the others against). ``options``: the node's
    ``force_limit``, ``integrator``, ``force_method`` and ``limit_moves``; ``tolerance`` [m] and
    ``force_tolerance`` [N]: the node's ``fidelity_tolerance`` and
    ``fidelity_force_tolerance``."""

    def __init__(
        self,
        fidelity: str,
        params,
        physics_dt: float,
        options: dict,
        tolerance: float,
        force_tolerance: float,
    ) -> None:
        (self.params, self.hydraulic), self.physics_dt = params, physics_dt
        self.fidelity = fidelity
        self.options, self.tolerance, self.force_tolerance = options, tolerance, force_tolerance
        self._errors = ladder_errors(*params) if fidelity == "auto" else None
        #: Monotonic time [s] until which auto waits for the subscribers (None: chosen).
        self.deadline: float | None = None

    @property
    def auto(self) -> bool:
        return self.fidelity == "auto"

    def make(self, rung: str):
        """A new actuator of rung ``rung``, at rest."""
        extra = {"hydraulic": self.hydraulic} if rung == RUNGS["hydraulic"].name else {}
        options = dict(self.options)
        if self.auto:  # auto's rungs take the method options only where they use them
            for option in ("integrator", "force_method"):
                if option not in RUNGS[rung].method_options:
                    options.pop(option, None)
        return make_rung(rung, self.params, self.physics_dt, **options, **extra)

    def first(self):
        """The actuator the node starts with (a model too stiff for the physics rate raises
        :class:`~drs_model.errors.TooStiffError` now, not a refusal at every tick). Its moves'
        force check is run once now, on the ``~/drs`` moves from rest: it loads the compiled
        path scan (:mod:`drs_model.inverse.path_peak`, ~5 ms from numba's cache), which the
        first command's tick paid before (a missed deadline), and keeps those moves' peaks; the
        compiled hull check of a move's path (:mod:`drs_model.path_range`) is loaded too."""
        sim = self.make("rigid" if self.auto else self.fidelity)
        sim.check_stiffness()
        for open_flap in (True, False):
            sim.drs_duration(open_flap)  # changes nothing but the kept peaks and answer
        path_range.load_compiled()
        return sim

    def wait_for_subscribers(self, seconds: float) -> None:
        """auto: choose after ``seconds`` of discovery."""
        self.deadline = time.monotonic() + seconds

    def choose(self, asked: set[str]) -> str:
        """The rung for what the subscribers ask (``gap``, ``force``, ``hydraulics``)."""
        self.deadline = None
        return choose_rung(asked, self.tolerance, self.force_tolerance, self._errors)


__all__ = ["RungChoice"]
