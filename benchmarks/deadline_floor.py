"""The machine's own floor for the node's deadline goals: a bare Python loop that sleeps to
absolute deadlines as the node's tick thread does (``drs_ros.node.runner.run_deadline_loop``:
``time.sleep`` to the deadline, resume from now after a late tick; SCHED_FIFO when allowed,
through the node's own ``apply_tick_policy``), with no ROS, no model and no recording, and
``--work-us`` of busy work per tick in place of the tick.

It counts what the node's diagnostics count: a tick more than 1.5 periods after the last is a
missed deadline (``SimulationClock``), and the lateness against the absolute deadline in the
node's histogram (``LatenessHistogram``: p50, p99 as its bins' upper edges, max). Whatever this
loop misses, the node cannot do better on the same machine. The CPU time the hypervisor took from
the guest meanwhile (``steal`` in ``/proc/stat``, both cores) is printed beside.

``--policies fifo other`` measures the loop under each scheduling policy, alternated: under
SCHED_OTHER it shows what the machine does to any thread (its stalls of several ms).

Usage: ``python benchmarks/deadline_floor.py [--rate 1000] [--duration 10] [--repeats 2]
[--work-us 0 300] [--policies fifo other]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from drs_ros.node.tick import SimulationClock
from drs_ros.node.tick_schedule import (
    TICK_SCHEDULING,
    LatenessHistogram,
    apply_tick_policy,
    leave_tick_policy,
)

RESULTS = Path(__file__).with_name("results") / "deadline_floor.json"
CLK_TCK = os.sysconf("SC_CLK_TCK")


def steal_s() -> float:
    """CPU time [s] the hypervisor took from this guest so far, summed over the cores."""
    total = 0
    for line in Path("/proc/stat").read_text().splitlines():
        if line.startswith("cpu") and not line.startswith("cpu "):
            total += int(line.split()[8])
    return total / CLK_TCK


class DeadlineLoop:
    """The tick thread's loop (``time.sleep`` to absolute deadlines at ``rate_hz``, resumed from
    now after a tick late by more than a period), counted by the node's own parts: its clock's
    missed deadline and its lateness histogram."""

    def __init__(self, rate_hz: float) -> None:
        self.period_ns = round(1e9 / rate_hz)
        # the steady clock, as the node's wall clock is: a clock built for /clock time
        # (False) counts no missed deadline at all, and the floor then showed none
        self.clock = SimulationClock(True, self.period_ns)
        self.lateness = LatenessHistogram()
        self.missed = 0

    def ticks(self, duration_s: float):
        """Wake at each deadline for ``duration_s`` [s], counting it; yield the wake-up time [ns]
        (the caller's work a tick runs between two wake-ups)."""
        deadline = time.monotonic_ns()
        end = deadline + round(duration_s * 1e9)
        while deadline < end:
            deadline += self.period_ns
            wait = deadline - time.monotonic_ns()
            if wait > 0:
                time.sleep(wait / 1e9)
            now = time.monotonic_ns()
            self.lateness.add(now - deadline)
            if now - deadline > self.period_ns:  # late by more than a period: resume from now
                # before the tick's work, as the node's loop does (run_deadline_loop)
                self.lateness.skipped += (now - deadline) // self.period_ns
                deadline = time.monotonic_ns()
            if self.clock.since_last_if_late(now) is not None:
                self.missed += 1
            self.clock.ticked(now, now)
            yield now

    def counts(self) -> dict:
        """Ticks, missed deadlines and lateness quantiles [us] so far."""
        lateness = self.lateness
        return {
            "ticks": lateness.count,
            "missed": self.missed,
            "missed_share": self.missed / max(lateness.count, 1),
            "lateness_p50_us": lateness.quantile_us(0.5),
            "lateness_p99_us": lateness.quantile_us(0.99),
            "lateness_max_us": lateness.max_ns / 1e3,
            "skipped_deadlines": lateness.skipped,
        }


def publish_on_deadlines(pubs, rate_hz: float, warm_s: float, duration_s: float, tick_cpu=-1):
    """Publish ``pubs`` (``(publisher, bytes)``) at each deadline of a :class:`DeadlineLoop` at
    ``rate_hz``, under the node's default tick policy (SCHED_FIFO 10 where allowed; on CPU
    ``tick_cpu`` as the node's ``tick_cpu``, -1: any): ``warm_s`` not counted, then
    ``duration_s``; returns ``(process CPU [s], wall [s], the loop, the policy's text)``."""
    policy = apply_tick_policy("fifo", 10, tick_cpu)  # the node's default priority
    try:
        if tick_cpu >= 0 and policy.cpu != tick_cpu:  # a floor measured elsewhere is no floor
            raise SystemExit(f"the floor's loop could not be kept on CPU {tick_cpu}: {policy.note}")
        for _ in DeadlineLoop(rate_hz).ticks(warm_s):  # not counted
            for pub, data in pubs:
                pub.publish(data)
        loop = DeadlineLoop(rate_hz)
        cpu0, wall0 = time.process_time(), time.monotonic()
        for _ in loop.ticks(duration_s):
            for pub, data in pubs:
                pub.publish(data)
        return time.process_time() - cpu0, time.monotonic() - wall0, loop, policy.text()
    finally:
        leave_tick_policy(policy)


def run(rate_hz: float, duration_s: float, work_us: float) -> dict:
    """One loop of ``duration_s`` at ``rate_hz`` with ``work_us`` of busy work per tick."""
    loop = DeadlineLoop(rate_hz)
    steal0 = steal_s()
    for _ in loop.ticks(duration_s):
        if work_us:
            stop = time.perf_counter() + work_us * 1e-6
            while time.perf_counter() < stop:
                pass
    return {"work_us": work_us, **loop.counts(), "steal_s": steal_s() - steal0}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=1000.0, help="ticks per second [Hz]")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds per loop")
    ap.add_argument("--repeats", type=int, default=2, help="loops per amount of work, alternated")
    ap.add_argument(
        "--work-us",
        type=float,
        nargs="+",
        default=[0.0, 300.0],
        help="busy work per tick [us], each measured",
    )
    ap.add_argument(
        "--policies",
        nargs="+",
        choices=TICK_SCHEDULING,
        default=["fifo"],
        help="the tick thread's scheduling, each measured: fifo (the node's default, "
        "priority 10, when allowed) or other (SCHED_OTHER, as any thread)",
    )
    ap.add_argument("--output", type=Path, default=RESULTS)
    args = ap.parse_args()
    print(f"deadline loop at {args.rate:g} Hz")
    runs = []
    for _ in range(args.repeats):
        for requested in args.policies:
            for work in args.work_us:
                policy = apply_tick_policy(requested, 10)  # the node's default priority
                try:
                    r = {
                        "policy_requested": requested,
                        "policy": policy.text(),
                        **run(args.rate, args.duration, work),
                    }
                finally:
                    leave_tick_policy(policy)
                runs.append(r)
                print(
                    f"{r['policy']}, work {work:5g} us a tick: missed {r['missed']}/{r['ticks']} "
                    f"({100 * r['missed_share']:.2f} %), lateness p50/p99/max "
                    f"{r['lateness_p50_us']:.0f}/{r['lateness_p99_us']:.0f}/"
                    f"{r['lateness_max_us']:.0f} us, steal {r['steal_s']:.2f} s",
                    flush=True,
                )
    for name in dict.fromkeys(r["policy"] for r in runs):
        for work in args.work_us:
            mine = [r for r in runs if r["work_us"] == work and r["policy"] == name]
            print(
                f"{name}, work {work:5g} us: median missed "
                f"{100 * statistics.median(r['missed_share'] for r in mine):.2f} %, p99 "
                f"{statistics.median(r['lateness_p99_us'] for r in mine):.0f} us, max "
                f"{statistics.median(r['lateness_max_us'] for r in mine):.0f} us (medians "
                "of the runs')"
            )
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps({"rate_hz": args.rate, "runs": runs}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
