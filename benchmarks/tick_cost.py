"""What one tick of the drs node costs in CPU, part by part (1 kHz physics, 1 kHz publish).

A real :class:`~drs_ros.node.DRSNode` is built in this process (``tick_timer=False``, the MCAP
bag and the rerun ``.rrd`` recorded into a temporary directory, /tf on at ``tf_rate_hz``) and
its :meth:`tick` is called ``--ticks`` times, the node clock advancing one publish period per
call (a clock of this benchmark, so that the machine's load cannot make ticks late or catch
up). A listener in another process subscribes to ``/joint_states`` and ``/tf`` (``--listener
none``: no one), so that each publish pays DDS's delivery as it does beside a real consumer.
Every 100 ticks a stroke command arrives through the node's intake (the executor thread's work,
timed apart), and every 1000 ticks the node publishes its diagnostics (timed apart): both per
tick, amortised.

Measured on this thread's CPU clock (``time.thread_time_ns``), which the machine's load
barely moves, in two interleaved kinds of blocks of ticks:

* bare: the tick alone, nothing wrapped: the figure to compare (median and mean per tick; the
  mean includes what a tick does every N ticks: the markers, a command);
* instrumented: each part wrapped by a timer that counts its own time (a part's time excludes
  the timed parts it calls): the physics, packing each message, each publish, each bag write
  (the MCAP writer's ``add_message`` apart), the rerun log (buffering the state: its thread
  sends the batches), /tf (computed, packed), the action's update, the commands applied.
  ``rest`` is the tick's time outside every timed part (the tick's own bookkeeping, the lock).
  The wrappers' own cost (two reads of the thread clock, ~1 us) is measured first on a timed
  no-op and taken off.

The process's CPU per tick (every thread: DDS's, the recorders' writers) is given beside the
tick thread's. Results go to ``benchmarks/results/tick_cost.json``.

``--gaps``: the cold tick. The deadline loop sleeps between ticks, and on this kind of machine
(a KVM guest) a tick costs more CPU the longer the thread was idle before it (most likely the
caches and predictors it warmed were taken meanwhile: a busy wait instead of the sleep costs
about as much). The bare tick's thread CPU after idle gaps of 0,
1, 4 and 10 ms (a 1 kHz, 250 Hz and 100 Hz period), beside a plain-Python control of about a
tick's CPU that touches less code.

Usage: ``python benchmarks/tick_cost.py [--gaps] [--ticks 3000] [--rounds 3]
[--listener process|none] [--fidelity rigid] [--domain N]``
"""

from __future__ import annotations

import argparse
import collections
import gc
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RESULTS = Path(__file__).with_name("results") / "tick_cost.json"
RATE_HZ = 1000.0
COMMAND_EVERY = 100
DIAGNOSTICS_EVERY = 1000

LISTENER = """
import sys, rclpy
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage
rclpy.init()
node = rclpy.create_node("tick_cost_listener")
got = [0]
def on(_msg):
    got[0] += 1
node.create_subscription(JointState, "/joint_states", on, QoSProfile(depth=10), raw=True)
node.create_subscription(TFMessage, "/tf", on, QoSProfile(depth=100), raw=True)
print("ready", flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""


class PartTimer:
    """Wrappers that add each call's own CPU time [ns] (less that of the timed calls it makes)
    to its part's sum of the current tick, with the number of calls and of timed calls made."""

    def __init__(self) -> None:
        # defaultdict: a Counter's missing key goes through a Python __missing__
        self.tick: dict[str, int] = collections.defaultdict(int)
        self.calls: dict[str, int] = collections.defaultdict(int)
        self.children: dict[str, int] = collections.defaultdict(int)
        self._stack = [[0, 0]]
        self._undo: list = []

    def wrap(self, obj, attr: str, key) -> None:
        """Time ``obj.attr`` under ``key`` (a string, or a function of the call's arguments)."""
        fn = getattr(obj, attr)
        clock, tick, calls, stack = time.thread_time_ns, self.tick, self.calls, self._stack
        keyed = key if callable(key) else (lambda *_a, **_k: key)

        def timed(*args, **kwargs):
            frame = [0, 0]  # the timed calls' time [ns] and number
            stack.append(frame)
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                elapsed = clock() - t0
                stack.pop()
                name = keyed(*args, **kwargs)
                tick[name] += elapsed - frame[0]
                calls[name] += 1
                self.children[name] += frame[1]
                stack[-1][0] += elapsed
                stack[-1][1] += 1

        had = attr in vars(obj) if hasattr(obj, "__dict__") else False
        self._undo.append((obj, attr, fn if had else None))
        setattr(obj, attr, timed)

    def calibrate(self, n: int = 20000) -> tuple[float, float]:
        """The wrappers' own cost [ns]: inside a timed call (counted in its part) and around it
        (counted in its caller's), from a timed no-op called ``n`` times by a timed loop."""

        class Probe:
            def noop(self):
                return None

            def loop(self):
                for _ in range(n):
                    self.noop()

        bare = Probe()
        t0 = time.thread_time_ns()
        bare.loop()
        loop_bare = time.thread_time_ns() - t0
        probe = Probe()
        self.wrap(probe, "noop", "noop")
        self.wrap(probe, "loop", "loop")
        self.reset()
        probe.loop()
        self.restore()
        inside = self.tick["noop"] / n
        around = max(0.0, (self.tick["loop"] - loop_bare) / n)
        self.reset()
        return inside, around

    def reset(self) -> None:
        self.tick.clear()
        self.calls.clear()
        self.children.clear()
        self._stack[0][:] = [0, 0]

    def restore(self) -> None:
        for obj, attr, fn in reversed(self._undo):
            if fn is None:
                delattr(obj, attr)
            else:
                setattr(obj, attr, fn)
        self._undo.clear()


def instrument(node, timer: PartTimer) -> None:
    """Wrap the parts of ``node``'s tick (see the module docstring)."""
    from drs_ros.stack import tf_tree

    out = node.outputs
    timer.wrap(node.sim, "advance", "physics")
    timer.wrap(out, "state_messages", "pack: state messages, other")
    timer.wrap(out, "_pack_joint_state", "pack: /joint_states")
    timer.wrap(out, "_pack_float64", "pack: Float64 x3")
    timer.wrap(out, "_markers", "pack: ~/markers drawing")
    pubs = list(out.all)
    if node.stack.tf is not None:
        tf = node.stack.tf
        pubs += list(tf.publishers)
        timer.wrap(tf, "publish", "/tf: compute, other")
        timer.wrap(tf._moving, "pack", "/tf: pack")
        timer.wrap(tf_tree.description, "moving_transforms", "/tf: moving_transforms")
    for pub in pubs:
        timer.wrap(pub, "publish", f"publish {pub.topic_name}")
    timer.wrap(node.stack.action, "update", "action update")
    timer.wrap(node.recordings, "record", lambda topic, *_a: f"record {topic}")
    timer.wrap(node.recordings, "record_many", "record: the tick's states (one batch)")
    if node.recordings.recorder is not None:
        recorder = node.recordings.recorder
        # without chunks the appender's append is mcap's own add_message: timed the same way
        for attr in ("append", "append_many"):
            timer.wrap(recorder._appender, attr, "record: mcap message record")
    # the rerun batches are sent by the recorder's own thread: the tick only buffers the state
    timer.wrap(node.recordings, "log_state", "rerun: log_state")
    timer.wrap(node.intake, "apply_pending", "commands applied")


def start_listener(domain: int) -> subprocess.Popen:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    proc = subprocess.Popen(
        [sys.executable, "-c", LISTENER], env=env, stdout=subprocess.PIPE, text=True
    )
    if proc.stdout.readline().strip() != "ready":
        proc.kill()
        raise RuntimeError("the listener did not start")
    return proc


def stop_listener(proc: subprocess.Popen) -> None:
    """End the listener: SIGTERM, then SIGKILL if it has not ended within 5 s."""
    proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def make_node(tmp: Path, fidelity: str, domain: int):
    import rclpy
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    overrides = [
        Parameter("physics_rate_hz", value=RATE_HZ),
        Parameter("publish_rate_hz", value=RATE_HZ),
        Parameter("fidelity", value=fidelity),
        Parameter("bag_path", value=str(tmp / "bag")),
        Parameter("rrd_path", value=str(tmp / "run.rrd")),
    ]
    node = DRSNode(context=ctx, parameter_overrides=overrides, tick_timer=False)
    return ctx, node


class FakeClock:
    """The node clock of the benchmark: one publish period on at each tick [ns]."""

    def __init__(self, period_ns: int) -> None:
        self.now, self.period = time.time_ns(), period_ns

    def __call__(self) -> int:
        return self.now


def drive(node, clock: FakeClock, ticks: int, state: dict) -> tuple[list, list, dict]:
    """``ticks`` ticks: each tick's thread and process CPU [ns], and the CPU [ns] of the
    commands received and the diagnostics published meanwhile (not the tick's)."""
    from std_msgs.msg import Float64

    from drs_ros.recording import cdr

    lo, hi = node.sim.s_min, node.sim.s_max
    pack = cdr.flat_packer(Float64)
    thread_ns, process_ns = [], []
    aside = collections.Counter()
    tt, pt = time.thread_time_ns, time.process_time_ns
    for _ in range(ticks):
        state["n"] += 1
        clock.now += clock.period
        if state["n"] % COMMAND_EVERY == 0:
            t0 = tt()
            node.intake.receive("stroke_cmd", pack(hi if state["n"] % 200 else lo))
            aside["command intake (executor thread)"] += tt() - t0
        if state["n"] % DIAGNOSTICS_EVERY == 0:
            t0 = tt()
            node._on_diagnostics()
            aside["diagnostics (1 Hz)"] += tt() - t0
        p0, t0 = pt(), tt()
        node.tick()
        t1, p1 = tt(), pt()
        thread_ns.append(t1 - t0)
        process_ns.append(p1 - p0)
    return thread_ns, process_ns, aside


def summary(values_ns) -> dict[str, float]:
    return {
        "median_us": statistics.median(values_ns) / 1e3,
        "mean_us": statistics.fmean(values_ns) / 1e3,
    }


def measure(node, clock: FakeClock, ticks: int, rounds: int) -> dict:
    """Interleaved bare and instrumented blocks of ``ticks`` ticks, ``rounds`` times each."""
    timer = PartTimer()
    inside, around = timer.calibrate()
    state = {"n": 0}
    drive(node, clock, 1000, state)  # warm-up: caches, the first chunk, the first batch
    bare_t, bare_p, inst_t = [], [], []
    parts: dict[str, list] = collections.defaultdict(list)
    aside = collections.Counter()
    for _ in range(rounds):
        t, p, a = drive(node, clock, ticks, state)
        bare_t += t
        bare_p += p
        aside.update(a)
        instrument(node, timer)
        try:
            for _ in range(ticks):
                timer.reset()
                t, _p, a = drive(node, clock, 1, state)
                aside.update(a)
                own = {
                    key: timer.tick[key] - inside * timer.calls[key] - around * timer.children[key]
                    for key in timer.tick
                }
                for key, ns in own.items():
                    parts[key].append(ns)
                raw = sum(timer.tick.values())
                top = timer._stack[0][1]  # the timed calls the tick made itself
                parts["rest"].append(t[0] - raw - around * top)
                inst_t.append(t[0] - (inside + around) * sum(timer.calls.values()))
        finally:
            timer.restore()
    n_inst = len(inst_t)
    table = {}
    for key, values in parts.items():
        values = values + [0] * (n_inst - len(values))  # ticks where the part did not run
        table[key] = summary(values)
    return {
        "tick_thread": summary(bare_t),
        "tick_process": summary(bare_p),
        "tick_instrumented": summary(inst_t),
        "parts": dict(sorted(table.items(), key=lambda kv: -kv[1]["mean_us"])),
        "aside_per_tick_us": {k: v / 1e3 / (2 * rounds * ticks) for k, v in aside.items()},
        "ticks_per_kind": rounds * ticks,
        "wrapper_cost_ns": {"inside": inside, "around": around},
    }


#: ``--gaps``: the idle times [s] before a tick, and the ticks measured per gap and round.
GAPS_S = (0.0, 0.001, 0.004, 0.010)
GAP_TICKS = 300


def _control_work() -> None:
    """Plain Python of about a tick's CPU on this machine (~0.2 ms): ``json.dumps`` of a fixed
    structure, the control of ``--gaps``: it touches less code than a tick does."""
    json.dumps(_CONTROL_DATA)


_CONTROL_DATA = [{f"k{i}": [i / 7.0] * 8, "s": str(i)} for i in range(25)]


def cold_ticks(node, clock: FakeClock, rounds: int) -> dict:
    """The bare tick's thread CPU [us] after each idle gap of :data:`GAPS_S` (``time.sleep``:
    what the deadline loop does between ticks), and the control workload's after the same
    gaps, rounds interleaved; medians per gap and the ratio to back to back (gap 0)."""
    state = {"n": 0}
    drive(node, clock, 1000, state)  # warm-up
    tt = time.thread_time_ns
    runs: dict[str, dict[float, list]] = {
        "tick": collections.defaultdict(list),
        "control": collections.defaultdict(list),
    }
    for _ in range(rounds):
        for gap in GAPS_S:
            for kind in ("tick", "control"):
                values = []
                for _ in range(GAP_TICKS):
                    if gap:
                        time.sleep(gap)
                    if kind == "tick":
                        values.append(drive(node, clock, 1, state)[0][0])
                    else:
                        t0 = tt()
                        _control_work()
                        values.append(tt() - t0)
                runs[kind][gap].append(statistics.median(values) / 1e3)
    out = {}
    for kind, by_gap in runs.items():
        base = statistics.median(by_gap[0.0])
        out[kind] = {
            f"{1e3 * gap:g} ms": {
                "median_us": statistics.median(v),
                "ratio": statistics.median(v) / base,
                "rounds_us": v,
            }
            for gap, v in by_gap.items()
        }
    return out


def print_cold(res: dict) -> None:
    print(
        f"{'idle before the tick':22s} {'tick us':>9s} {'ratio':>6s} {'control us':>11s} "
        f"{'ratio':>6s}"
    )
    for gap in res["tick"]:
        tick, control = res["tick"][gap], res["control"][gap]
        print(
            f"{gap:22s} {tick['median_us']:9.1f} {tick['ratio']:6.2f} "
            f"{control['median_us']:11.1f} {control['ratio']:6.2f}"
        )


def print_table(res: dict) -> None:
    total = res["tick_instrumented"]["mean_us"]
    print(f"{'part of a tick':44s} {'median us':>10s} {'mean us':>10s} {'share':>7s}")
    for key, s in res["parts"].items():
        print(
            f"{key:44s} {s['median_us']:10.1f} {s['mean_us']:10.1f} "
            f"{100 * s['mean_us'] / total:6.1f}%"
        )
    for label, key in (
        ("tick, instrumented, less the wrappers", "tick_instrumented"),
        ("tick, bare (tick thread)", "tick_thread"),
        ("tick, bare (whole process)", "tick_process"),
    ):
        s = res[key]
        print(f"{label:44s} {s['median_us']:10.1f} {s['mean_us']:10.1f}")
    for key, us in res["aside_per_tick_us"].items():
        print(f"{key + ', per tick':44s} {'':10s} {us:10.1f}")
    share = (res["tick_process"]["mean_us"] + sum(res["aside_per_tick_us"].values())) / 1e3
    print(f"share of a core at {RATE_HZ:g} Hz (process CPU of ticks + aside): {100 * share:.1f} %")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=3000, help="ticks per block")
    ap.add_argument("--rounds", type=int, default=3, help="blocks of each kind, interleaved")
    ap.add_argument("--listener", choices=("process", "none"), default="process")
    ap.add_argument("--fidelity", default="rigid")
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--output", type=Path, default=RESULTS)
    ap.add_argument(
        "--gaps",
        action="store_true",
        help="only the tick's CPU after idle gaps of 0, 1, 4, 10 ms (the cold "
        "tick) beside a plain-Python control; to tick_cost_gaps.json",
    )
    args = ap.parse_args()
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if os.environ.pop("ROS_PYTHON_CHECK_FIELDS", None):
        print("ROS_PYTHON_CHECK_FIELDS unset: the node runs without it", file=sys.stderr)
    import rclpy

    listener = start_listener(args.domain) if args.listener == "process" else None
    with tempfile.TemporaryDirectory(prefix="tick_cost-") as tmp:
        os.environ.setdefault("ROS_LOG_DIR", str(Path(tmp) / "ros-log"))
        ctx, node = make_node(Path(tmp), args.fidelity, args.domain)
        try:
            clock = FakeClock(round(1e9 / RATE_HZ))
            node._now_ns = clock  # every stamp and log time of the node from this clock
            node.tick_part.parts.__dict__["now_ns"] = clock  # the tick's own (a frozen part)
            node.intake._now_ns = clock  # the commands' log times
            node.clock.wall_clock = False  # no jump against the steady clock
            if listener is not None:
                deadline = time.monotonic() + 20.0
                while node.outputs.joints.get_subscription_count() == 0:
                    if time.monotonic() > deadline:
                        raise RuntimeError("the listener never matched /joint_states")
                    time.sleep(0.05)
            gc.collect()
            gc.freeze()  # as drs-node does after start-up
            if args.gaps:
                res = {"cold": cold_ticks(node, clock, args.rounds)}
            else:
                res = measure(node, clock, args.ticks, args.rounds)
        finally:
            node.close_recordings()
            node.destroy_node()
            rclpy.try_shutdown(context=ctx)
            if listener is not None:
                stop_listener(listener)
    res.update(
        listener=args.listener, fidelity=args.fidelity, loadavg=os.getloadavg(), cpus=os.cpu_count()
    )
    print(
        f"tick_cost: {args.rounds} x {args.ticks} ticks of each kind, listener "
        f"{args.listener}, fidelity {args.fidelity}, load {os.getloadavg()[0]:.1f} on "
        f"{os.cpu_count()} cores"
    )
    if args.gaps:
        print_cold(res["cold"])
        if args.output == RESULTS:
            args.output = RESULTS.with_name("tick_cost_gaps.json")
    else:
        print_table(res)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(res, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
