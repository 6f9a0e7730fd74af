"""The tick thread's scheduling: the lateness histogram against numpy's percentiles, a tick
late by several periods counted in diagnostics, and the node without the privilege of
SCHED_FIFO starting, saying why and running."""

from __future__ import annotations

import os
import signal
import sys
import textwrap
import threading
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from node_support import (  # noqa: F401
    domain_for,
    node_env,
    ros_context,
    start_node,
    wait_for_file_growth,
)

from drs_ros.node.tick_schedule import (
    _EDGES_US,
    LatenessHistogram,
    TickPolicy,
    apply_tick_policy,
    cpu_refusal,
    leave_tick_policy,
    usable_cpus,
)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(min_value=-5_000, max_value=3_000_000_000), min_size=1, max_size=400))
def test_histogram_quantiles_bound_numpy_percentiles_within_a_bin(lateness_ns):
    hist = LatenessHistogram()
    for x in lateness_ns:
        hist.add(x)
    clipped = np.sort(np.maximum(np.array(lateness_ns, dtype=np.int64), 0))  # [ns]
    assert hist.count == len(lateness_ns)
    assert hist.max_ns == clipped[-1]
    edges_ns = 1000 * np.array(_EDGES_US, dtype=np.int64)
    for q in (0.5, 0.99):
        # the order statistic of rank ceil(q n) lies in the bin reported: its upper edge (or
        # the largest lateness, when smaller or beyond the last edge)
        exact = clipped[max(int(np.ceil(q * len(clipped))) - 1, 0)]
        k = np.searchsorted(edges_ns, exact, side="left")
        edge = edges_ns[k] if k < len(edges_ns) else clipped[-1]
        assert hist.quantile_us(q) == min(edge, clipped[-1]) / 1000.0


def test_an_empty_histogram_reports_zero():
    values = LatenessHistogram().values()
    assert values["tick_lateness_p99_us"] == "0" and values["skipped_ticks"] == 0


def test_other_is_not_fifo_and_a_refusal_names_why(monkeypatch):
    assert apply_tick_policy("other", 10) == TickPolicy("SCHED_OTHER", 0)

    def refuse(*_):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr("os.sched_setscheduler", refuse)
    policy = apply_tick_policy("fifo", 10)
    assert policy.name == "SCHED_OTHER"
    assert "Operation not permitted" in policy.note and "CAP_SYS_NICE" in policy.note


def test_a_thread_leaves_fifo_for_the_ordinary_policy_after_the_loop():
    """The tick thread is real-time for the loop only: after :func:`leave_tick_policy` it is
    back under SCHED_OTHER (where SCHED_FIFO is granted; elsewhere it never left it)."""
    import os
    import threading

    seen = {}

    def loop_thread():
        policy = apply_tick_policy("fifo", 5)
        seen["during"] = (policy.name, os.sched_getscheduler(0))
        leave_tick_policy(policy)
        seen["after"] = os.sched_getscheduler(0)

    thread = threading.Thread(target=loop_thread)
    thread.start()
    thread.join()
    name, during = seen["during"]
    assert during == (os.SCHED_FIFO if name == "SCHED_FIFO" else os.SCHED_OTHER)
    assert seen["after"] == os.SCHED_OTHER


def test_no_callback_starts_while_the_tick_holds_the_gate():
    """The deadline loop holds the gate for each tick: the executor's loop waits for the tick
    to be over before each callback (a flood's callbacks do not share the GIL with the whole
    tick), for at most a stop poll (a tick that stalls does not stall the executor)."""
    import threading

    from drs_ros.node.runner import STOP_POLL_S, spin_until_stopped
    from drs_ros.node.tick_gate import TickGate
    from drs_ros.stop_request import StopRequest

    class Context:
        def ok(self):
            return True

    class Executor:
        context = Context()
        calls = 0

        def spin_once(self, timeout_sec):
            self.calls += 1
            time.sleep(0.0005)

    executor, stop, gate = Executor(), StopRequest(), TickGate()
    tick_over, tick_started = threading.Event(), threading.Event()

    def tick():
        tick_started.set()
        tick_over.wait(10.0)

    ticking = threading.Thread(target=gate.run, args=(tick, time.monotonic_ns()))
    ticking.start()  # a tick in progress
    assert tick_started.wait(5.0)
    thread = threading.Thread(target=spin_until_stopped, args=(None, executor, stop, gate))
    thread.start()
    try:
        time.sleep(0.2)  # four of the loop's stop polls: one callback after each
        held = executor.calls
        tick_over.set()  # the tick is over
        time.sleep(0.4)
        free = executor.calls - held
    finally:
        tick_over.set()
        stop()
        thread.join(timeout=5.0)
        ticking.join(timeout=5.0)
    assert held <= 0.2 / STOP_POLL_S + 1
    assert free >= 20  # 0.5 ms each (~800), nothing to wait for; a busy machine is slower
    assert not thread.is_alive()


@pytest.mark.ros
def test_a_tick_late_by_several_periods_is_counted_in_diagnostics(ros_context):  # noqa: F811
    """The deadline loop in this thread, the tick held once for four periods: the deadlines
    it overran are counted (skipped_ticks), the tick itself is a missed deadline, and the
    histogram's maximum holds it. The loop is stopped from inside a tick (no wall clock)."""
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode
    from drs_ros.node.runner import run_deadline_loop
    from drs_ros.stop_request import StopRequest

    node = DRSNode(
        context=ros_context,
        tick_timer=False,
        parameter_overrides=[
            Parameter("tick_scheduling", value="other"),  # this is pytest's own thread
        ],
    )
    stop = StopRequest()
    tick, count = node.tick, [0]
    stall_s = 4 * node.publish_period

    def held_tick():
        count[0] += 1
        if count[0] == 20:
            import time

            time.sleep(stall_s)  # the held tick (a stall of the process, say)
        if count[0] == 60:
            stop()
        tick()

    node.tick = held_tick
    try:
        run_deadline_loop(node, stop, ros_context)
        values = node.diagnostics_values()
    finally:
        node.close_recordings()
        node.destroy_node()
    assert values["tick_policy"] == "SCHED_OTHER"
    assert values["skipped_ticks"] >= 3
    assert values["missed_deadlines"] >= 1
    assert float(values["tick_lateness_max_us"]) >= 3e6 * node.publish_period
    assert node.effects.lateness.count >= 59


class CountingExecutor:
    """rclpy's EventsExecutor (C++, its methods cannot be patched) with the timeouts of its
    ``spin_once`` calls counted."""

    def __init__(self, context):
        from rclpy.experimental import EventsExecutor

        self._executor = EventsExecutor(context=context)
        self.context = context
        self.spins: list[float] = []

    def spin_once(self, timeout_sec=None):
        self.spins.append(timeout_sec)
        self._executor.spin_once(timeout_sec=timeout_sec)

    def __getattr__(self, name):
        return getattr(self._executor, name)


@pytest.mark.ros
def test_the_executor_thread_waits_for_work_and_the_stop_wakes_it(ros_context, monkeypatch):  # noqa: F811
    """The deadline loop's executor thread does not poll: over a second of ticks an idle node's
    executor wakes a few times (start-up), not every 50 ms, and the loop's stop ends its wait at
    once instead of at the end of its idle wait (20 s here; the diagnostics' timer, which would
    end it within a second, is cancelled)."""
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode, runner
    from drs_ros.stop_request import StopRequest

    monkeypatch.setattr(runner, "EXECUTOR_IDLE_WAIT_S", 20.0)
    made = []

    def counting(*, context):
        made.append(CountingExecutor(context))
        return made[-1]

    monkeypatch.setattr(runner, "EventsExecutor", counting)
    node = DRSNode(
        context=ros_context,
        tick_timer=False,
        parameter_overrides=[
            Parameter("tick_scheduling", value="other"),  # this is pytest's own thread
        ],
    )
    stop = StopRequest()
    tick, count, stopped_at = node.tick, [0], []
    ticks = round(1.0 / node.publish_period)  # a second of ticks

    def counting_tick():
        count[0] += 1
        if count[0] == ticks:
            stopped_at.append(time.monotonic())
            stop()
        tick()

    node.tick = counting_tick
    node.diag_timer.cancel()  # its once a second would end the idle wait too
    try:
        runner.run_deadline_loop(node, stop, ros_context)
        returned_at = time.monotonic()
    finally:
        node.close_recordings()
        node.destroy_node()
    spins = made[0].spins
    assert set(spins) == {20.0}
    assert len(spins) < 10, spins  # polling every 50 ms: >= 20
    assert returned_at - stopped_at[0] < 10.0  # not the idle wait's 20 s


@pytest.mark.ros
def test_end_idle_wait_ends_a_wait_at_once_and_leaves_no_timer_running(ros_context):  # noqa: F811
    """:func:`runner.end_idle_wait` ends a ``spin_once`` that waits 20 s in another thread
    within a second, where the EventsExecutor's own ``wake()`` does not (it waits out its
    timeout), and its one-shot timer fires once."""
    import rclpy
    from rclpy.experimental import EventsExecutor

    from drs_ros.node import runner
    from drs_ros.stop_request import StopRequest

    node = rclpy.create_node("executor_wakes", context=ros_context)
    executor = EventsExecutor(context=ros_context)
    executor.add_node(node)
    stop = StopRequest()
    thread = threading.Thread(
        target=runner.spin_until_stopped, args=(node, executor, stop, None, 20.0)
    )
    thread.start()
    try:
        time.sleep(0.2)
        stop()
        asked = time.monotonic()
        runner.end_idle_wait(node)
        thread.join(timeout=10.0)
        assert not thread.is_alive(), "the stop did not end the executor's wait"
        assert time.monotonic() - asked < 5.0
        timers = list(node.timers)
        assert len(timers) == 1 and timers[0].is_canceled()
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()


REFUSED_FIFO = textwrap.dedent(
    """
    import os, sys

    def refuse(*_):
        raise PermissionError(1, "Operation not permitted")

    os.sched_setscheduler = refuse  # as for a process without root, CAP_SYS_NICE or rtprio
    from drs_ros.node import runner
    sys.exit(runner.main(["drs-node", "--ros-args", "-p", "bag_path:=" + sys.argv[1],
                          "-p", "tick_scheduling:=fifo"]))
    """
)


def _wait_past_start_up(bag, more: int) -> None:
    """Wait for the bag's file, then for ``more`` bytes after what start-up writes (the
    description, the parameters): the ticks' own."""
    assert wait_for_file_growth(bag / "bag_0.mcap", timeout=60, min_size=64 * 1024)
    started = (bag / "bag_0.mcap").stat().st_size
    assert wait_for_file_growth(bag / "bag_0.mcap", timeout=60, min_size=started + more)


@pytest.mark.ros
@pytest.mark.slow
def test_without_the_privilege_of_fifo_the_node_starts_says_why_and_runs(tmp_path, request):
    bag = tmp_path / "bag"
    proc = start_node(
        tmp_path,
        domain_for(request.node.nodeid),
        argv=[sys.executable, "-c", REFUSED_FIFO, str(bag)],
    )
    try:
        _wait_past_start_up(bag, 64 * 1024)
    finally:
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out[-2000:]
    assert "tick thread: SCHED_OTHER (SCHED_FIFO asked for, refused" in out
    assert "CAP_SYS_NICE" in out
    from decoded_support import read_bag

    data = read_bag(bag, ["/drs/command_events", "/joint_states"])
    scheduling = [
        status
        for _, msg in data.messages["/drs/command_events"]
        for status in msg.status
        if status.name == "scheduling"
    ]
    assert len(scheduling) == 1
    values = {kv.key: kv.value for kv in scheduling[0].values}
    assert values["policy"] == "SCHED_OTHER"
    assert "Operation not permitted" in scheduling[0].message
    assert len(data.messages["/joint_states"]) >= 10  # it ran: ticks after start-up


@pytest.mark.ros
@pytest.mark.slow
def test_at_1_khz_every_recorded_message_is_exact_and_every_tick_is_counted(tmp_path, request):
    """A node at 1 kHz physics and publish for 6.5 s (diagnostics come at 1 Hz: five of them after
    the first state) with both recordings. Read back by the
    ``mcap`` library and decoded by ``rosbags`` (neither ours): every recorded message is the
    bytes rosbags serialises it to (exact CDR: zero padding, no transport padding; rclpy's own
    ``serialize_message`` is no reference here, it leaves heap bytes in the padding of a
    parameter event). And no deadline is lost
    uncounted: between the first published state and a diagnostics message, the deadlines that
    passed are the ticks plus the skipped deadlines that diagnostics report (a resume from now
    after a skip loses less than a period: one more per skip at most)."""
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    bag = tmp_path / "bag"
    proc = start_node(
        tmp_path,
        domain_for(request.node.nodeid),
        f"bag_path:={bag}",
        f"rrd_path:={tmp_path / 'run.rrd'}",
        "publish_rate_hz:=1000.0",
        "physics_rate_hz:=1000.0",
        "fidelity:=rigid",
    )
    try:
        _wait_past_start_up(bag, 1024)
        time.sleep(6.5)
    finally:
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out[-2000:]
    store = get_typestore(Stores.ROS2_JAZZY)
    states, diagnostics, checked, tf = [], [], 0, 0
    with open(bag / "bag_0.mcap", "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if schema.name not in store.types:  # the bag's own definition of the type
                store.register(get_types_from_msg(schema.data.decode(), schema.name))
            decoded = store.deserialize_cdr(message.data, schema.name)
            again = store.serialize_cdr(decoded, schema.name)
            assert again == message.data, (channel.topic, message.sequence)
            checked += 1
            if channel.topic == "/joint_states":
                states.append(message.log_time)
            elif channel.topic == "/diagnostics":
                diagnostics.append((message.log_time, decoded))
            elif channel.topic == "/tf":
                tf += 1
    # each tick: the joint states and the three Float64 states; /tf at tf_rate_hz (100 Hz)
    assert len(states) > 3000 and checked > 4 * len(states)
    expected_tf = (states[-1] - states[0]) / 10_000_000  # a stall of > 10 ms may skip one
    assert 0.9 * expected_tf <= tf <= expected_tf + 2
    period_ns = 1_000_000
    after_start = [(log_ns, msg) for log_ns, msg in diagnostics if log_ns > states[0]]
    assert len(after_start) >= 5
    for log_ns, msg in after_start:
        values = {kv.key: kv.value for kv in msg.status[0].values}
        ticks, skipped = int(values["ticks"]), int(values["skipped_ticks"])
        deadlines = (log_ns - states[0]) / period_ns
        assert ticks + skipped <= deadlines + 2, (ticks, skipped, deadlines)
        assert ticks + 2 * skipped >= deadlines - 2, (ticks, skipped, deadlines)


def _in_a_thread(fn):
    """``fn()`` in a thread of its own (what it does to its thread stays there); its result, or
    what it raised, raised again."""
    out: list = []

    def run():
        try:
            out.append(("ok", fn()))
        except BaseException as exc:  # noqa: BLE001 - raised again in the test's thread
            out.append(("raised", exc))

    thread = threading.Thread(target=run)
    thread.start()
    thread.join(timeout=60.0)
    assert out, "the thread did not finish"
    kind, value = out[0]
    if kind == "raised":
        raise value
    return value


def _two_cpus() -> set[int]:
    cpus = set(usable_cpus())
    if len(cpus) < 2:  # a machine fact, not a dependency: one CPU cannot show a thread kept
        pytest.skip(f"keeping a thread on one CPU shows nothing with one CPU usable ({cpus})")
    return cpus


def test_tick_cpu_keeps_the_thread_on_that_cpu_and_leaving_gives_the_others_back():
    cpus = _two_cpus()
    cpu = max(cpus)

    def pinned():
        policy = apply_tick_policy("other", 10, cpu)
        during = os.sched_getaffinity(0)
        leave_tick_policy(policy)
        return policy, during, os.sched_getaffinity(0)

    policy, during, after = _in_a_thread(pinned)
    assert during == {cpu}
    assert after == cpus
    assert policy.text() == f"SCHED_OTHER on CPU {cpu}"
    assert os.sched_getaffinity(0) == cpus  # the calling thread only


def test_a_cpu_the_system_refuses_leaves_the_thread_where_it_was_and_says_why():
    cpus = set(usable_cpus())
    policy, after = _in_a_thread(
        lambda: (apply_tick_policy("other", 10, 1023), os.sched_getaffinity(0))
    )
    assert policy.cpu == -1 and "CPU 1023 asked for, refused" in policy.note
    assert after == cpus


@pytest.mark.ros
def test_the_deadline_loop_keeps_its_ticks_on_tick_cpu(ros_context):  # noqa: F811
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode
    from drs_ros.node.runner import run_deadline_loop
    from drs_ros.stop_request import StopRequest

    cpus = _two_cpus()
    cpu = max(cpus)
    node = DRSNode(
        context=ros_context,
        tick_timer=False,
        parameter_overrides=[
            Parameter("tick_scheduling", value="other"),
            Parameter("tick_cpu", value=cpu),
        ],
    )
    stop, seen, tick = StopRequest(), [], node.tick

    def watched_tick():
        seen.append(frozenset(os.sched_getaffinity(0)))
        if len(seen) == 5:
            stop()
        tick()

    node.tick = watched_tick

    def loop():
        run_deadline_loop(node, stop, ros_context)
        return os.sched_getaffinity(0)

    try:
        after = _in_a_thread(loop)
        values = node.diagnostics_values()
    finally:
        node.close_recordings()
        node.destroy_node()
    assert seen and set(seen) == {frozenset({cpu})}
    assert after == cpus  # given back as the loop ended
    assert values["tick_policy"] == f"SCHED_OTHER on CPU {cpu}"


def test_a_cpu_outside_the_processs_own_is_still_one_a_thread_may_take():
    """``isolcpus`` leaves a real-time CPU out of every process's CPUs; the kernel still lets
    a thread take it: configure asks the kernel, not the process's own CPUs."""
    cpus = _two_cpus()
    low, high = min(cpus), max(cpus)

    def confined():
        os.sched_setaffinity(0, {low})  # this thread (and those it starts) on one CPU
        return usable_cpus(), cpu_refusal(high)

    own, refusal = _in_a_thread(confined)
    assert high not in own
    assert refusal is None
    assert cpu_refusal(1023) is not None  # no such CPU here


@pytest.mark.parametrize("tick_cpu, warned", [(0, True), (-1, False)])
def test_a_tick_cpu_given_where_no_deadline_loop_runs_is_said_to_be_ignored(tick_cpu, warned):
    import types

    from drs_ros.node.runner import warn_tick_cpu_unused

    seen: list[str] = []
    node = types.SimpleNamespace(
        get_parameter=lambda name: types.SimpleNamespace(value={"tick_cpu": tick_cpu}[name]),
        get_logger=lambda: types.SimpleNamespace(warning=seen.append),
    )
    warn_tick_cpu_unused(node)
    assert bool(seen) is warned
    assert all("tick_cpu is ignored" in line for line in seen)
