"""Sub-steps of the hydraulic rung split where its right-hand side is not smooth.

A fixed-step method keeps its order only where the right-hand side is smooth. The hydraulic
rung's is not everywhere: a stop's contact starts with a jump of its damping force, the vapour
pressure, the relief, the servo's clips and the spool's null are kinks
(:func:`~drs_model.fidelity.hydraulic_kernels.switching_functions`). A sub-step that crosses one
makes an error of the order of the sub-step itself (a jump) or of its square (a kink), whatever
the method: at the force step's impact on the open stop, RK4 at a quarter of its stable sub-step
is then further from the truth than at the whole one.

:class:`EventLocator` takes each sub-step whole where no switching function changes sign over
it; where one does, it finds the earliest change by bisection of the step's own solution
(``BISECTIONS`` halvings), steps to just before it, and restarts just after it by a forward
Euler step of ``NUDGE`` sub-steps (so that every stage of the next step sees the new side of the
jump). The approach to the event is taken in three shrinking steps (ending ``APPROACH``, then
``NUDGE`` of the sub-step before it, then at it), so that the last stage of the long one, which
evaluates a little past its end, stays on the old side. What remains of a jump's error is of
the order of ``NUDGE`` times the sub-step.

:class:`ContactLocator` is the default rung's: it locates only the stops' contact (its start, a
jump of the damping force, and its end, where the force falls to zero), with the same
:class:`EventLocator` on those switching functions alone
(:func:`~drs_model.fidelity.hydraulic_kernels.stop_switches`, functions of the rod's angle and
rate only), and evaluates them only where the rod is past a stop at either end of a sub-step
(elsewhere no contact can begin or end in it).
"""

from __future__ import annotations

import numpy as np

#: Halvings of the sub-step in the search for an event (2^-52: the double's resolution).
BISECTIONS = 52
#: The long step towards an event ends this fraction of the sub-step before it.
APPROACH = 1e-3
#: The last approach ends, and the Euler step across the event takes, this fraction.
NUDGE = 1e-9
#: At most this many events in one sub-step (beyond them the sub-step is taken whole).
MAX_EVENTS = 16
#: A flap angle [rad] this close to a stop's counts as past it (~1e-11 m of stroke: the stroke
#: computed from the angle and the angle solved from the stop's stroke each round).
CONTACT_SLACK = 1e-9


def _crossed(g0, g1) -> bool:
    """Whether any of the functions ``g0`` (at the start) changed sign by ``g1``."""
    for a, b in zip(g0, g1, strict=True):
        if a != 0.0 and (a > 0.0) != (b > 0.0):
            return True
    return False


class EventLocator:
    """Event-located sub-steps (module docstring), from the rung's own pieces:

    ``step_to(y, t, h, mode, f_ref, held)``: the method's step of ``h`` [s] from ``t``;
    ``switches(y, t, mode, f_ref, held)``: the switching functions at ``t``;
    ``rate(y, t, mode, f_ref, held)``: the right-hand side at ``t`` (a float64 array).

    """

    def __init__(self, step_to, switches, rate) -> None:
        self._step_to, self._switches, self._rate = step_to, switches, rate
        #: Events located so far (a count, for tests and benchmarks).
        self.events = 0

    def advance(
        self, y, ta: float, hsub: float, mode: float, f_ref: float, held: float, whole=None
    ):
        """The state at ``ta + hsub`` [s] from ``y`` at ``ta``, split at each event; ``whole``:
        the method's step over the whole sub-step where the caller has taken it already."""
        args = (mode, f_ref, held)
        t, t_end = ta, ta + hsub
        for _ in range(MAX_EVENTS):
            rest = t_end - t
            if rest <= 0.0:
                return y
            y1 = self._step_to(y, t, rest, *args) if whole is None else whole
            whole = None
            g0 = self._switches(y, t, *args)
            if not _crossed(g0, self._switches(y1, t_end, *args)):
                return y1
            lo, hi = 0.0, 1.0
            for _ in range(BISECTIONS):
                mid = 0.5 * (lo + hi)
                if _crossed(
                    g0,
                    self._switches(self._step_to(y, t, mid * rest, *args), t + mid * rest, *args),
                ):
                    hi = mid
                else:
                    lo = mid
            t_event = t + lo * rest
            for t_stop in (t_event - APPROACH * hsub, t_event - NUDGE * hsub, t_event):
                if t_stop > t:
                    y = self._step_to(y, t, t_stop - t, *args)
                    t = t_stop
            y = y + NUDGE * hsub * np.asarray(self._rate(y, t, *args))
            t += NUDGE * hsub
            self.events += 1
        return self._step_to(y, t, t_end - t, *args) if t_end > t else y


class ContactLocator:
    """The stops' contact located within a sub-step, nothing else (module docstring): the
    rung's ``step_to`` and ``rate`` as for :class:`EventLocator`, ``switches`` its stops'
    (:func:`~drs_model.fidelity.hydraulic_kernels.stop_switches`, called as for
    :class:`EventLocator`), and the flap angle ``psi3`` [rad] at the closed and the open stop (the
    stroke is monotonic in it).

    A sub-step whose ends both have the rod inside the stops (by more than
    :data:`CONTACT_SLACK`) is the method's step, unchanged; only one that starts or ends past a
    stop evaluates the stops' switching functions and, where one changed sign, is split there.
    """

    def __init__(self, step_to, switches, rate, psi3_closed: float, psi3_open: float) -> None:
        self._step_to, self._switches = step_to, switches
        self.locator = EventLocator(step_to, switches, rate)
        low, high = sorted((psi3_closed, psi3_open))
        self._inside = (low + CONTACT_SLACK, high - CONTACT_SLACK)
        self._last = (None, None)  # the last sub-step's end and its switching functions

    def advance(self, y, ta: float, hsub: float, mode: float, f_ref: float, held: float):
        """The state at ``ta + hsub`` [s] from ``y`` at ``ta``, split where a contact begins or
        ends."""
        args = (mode, f_ref, held)
        y1 = self._step_to(y, ta, hsub, *args)
        low, high = self._inside
        if low < y[0] < high and low < y1[0] < high:
            return y1
        # on a stop for many sub-steps: each start's functions are the previous end's
        g0 = self._last[1] if self._last[0] is y else self._switches(y, ta, *args)
        g1 = self._switches(y1, ta + hsub, *args)
        if _crossed(g0, g1):
            y1 = self.locator.advance(y, ta, hsub, *args, y1)
            g1 = self._switches(y1, ta + hsub, *args)
        self._last = (y1, g1)
        return y1
