"""Every value the node takes is bounded by physics, and a long tick stays stoppable: each fault
at the edges of its range and beyond, on every rung, through the parameter service (the node as
its own process over loopback DDS); and SIGINT/SIGTERM in the middle of a tick of many seconds.
"""

from __future__ import annotations

import re
import signal
import time

import pytest
from node_support import domain_for
from ros_support import require_rclpy

pytestmark = [pytest.mark.ros, pytest.mark.slow]

require_rclpy()

from rclpy.parameter import Parameter  # noqa: E402
from test_node_robustness import start_node, stop_node  # noqa: E402

from drs_model.fidelity import RUNGS  # noqa: E402
from drs_model.fidelity.faults import FAULT_RANGES, FAULTS, HYDRAULIC_ONLY  # noqa: E402
from drs_model.kinematics import stroke_limits  # noqa: E402
from drs_ros.client import DRSClient  # noqa: E402

PUBLISH_HZ = 100.0
INT64_MAX = 2**63 - 1


def _modelled(name: str, rung: str) -> bool:
    """Whether ``rung`` models the fault (docs/fidelity.md, "Faults at run time")."""
    if name in HYDRAULIC_ONLY:
        return rung == "hydraulic"
    if name == "supply_loss":
        return rung != "kinematic"
    return True


def _plan(rung: str) -> list[tuple[str, object, str]]:
    """Every fault at its edges (taken where the rung models it, else refused as not modelled),
    back to healthy, and beyond each edge and at 1e300 (refused with its range): (name, value,
    'taken' | 'not modelled' | 'out of range')."""
    plan = []
    for name, (healthy, _) in FAULTS.items():
        taken = "taken" if _modelled(name, rung) else "not modelled"
        if isinstance(healthy, bool):
            plan += [(name, True, taken), (name, False, "taken")]
            continue
        low, high, _ = FAULT_RANGES[name]
        edges = [v for v in (low, high) if v != healthy]
        plan += [(name, v, taken) for v in edges] + [(name, healthy, "taken")]
        if isinstance(healthy, int):
            plan.append((name, low - 1, "out of range"))  # high + 1 is no ROS integer
        else:
            step = 1e-3 * (high - low)
            plan += [(name, v, "out of range") for v in (low - step, high + step, 1e300)]
    return plan


@pytest.mark.parametrize("rung", list(RUNGS))
def test_every_fault_at_its_edges_and_beyond_through_the_parameter_service(
    tmp_path, request, rung, params
):
    """Each value taken or refused as the plan says, the refusals with the fault's range (or the
    rung's reason) in the SetParametersResult and in the effect record; meanwhile the node
    publishes at its rate (no gap of a second, at least half the rate overall); afterwards a
    good command is obeyed; SIGINT ends it with exit 0 and a bag that reads to its end, every
    byte verified (``drs-bag check``'s first stage)."""
    from decoded_support import read_bag

    from drs_ros.bag.read.effects import effect_records
    from drs_ros.bag.read.reader import scan

    domain = domain_for(request.node.nodeid)
    bag = tmp_path / "bag"
    proc = start_node(
        tmp_path, domain, f"bag_path:={bag}", f"fidelity:={rung}", f"publish_rate_hz:={PUBLISH_HZ}"
    )
    client = DRSClient(domain, timeout=60.0, keep=True, listen=("joint_states",))
    lo, hi = stroke_limits(params)
    target = lo + 0.4 * (hi - lo)
    plan = _plan(rung)
    try:
        assert client.wait_for(lambda: len(client.arrival_times) > 10)
        start = time.monotonic()
        for name, value, outcome in plan:
            result = client.set_parameter(f"fault.{name}", value)
            assert result.successful == (outcome == "taken"), (name, value, result.reason)
            if outcome == "out of range":
                edges = ", ".join(
                    f"{v:g}" if isinstance(v, float) else str(v) for v in FAULT_RANGES[name][:2]
                )
                assert f"fault {name} must be in [{edges}]" in result.reason, result.reason
                assert f"got {value!r}" in result.reason or f"got {float(value)!r}" in (
                    result.reason
                )
            elif outcome == "not modelled":
                assert f"'{rung}' rung cannot model fault {name}" in result.reason
        client.spin(0.2)
        during = [t for t in client.arrival_times if t >= start]
        elapsed = during[-1] - start
        assert len(during) >= 0.5 * PUBLISH_HZ * elapsed, (len(during), elapsed)
        assert max(b - a for a, b in zip([start, *during[:-1]], during, strict=True)) < 1.0
        # a good command afterwards: the stroke goes where it is told
        client.stroke(target)
        assert client.wait_for(lambda: abs(client.stroke_now() - target) < 1e-5, timeout=30.0), (
            client.stroke_now(),
            target,
        )
    finally:
        client.close()
        out = stop_node(proc)
    assert proc.returncode == 0, out[-3000:]
    assert scan(bag).complete
    refused = [
        (r.source, r.values["value"])
        for r in effect_records(
            read_bag(bag, ["/drs/command_events"]).messages["/drs/command_events"]
        )
        if r.outcome == "refused"
    ]
    assert refused == [
        (f"fault.{n}", repr(v if isinstance(FAULTS[n][0], int) else float(v)))
        for n, v, outcome in plan
        if outcome != "taken"
    ]


@pytest.mark.parametrize(
    ("sig", "executor"), [(signal.SIGINT, "deadline"), (signal.SIGTERM, "single")]
)
def test_a_stop_in_a_tick_of_many_seconds_ends_the_node_within_a_second(
    tmp_path, request, params, sig, executor
):
    """A tick of thousands of expensive physics steps: the hydraulic rung (0.04-0.2 ms of CPU
    per 1 ms step at the open stop, by machine, so the node keeps up), the process stopped 6 s, so
    the next tick has 6,000 steps to catch up, 0.25-1.2 s of work. The signal comes 50 ms after
    the process resumes: after the tick the stall interrupted (a few steps), early in the long one
    on any of these machines. SIGINT or SIGTERM in its middle ends the
    node within a second (the tick ends at the next physics step, over a thousand steps before
    its end), with exit 0, the bag read to its end and the .rrd verified by rerun. With the stop
    read only between ticks, the SIGINT case fails: the tick runs to its end.

    A rung the node cannot keep up with (a 5 kN jam: ~1 s of CPU per simulated second, or
    20 kHz physics) makes its ticks grow without bound from the moment it falls behind, and
    which tick a signal then meets depends on the machine's speed: the stall must make the long
    tick, not the load."""
    from drs_ros.bag.read.reader import scan
    from drs_ros.recording.rerun_cli import run_rerun_cli

    domain = domain_for(request.node.nodeid)
    bag, rrd = tmp_path / "bag", tmp_path / "run.rrd"
    proc = start_node(
        tmp_path,
        domain,
        f"bag_path:={bag}",
        f"rrd_path:={rrd}",
        "fidelity:=hydraulic",
        "max_catch_up_steps:=100000",
        f"executor:={executor}",
    )
    client = DRSClient(domain, timeout=60.0, keep=True, listen=("joint_states",))
    _, s_max = stroke_limits(params)
    try:
        assert client.call_drs(True).startswith("ok")
        assert client.wait_for(lambda: client.stroke_now() > s_max - 1e-4, timeout=30.0)
        client.spin(0.3)
        proc.send_signal(signal.SIGSTOP)
        time.sleep(6.0)
        proc.send_signal(signal.SIGCONT)
        time.sleep(0.05)  # the tick the stall interrupted was short: inside the long one now
        t0 = time.monotonic()
        proc.send_signal(sig)
        proc.wait(timeout=60)
        took = time.monotonic() - t0
    finally:
        client.close()
        out = stop_node(proc)
    assert proc.returncode == 0, out[-3000:]
    cut = re.search(r"the last tick ends after (\d+) of its (\d+) physics steps", out)
    # cut well before its end (6,000 steps after the stall)
    assert cut and int(cut[2]) - int(cut[1]) > 1000, out[-3000:]
    assert took < 1.0, f"{sig.name} took {took:.2f} s to end the node"
    assert f"stopped by {sig.name}, recordings finished" in out
    assert scan(bag).complete
    verify = run_rerun_cli(["rrd", "verify", str(rrd)])
    assert verify.returncode == 0, verify.stderr[-1000:]


def test_a_step_too_stiff_for_the_cap_holds_the_node_which_publishes_on(ros_context, tmp_path):
    """Should a state need more sub-steps than the rung's cap (here forced: a cap of 1 while
    the flap moves), the step is refused (TooStiffError), the node holds where it is, as for
    any model refusal (effect record ``reset``, counted), and goes on ticking and publishing;
    with the cap back, the next command moves it again."""
    from decoded_support import read_bag
    from node_support import spin_until
    from rclpy.executors import SingleThreadedExecutor

    from drs_ros.bag.read.effects import effect_records
    from drs_ros.node import DRSNode

    node = DRSNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("fidelity", value="hydraulic"),
            Parameter("bag_path", value=str(tmp_path / "bag")),
        ],
    )
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: node.effects.ticks > 5, 10.0)
        node.sim._max_substeps = 1  # every step needs more
        node.sim.command_drs(True)
        ticks, refused = node.effects.ticks, node.effects.refused
        assert spin_until(ex, lambda: node.effects.ticks > ticks + 20, 10.0)
        assert node.effects.refused > refused and "too stiff" in node.effects.last_refusal
        held = node.sim.state.q[0]
        node.sim._max_substeps = None  # the default cap again
        node.sim.command_drs(True)
        assert spin_until(ex, lambda: node.sim.state.q[0] > held + 1e-3, 10.0)
    finally:
        ex.shutdown()
        lines = node.close_recordings()
        node.destroy_node()
    assert lines == []
    records = effect_records(
        read_bag(tmp_path / "bag", ["/drs/command_events"]).messages["/drs/command_events"]
    )
    resets = [r for r in records if r.outcome == "reset"]
    steps = [line for line in node.effects.refusals if line.startswith("step ")]
    assert resets and steps  # each refused step held the flap, with the rung's reason
    assert all("too stiff for a physics step" in line for line in steps), steps[:3]
