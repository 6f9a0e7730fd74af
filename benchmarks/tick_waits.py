"""Where the node's tick thread waits: the kernel's scheduler events of one run, read back.

The node runs as in ``node_vs_floor.py`` (``node_vs_floor.node_run``: both recordings, the
listener, the command client's ``--load``, an optional ``--flood``); meanwhile ``perf record``
takes every context switch, waking and wake-up of the machine, with call chains, for
``--record`` s. Each time the node's main thread (the tick thread) leaves its core is one
*block*, from the switch that took it off to the switch that put it back, named by the state
the kernel gives it (``R``: preempted while running) or else by the C function it stopped in:

* ``clock_nanosleep``: the deadline loop's sleep to the next tick (wanted);
* ``__futex_abstimed_wait_common``: a condition or timed wait: the GIL (CPython waits for it in
  steps of the switch interval), a Python lock, or a Fast DDS mutex or condition;
* ``__lll_lock_wait`` (glibc's ``__GI___lll_lock_wait``): a plain mutex (the GIL's own, a Fast
  DDS lock).

A block other than the sleep that lasts more than half a publish period is where a late tick's
time goes (a missed deadline is a tick more than 1.5 periods after the last). For those, the
thread that woke the main thread is named (``sched_waking``, reported in the waking thread), and
whether it is one of the node's own threads (the executor, a Fast DDS thread, a recorder) or
another process's; a wait that ran out is woken by its timer (named ``its own timeout``). The
scheduling delay (woken to running) is reported apart: under SCHED_FIFO it is the machine's.

perf's own recording costs CPU, and it can lose events: a block with a second switch off before
its switch on, or with a switch or a waking by the main thread itself inside it, is left out,
not counted as a long one (before this rule, lost events showed as sleeps of 10-18 ms that
never happened).

Needs ``perf`` with the ``sched`` tracepoints (root, or ``perf_event_paranoid`` <= -1); says so
and exits 2 without it. Nothing is asserted: the figures are read by a person, in
``benchmarks/results/node_rate.md``.

Usage: ``python benchmarks/tick_waits.py [--rate 1000] [--load mix] [--flood 0] [--duration 12]
[--record 5] [--domain 98]``
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

#: The C function a blocked thread stopped in, as the report names it.
REASONS = {
    "clock_nanosleep": "deadline sleep",
    "__futex_abstimed_wait_common": "timed wait (GIL, a lock, a Fast DDS wait)",
    "lll_lock_wait": "mutex (the GIL's, a Fast DDS lock)",
}
#: The reason of a block the kernel took the thread off while it could run (``prev_state`` R).
PREEMPTED = "preempted while running"
#: perf's ring buffer per core [pages]: with call chains on every switch, the default loses
#: events under a command flood.
PERF_BUFFER_PAGES = 4096
#: Seconds the node runs before the recording starts (start-up, the listener matched).
WARM_S = 4.0

_EVENT = re.compile(
    r"^\s*(\d+)/(\d+)\s+([\d.]+):\s+sched:(sched_switch|sched_wakeup|sched_waking):\s+(.*)$"
)
_SWITCH = re.compile(
    r"prev_comm=(.*) prev_pid=(\d+) .*prev_state=(\S+) ==> next_comm=(.*) next_pid=(\d+)"
)
_WAKEUP = re.compile(r"comm=(.*) pid=(\d+) prio=")


@dataclass(frozen=True)
class Block:
    """One stretch of time the main thread was off its core: from ``start`` to ``end`` [s],
    stopped in ``frame`` (a C function) in ``state`` (the kernel's ``prev_state``: ``S`` or
    ``D`` asleep, ``R`` preempted); ``waker``: the thread that woke it, ``(pid, tid, name)``,
    ``(0, 0, "timer")`` for a timer's expiry, and ``woken`` when [s] (both None: preempted,
    runnable all along)."""

    start: float
    end: float
    frame: str
    state: str
    waker: tuple[int, int, str] | None
    woken: float | None

    @property
    def seconds(self) -> float:
        return self.end - self.start

    @property
    def delay(self) -> float | None:
        """Seconds from its wake-up to running again (the scheduler's part), None if preempted."""
        return None if self.woken is None else self.end - self.woken

    @property
    def reason(self) -> str:
        if self.state.startswith("R"):  # runnable: taken off its core, wherever it was
            return PREEMPTED
        for name, text in REASONS.items():
            if name in self.frame:
                return text
        return f"other ({self.frame})"


@dataclass(frozen=True)
class Event:
    """One scheduler event of ``perf script -F pid,tid,time,event,trace,ip,sym``: the running
    thread's ``pid`` and ``tid``, ``time`` [s], ``kind`` (``sched_switch``, ``sched_waking`` or
    ``sched_wakeup``), ``fields`` (a switch: ``(prev name, prev tid, next name, next tid, prev
    state)``; a waking or wake-up: ``(woken name, woken tid)``) and ``chain``, the call chain's
    function names, innermost first, each ``k:`` (the kernel's) or ``u:``."""

    pid: int
    tid: int
    time: float
    kind: str
    fields: tuple
    chain: tuple[str, ...]

    def first_user_frame(self) -> str:
        """The first function of the chain outside the kernel (``?`` when none is named)."""
        for frame in self.chain:
            if frame[0] != "k":
                return frame[2:].split("+")[0].strip()
        return "?"


def parse_script(text: str) -> list[Event]:
    """The events of ``perf script -F pid,tid,time,event,trace,ip,sym`` (call chains recorded):
    each header line, then its chain as ``k:<function>`` (a kernel address) or ``u:<function>``."""
    out = []
    for block in text.split("\n\n"):
        lines = block.strip("\n").splitlines()
        if not lines:
            continue
        m = _EVENT.match(lines[0])
        if not m:
            continue
        pid, tid, t, kind, rest = int(m[1]), int(m[2]), float(m[3]), m[4], m[5]
        if kind == "sched_switch":
            f = _SWITCH.search(rest)
            fields = (f[1], int(f[2]), f[4], int(f[5]), f[3]) if f else None
        else:
            f = _WAKEUP.search(rest)
            fields = (f[1], int(f[2])) if f else None
        if fields is None:
            continue
        chain = []
        for line in lines[1:]:
            parts = line.split(None, 1)
            if len(parts) == 2:
                chain.append(("k:" if parts[0].startswith("ffffffff") else "u:") + parts[1])
        out.append(Event(pid, tid, t, kind, fields, tuple(chain)))
    return out


def blocks_of(main_tid: int, events: list[Event]) -> list[Block]:
    """The main thread's blocks, in the events' order: each switch off its core to its next
    switch on, with the first waking of it in between (``sched_waking``, reported in the thread
    that wakes it; ``sched_wakeup`` when no waking was recorded: the kernel may report that one
    on the woken thread's idle core). A timer's expiry is named ``timer``, whichever thread the
    interrupt came in. A block is left out when perf lost part of it: a second switch off before
    a switch on, or a switch or waking by the main thread itself in between (it was running)."""
    events = sorted(events, key=lambda e: e.time)  # stable: perf's order kept within a tick
    wake_kind = (
        "sched_waking"
        if any(e.kind == "sched_waking" and e.fields[1] == main_tid for e in events)
        else "sched_wakeup"
    )
    names: dict[int, str] = {}
    for e in events:
        if e.kind == "sched_switch":
            names[e.fields[1]], names[e.fields[3]] = e.fields[0], e.fields[2]
    out: list[Block] = []
    start = None  # (the switch off, waker, woken, intact) of the open block
    for e in events:
        if e.kind == "sched_switch" and e.fields[1] == main_tid:
            start = (e, None, None, True)  # an open block without its end: lost, replaced
        elif start is None:
            continue
        elif e.kind == "sched_switch" and e.fields[3] == main_tid:
            off, waker, woken, intact = start
            if intact:
                state = off.fields[4]
                out.append(Block(off.time, e.time, off.first_user_frame(), state, waker, woken))
            start = None
        elif e.tid == main_tid and e.kind != "sched_wakeup":
            # it ran meanwhile: events lost (a wake-up is not evidence: the kernel may report
            # it on the woken thread's core, under whichever thread perf last saw there)
            start = (start[0], start[1], start[2], False)
        elif e.kind == wake_kind and e.fields[1] == main_tid and start[1] is None:
            timer = any("hrtimer_wakeup" in frame for frame in e.chain)
            waker = (0, 0, "timer") if timer else (e.pid, e.tid, names.get(e.tid, "?"))
            start = (start[0], waker, e.time, start[3])
    return out


def quantile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(int(q * len(ordered)), len(ordered) - 1)] if ordered else float("nan")


def report(blocks: list[Block], node_pid: int, period_s: float) -> str:
    """The blocks by reason, the long ones' wakers, the scheduling delays: text for a person."""
    lines = [f"the main thread's blocks ({len(blocks)}), by where it stopped:"]
    by_reason: dict[str, list[float]] = {}
    for b in blocks:
        by_reason.setdefault(b.reason, []).append(b.seconds)
    half_period_s = period_s / 2
    for reason, secs in sorted(by_reason.items(), key=lambda kv: -sum(kv[1])):
        # a sleep to the next deadline lasts up to a period; any other wait, hardly any time
        bound, named = (
            (period_s, "a period")
            if reason == REASONS["clock_nanosleep"]
            else (half_period_s, "half a period")
        )
        lines.append(
            f"  {reason}: {len(secs)}, {1e3 * sum(secs):.1f} ms in all, p50 "
            f"{1e6 * quantile(secs, 0.5):.0f} us, p99 {1e6 * quantile(secs, 0.99):.0f} us, max "
            f"{1e6 * max(secs):.0f} us, {sum(s > bound for s in secs)} over {named}"
        )
    long_waits = [
        b
        for b in blocks
        if b.seconds > half_period_s and b.reason not in (REASONS["clock_nanosleep"], PREEMPTED)
    ]
    lines.append(
        f"waits over half a period ({1e6 * half_period_s:.0f} us), by the thread that ended them:"
    )
    wakers: dict[str, int] = {}
    for b in long_waits:
        if b.waker is None:
            who = "none (preempted)"
        elif b.waker[2] == "timer":
            who = "its own timeout (no thread)"
        elif b.waker[0] == 0:
            who = "the kernel on an idle core (an interrupt)"
        else:
            pid, _tid, name = b.waker
            who = f"{name} ({'the node' if pid == node_pid else 'another process'})"
        wakers[who] = wakers.get(who, 0) + 1
    for who, n in sorted(wakers.items(), key=lambda kv: -kv[1]):
        lines.append(f"  {who}: {n}")
    delays = [b.delay for b in blocks if b.delay is not None]
    if delays:
        lines.append(
            f"scheduling delay (woken to running): p50 {1e6 * quantile(delays, 0.5):.0f} us, "
            f"p99 {1e6 * quantile(delays, 0.99):.0f} us, max {1e6 * max(delays):.0f} us, "
            f"{sum(d > half_period_s for d in delays)} over half a period"
        )
    return "\n".join(lines)


def find_node(parent_pid: int, timeout_s: float = 20.0) -> int:
    """The pid of the ``drs-node`` a child of ``parent_pid`` runs (``node_run`` starts it)."""
    give_up = time.monotonic() + timeout_s
    while time.monotonic() < give_up:
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit():
                continue
            try:
                ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
                cmd = (entry / "cmdline").read_bytes()
            except (OSError, IndexError, ValueError):
                continue
            if ppid == parent_pid and (b"drs-node" in cmd or b"drs_ros" in cmd):
                return int(entry.name)
        time.sleep(0.1)
    raise RuntimeError("the node did not start")


def perf_available() -> str | None:
    """Why ``perf`` cannot record the scheduler here, or None when it can."""
    if shutil.which("perf") is None:
        return "no perf on PATH"
    probe = subprocess.run(
        ["perf", "record", "-e", "sched:sched_switch", "-a", "-o", os.devnull, "--", "true"],
        capture_output=True,
        text=True,
    )
    if probe.returncode != 0:
        return f"perf cannot record sched:sched_switch: {probe.stderr.strip()[:200]}"
    return None


def main(argv: list[str] | None = None) -> int:
    from node_vs_floor import LOADS, node_run

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=1000.0, help="publish rate [Hz]")
    ap.add_argument("--load", choices=list(LOADS), default="mix", help="the client's commands")
    ap.add_argument("--flood", type=float, default=0.0, help="stroke-command flood [Hz]")
    ap.add_argument("--duration", type=float, default=12.0, help="seconds the node is measured")
    ap.add_argument("--record", type=float, default=5.0, help="seconds perf records")
    ap.add_argument("--domain", type=int, default=98)
    args = ap.parse_args(argv)
    why = perf_available()
    if why:
        print(f"tick_waits: {why}", file=sys.stderr)
        return 2
    if args.duration < WARM_S + args.record:
        print(
            f"tick_waits: --duration {args.duration:g} s does not cover the {WARM_S:g} s "
            f"before the recording and --record {args.record:g} s",
            file=sys.stderr,
        )
        return 2
    env = dict(
        os.environ, ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    with tempfile.TemporaryDirectory() as d:
        result: dict = {}
        failure: list[BaseException] = []

        def run_node() -> None:
            try:
                result.update(
                    node_run(
                        args.rate,
                        args.duration,
                        ["joint_states"],
                        env,
                        Path(d) / "node",
                        args.domain,
                        args.flood or None,
                        args.load,
                    )
                )
            except BaseException as exc:  # noqa: BLE001 - raised again in the main thread
                failure.append(exc)

        runner = threading.Thread(target=run_node)
        runner.start()
        data = Path(d) / "perf.data"
        try:  # the node's run ends (node_run's own timeouts) before its directory goes
            node_pid = find_node(os.getpid())
            time.sleep(WARM_S)
            record = subprocess.run(
                ["perf", "record", "-q", "-a", "-g", "-m", str(PERF_BUFFER_PAGES)]
                + ["-e", "sched:sched_switch", "-e", "sched:sched_waking"]
                + ["-e", "sched:sched_wakeup", "-o", str(data), "--", "sleep", str(args.record)],
                capture_output=True,
                text=True,
            )
        finally:
            runner.join()
        if failure:
            raise failure[0]
        if record.returncode != 0:
            raise RuntimeError(f"perf record failed: {record.stderr.strip()[:500]}")
        script = subprocess.run(
            ["perf", "script", "--ns", "-i", str(data), "-F", "pid,tid,time,event,trace,ip,sym"],
            capture_output=True,
            text=True,
            check=True,
        )
        events = parse_script(script.stdout)
    blocks = blocks_of(node_pid, events)
    what = f"{args.rate:g} Hz, load {args.load}" + (
        f", flood {args.flood:g} Hz" if args.flood else ""
    )
    print(
        f"node at {what}, the whole run: {100 * result['cpu_share']:.1f} % of a core, missed "
        f"{result['missed']}/{result['ticks']}; perf recorded {args.record:g} s of it, from "
        f"{WARM_S:g} s after the node's start"
    )
    print(report(blocks, node_pid, 1.0 / args.rate))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
