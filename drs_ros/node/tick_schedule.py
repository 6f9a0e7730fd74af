"""The tick thread's scheduling: the policy it runs under (``SCHED_FIFO`` when the process may
have it, else the ordinary ``SCHED_OTHER`` with the reason) and the lateness of its ticks
against their absolute deadlines, kept in a fixed histogram.

Why ``SCHED_FIFO``: a tick thread sleeping to absolute deadlines under it held 1 kHz with two
busy processes beside it (p99 period 1.04 ms), against a p99 period of 4.7-9.3 ms without it
(docs/ros.md, "Rate"). It needs root, ``CAP_SYS_NICE`` or an rtprio limit; without them the
node runs as before and says why. The thread may also be kept on one CPU (``tick_cpu``,
:func:`pin_to_cpu`).
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass

#: The ``tick_scheduling`` choices: ``fifo`` asks for SCHED_FIFO (the ordinary policy when the
#: process may not have it), ``other`` keeps the ordinary time-sharing policy.
TICK_SCHEDULING = ("fifo", "other")

#: The ``tick_fifo_priority`` range (Linux's SCHED_FIFO priorities are 1..99; 99 is left to
#: the kernel's own threads).
FIFO_PRIORITY_RANGE = (1, 98)

#: The ``tick_cpu`` range: -1 leaves the tick thread on every CPU the process may use; 0 and up
#: name the one CPU it is kept on (one the system lets a thread take: checked at configure).
TICK_CPU_RANGE = (-1, 1023)

#: Upper edges [us] of the lateness bins: 1 us wide up to 100 us, then 10 us to 1 ms, then
#: 100 us to 10 ms, then 10 ms to 1 s; a lateness beyond lands in one more bin, reported as the
#: largest lateness seen. 380 bins: the memory does not grow with the ticks.
_EDGES_US = (
    list(range(1, 101))
    + list(range(110, 1001, 10))
    + list(range(1100, 10001, 100))
    + list(range(20000, 1000001, 10000))
)


@dataclass(frozen=True)
class TickPolicy:
    """The policy the tick thread runs under: ``name`` (``SCHED_FIFO`` or ``SCHED_OTHER``),
    ``priority`` (0 for SCHED_OTHER) and ``note``: why it is not the one asked for ('' when
    it is); ``cpu``: the one CPU it is kept on (-1: none), and ``cpus_before`` the CPUs it
    could use before (given back when the loop ends)."""

    name: str
    priority: int
    note: str = ""
    cpu: int = -1
    cpus_before: tuple[int, ...] = ()

    def text(self) -> str:
        """One line for the log and diagnostics."""
        prio = f" priority {self.priority}" if self.name == "SCHED_FIFO" else ""
        on = f" on CPU {self.cpu}" if self.cpu >= 0 else ""
        return f"{self.name}{prio}{on}" + (f" ({self.note})" if self.note else "")


def usable_cpus() -> frozenset[int]:
    """The CPUs the calling thread may run on now (all of them where the system cannot say)."""
    if hasattr(os, "sched_getaffinity"):
        return frozenset(os.sched_getaffinity(0))
    return frozenset(range(os.cpu_count() or 1))


def _keep_on(cpu: int) -> str | None:
    """Keep the calling thread on CPU ``cpu``; why the system refused (None: done)."""
    if not hasattr(os, "sched_setaffinity"):
        return "keeping a thread on one CPU is not offered on this system"
    try:
        os.sched_setaffinity(0, {cpu})
    except (OSError, ValueError, OverflowError) as exc:
        return str(exc)
    return None


def cpu_refusal(cpu: int) -> str | None:
    """Why the system would not keep a thread on CPU ``cpu`` (None: it would), asked of the
    system itself from a short-lived thread: a CPU left out of the process's own CPUs (an
    ``isolcpus`` one, the usual home of a real-time thread) is still one a thread may take."""
    refused: list[str | None] = []
    thread = threading.Thread(target=lambda: refused.append(_keep_on(cpu)), name="tick-cpu-check")
    thread.start()
    thread.join()
    return refused[0]


def apply_tick_policy(requested: str, priority: int, cpu: int = -1) -> TickPolicy:
    """Put the calling thread under the ``requested`` policy (of :data:`TICK_SCHEDULING`);
    ``priority`` is the SCHED_FIFO priority; ``cpu`` >= 0 keeps the thread on that one CPU
    (:func:`pin_to_cpu`). On Linux ``sched_setscheduler(0, ...)`` and ``sched_setaffinity(0,
    ...)`` change the calling thread only: threads started before keep theirs, threads it
    starts later inherit both (the node's tick thread starts none). When the process
    may not have SCHED_FIFO (EPERM: no root, no CAP_SYS_NICE, no rtprio limit; or no such call
    on this system) the thread keeps SCHED_OTHER and the returned policy's note says why."""
    return pin_to_cpu(_scheduling(requested, priority), cpu)


def pin_to_cpu(policy: TickPolicy, cpu: int) -> TickPolicy:
    """``policy`` with the calling thread kept on CPU ``cpu`` (-1: left as it is). Why: at 1 kHz,
    on a machine of 2 CPUs with the tick under SCHED_FIFO, the node took 1.3 points of a core
    less with its tick thread kept on one CPU (median of 17 interleaved pairs, 15 lower; at
    250 Hz no gain: benchmarks/results/node_rate.md, 2026-11-29); likely its caches, which a
    thread woken on whichever CPU is free leaves behind. A CPU the system refuses (offline
    since the node was configured) leaves the thread where it was, and the note says so. The
    kernel may drop the pin later (the CPU taken offline, the cpuset rewritten) without a
    word."""
    if cpu < 0:
        return policy
    before = tuple(sorted(usable_cpus()))
    refusal = _keep_on(cpu)
    if refusal is not None:
        note = "; ".join(filter(None, (policy.note, f"CPU {cpu} asked for, refused: {refusal}")))
        return TickPolicy(policy.name, policy.priority, note)
    return TickPolicy(policy.name, policy.priority, policy.note, cpu, before)


def _scheduling(requested: str, priority: int) -> TickPolicy:
    if requested != "fifo":
        return TickPolicy("SCHED_OTHER", 0)
    if not hasattr(os, "sched_setscheduler"):
        return TickPolicy("SCHED_OTHER", 0, "SCHED_FIFO asked for: not offered on this system")
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError as exc:
        why = exc.strerror or str(exc)
        return TickPolicy(
            "SCHED_OTHER",
            0,
            f"SCHED_FIFO asked for, refused ({why}): it needs "
            "root, CAP_SYS_NICE or an rtprio limit",
        )
    except OSError as exc:
        return TickPolicy("SCHED_OTHER", 0, f"SCHED_FIFO asked for, refused: {exc}")
    return TickPolicy("SCHED_FIFO", priority)


def leave_tick_policy(policy: TickPolicy) -> None:
    """Put the calling thread back under SCHED_OTHER when ``policy`` is SCHED_FIFO: the loop
    ends, and what follows (the executor's shutdown, the recordings' finish, the interpreter's
    exit) runs as any thread does. Under SCHED_FIFO the exit was not preempted by the
    middleware's and the recorders' own threads still winding down, and 1 stop in ~30 ended in
    a heap abort after the recordings had finished (``benchmarks/shutdown_stress.py``)."""
    # each step on its own: a failing one must not keep the next, nor the loop's shutdown after
    if policy.name == "SCHED_FIFO":
        try:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        except OSError:
            pass  # the shutdown then runs real-time: it still runs
    if policy.cpu >= 0 and policy.cpus_before:  # and back on the CPUs it could use before
        try:
            os.sched_setaffinity(0, policy.cpus_before)
        except OSError:
            pass  # none of them usable any more (a cpuset shrunk meanwhile): it stays pinned


class LatenessHistogram:
    """Lateness [ns] of each tick against its absolute deadline, in fixed bins (
    :data:`_EDGES_US`): adding one costs a bisection and an increment, nothing is allocated per
    tick. ``skipped`` counts the deadlines a late tick left out (the loop resumes from now)."""

    def __init__(self) -> None:
        self._edges_ns = [1000 * e for e in _EDGES_US] + [2**63 - 1]  # and beyond 1 s
        self._counts = [0] * len(self._edges_ns)
        self.count = 0
        self.max_ns = 0
        self.skipped = 0

    def add(self, lateness_ns: int) -> None:
        """One tick ``lateness_ns`` after its deadline (a negative value counts as 0)."""
        lateness_ns = max(lateness_ns, 0)
        lo, hi = 0, len(self._edges_ns) - 1
        while lo < hi:  # the first bin whose upper edge is >= lateness
            mid = (lo + hi) // 2
            if self._edges_ns[mid] < lateness_ns:
                lo = mid + 1
            else:
                hi = mid
        self._counts[lo] += 1
        self.count += 1
        if lateness_ns > self.max_ns:
            self.max_ns = lateness_ns

    def quantile_us(self, q: float) -> float:
        """The upper edge [us] of the bin holding quantile ``q`` (0..1) of the ticks (at most
        the largest lateness seen); 0 before the first tick."""
        if self.count == 0:
            return 0.0
        rank = q * self.count
        seen = 0
        for edge_ns, n in zip(self._edges_ns, self._counts, strict=True):
            seen += n
            if seen >= rank and n:
                return min(edge_ns, self.max_ns) / 1000.0
        return self.max_ns / 1000.0

    def values(self) -> dict[str, object]:
        """What diagnostics report: p50, p99 and max [us], the ticks measured and skipped."""
        return {
            "tick_lateness_p50_us": f"{self.quantile_us(0.5):.0f}",
            "tick_lateness_p99_us": f"{self.quantile_us(0.99):.0f}",
            "tick_lateness_max_us": f"{self.max_ns / 1000.0:.0f}",
            "skipped_ticks": self.skipped,
        }


__all__ = [
    "FIFO_PRIORITY_RANGE",
    "TICK_SCHEDULING",
    "LatenessHistogram",
    "TickPolicy",
    "TICK_CPU_RANGE",
    "apply_tick_policy",
    "cpu_refusal",
    "leave_tick_policy",
    "pin_to_cpu",
    "usable_cpus",
]
