"""The command intake (``drs_ros.node.intake``): a ``~/drs`` call with a tick due soon is
answered by that tick, on the tick's thread, in its place among the commands that arrived
around it; with no tick due soon, or when the ticks stop first, its caller answers it, once."""

from __future__ import annotations

import threading
import time

import pytest
from node_support import ros_context  # noqa: F401

from drs_ros import commands
from drs_ros.node import intake as intake_module

MS = 1_000_000  # [ns]
pytestmark = pytest.mark.ros


@pytest.fixture
def node(ros_context):  # noqa: F811
    """A node whose ticks the test runs itself, through the node's tick gate."""
    from drs_ros.node import DRSNode

    node = DRSNode(context=ros_context, tick_timer=False)
    try:
        yield node
    finally:
        node.close_recordings()
        node.destroy_node()


@pytest.fixture
def applied(monkeypatch):
    """``(command key, thread id)`` of each command the actuator is given, in order."""
    seen: list[tuple[str, int]] = []
    apply = commands.apply

    def watched(sim, key, *args, **kwargs):
        seen.append((key, threading.get_ident()))
        return apply(sim, key, *args, **kwargs)

    monkeypatch.setattr(commands, "apply", watched)
    return seen


def _call_in_thread(node, data: bool):
    """``node._on_drs`` in another thread (the executor's role): the thread, its response."""
    from std_srvs.srv import SetBool

    out: dict = {}

    def call():
        out["ident"] = threading.get_ident()
        out["response"] = node._on_drs(SetBool.Request(data=data), SetBool.Response())

    thread = threading.Thread(target=call)
    thread.start()
    return thread, out


def _until(condition, timeout_s: float = 30.0) -> None:
    give_up = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < give_up, "the condition never held"
        time.sleep(0.001)


def _stroke_bytes(value: float) -> bytes:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64

    return serialize_message(Float64(data=value))


def test_a_call_with_a_tick_due_is_answered_by_that_tick_on_its_thread(node, applied):
    gate = node.tick_gate
    gate.run(node.tick, time.monotonic_ns())  # the first tick; the next one due now
    thread, out = _call_in_thread(node, True)
    try:
        _until(lambda: node.intake.call_waiting)
        time.sleep(0.02)
        assert thread.is_alive(), "answered before the tick"
        gate.run(node.tick, time.monotonic_ns() + 10_000 * MS)
    finally:
        thread.join(timeout=30.0)
    assert not thread.is_alive()
    assert out["response"].success, out["response"].message
    assert out["response"].message.startswith("opening to ")
    assert applied == [(commands.SERVICE_KEY, threading.get_ident())]  # the tick's thread
    assert node.effects.accepted == 1
    assert not node.intake.waiting


def test_a_call_with_no_tick_scheduled_is_answered_at_once_by_its_caller(node, applied):
    thread, out = _call_in_thread(node, True)
    thread.join(timeout=30.0)
    assert out["response"].success, out["response"].message
    assert applied == [(commands.SERVICE_KEY, out["ident"])]
    assert node.tick_gate.ticks == 0


def test_a_call_with_the_next_tick_later_than_the_bound_is_answered_at_once(node, applied):
    gate = node.tick_gate
    later_ns = int(2 * intake_module.TICK_ANSWERS_WITHIN_S * 1e9) + 10_000 * MS
    gate.run(node.tick, time.monotonic_ns() + later_ns)
    thread, out = _call_in_thread(node, False)
    thread.join(timeout=30.0)
    assert out["response"].success, out["response"].message
    assert applied == [(commands.SERVICE_KEY, out["ident"])]
    assert gate.ticks == 1  # no tick came between


def test_a_call_waiting_when_the_ticks_stop_is_answered_once_by_its_caller(node, applied):
    gate = node.tick_gate
    gate.run(node.tick, time.monotonic_ns())
    thread, out = _call_in_thread(node, True)
    try:
        _until(lambda: node.intake.call_waiting)
        gate.stopped()  # the loop ended: no tick will take it
    finally:
        thread.join(timeout=30.0)
    assert not thread.is_alive()
    assert out["response"].success, out["response"].message
    assert applied == [(commands.SERVICE_KEY, out["ident"])]
    assert node.effects.accepted == 1
    assert not node.intake.waiting
    node.tick()  # a tick after it applies it no second time
    assert len(applied) == 1


def test_the_tick_applies_a_call_between_the_commands_that_came_before_and_after_it(node, applied):
    gate = node.tick_gate
    gate.run(node.tick, time.monotonic_ns())
    lo, hi = node.sim.s_min, node.sim.s_max
    node.intake.receive("stroke_cmd", _stroke_bytes(lo + 0.3 * (hi - lo)))
    time.sleep(0.002)  # the node clock moves on: the call is received after the command
    thread, out = _call_in_thread(node, True)
    try:
        _until(lambda: node.intake.call_waiting)
        time.sleep(0.002)
        node.intake.receive("force_cmd", _stroke_bytes(100.0))  # a force [N], after the call
        gate.run(node.tick, time.monotonic_ns() + 10_000 * MS)
    finally:
        thread.join(timeout=30.0)
    assert out["response"].success, out["response"].message
    tick_thread = threading.get_ident()
    assert applied == [
        ("stroke_cmd", tick_thread),
        (commands.SERVICE_KEY, tick_thread),
        ("force_cmd", tick_thread),
    ]


def test_a_call_while_auto_still_discovers_is_answered_by_the_tick_which_chooses_now(
    ros_context,  # noqa: F811
    applied,
):
    """As a call answered on the executor thread does, a call handed to the ticks makes
    ``fidelity: auto`` choose at once rather than wait for the end of its discovery."""
    from rclpy.parameter import Parameter

    from drs_ros.node import DRSNode

    overrides = [
        Parameter("fidelity", value="auto"),
        Parameter("fidelity_auto_discovery_s", value=60.0),
    ]
    node = DRSNode(context=ros_context, tick_timer=False, parameter_overrides=overrides)
    try:
        gate = node.tick_gate
        gate.run(node.tick, time.monotonic_ns())  # auto still waits: the tick does nothing
        assert node.rungs.deadline is not None and node.effects.ticks == 0
        thread, out = _call_in_thread(node, True)
        try:
            _until(lambda: node.intake.call_waiting)
            gate.run(node.tick, time.monotonic_ns() + 10_000 * MS)
            thread.join(timeout=5.0)
        finally:
            gate.stopped()  # a call still waiting is then answered by its caller
            thread.join(timeout=30.0)
        assert node.rungs.deadline is None  # chosen
        assert applied == [(commands.SERVICE_KEY, threading.get_ident())]
        assert out["response"].success, out["response"].message
    finally:
        node.close_recordings()
        node.destroy_node()
